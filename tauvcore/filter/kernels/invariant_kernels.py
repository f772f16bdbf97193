"""The invariant filter's correction compiled: the retraction on SE_2(3) and the covariance's carry
(the compiled twins of tauvcore.filter.invariant.retract and carry_matrix, held equal to them by
tests/unit/tauvcore/filter/test_invariant.py)."""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import ATT, BA, BDVL, BG, POS, SF, VEL, jit
from tauvcore.filter.kernels.correction import add_position_into
from tauvcore.filter.kernels.rotation_kernels import exp_so3_into

SERIES_ANGLE = 1e-4  # below this angle [rad] J_l uses its Taylor series (as tauvcore.filter.invariant)


@jit
def left_jacobian_so3_into(p0: float, p1: float, p2: float, out: np.ndarray) -> None:
    """``J_l(phi) = I + a [phi x] + b [phi x]^2`` (tauvcore.filter.invariant.left_jacobian_so3) into
    ``out`` (3, 3)."""
    a2 = p0 * p0 + p1 * p1 + p2 * p2
    angle = math.sqrt(a2)
    if angle < SERIES_ANGLE:
        a = 0.5 - a2 / 24.0
        b = 1.0 / 6.0 - a2 / 120.0
    else:
        a = (1.0 - math.cos(angle)) / a2
        b = (angle - math.sin(angle)) / (a2 * angle)
    # [phi x]^2 = phi phi^T - |phi|^2 I
    p = (p0, p1, p2)
    k = ((0.0, -p2, p1), (p2, 0.0, -p0), (-p1, p0, 0.0))
    for r in range(3):
        for c in range(3):
            out[r, c] = (1.0 if r == c else 0.0) + a * k[r][c] + b * (p[r] * p[c] - (a2 if r == c else 0.0))


@jit
def retract_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    dvl_bias: np.ndarray,
    sf: np.ndarray,
    extra: np.ndarray,
    P: np.ndarray,
    dx: np.ndarray,
    i: int,
    geodetic: bool,
) -> None:
    """Filter ``i``: ``X_hat <- exp(T dx) X_hat``, sensor errors and the sources' states added, then
    ``P <- M P M^T`` (M the identity on the sources' states)."""
    N = P.shape[-1]
    E = np.empty((3, 3))
    J = np.empty((3, 3))
    C0 = np.empty((3, 3))
    exp_so3_into(dx[i, ATT], dx[i, ATT + 1], dx[i, ATT + 2], E)
    left_jacobian_so3_into(dx[i, ATT], dx[i, ATT + 1], dx[i, ATT + 2], J)
    for r in range(3):
        for c in range(3):
            C0[r, c] = C[i, r, c]
    move = np.empty(3)
    v_new = np.empty(3)
    Cdv = np.empty(3)
    for r in range(3):
        move[r] = J[r, 0] * dx[i, POS] + J[r, 1] * dx[i, POS + 1] + J[r, 2] * dx[i, POS + 2]
        Cdv[r] = C0[r, 0] * dx[i, VEL] + C0[r, 1] * dx[i, VEL + 1] + C0[r, 2] * dx[i, VEL + 2]
    for r in range(3):
        v_new[r] = (E[r, 0] * vel[i, 0] + E[r, 1] * vel[i, 1] + E[r, 2] * vel[i, 2]) + (
            J[r, 0] * Cdv[0] + J[r, 1] * Cdv[1] + J[r, 2] * Cdv[2]
        )
    add_position_into(pos[i], move[0], move[1], move[2], geodetic)
    for r in range(3):
        vel[i, r] = v_new[r]
        for c in range(3):
            C[i, r, c] = E[r, 0] * C0[0, c] + E[r, 1] * C0[1, c] + E[r, 2] * C0[2, c]
        accel_bias[i, r] += dx[i, BA + r]
        gyro_bias[i, r] += dx[i, BG + r]
    for b in range(4):
        dvl_bias[i, b] += dx[i, BDVL + b]
    sf[i] += dx[i, SF]
    for e in range(extra.shape[1]):
        extra[i, e] += dx[i, SF + 1 + e]
    # M = I but M[pos, att] = -[move x], M[vel, vel] = C_new^T C_old (= C_old^T E^T C_old)
    Rv = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            Rv[r, c] = C[i, 0, r] * C0[0, c] + C[i, 1, r] * C0[1, c] + C[i, 2, r] * C0[2, c]
    K = ((0.0, move[2], -move[1]), (-move[2], 0.0, move[0]), (move[1], -move[0], 0.0))  # -[move x]
    Pi = P[i]
    A = np.empty((N, N))  # M P
    for j in range(N):
        for r in range(3):
            A[POS + r, j] = (
                Pi[POS + r, j] + K[r][0] * Pi[ATT, j] + K[r][1] * Pi[ATT + 1, j] + K[r][2] * Pi[ATT + 2, j]
            )
            A[VEL + r, j] = Rv[r, 0] * Pi[VEL, j] + Rv[r, 1] * Pi[VEL + 1, j] + Rv[r, 2] * Pi[VEL + 2, j]
        for r in range(ATT, ATT + 3):
            A[r, j] = Pi[r, j]
        for r in range(VEL + 3, N):
            A[r, j] = Pi[r, j]
    for j in range(N):  # (M P) M^T: the same on the columns
        for r in range(3):
            Pi[j, POS + r] = (
                A[j, POS + r] + K[r][0] * A[j, ATT] + K[r][1] * A[j, ATT + 1] + K[r][2] * A[j, ATT + 2]
            )
            Pi[j, VEL + r] = Rv[r, 0] * A[j, VEL] + Rv[r, 1] * A[j, VEL + 1] + Rv[r, 2] * A[j, VEL + 2]
        for r in range(ATT, ATT + 3):
            Pi[j, r] = A[j, r]
        for r in range(VEL + 3, N):
            Pi[j, r] = A[j, r]
    for r in range(N):  # exactly symmetric
        for c in range(r):
            Pi[r, c] = Pi[c, r]


@jit
def retract_batch(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    dvl_bias: np.ndarray,
    sf: np.ndarray,
    extra: np.ndarray,
    P: np.ndarray,
    dx: np.ndarray,
    invariant: np.ndarray,
    geodetic: bool,
) -> None:
    """:func:`retract_into` for the filters ``invariant`` (n,) of n, in place; the others untouched."""
    for i in range(pos.shape[0]):
        if invariant[i]:
            retract_into(pos, vel, C, accel_bias, gyro_bias, dvl_bias, sf, extra, P, dx, i, geodetic)
