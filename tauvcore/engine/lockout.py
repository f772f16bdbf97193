"""Recovery from a lock-out: the velocity reset to the DVL's after the gate has rejected it for long.

A filter whose error has left its own covariance (an initial misalignment drawn in the tail of its
prior, a sensor fault) sees innovations beyond the gate; rejected, they correct nothing, the error
keeps growing faster than the covariance, and every later ping is rejected too: the filter is
locked out for good (the divergence monitor's lock-out, tauvcore.engine.monitor). PX4's EKF2
resets the states a source observes to its measurement after a timeout and says so; this does the
same for the DVL, whose measurement is the velocity.

After ``filter.lockout_reset_updates`` consecutive pings that returned beams but fused nothing,
the velocity is reset at the next such ping. The ping's beams ``A_k`` (k x 3, the unit vectors
of the beams that returned) measure ``y_k = (1 + sf) A_k v_b + A_k (omega x l) + b_k + n``
(tauvcore.sensors.dvl); with the estimated beam biases, scale factor and the lever arm's
velocity taken out,

    m = (y_k - b_k - A_k (omega x l)) / (1 + sf)  =  A_k v_b + noise,

and the reset moves the body velocity by the least change that meets it:

    v_b+ = v_b + A_k^+ (m - A_k v_b),     v_n+ = C_nb v_b+.

With three or four beams ``A_k^+ A_k = I``: the velocity is the ping's, whatever it was. With two
(or one) the component along ``N = I - A_k^+ A_k``, which the beams do not see, is kept.

The velocity error state is the body frame's (tauvcore.filter.layout), so the error after the
reset is a linear function of the error before, to first order:

    dv+ = N dv - A_k^+ (E_k db + A_k v_b dsf + A_k [l x] dbg + n) / (1 + sf),

``E_k`` the rows of the beams that returned. The covariance follows exactly: ``P+ = J P J^T``
plus ``A_k^+ R_k A_k^+T / (1 + sf)^2`` on the velocity, ``J`` the identity with the velocity rows
replaced by those of ``dv+``. The velocity's error is now the measurement's, correlated with the
DVL's own error states as the measurement is.
The reset is marked in the DVL's update records (``UpdateRecord.reset``); the monitor does not
count the rejected pings before it as a lock-out, and starts its innovation window again after it.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import skew


class BeamPing(NamedTuple):
    """One DVL ping of one run as the reset reads it."""

    y_beam_mps: np.ndarray  # (4,) the beam velocities [m/s] (those not returned are ignored)
    available: np.ndarray  # (4,) bool: the beams that returned (at least one)
    omega_nb_b_rps: np.ndarray  # (3,) the gyro's body rate relative to n (earth rate out, bias in) [rad/s]


class BeamGeometry(NamedTuple):
    """The DVL's beams as the reset reads them."""

    A_b: np.ndarray  # (4, 3) the beams' unit vectors in the body frame (tauvcore.sensors.dvl)
    l_dvl_b_m: np.ndarray  # (3,) the DVL's lever arm from the IMU, body frame [m]
    beam_var_m2ps2: float  # variance of one beam's velocity noise [m^2/s^2]


def dvl_velocity_reset(
    vel_n: np.ndarray,
    P: np.ndarray,
    C_nb: np.ndarray,
    sensor_errors: tuple[float, np.ndarray, np.ndarray],
    ping: BeamPing,
    geometry: BeamGeometry,
) -> tuple[np.ndarray, np.ndarray]:
    """One filter's velocity and covariance reset to a DVL ping (module docstring).

    Parameters
    ----------
    vel_n : numpy.ndarray
        Shape (3,), the estimated velocity, NED [m/s].
    P : numpy.ndarray
        Shape (20, 20), the error-state covariance (tauvcore.filter.layout.STATE) in SI units.
    C_nb : numpy.ndarray
        Shape (3, 3), the estimated attitude, body to NED.
    sensor_errors : tuple
        ``(sf, b_dvl_mps, gyro_bias_rps)``: the estimated DVL scale factor [-], beam biases (4,)
        [m/s] and gyro bias (3,), body frame [rad/s] (taken out of ``ping.omega_nb_b_rps`` here).
    ping : BeamPing
        The ping.
    geometry : BeamGeometry
        The DVL's beams, lever arm and beam noise.

    Returns
    -------
    vel_n : numpy.ndarray
        Shape (3,), the reset velocity, NED [m/s].
    P : numpy.ndarray
        Shape (20, 20), the reset covariance (a new array, symmetric).
    """
    sf, b_dvl_mps, gyro_bias_rps = sensor_errors
    y_beam_mps, available, omega_nb_b_rps = ping
    A_b, l_dvl_b_m, beam_var_m2ps2 = geometry
    beams = np.asarray(available, dtype=bool)
    A = A_b[beams]
    scale = 1.0 + sf
    omega_b = omega_nb_b_rps - gyro_bias_rps
    lever_mps = A @ np.cross(omega_b, l_dvl_b_m)
    measured = (y_beam_mps[beams] - b_dvl_mps[beams] - lever_mps) / scale
    v_b = C_nb.T @ vel_n
    A_pinv = np.linalg.pinv(A)
    v_b_new = v_b + A_pinv @ (measured - A @ v_b)
    J = np.eye(P.shape[-1])  # the sources' own states (after the 20) as they are
    J[: STATE.dim, : STATE.dim] = reset_jacobian(v_b, sf, beams, A_b, l_dvl_b_m)
    out = J @ P @ J.T
    out[STATE.vel, STATE.vel] += beam_var_m2ps2 * (A_pinv @ A_pinv.T) / scale**2
    return C_nb @ v_b_new, 0.5 * (out + out.T)


def reset_jacobian(
    v_b_mps: np.ndarray, sf: float, available: np.ndarray, A_b: np.ndarray, l_dvl_b_m: np.ndarray
) -> np.ndarray:
    """The error state after a reset as a linear function of the error state before (module
    docstring): the identity with the velocity rows replaced.

    Parameters
    ----------
    v_b_mps : numpy.ndarray
        Shape (3,), the estimated body velocity before the reset [m/s].
    sf : float
        The estimated DVL scale factor [-].
    available : numpy.ndarray
        Shape (4,) bool, the beams that returned.
    A_b : numpy.ndarray
        Shape (4, 3), the beams' unit vectors in the body frame.
    l_dvl_b_m : numpy.ndarray
        Shape (3,), the DVL's lever arm from the IMU, body frame [m].

    Returns
    -------
    numpy.ndarray
        Shape (20, 20): ``dx+ = J dx`` (tauvcore.filter.layout.STATE), without the ping's noise.
    """
    beams = np.asarray(available, dtype=bool)
    A = A_b[beams]
    A_pinv = np.linalg.pinv(A)
    scale = 1.0 + sf
    J = np.eye(STATE.dim)
    vel = STATE.vel
    J[vel, vel] = np.eye(3) - A_pinv @ A
    J[vel, STATE.b_dvl] = 0.0
    J[vel, np.flatnonzero(beams) + STATE.b_dvl.start] = -A_pinv / scale
    J[vel, STATE.sf_dvl] = -(A_pinv @ A @ v_b_mps)[:, None] / scale
    J[vel, STATE.bg] = -A_pinv @ A @ skew(l_dvl_b_m) / scale
    return J


def fuse_reacquiring(
    bank: Any,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    reacquire: np.ndarray,
) -> tuple[np.ndarray, ...]:
    """The DVL's correction of the filter bank ``bank`` (tauvcore.engine.filter_bank.FilterBank)
    with the gate open for the filters ``reacquire`` (M, R) and as usual for the others: two
    compiled corrections over disjoint filters. The records keep the test ratio against the
    configured gate, so the ping shows as beyond it.

    Parameters
    ----------
    bank : FilterBank
        The bank, corrected in place.
    H, Rm, nu, active : numpy.ndarray
        The ping's rows of every filter: Jacobians (M, R, 4, d), noise (M, R, 4, 4) [m^2/s^2],
        innovations (M, R, 4) [m/s], the rows in use (M, R, 4) bool.
    reacquire : numpy.ndarray
        Shape (M, R) bool: the filters whose velocity was reset at the last ping.

    Returns
    -------
    tuple of numpy.ndarray
        The correction's outcome as tauvcore.filter.eskf.fuse_in_place returns it, (M, R, ...).
    """
    gated = bank._fuse(H, Rm, nu, active & ~reacquire[..., None], bank.dvl_gate_rows)
    opened = bank._fuse(H, Rm, nu, active & reacquire[..., None], bank.dvl_gate_rows, gate=np.inf)
    s_diag, keep, nis, _, unusable, log_det_s = opened
    gate = bank.gate
    with np.errstate(invalid="ignore", divide="ignore"):
        each = np.where(active & reacquire[..., None], nu**2 / (gate**2 * s_diag), -np.inf)
    ratio = np.where(reacquire, np.max(each, axis=-1), gated[3])
    pick = reacquire[..., None]
    return (
        np.where(pick, s_diag, gated[0]),
        np.where(pick, keep, gated[1]),
        np.where(reacquire, nis, gated[2]),
        ratio,
        np.where(reacquire, unusable, gated[4]),
        np.where(reacquire, log_det_s, gated[5]),
    )


def lockout_reset(
    bank: Any,
    refused: np.ndarray,
    valid: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    omega_meas: np.ndarray,
) -> np.ndarray:
    """At the ``filter.lockout_reset_updates``-th consecutive ping of which the gate let
    nothing through, reset the velocity of the filter bank ``bank`` to it (:func:`dvl_velocity_reset`).
    A tightly coupled filter that refuses one beam and fuses the others is not locked out: its gate
    is isolating that beam (a real DVL's faulty beam).

    Parameters
    ----------
    bank : FilterBank
        The bank (tauvcore.engine.filter_bank.FilterBank): its velocities, covariances and counts
        of rejected pings, written in place.
    refused : numpy.ndarray
        Shape (M, R) bool: the filters that fused nothing of this ping.
    valid : numpy.ndarray
        Shape (M, R) bool: the filters that had a measurement from it.
    y : numpy.ndarray
        The ping's beam velocities, shape (R, 4) [m/s].
    available : numpy.ndarray
        Shape (R, 4) bool: the beams that returned.
    omega_meas : numpy.ndarray
        The gyros' rate at the ping, shape (R, 3) [rad/s].

    Returns
    -------
    numpy.ndarray
        Shape (M, R) bool: the filters reset at this ping.
    """
    rejected = valid & refused
    bank.dvl_rejected = np.where(rejected, bank.dvl_rejected + 1, 0)
    limit = bank.config.filter.lockout_reset_updates
    due = rejected & (bank.dvl_rejected >= limit) if limit > 0 else np.zeros(bank.batch, bool)
    if not due.any():
        return due
    geometry = BeamGeometry(bank.A_b, bank.l_dvl_b, dvl_beam_sigma_mps(bank.config.dvl.noise_mps) ** 2)
    for m, r in zip(*np.nonzero(due), strict=True):
        C = bank.C[m, r]
        w_ie_b = C.T @ bank.w_ie
        bank.vel[m, r], bank.P[m, r] = dvl_velocity_reset(
            bank.vel[m, r],
            bank.P[m, r],
            C,
            (float(bank.sf[m, r]), bank.bdvl[m, r], bank.bg[m, r]),
            BeamPing(y[r], available[r], omega_meas[r] - w_ie_b),
            geometry,
        )
    bank.dvl_rejected[due] = 0
    bank.dvl_reacquire[due] = True
    return due
