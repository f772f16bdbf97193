"""The NED velocity aid of Yoo 2014's filter (tauvcore.filter.families.yoo.model_kernels.fuse), and
the states the aiding sources add (tauvcore.filter.layout.StateBlock) in it: today the DVL's
current (north, east, ``dvl.current_states``).

The covariance of the 12-state filter is ``[12 estimated, 5 consider, E added]``: the added states
come after the consider states, are estimated (their rows of the gain are the Kalman gain's) and
are uncoupled from the rest in F (each a first-order Gauss-Markov process or a random walk,
the 20-state kernels' exact discrete step, tauvcore.filter.kernels.error_model_kernels.extra_step_into).

The current enters through the velocities that are relative to the water. Yoo's aiding velocity is
a NED velocity rotated with the estimated attitude, ``z = C_est u_b``; when ``u_b`` is the
velocity through the water (the RPM velocity of ``vkf`` beyond the switch altitude, the DVL's
water-track), ``z = v - c`` with ``c = [c_N, c_E, 0]``. With ``C_est = exp(-[rho x]) C_true`` the
innovation ``z - (v_est - c_est)`` is ``dv - dc + [w x] rho`` with ``w = v_est - c_est``, so

    H = [I, [w x], 0, 0 | consider | -[e_N e_E]]

(the numpy reference's ``velocity_H``, tests/unit/tauvcore/engine/yoo_reference.py; tests/unit/tauvcore/engine/test_yoo_velocity.py
holds it to finite differences). Over ground
(bottom-track) ``w = v_est`` and the current's columns are zero: Yoo's H, exactly.

The VKF learns its scale factor and bias from the DVL's surge through the water, the bottom-track
surge less the current's body part by the ``vkf`` method's own estimate (as ``--rpm-fallback``
does, tauvcore.engine.dvl_fusion.rpm_fallback). What it learns then carries that estimate's error
along the body axis ``a`` it learned on: its speed is ``x . (v - c) + (c - c_l) . a``, ``c_l`` the
estimate it took (tauvcore.engine.rpm_aid.RpmAid). So the RPM velocity predicts
``v - c + x (c - c_l) . a`` and its current columns are ``-[e_N e_E] + x a_NE^T``: on a straight
track (``x = a``) the RPM says nothing of the current along it, which the VKF's bias took, and
only its zero sway and heave observe the current across it. (With ``-[e_N e_E]`` alone the filter
would read the along-track current from a VKF that learned it from the filter: on the long-range
mission its current NEES per dimension is then about 2.2, over-confident.)

The water-track beams of a ping (``dvl.water_track``) are the least squares' body velocity over
the beams that water-tracked (at least three), fused by both methods after the bottom-track's
update as a NED velocity through the water (tauvcore.engine.yoo_loop.run_stops), recorded as the
source ``water``.
It shares the DVL's scale factor and beam biases (tauvcore.sensors.dvl), so its consider columns are
the bottom-track's with the velocity through the water.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.dvl_water import CURRENT_BLOCK
from tauvcore.config import Config
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.families.yoo.model_kernels import NA
from tauvcore.filter.layout import STATE, Layout


@dataclass(frozen=True)
class Added:
    """The added states of a run's layout as the 12-state filter carries them."""

    layout: Layout
    rate: np.ndarray  # (E,) -1/tau [1/s], 0 for a random walk
    q: np.ndarray  # (E,) PSD of the driving noise [unit^2/s]
    sigma0: np.ndarray  # (E,) initial 1-sigma [unit]
    current: slice | None  # the current's (north, east) columns of the covariance; None: none
    water_var: float | None  # a water-track beam's noise variance [m^2/s^2]; None: not fused

    @property
    def num(self) -> int:
        """E: number of added states."""
        return self.layout.num_extra

    @property
    def dim(self) -> int:
        """The covariance's dimension: 12 estimated, 5 consider, E added."""
        return NA + self.num

    @property
    def estimated(self) -> np.ndarray:
        """The estimated states' indices in the covariance: the 12, then the added (12 + E,)."""
        return np.r_[np.arange(yoo.DIM), np.arange(NA, self.dim)].astype(np.int64)

    def nees_blocks(self, base: np.ndarray, num_base: int) -> tuple[np.ndarray, int]:
        """Each estimated state's NEES block: the 12 states' own, then one per added block.

        Parameters
        ----------
        base : numpy.ndarray
            Shape (12,) int: the 12 states' blocks (0 .. ``num_base`` - 1).
        num_base : int
            Their number of blocks.

        Returns
        -------
        block_of_state : numpy.ndarray
            Shape (12 + E,) int.
        num_blocks : int
            ``num_base`` and the added blocks.
        """
        out = np.r_[np.asarray(base, np.int64), np.zeros(self.num, np.int64)]
        start = yoo.DIM
        for b, block in enumerate(self.layout.blocks):
            out[start : start + block.dim] = num_base + b
            start += block.dim
        return out, num_base + len(self.layout.blocks)

    def current_in(self, extra: np.ndarray) -> np.ndarray:
        """The estimated current.

        Parameters
        ----------
        extra : numpy.ndarray
            The added states' estimates, shape (..., E), in their units.

        Returns
        -------
        numpy.ndarray
            The current, NED with a zero down part, shape (..., 3) [m/s]; zero without a current
            block.
        """
        c_n = np.zeros(extra.shape[:-1] + (3,))
        if self.current is not None:
            c_n[..., :2] = extra[..., self.current.start - NA : self.current.stop - NA]
        return c_n


def added_states(config: Config, layout: Layout) -> Added:
    """The added states of ``layout`` (tauvcore.engine.source_streams.layout_of) for the 12-state filter.

    Parameters
    ----------
    config : Config
        The configuration: its ``[dvl]`` section's water-track.
    layout : Layout
        The run's error state.

    Returns
    -------
    Added
        Their processes, the current's columns (after the 12 + 5) and, with current states and a
        water-tracking DVL, the water-track beam's noise variance.
    """
    rate, q, sigma0 = layout.extra_arrays()
    current = None
    if CURRENT_BLOCK in {b.name for b in layout.blocks}:
        s = layout.slice_of(CURRENT_BLOCK)
        current = slice(NA + s.start - STATE.dim, NA + s.stop - STATE.dim)
    water = current is not None and config.dvl.water_track != "off"
    water_var = max(config.dvl.water_track_noise_mps, 1e-3) ** 2 if water else None
    return Added(layout, rate, q, sigma0, current, water_var)
