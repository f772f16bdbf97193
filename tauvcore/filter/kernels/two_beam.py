"""The two-beam constructions of the extended methods, compiled.

tauvcore.aiding.dvl_partial derives them: every extended method is affine in the compensated
beams and the predicted velocity, v = C y_c + D v_hat; its C, D, per-row gain g and assumption
error a depend only on the beam geometry and which two beams returned, so the filter bank looks
them up in tables built once (DVL_PATTERNS availability patterns x up to four candidates), and
:func:`partial_into` applies a method's candidates (the selector's choice among four, eq. 48-49).
"""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import jit

MAX_CANDIDATES = 4
SELECT_TIE_REL = 1e-12
"""The selector takes a later candidate's row only if its variance is smaller by more than this
(relative): rows that several methods build identically tie within round-off."""


@jit
def compensated_beams_into(
    A: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    dvl_bias: np.ndarray,
    sf: float,
    omega_comp: np.ndarray,
    l: np.ndarray,
    out: np.ndarray,
) -> None:
    """``y_c = (y - b_hat - A (omega_hat_nb x l)) / (1 + SF_hat)``, zero where not returned."""
    lx = (
        omega_comp[1] * l[2] - omega_comp[2] * l[1],
        omega_comp[2] * l[0] - omega_comp[0] * l[2],
        omega_comp[0] * l[1] - omega_comp[1] * l[0],
    )
    for k in range(4):
        if available[k]:
            lever = A[k, 0] * lx[0] + A[k, 1] * lx[1] + A[k, 2] * lx[2]
            out[k] = (y[k] - dvl_bias[k] - lever) / (1.0 + sf)
        else:
            out[k] = 0.0


@jit
def apply_solution_into(
    C: np.ndarray,
    D: np.ndarray,
    gain: np.ndarray,
    a: np.ndarray,
    y_c: np.ndarray,
    S: np.ndarray,
    v_hat: np.ndarray,
    P_vel: np.ndarray,
    v: np.ndarray,
    R: np.ndarray,
) -> None:
    """``v = C y_c + D v_hat``, ``R = C S C^T + (g D) P (g D)^T + a a^T`` (one row of C, D, g, a
    per velocity axis)."""
    CS = np.empty((3, 4))
    GP = np.empty((3, 3))
    for i in range(3):
        s = 0.0
        for k in range(4):
            s += C[i, k] * y_c[k]
        for k in range(3):
            s += D[i, k] * v_hat[k]
        v[i] = s
        for j in range(4):
            t = 0.0
            for k in range(4):
                t += C[i, k] * S[k, j]
            CS[i, j] = t
        for j in range(3):
            t = 0.0
            for k in range(3):
                t += gain[i] * D[i, k] * P_vel[k, j]
            GP[i, j] = t
    for i in range(3):
        for j in range(3):
            t = 0.0
            for k in range(4):
                t += CS[i, k] * C[j, k]
            u = 0.0
            for k in range(3):
                u += GP[i, k] * (gain[j] * D[j, k])
            R[i, j] = (t + u) + a[i] * a[j]


@jit
def partial_into(
    candidates: tuple,
    y_c: np.ndarray,
    S: np.ndarray,
    v_hat: np.ndarray,
    P_vel: np.ndarray,
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """A method's two-beam velocity from its candidates (one for VB, NSV, PLCF, VHV; four for the
    selector, eq. 48-49: per axis the candidate with the smallest variance, the earlier one on a
    tie within :data:`SELECT_TIE_REL`; rows recombined so that R keeps their cross terms).
    ``candidates`` ``(n_cand, ok, Cc, Dc, gc, ac, mc)``: candidate c < n_cand is ok[c], C (3, 4),
    D (3, 3), g, a, measured (3,). ``out`` ``(v, R, measured, choice)``, written: the velocity (3,),
    its covariance (3, 3), the measured axes (3,) and the candidate of each measured axis, -1 none
    (``choice``, selector only; else -1)."""
    n_cand, ok, Cc, Dc, gc, ac, mc = candidates
    v, R, measured, choice = out
    v_c = np.empty(3)
    R_c = np.empty((3, 3))
    if n_cand == 1:
        for i in range(3):
            choice[i] = -1
            measured[i] = ok[0] and mc[0, i]
        if ok[0]:
            apply_solution_into(Cc[0], Dc[0], gc[0], ac[0], y_c, S, v_hat, P_vel, v, R)
        else:
            for i in range(3):
                v[i] = 0.0
                for j in range(3):
                    R[i, j] = 1.0 if i == j else 0.0
        return
    best = np.full(3, np.inf)
    pick = np.zeros(3, dtype=np.int64)
    for c in range(n_cand):
        if not ok[c]:
            continue
        apply_solution_into(Cc[c], Dc[c], gc[c], ac[c], y_c, S, v_hat, P_vel, v_c, R_c)
        for i in range(3):
            # a tie within round-off (several methods share the same row, e.g. the surge of beams 1-2)
            # goes to the earlier candidate: the last bit does not decide
            if mc[c, i] and R_c[i, i] < best[i] * (1.0 - SELECT_TIE_REL):
                best[i] = R_c[i, i]
                pick[i] = c
    C = np.empty((3, 4))
    D = np.empty((3, 3))
    g = np.empty(3)
    a = np.empty(3)
    for i in range(3):
        measured[i] = math.isfinite(best[i])
        choice[i] = pick[i] if measured[i] else -1
        C[i, :] = Cc[pick[i], i, :]
        D[i, :] = Dc[pick[i], i, :]
        g[i] = gc[pick[i], i]
        a[i] = ac[pick[i], i]
    apply_solution_into(C, D, g, a, y_c, S, v_hat, P_vel, v, R)


@jit
def apply_solution_batch(
    C: np.ndarray,
    D: np.ndarray,
    gain: np.ndarray,
    a: np.ndarray,
    y_c: np.ndarray,
    S: np.ndarray,
    v_hat: np.ndarray,
    P_vel: np.ndarray,
) -> tuple:
    n = y_c.shape[0]
    v = np.empty((n, 3))
    R = np.empty((n, 3, 3))
    for i in range(n):
        apply_solution_into(C[i], D[i], gain[i], a[i], y_c[i], S[i], v_hat[i], P_vel[i], v[i], R[i])
    return v, R


@jit
def compensated_beams_batch(
    A: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    dvl_bias: np.ndarray,
    sf: np.ndarray,
    omega_comp: np.ndarray,
    l: np.ndarray,
) -> np.ndarray:
    out = np.empty((y.shape[0], 4))
    for i in range(y.shape[0]):
        compensated_beams_into(A, y[i], available[i], dvl_bias[i], sf[i], omega_comp[i], l, out[i])
    return out


@jit
def select_batch(
    ok: np.ndarray,
    Cc: np.ndarray,
    Dc: np.ndarray,
    gc: np.ndarray,
    ac: np.ndarray,
    mc: np.ndarray,
    y_c: np.ndarray,
    S: np.ndarray,
    v_hat: np.ndarray,
    P_vel: np.ndarray,
) -> tuple:
    """:func:`partial_into` with the selector's candidates for n entries sharing one pattern."""
    n = y_c.shape[0]
    v = np.empty((n, 3))
    R = np.empty((n, 3, 3))
    measured = np.empty((n, 3), dtype=np.bool_)
    choice = np.empty((n, 3), dtype=np.int64)
    for i in range(n):
        candidates = (ok.shape[0], ok, Cc, Dc, gc, ac, mc)
        partial_into(candidates, y_c[i], S[i], v_hat[i], P_vel[i], (v[i], R[i], measured[i], choice[i]))
    return v, R, measured, choice
