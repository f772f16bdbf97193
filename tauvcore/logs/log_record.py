"""A recorded log as the reader hands it out (tauvcore.logs.read_log) and the plausibility checks
judge it (tauvcore.logs.checks): every table validated, in SI units and the frames of
tauvcore.conventions."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Log:
    """A validated log, in SI units and the frames of tauvcore.conventions."""

    source: str  # the directory it was read from
    imu_t_s: np.ndarray  # (K,) IMU sample times [s], uniform
    dtheta_b: np.ndarray  # (K, 3) angle increments over (t_k-1, t_k] [rad]; row 0 zero
    dv_b: np.ndarray  # (K, 3) velocity increments [m/s]; row 0 zero
    ref_t_s: np.ndarray | None = None  # (N,) reference times [s]; None: the log has no reference
    ref_position: np.ndarray | None = None  # (N, 3) latitude [rad], longitude [rad], depth [m]; or NED [m]
    ref_geodetic: bool = False  # whether ref_position is geodetic
    ref_euler: np.ndarray | None = None  # (N, 3) roll, pitch, yaw [rad]
    ref_vel_n: np.ndarray | None = None  # (N, 3) NED velocity [m/s]
    dvl_t_s: np.ndarray | None = None  # (M,) ping times [s]
    dvl_beams_mps: np.ndarray | None = None  # (M, 4) beam velocities, NaN where not returned
    dvl_body_mps: np.ndarray | None = None  # (M, 3) body velocity (NaN rows: invalid), if the log has that
    dvl_water_track: np.ndarray | None = None  # (M, 4) bool: the beam's velocity (of a body velocity:
    # the row's, each beam's projection) is water-track, relative to the water layer; None: every
    # velocity bottom-track (a table without the mode columns)
    dvl_water_mps: np.ndarray | None = None  # (M, 4) water-track beam velocities beside the bottom-track
    # ones (dvl_beams_mps or dvl_body_mps then bottom-track only), NaN where a beam did not water-track
    # [m/s]; None: a table without beam1_water_mps .. beam4_water_mps (a DVL that does not output both)
    dvl_truth: Mapping[str, np.ndarray] = field(default_factory=dict)  # (M,) each: the DVL's true errors
    # a simulated log carries (tauvcore.aiding.dvl_beams: true_beam1_bias_mps, ..., true_scale_factor)
    notes: tuple[str, ...] = ()  # what the reader changed (a resampled IMU), for the user
    sources: Mapping[str, Mapping[str, np.ndarray]] = field(default_factory=dict)  # the aiding
    # sources' tables (tauvcore.aiding.sources: the depth's, the magnetometer's attitude, a USBL's)
    # by source name: "t_s" (E,) [s] and each of its columns (E,) in SI (an angle in radians)

    def table(self, name: str, columns: Sequence[str]) -> tuple[np.ndarray, np.ndarray] | None:
        """An aiding source's table: its times and the columns asked for, side by side.

        Parameters
        ----------
        name : str
            The source's name (a key of :attr:`sources`, e.g. ``"depth"``).
        columns : Sequence[str]
            Names of the table's columns to return, in SI units (an angle in radians), e.g.
            ``("depth_m",)``.

        Returns
        -------
        tuple of numpy.ndarray or None
            The source's times (E,) [s] and its ``columns`` side by side (E, len(columns)), each in
            the unit and frame its name says; None if the log has no table for it.
        """
        table = self.sources.get(name)
        if table is None:
            return None
        return table["t_s"], np.stack([table[c] for c in columns], axis=-1)

    @property
    def dt_s(self) -> float:
        """The IMU's sample interval [s] (the median of the log's)."""
        return float(np.median(np.diff(self.imu_t_s)))

    @property
    def duration_s(self) -> float:
        """The IMU record's span, last sample time less the first [s]."""
        return float(self.imu_t_s[-1] - self.imu_t_s[0])
