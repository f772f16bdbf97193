"""The nominal navigation state, the one error-state layout (Tal et al. 2017 eq. 8) and the
process-noise layout (eq. 11).

No other module spells a numeric state index: use ``STATE.vel`` etc.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from tauvcore.geo.rotations import mv


@dataclass(frozen=True)
class NavState:
    """Navigation solution: position and velocity in the NED n-frame, attitude body to NED
    (batch shape ``...``)."""

    pos_n: np.ndarray  # (..., 3) [m]
    vel_n: np.ndarray  # (..., 3) [m/s]
    C_nb: np.ndarray  # (..., 3, 3)

    @property
    def vel_b(self) -> np.ndarray:
        """Body-frame velocity (surge, sway, heave), shape (..., 3) [m/s], b-frame (FRD)."""
        return mv(np.swapaxes(self.C_nb, -1, -2), self.vel_n)


class ErrorStateLayout:
    """Named slices of the 20-state error vector ``dx = x_true - x_hat``."""

    pos: ClassVar[slice] = slice(0, 3)  # position error, n frame [m]
    att: ClassVar[slice] = slice(3, 6)  # misalignment rho, n frame [rad]: C_true = exp([rho x]) C_hat
    vel: ClassVar[slice] = slice(6, 9)  # body-frame velocity error [m/s]
    ba: ClassVar[slice] = slice(9, 12)  # accelerometer bias error, b frame [m/s^2]
    bg: ClassVar[slice] = slice(12, 15)  # gyro bias error, b frame [rad/s]
    b_dvl: ClassVar[slice] = slice(15, 19)  # DVL beam bias errors, beams 1-4 [m/s]
    sf_dvl: ClassVar[slice] = slice(19, 20)  # DVL scale factor error [-]
    dim: ClassVar[int] = 20

    @property
    def names(self) -> tuple[str, ...]:
        """The blocks' names in state order, each the attribute that holds its slice."""
        return ("pos", "att", "vel", "ba", "bg", "b_dvl", "sf_dvl")


class ProcessNoiseLayout:
    """Named slices of the 17-element process noise ``w`` (eq. 11)."""

    accel: ClassVar[slice] = slice(0, 3)  # accelerometer white noise [m/s^2/sqrt(Hz)]
    gyro: ClassVar[slice] = slice(3, 6)  # gyro white noise [rad/s/sqrt(Hz)]
    ba: ClassVar[slice] = slice(6, 9)  # accelerometer bias random walk
    bg: ClassVar[slice] = slice(9, 12)  # gyro bias random walk
    b_dvl: ClassVar[slice] = slice(12, 16)  # DVL beam bias random walk
    sf_dvl: ClassVar[slice] = slice(16, 17)  # DVL scale factor random walk
    dim: ClassVar[int] = 17


STATE = ErrorStateLayout()
NOISE = ProcessNoiseLayout()


def _indices(*slices: slice) -> tuple[int, ...]:
    return tuple(i for s in slices for i in range(s.start, s.stop))


NEES_BLOCKS: dict[str, tuple[int, ...]] = {
    "pos": _indices(STATE.pos),
    "vel": _indices(STATE.vel),
    "tilt": _indices(slice(STATE.att.start, STATE.att.start + 2)),  # rho_N, rho_E: roll and pitch
    "heading": _indices(slice(STATE.att.start + 2, STATE.att.stop)),  # rho_D: rotation about the vertical
    "sensor": _indices(STATE.ba, STATE.bg, STATE.b_dvl, STATE.sf_dvl),
}
"""The blocks whose NEES every method reports beside the full state's, as state indices.

The misalignment ``rho`` is in the n (NED) frame, so its horizontal components are the tilt
(levelling error: what the accelerometers and gravity observe) and its down component is the
heading (azimuth) error, which DVL aiding alone leaves unobservable on a straight line. The
sensor block holds the IMU biases and the DVL beam biases and scale factor."""
