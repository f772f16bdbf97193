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


@dataclass(frozen=True)
class StateBlock:
    """States an aiding source adds after the layout's 20 (``AidingSource.states``): each a
    first-order Gauss-Markov process (``rate_per_s`` = -1/tau) or a random walk (0) driven by
    white noise of PSD ``q_psd``, uncoupled in F from the rest (what couples them is the
    source's measurement), starting at zero with 1-sigma ``sigma0``."""

    name: str  # the block's name: its NEES block and its column in every table ("current")
    labels: tuple[str, ...]  # each state's name, its unit in it ("current_north_mps", ...)
    sigma0: tuple[float, ...]  # initial 1-sigma of each state, in its unit
    rate_per_s: tuple[float, ...]  # -1/tau [1/s] of each state; 0: a random walk
    q_psd: tuple[float, ...]  # PSD of each state's driving noise [unit^2/s]

    @property
    def dim(self) -> int:
        """Number of states."""
        return len(self.labels)


@dataclass(frozen=True)
class Layout:
    """The error state of a run: the 20 of :data:`STATE`, then the blocks its sources add, in order."""

    blocks: tuple[StateBlock, ...] = ()

    @property
    def dim(self) -> int:
        """Number of error states, 20 and the blocks'."""
        return STATE.dim + self.num_extra

    @property
    def num_extra(self) -> int:
        """E: number of the sources' states."""
        return sum(b.dim for b in self.blocks)

    def slice_of(self, name: str) -> slice:
        """The states of block ``name``: a slice of the error state.

        Parameters
        ----------
        name : str
            A block of :attr:`blocks` (e.g. ``"current"``).

        Returns
        -------
        slice
            Its indices in the error state (after the 20 of :data:`STATE`).
        """
        start = STATE.dim
        for b in self.blocks:
            if b.name == name:
                return slice(start, start + b.dim)
            start += b.dim
        raise KeyError(name)

    @property
    def nees_blocks(self) -> dict[str, tuple[int, ...]]:
        """:data:`NEES_BLOCKS`, then one NEES block per source block, by name."""
        out = dict(NEES_BLOCKS)
        for b in self.blocks:
            out[b.name] = _indices(self.slice_of(b.name))
        return out

    def extra_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The blocks' states as the kernels take them.

        Returns
        -------
        rate : numpy.ndarray
            Shape (E,): each state's -1/tau [1/s] (0 for a random walk).
        q : numpy.ndarray
            Shape (E,): the PSD of its driving noise [unit^2/s].
        sigma0 : numpy.ndarray
            Shape (E,): its initial 1-sigma [unit].
        """
        rate = np.array([r for b in self.blocks for r in b.rate_per_s], dtype=float)
        q = np.array([v for b in self.blocks for v in b.q_psd], dtype=float)
        sigma = np.array([v for b in self.blocks for v in b.sigma0], dtype=float)
        return rate, q, sigma


BASE_LAYOUT = Layout()
"""The error state without any source's states: the 20 of :data:`STATE`."""
