"""Strapdown mechanization in the earth-fixed NED tangent frame n, at the IMU rate.

Continuous model (tauvcore.conventions; Farrell 2008, tangent-frame mechanization):

    pos_n' = vel_n
    vel_n' = C_nb f_b + g_n - 2 omega_ie_n x vel_n
    C_nb'  = C_nb [omega_ib_b x] - [omega_ie_n x] C_nb

Discrete step over the interval (t_k-1, t_k] from the IMU increments ``dtheta``, ``dv`` of this
and the previous interval (Savage's two-sample algorithms, Strapdown Analytics ch. 7):

- attitude: ``C_k = exp(-[omega_ie_n x] dt) C_k-1 exp([phi x])``,
  ``phi = dtheta_k + (dtheta_k-1 x dtheta_k) / 12`` (coning);
- velocity: ``vel_k = vel_k-1 + C_e/2 C_k-1 dv_rot + (g_n - 2 omega_ie_n x vel_mid) dt`` with
  ``dv_rot = dv_k + (dtheta_k x dv_k) / 2 + dtheta_k x (dtheta_k x dv_k) / 6
  + (dtheta_k-1 x dv_k + dv_k-1 x dtheta_k) / 12`` (rotation compensation to second order: the
  series of ``int exp([omega t x]) f dt`` for a constant rate over the interval; and sculling) and ``C_e/2 = exp(-[omega_ie_n x] dt/2)``, the n frame's
  own turn to mid-interval (without it a level vehicle sees a spurious ``omega_ie x g dt / 2``,
  2e-6 m/s^2 at 150 Hz);
- position: trapezoid of velocity.

The coning and sculling corrections depend on the increments only, so :func:`body_increments`
computes them for a whole run at once; the per-step work is then a Rodrigues formula and a few
products, and every step function takes a leading batch shape (Monte Carlo runs and methods as
array dimensions). Bias corrections enter as ``- b dt`` on the compensated increments (the bias
part of the coning/sculling terms is below 1e-12 and dropped).
"""

from __future__ import annotations

import numpy as np

from tauvcore.filter.layout import NavState
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import exp_so3, skew

SECOND_ORDER_ROTATION = True
"""Include ``dtheta x (dtheta x dv) / 6`` in the velocity increment. Off only to measure what the
term buys (benchmarks/strapdown_rate.py): 1 / rate^2 of error, metres in minutes of rolling turns."""


def body_increments(
    dtheta_b: np.ndarray, dv_b: np.ndarray, previous: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Coning- and sculling-compensated increments for every interval of a run (or of a chunk).

    dtheta_b, dv_b: (K, ..., 3) raw increments, row k over (t_k-1, t_k]. Without ``previous`` the
    rows are a mission's from its start: row 0 is unused and the first interval (row 1) has no
    predecessor, so its corrections use zero. With ``previous`` = the raw increments (..., 3) of
    the interval before row 0 (a chunk of a longer mission), every row has its predecessor.
    Returns ``phi`` (rotation vector) and ``dv_rot`` (velocity increment in the b frame at
    t_k-1), each (K, ..., 3).
    """
    if previous is None:
        prev_th = np.concatenate([np.zeros_like(dtheta_b[:1]), dtheta_b[:-1]])
        prev_dv = np.concatenate([np.zeros_like(dv_b[:1]), dv_b[:-1]])
        prev_th[1:2] = 0.0
        prev_dv[1:2] = 0.0
    else:
        prev_th = np.concatenate([np.asarray(previous[0])[None], dtheta_b[:-1]])
        prev_dv = np.concatenate([np.asarray(previous[1])[None], dv_b[:-1]])
    phi = dtheta_b + np.cross(prev_th, dtheta_b) / 12.0
    cross = np.cross(dtheta_b, dv_b)
    dv_rot = dv_b + 0.5 * cross + (np.cross(prev_th, dv_b) + np.cross(prev_dv, dtheta_b)) / 12.0
    if SECOND_ORDER_ROTATION:
        dv_rot = dv_rot + np.cross(dtheta_b, cross) / 6.0
    return phi, dv_rot


class Strapdown:
    """Mechanization with the earth terms of one :class:`Earth` precomputed."""

    def __init__(self, earth: Earth, dt_s: float) -> None:
        self.dt_s = dt_s
        self.g_n = np.ascontiguousarray(earth.g_n, dtype=float)
        self.omega_ie_n = earth.omega_ie_n
        self.C_earth = exp_so3(-self.omega_ie_n * dt_s)  # n-frame turn of one step
        self.C_earth_half = exp_so3(-0.5 * self.omega_ie_n * dt_s)
        # v @ M == -2 omega_ie_n x v  (row-vector form)
        self.coriolis_T = np.ascontiguousarray((-2.0 * skew(self.omega_ie_n)).T)
        self.geodetic = (
            earth.geodetic
        )  # WGS-84: positions are latitude, longitude, depth; earth terms per step

    def step(self, nav: NavState, phi_b: np.ndarray, dv_rot_b: np.ndarray) -> NavState:
        """Advance one IMU interval with bias-corrected compensated increments (:func:`body_increments`).

        The formula is the compiled kernel :func:`tauvcore.filter.kernels.strapdown_kernels.strapdown_step_into` (the one
        the filter bank runs), applied to every entry of the batch."""
        # numba: not loaded for `tauv --help`
        from tauvcore.filter.kernels.common import plain
        from tauvcore.filter.kernels.strapdown_kernels import StrapdownConstants, strapdown_batch

        batch = nav.pos_n.shape[:-1]
        shape = np.broadcast_shapes(batch, phi_b.shape[:-1], dv_rot_b.shape[:-1])
        pos = np.array(np.broadcast_to(nav.pos_n, shape + (3,)), dtype=float).reshape(-1, 3)
        vel = np.array(np.broadcast_to(nav.vel_n, shape + (3,)), dtype=float).reshape(-1, 3)
        C = np.array(np.broadcast_to(nav.C_nb, shape + (3, 3)), dtype=float).reshape(-1, 3, 3)
        phi = np.ascontiguousarray(np.broadcast_to(phi_b, shape + (3,)), dtype=float).reshape(-1, 3)
        dv = np.ascontiguousarray(np.broadcast_to(dv_rot_b, shape + (3,)), dtype=float).reshape(-1, 3)
        sd = StrapdownConstants(
            self.dt_s, self.C_earth, self.C_earth_half, self.g_n, self.coriolis_T, self.geodetic
        )
        strapdown_batch(pos, vel, C, phi, dv, plain(sd))
        return NavState(
            pos_n=pos.reshape(shape + (3,)), vel_n=vel.reshape(shape + (3,)), C_nb=C.reshape(shape + (3, 3))
        )
