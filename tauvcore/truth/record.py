"""The one truth record that every generator fills (kinematic now, 6-DOF dynamics later)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.geo.earth import Earth


@dataclass(frozen=True)
class Truth:
    """True vehicle motion sampled at the IMU epochs ``t_s`` (K samples, uniform step): a whole
    mission, or a chunk of one (tauvcore.truth.kinematic.TruthStream) whose ``t_s`` are the
    mission's times and whose row k is the mission's sample k0 + k.

    Every field is resolved in the frame its name says (tauvcore.conventions); the IMU
    quantities ``f_b`` and ``omega_ib_b`` are the instantaneous values; ``dtheta_ib_b`` and ``dv_b``
    the increments an error-free strapdown IMU outputs over each sample interval.
    """

    name: str                 # generator/scenario name, e.g. "figure8"
    earth: Earth              # earth model the motion was generated with
    t_s: np.ndarray           # (K,) time [s]; t_s[0] = 0 for a whole mission
    pos_n: np.ndarray         # (K, 3) position from the sea-surface point above the start, NED [m] (WGS-84: in
                              # that point's tangent frame)
    vel_n: np.ndarray         # (K, 3) velocity relative to the earth, NED [m/s]
    vel_b: np.ndarray         # (K, 3) the same velocity in the body frame [m/s] (surge, sway, heave)
    C_nb: np.ndarray          # (K, 3, 3) attitude, body to NED
    euler: np.ndarray         # (K, 3) roll, pitch, yaw [rad]
    omega_nb_b: np.ndarray    # (K, 3) body rate relative to the tangent frame [rad/s]
    omega_ib_b: np.ndarray    # (K, 3) body rate relative to inertial space (gyro truth) [rad/s]
    f_b: np.ndarray           # (K, 3) specific force (accelerometer truth) [m/s^2]
    dtheta_ib_b: np.ndarray   # (K, 3) exact integral of omega_ib_b over (t_k-1, t_k]; mission's row 0 zero [rad]
    dv_b: np.ndarray          # (K, 3) exact integral of f_b over (t_k-1, t_k]; mission's row 0 zero [m/s]
    step_s: float | None = None  # sample interval [s] when known exactly (a chunk's t_s[1] - t_s[0] is off by
                                 # round-off late in a long mission, and a 1-sample chunk has none); None: from t_s
    pos_nav: np.ndarray | None = None  # (K, 3) position as the INS holds it: pos_n in the flat model; latitude
                                       # [rad], longitude [rad], depth [m] on WGS-84 (earth.model); None: pos_n

    def __post_init__(self) -> None:
        k = self.t_s.shape[0]
        for name in ("pos_n", "vel_n", "vel_b", "euler", "omega_nb_b", "omega_ib_b", "f_b", "dtheta_ib_b", "dv_b"):
            if getattr(self, name).shape != (k, 3):
                raise ValueError(f"Truth.{name} must have shape ({k}, 3), got {getattr(self, name).shape}")
        if self.C_nb.shape != (k, 3, 3):
            raise ValueError(f"Truth.C_nb must have shape ({k}, 3, 3), got {self.C_nb.shape}")
        if self.pos_nav is None:
            object.__setattr__(self, "pos_nav", self.pos_n)
        elif self.pos_nav.shape != (k, 3):
            raise ValueError(f"Truth.pos_nav must have shape ({k}, 3), got {self.pos_nav.shape}")

    @property
    def depth_m(self) -> np.ndarray:
        """(K,) depth below the surface [m] (the flat model's down coordinate; -height on WGS-84)."""
        return self.pos_nav[:, 2]

    @property
    def dt_s(self) -> float:
        """Sample interval [s]."""
        return float(self.t_s[1] - self.t_s[0]) if self.step_s is None else self.step_s

    @property
    def num_samples(self) -> int:
        return int(self.t_s.shape[0])
