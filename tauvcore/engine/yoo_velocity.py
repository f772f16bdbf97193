"""The NED velocity aid of Yoo 2014's filter (tauvcore.engine.yoo_bank: :func:`fuse_velocity`), and
the states the aiding sources add (tauvcore.filter.layout.StateBlock) in it: today the DVL's
current (north, east, ``dvl.current_states``).

The covariance of the 12-state filter is ``[12 estimated, 5 consider, E added]``: the added states
come after the consider states, are estimated (their rows of the gain are the Kalman gain's) and
are uncoupled from the rest in F (each a first-order Gauss-Markov process or a random walk,
:func:`propagate_added`, the 20-state kernels' exact discrete step).

The current enters through the velocities that are relative to the water. Yoo's aiding velocity is
a NED velocity rotated with the estimated attitude, ``z = C_est u_b``; when ``u_b`` is the
velocity through the water (the RPM velocity of ``vkf`` beyond the switch altitude, the DVL's
water-track), ``z = v - c`` with ``c = [c_N, c_E, 0]``. With ``C_est = exp(-[rho x]) C_true`` the
innovation ``z - (v_est - c_est)`` is ``dv - dc + [w x] rho`` with ``w = v_est - c_est``, so

    H = [I, [w x], 0, 0 | consider | -[e_N e_E]]

(:func:`velocity_H`; tests/unit/test_yoo_velocity.py holds it to finite differences). Over ground
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
update as a NED velocity through the water (:func:`fuse_water`), recorded as the source ``water``.
It shares the DVL's scale factor and beam biases (tauvcore.sensors.dvl), so its consider columns are
the bottom-track's with the velocity through the water.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.aiding.dvl_water import CURRENT_BLOCK
from tauvcore.config import Config
from tauvcore.filter import yoo
from tauvcore.filter.layout import STATE, Layout
from tauvcore.filter.yoo_kernels import NA
from tauvcore.geo.rotations import exp_so3, skew


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
    """The added states of ``layout`` (tauvcore.engine.sources.layout_of) for the 12-state filter.

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


def propagate_added(P: np.ndarray, added: Added, dt_s: float) -> None:
    """The added states over ``dt_s``, in place: their rows and columns of ``P`` (B, N, N) scale by
    ``phi = exp(rate dt)`` and each variance gains ``q (1 - phi^2) / (-2 rate)`` (``q dt`` for a
    walk), as tauvcore.filter.kernels.error_model.extra_step_into.

    Parameters
    ----------
    P : numpy.ndarray
        Covariance, shape (B, N, N), the added states last, in their units squared; written.
    added : Added
        The added states.
    dt_s : float
        The step [s].
    """
    for e in range(added.num):
        a, rate, q = NA + e, float(added.rate[e]), float(added.q[e])
        if rate != 0.0:
            phi = np.exp(rate * dt_s)
            P[:, a, :] *= phi
            P[:, :, a] *= phi
            P[:, a, a] += q * (1.0 - phi * phi) / (-2.0 * rate)
        else:
            P[:, a, a] += q * dt_s


def velocity_H(
    vel_n: np.ndarray,
    c_n: np.ndarray,
    Hc: np.ndarray,
    through_water: np.ndarray | None,
    added: Added,
    learned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """A NED velocity aid's prediction and Jacobian (module docstring).

    Parameters
    ----------
    vel_n : numpy.ndarray
        Estimated velocity over ground, shape (..., 3) [m/s], NED.
    c_n : numpy.ndarray
        Estimated current, shape (..., 3) [m/s], NED (down zero).
    Hc : numpy.ndarray
        The measurement's columns on the consider states, shape (..., 3, 5) [m/s per unit].
    through_water : numpy.ndarray or None
        Shape (...) bool: the measured velocity is through the water; None: over ground.
    added : Added
        The added states.
    learned : tuple of numpy.ndarray or None
        An RPM velocity's VKF (module docstring): the body x axis ``x`` now, the axis ``a`` and the
        current estimate ``c_l`` [m/s] of its last update, each (..., 3) NED; None: none.

    Returns
    -------
    h : numpy.ndarray
        The prediction, ``v``, ``v - c`` or with ``learned`` ``v - c + x (c - c_l) . a``, shape
        (..., 3) [m/s].
    H : numpy.ndarray
        Its Jacobian over ``[dv_n, rho, d_ba, d_bg, consider, added]``, shape (..., 3, N).
    """
    water = np.zeros(vel_n.shape[:-1], bool) if through_water is None else np.asarray(through_water, bool)
    h = vel_n - np.where(water[..., None], c_n, 0.0)
    H = np.zeros(vel_n.shape[:-1] + (3, added.dim))
    H[..., yoo.VEL] = np.eye(3)
    H[..., yoo.ATT] = skew(h)
    H[..., yoo.DIM : NA] = np.where(np.isfinite(Hc), Hc, 0.0)
    if added.current is not None:
        Hcur = np.broadcast_to(-np.eye(3)[:, :2], H.shape[:-2] + (3, 2))
        if learned is not None:
            x_n, a_n, c_l = learned
            along = np.einsum("...j,...j->...", c_n - c_l, a_n)
            h = h + np.where(water[..., None], x_n * along[..., None], 0.0)
            Hcur = Hcur + x_n[..., :, None] * a_n[..., None, :2]
        H[..., added.current] = np.where(water[..., None, None], Hcur, 0.0)
    return h, H


def surge_current(C_nb: np.ndarray, c_n: np.ndarray) -> np.ndarray:
    """The current's part along the body x axis, ``(C^T c)_x``.

    Parameters
    ----------
    C_nb : numpy.ndarray
        Attitudes, shape (..., 3, 3), body (FRD) to NED.
    c_n : numpy.ndarray
        Currents, shape (..., 3) [m/s], NED.

    Returns
    -------
    numpy.ndarray
        Shape (...) [m/s].
    """
    return np.einsum("...j,...j->...", C_nb[..., :, 0], c_n)


def fuse_water(bank: Any, chunk: Any, p: int, i: int, store: dict[str, np.ndarray]) -> None:
    """The water-track beams of ping ``p`` (sample ``i`` of ``chunk``) fused by every method of the
    Yoo bank ``bank`` (tauvcore.engine.yoo_bank.YooBank) with at least three of them, as a NED
    velocity through the water (module docstring), gated as the bank's DVL update
    (:func:`fuse_velocity`), recorded in the store's ``wt_*`` rows of the ping (the source
    ``water``).

    Parameters
    ----------
    bank : YooBank
        The bank: its estimates and covariance, written in place.
    chunk : SimChunk
        The chunk of the ping: its DVL data's ``y_water_mps`` and ``water_available`` (pings, R, 4).
    p : int
        The ping within the chunk.
    i : int
        The ping's sample within the chunk.
    store : dict[str, numpy.ndarray]
        The chunk's store.
    """
    added: Added = bank.added
    assert added.water_var is not None  # called only when the bank fuses water-track
    R = bank.batch[1]
    dvl = chunk.dvl
    w_b, cov_b, ok, gain = bank._dvl_velocity(
        chunk, i, dvl.y_water_mps[p], dvl.water_available[p], added.water_var
    )
    for m in range(bank.batch[0]):
        C = bank.C[m]
        z = np.einsum("rij,rj->ri", C, w_b)
        Rm = np.einsum("rij,rjk,rlk->ril", C, cov_b, C)
        w_est_b = np.einsum("rji,rj->ri", C, bank.vel[m] - added.current_in(bank.extra[m]))
        Hc = C @ np.concatenate([w_est_b[..., None], gain], axis=-1)
        fuse_velocity(bank, m, z, Rm, ok, Hc, p, store, np.ones(R, bool), prefix="wt")


def fuse_velocity(
    bank: Any,
    m: int,
    z: np.ndarray,
    Rm: np.ndarray,
    valid: np.ndarray,
    Hc: np.ndarray,
    p: int,
    store: dict[str, np.ndarray],
    water: np.ndarray | None = None,
    learned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    prefix: str = "up",
) -> None:
    """One method of the Yoo bank fuses a NED velocity rotated into n with the estimated attitude.

    Its error is ``dv + [v x] rho`` (``C_est = exp(-[rho x]) C_true``), so ``H = [I, [v x], 0, 0]``
    (the paper's H of eq. 18 leaves the attitude column out), ``v`` the estimated velocity (the
    measured one would put the measurement's noise into H: a random lever on the heading that
    the filter reads as information about it), and ``Hc`` on the consider states, whose rows of K
    are zero. Through the water it is ``v - c`` with the current states (:func:`velocity_H`).
    Gated as a whole at ``bank.gate``; the NIS is over S before the gate (NaN where S is not
    finite or not invertible).

    Parameters
    ----------
    bank : YooBank
        The bank (tauvcore.engine.yoo_bank.YooBank): its estimates and covariance, written in place.
    m : int
        The method's index along the bank's method axis.
    z : numpy.ndarray
        The measured velocity, shape (R, 3) [m/s], NED.
    Rm : numpy.ndarray
        Its noise covariance, shape (R, 3, 3) [m^2/s^2].
    valid : numpy.ndarray
        Shape (R,) bool: there is a measurement.
    Hc : numpy.ndarray
        Its columns on the consider states, shape (R, 3, 5) [m/s per unit].
    p : int
        The ping's row in ``store``.
    store : dict[str, numpy.ndarray]
        The chunk's store: its ``up_*`` records are written.
    water : numpy.ndarray or None
        Shape (R,) bool: the velocity is through the water; None: over ground.
    learned : tuple of numpy.ndarray or None
        An RPM velocity's learning (:func:`velocity_H`); None: none.
    prefix : str
        The store's records written: ``up`` (the DVL's, or the RPM's) or ``wt`` (water-track).
    """
    P = bank.P[m]
    c_n = bank.added.current_in(bank.extra[m])
    h, H = velocity_H(bank.vel[m], c_n, Hc, water, bank.added, learned)
    nu = z - h  # dv = true - estimate
    PHt = P @ H.swapaxes(-1, -2)  # (R, N, 3)
    S = H @ PHt + Rm
    S_diag = np.einsum("rii->ri", S)
    with np.errstate(invalid="ignore"):
        passed = np.all(nu**2 <= bank.gate**2 * S_diag, axis=-1)
    invertible = np.isfinite(S).all(axis=(-2, -1)) & (
        np.abs(np.linalg.det(np.where(np.isfinite(S), S, 0.0))) > 0.0
    )
    use = valid & passed & np.isfinite(nu).all(axis=-1) & invertible
    S_inv = np.linalg.inv(np.where(invertible[:, None, None], S, np.eye(3)))
    K = PHt @ np.where(use[:, None, None], S_inv, np.eye(3))  # (R, N, 3)
    K[:, yoo.DIM : NA, :] = 0.0  # consider states: never corrected
    dx = np.einsum("rij,rj->ri", K, np.where(use[:, None], nu, 0.0))
    I_KH = np.eye(bank.added.dim) - K @ H
    P_new = I_KH @ P @ I_KH.swapaxes(-1, -2) + K @ Rm @ K.swapaxes(-1, -2)
    P_new = 0.5 * (P_new + P_new.swapaxes(-1, -2))
    bank.P[m] = np.where(use[:, None, None], P_new, P)
    with np.errstate(invalid="ignore"):
        nis = np.where(invertible, np.einsum("ri,rij,rj->r", nu, S_inv, nu), np.nan)
    # inject and reset (feedback)
    bank.vel[m] += dx[:, yoo.VEL]
    bank.C[m] = exp_so3(dx[:, yoo.ATT]) @ bank.C[m]
    bank.ba[m] += dx[:, yoo.BA]
    bank.bg[m] += dx[:, yoo.BG]
    bank.extra[m] += dx[:, NA:]
    store[f"{prefix}_z"][p, m] = z
    store[f"{prefix}_nu"][p, m] = np.where(valid[:, None], nu, np.nan)
    store[f"{prefix}_S"][p, m] = np.where(valid[:, None], S_diag, np.nan)
    store[f"{prefix}_flags"][p, m] = np.stack([valid, use, valid & ~passed], axis=-1)
    store[f"{prefix}_nis"][p, m] = np.where(valid, nis, np.nan)
