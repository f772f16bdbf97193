"""A calibration (``[calibration]``, tauvcore.config.CalibrationConfig) applied to a log's measurements
before the filters see them: the replay's DVL rows and reference (tauvcore.eval.replay.LogRows).

DVL (mounting misalignment ``C_bh`` and scale factor ``s``, tauvcore.conventions): a logged head
velocity ``v_h`` is the body's ``v_b = C_bh v_h / (1 + s)``.

- A body-velocity table (A-KIT, a bag's twist): every row so, bottom- and water-track alike (one
  transducer head, one sound speed).
- A beam table: per ping, the beams of one track (bottom-track, and apart from them water-track)
  give the head velocity by least squares when three or more returned, ``v_h = A^+ y`` (``A`` the
  configured beams that returned, rows of ``dvl.A_b``); the corrected beams are ``A v_b`` plus the
  least-squares residual ``y - A v_h``, which the correction leaves as it was (the noise and biases
  the velocity does not explain, what the filters' beam-bias states and gate read). A track with
  one or two beams at a ping does not fix the head velocity: its beams are corrected for the scale
  factor alone, ``y / (1 + s)``, and keep the misalignment's error (at a 1 deg misalignment and 2 m/s,
  at most 0.035 m/s on a beam, below one beam's 0.042 m/s noise of Table 2).

Reference (boresight ``C_rb``): its attitude ``C_nr`` is turned to the IMU's body, ``C_nb = C_nr C_rb``,
so that the truth the errors and NEES are measured against is the IMU's attitude.

With a zero calibration the log is returned as it is, the same object: a replay is then the one
without a calibration to the last bit.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from tauvcore import units
from tauvcore.config import CalibrationConfig
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb
from tauvcore.logs.log_record import Log

MIN_BEAMS_FOR_VELOCITY = 3
"""Beams of one track at one ping that fix the head velocity (three unknowns)."""


def calibrated(log: Log, calibration: CalibrationConfig, A_b: np.ndarray) -> Log:
    """``log`` with ``calibration`` applied to its DVL velocities and its reference attitude.

    Parameters
    ----------
    log : Log
        The recorded log, in SI units and the frames of tauvcore.conventions.
    calibration : CalibrationConfig
        The DVL's misalignment [deg] and scale factor [%], the IMU's boresight [deg].
    A_b : numpy.ndarray
        The configured beam directions, shape (4, 3) [-] (``dvl.A_b``), the DVL head's frame h.

    Returns
    -------
    Log
        ``log`` itself for a zero calibration; else a copy with ``dvl_body_mps`` (M, 3) [m/s],
        ``dvl_beams_mps`` and ``dvl_water_mps`` (M, 4) [m/s] corrected (module docstring) and
        ``ref_euler`` (N, 3) [rad] the IMU's attitude, ``C_nr C_rb``.
    """
    changes: dict[str, np.ndarray] = {}
    if calibration.dvl_corrected and log.dvl_t_s is not None:
        C_bh = C_nb_from_euler(np.asarray(calibration.dvl_misalignment_deg) * units.DEG)
        M = C_bh / (1.0 + calibration.dvl_scale_factor_pct * units.PERCENT)  # v_b = M v_h
        if log.dvl_body_mps is not None:
            changes["dvl_body_mps"] = np.einsum("ij,mj->mi", M, log.dvl_body_mps)
        if log.dvl_beams_mps is not None:
            water = log.dvl_water_track
            if water is None or not water.any():
                changes["dvl_beams_mps"] = corrected_beams(log.dvl_beams_mps, A_b, M)
            else:  # one track at a time: bottom- and water-track beams measure different velocities
                bottom = corrected_beams(np.where(water, np.nan, log.dvl_beams_mps), A_b, M)
                over_water = corrected_beams(np.where(water, log.dvl_beams_mps, np.nan), A_b, M)
                changes["dvl_beams_mps"] = np.where(water, over_water, bottom)
        if log.dvl_water_mps is not None:
            changes["dvl_water_mps"] = corrected_beams(log.dvl_water_mps, A_b, M)
    if calibration.reference_corrected and log.ref_euler is not None:
        C_rb = C_nb_from_euler(np.asarray(calibration.imu_boresight_deg) * units.DEG)
        changes["ref_euler"] = euler_from_C_nb(C_nb_from_euler(log.ref_euler) @ C_rb)
    return dataclasses.replace(log, **changes) if changes else log


def corrected_beams(y: np.ndarray, A_b: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Beam velocities of one track with the head velocity ``v_h`` replaced by ``M v_h``.

    Per ping with at least :data:`MIN_BEAMS_FOR_VELOCITY` beams: ``A (M A^+ y) + (y - A A^+ y)`` over
    the beams that returned (``A`` their rows of ``A_b``); with fewer, ``y`` times ``M``'s scale,
    ``cbrt(det M)`` (``1 / (1 + s)``: a rotation has determinant 1).

    Parameters
    ----------
    y : numpy.ndarray
        Beam velocities, shape (M, 4) [m/s], NaN where a beam did not return.
    A_b : numpy.ndarray
        Beam directions in the head frame, shape (4, 3) [-].
    M : numpy.ndarray
        The correction ``C_bh / (1 + s)``, shape (3, 3) [-].

    Returns
    -------
    numpy.ndarray
        Corrected beam velocities, shape (M, 4) [m/s], NaN where ``y`` is.
    """
    out = np.full_like(y, np.nan)
    returned = np.isfinite(y)
    scale = float(np.cbrt(np.linalg.det(M)))
    patterns, which = np.unique(returned, axis=0, return_inverse=True)
    for p, pattern in enumerate(patterns):
        rows = np.flatnonzero(which.reshape(-1) == p)
        if not pattern.any():
            continue
        Y = y[np.ix_(rows, np.flatnonzero(pattern))]
        if pattern.sum() < MIN_BEAMS_FOR_VELOCITY:
            corrected = Y * scale
        else:
            A = A_b[pattern]
            V = Y @ np.linalg.pinv(A).T  # (m, 3): each ping's least-squares head velocity
            corrected = (V @ M.T) @ A.T + (Y - V @ A.T)
        out[np.ix_(rows, np.flatnonzero(pattern))] = corrected
    return out
