"""The one truth record that every generator fills (kinematic and 6-DOF dynamic)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.geo.earth import Earth


@dataclass(frozen=True)
class VehicleRecord:
    """What only a simulated vehicle has, at the same samples as its :class:`Truth`
    (tauvcore.truth.dynamic): actuators and the autopilot's view of its mission.

    Raises
    ------
    ValueError
        If a field does not have K samples, shape (K,) (the fins (K, 4)).
    """

    propeller_rpm: np.ndarray  # (K,) propeller speed [rev/min]
    fin_angles_rad: np.ndarray  # (K, 4) fin deflections, fins 1-4 of tauvcore.truth.vehicle [rad]
    heading_cmd_rad: np.ndarray  # (K,) guidance's heading command [rad]
    pitch_cmd_rad: np.ndarray  # (K,) guidance's pitch command [rad]
    cross_track_m: np.ndarray  # (K,) distance from the mission's path, positive to its right [m]
    depth_error_m: np.ndarray  # (K,) depth less the mission's depth schedule [m]

    def __post_init__(self) -> None:
        k = self.propeller_rpm.shape[0]
        for name in ("propeller_rpm", "heading_cmd_rad", "pitch_cmd_rad", "cross_track_m", "depth_error_m"):
            if getattr(self, name).shape != (k,):
                raise ValueError(
                    f"VehicleRecord.{name} must have shape ({k},), got {getattr(self, name).shape}"
                )
        if self.fin_angles_rad.shape != (k, 4):
            raise ValueError(
                f"VehicleRecord.fin_angles_rad must have shape ({k}, 4), got {self.fin_angles_rad.shape}"
            )


@dataclass(frozen=True)
class Truth:
    """True vehicle motion sampled at the IMU epochs ``t_s`` (K samples, uniform step): a whole
    mission, or a chunk of one (tauvcore.truth.kinematic.TruthStream) whose ``t_s`` are the
    mission's times and whose row k is the mission's sample k0 + k.

    Every field is resolved in the frame its name says (tauvcore.conventions); the IMU
    quantities ``f_b`` and ``omega_ib_b`` are the instantaneous values; ``dtheta_ib_b`` and ``dv_b``
    the increments an error-free strapdown IMU outputs over each sample interval.

    Raises
    ------
    ValueError
        If a field does not have K samples: (K, 3) vectors, ``C_nb`` (K, 3, 3), ``vehicle`` K samples.
    """

    name: str  # generator/scenario name, e.g. "figure8"
    earth: Earth  # earth model the motion was generated with
    t_s: np.ndarray  # (K,) time [s]; t_s[0] = 0 for a whole mission
    pos_n: np.ndarray  # (K, 3) position from the sea-surface point above the start, NED [m] (WGS-84: in
    # that point's tangent frame)
    vel_n: np.ndarray  # (K, 3) velocity relative to the earth, NED [m/s]
    vel_b: np.ndarray  # (K, 3) the same velocity in the body frame [m/s] (surge, sway, heave)
    C_nb: np.ndarray  # (K, 3, 3) attitude, body to NED
    euler: np.ndarray  # (K, 3) roll, pitch, yaw [rad]
    omega_nb_b: np.ndarray  # (K, 3) body rate relative to the tangent frame [rad/s]
    omega_ib_b: np.ndarray  # (K, 3) body rate relative to inertial space (gyro truth) [rad/s]
    f_b: np.ndarray  # (K, 3) specific force (accelerometer truth) [m/s^2]
    dtheta_ib_b: (
        np.ndarray
    )  # (K, 3) exact integral of omega_ib_b over (t_k-1, t_k]; mission's row 0 zero [rad]
    dv_b: np.ndarray  # (K, 3) exact integral of f_b over (t_k-1, t_k]; mission's row 0 zero [m/s]
    step_s: float | None = None  # sample interval [s] when known exactly (a chunk's t_s[1] - t_s[0] is off by
    # round-off late in a long mission, and a 1-sample chunk has none); None: from t_s
    pos_nav: np.ndarray | None = (
        None  # (K, 3) position as the INS holds it: pos_n in the flat model; latitude
    )
    # [rad], longitude [rad], depth [m] on WGS-84 (earth.model); None: pos_n
    vehicle: VehicleRecord | None = None  # actuators and guidance of the dynamic truth; None: kinematic
    current_n_mps: np.ndarray | None = None  # (K, 3) the ocean current at the vehicle, NED [m/s]
    # (tauvcore.truth.current); None: still water

    @property
    def vel_water_b(self) -> np.ndarray:
        """(K, 3) velocity relative to the water in the body frame [m/s]: ``vel_b - C_nb^T c_n``
        (``vel_b`` in still water)."""
        if self.current_n_mps is None:
            return self.vel_b
        return self.vel_b - np.einsum("kji,kj->ki", self.C_nb, self.current_n_mps)

    def __post_init__(self) -> None:
        k = self.t_s.shape[0]
        for name in (
            "pos_n",
            "vel_n",
            "vel_b",
            "euler",
            "omega_nb_b",
            "omega_ib_b",
            "f_b",
            "dtheta_ib_b",
            "dv_b",
        ):
            if getattr(self, name).shape != (k, 3):
                raise ValueError(f"Truth.{name} must have shape ({k}, 3), got {getattr(self, name).shape}")
        if self.C_nb.shape != (k, 3, 3):
            raise ValueError(f"Truth.C_nb must have shape ({k}, 3, 3), got {self.C_nb.shape}")
        if self.pos_nav is None:
            object.__setattr__(self, "pos_nav", self.pos_n)
        elif self.pos_nav.shape != (k, 3):
            raise ValueError(f"Truth.pos_nav must have shape ({k}, 3), got {self.pos_nav.shape}")
        if self.current_n_mps is not None and self.current_n_mps.shape != (k, 3):
            raise ValueError(f"Truth.current_n_mps must have shape ({k}, 3), got {self.current_n_mps.shape}")
        if self.vehicle is not None and self.vehicle.propeller_rpm.shape != (k,):
            raise ValueError(
                f"Truth.vehicle must have {k} samples, got {self.vehicle.propeller_rpm.shape[0]}"
            )

    @property
    def depth_m(self) -> np.ndarray:
        """(K,) depth below the surface [m] (the flat model's down coordinate; -height on WGS-84)."""
        assert self.pos_nav is not None  # __post_init__ sets pos_n where it was not given
        return self.pos_nav[:, 2]

    @property
    def dt_s(self) -> float:
        """Sample interval [s]."""
        return float(self.t_s[1] - self.t_s[0]) if self.step_s is None else self.step_s

    @property
    def num_samples(self) -> int:
        """Number of samples K."""
        return int(self.t_s.shape[0])
