"""Magnetometer-derived attitude (Tal et al. 2017, Table 2: 0.5 Hz, yaw 5.72 deg, roll/pitch
1.15 deg). The unit reports Euler angles (a compass with its own tilt sensing), modelled as
truth plus white noise; the yaw is wrapped to (-180, 180] deg."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.geo.rotations import wrap_angle
from tauvcore.sensors.timing import Rng, batch_shape, epoch_indices, standard_normal
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import check_settings, setting


@dataclass(frozen=True)
class MagnetometerConfig:
    rate_hz: float = setting(0.5, "rate", "Hz", 0.01, 100.0, hint="attitudes per second")
    # Table 2; [0.01, 100]: compasses report at up to ~100 Hz
    roll_pitch_noise_deg: float = setting(
        1.15, "roll/pitch noise", "deg", 0.0, 30.0, hint="1-sigma white noise of roll and of pitch"
    )  # Table 2; [0, 30]: beyond, tilt sensing says nothing
    yaw_noise_deg: float = setting(5.72, "yaw noise", "deg", 0.0, 90.0, hint="1-sigma white noise of yaw")
    # Table 2; [0, 90]: beyond, the wrap to +-180 deg makes the error far from Gaussian and the
    # heading unknown

    def __post_init__(self) -> None:
        check_settings("magnetometer", self)

    def ideal(self) -> MagnetometerConfig:
        return MagnetometerConfig(rate_hz=self.rate_hz, roll_pitch_noise_deg=0.0, yaw_noise_deg=0.0)

    @property
    def noise_rad(self) -> np.ndarray:
        """(3,) roll, pitch, yaw 1-sigma [rad]."""
        return (
            np.array([self.roll_pitch_noise_deg, self.roll_pitch_noise_deg, self.yaw_noise_deg]) * units.DEG
        )


@dataclass(frozen=True)
class MagnetometerData:
    t_s: np.ndarray  # (M,) [s]
    index: np.ndarray  # (M,) IMU sample index
    euler: np.ndarray  # (M, [R,] 3) measured roll, pitch, yaw [rad]


def simulate(
    truth: Truth, config: MagnetometerConfig, rng: np.random.Generator, num_runs: int | None = None
) -> MagnetometerData:
    """Attitudes of the whole mission as one chunk."""
    return simulate_chunk(truth, 0, epoch_indices(truth, config.rate_hz), config, rng, num_runs)


def simulate_chunk(
    truth: Truth, k0: int, index: np.ndarray, config: MagnetometerConfig, rng: Rng, num_runs: int | None
) -> MagnetometerData:
    """Euler angles plus white noise, yaw wrapped, at the mission's IMU samples ``index`` (all
    within ``truth``, whose sample 0 is the mission's sample ``k0``)."""
    rows = index - k0
    runs = batch_shape(num_runs)
    euler = truth.euler[rows][(slice(None),) + (None,) * len(runs)]
    euler = euler + standard_normal(rng, (index.size,) + runs + (3,), 1) * config.noise_rad
    euler[..., 2] = wrap_angle(euler[..., 2])
    return MagnetometerData(t_s=truth.t_s[rows], index=index, euler=euler)
