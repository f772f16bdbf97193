"""The fixed-interval smoother's backward pass (Rauch-Tung-Striebel) on the error state of a
closed-loop (feedback) filter, compiled: :func:`smooth_backward`.

The forward filter leaves, at each of its marks (an output epoch, or an aiding epoch where it
corrected), the transition ``Phi`` from the previous mark's posterior to this mark's prior, the
prior and posterior covariances ``P-`` and ``P+`` and the correction ``d`` it injected into its
nominal state there (``x+ = x- (+) d``). Its error-state estimate is zero after every correction
(the feedback filter's reset), and the prediction of the error at the next mark is zero too, so
the smoother's estimates are the errors of the filtered nominal states:

    s+_e = A_e s-_{e+1},          A_e = P+_e Phi_{e+1}^T (P-_{e+1})^-1
    s-_e = d_e + s+_e
    Ps_e = P+_e + A_e (Ps_{e+1} - P-_{e+1}) A_e^T

from ``s+ = 0``, ``Ps = P+`` at the last mark: ``s+_e`` estimates ``x_true (-) x+_e``, the
error of the filter's posterior, given every measurement of the mission, and ``s-_e`` the same
error of its prior, ``x-_e`` (a correction moves the nominal by ``d``: to first order, errors
relative to ``x-`` and to ``x+`` differ by ``d``). The smoothed estimate is ``x+_e (+) s+_e``.
This is the RTS smoother of the linearised system the filter ran (its F, H, gate decisions and
corrections as they were), written for the error state the filter resets; on a linear model it
is the RTS smoother of that model, exactly (tests/unit/tauvcore/filter/kernels/test_smoother.py holds it equal to batch
least squares).

The transitions are those of tauvcore.filter.kernels.error_model_kernels: the identity but for rows
``0..a-1`` and columns ``0..b-1``, given as ``X = (Phi - I)[:a, :b]``, and for the last E
states, the ones the aiding sources add (tauvcore.filter.layout.StateBlock), each uncoupled and
scaled by its own ``phi`` (``exp(-dt/tau)`` of a Gauss-Markov state, 1 for a random walk);
``a = b = n`` and E = 0 give a dense Phi. ``A_e`` is never formed: ``Z = (P-_{e+1})^-1 Phi_{e+1} P+_e`` by Cholesky, ``A_e = Z^T``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tauvcore.filter.kernels.common import jit
from tauvcore.filter.kernels.nees import cholesky_into


@jit
def _solve_spd_into(A: np.ndarray, B: np.ndarray, Z: np.ndarray, L: np.ndarray, idx: np.ndarray) -> bool:
    """``Z = A^-1 B`` for a symmetric positive definite A (n, n) and B (n, n) by Cholesky (L
    scratch); False where A is not positive definite or not finite."""
    n = A.shape[0]
    if not cholesky_into(A, idx, n, L):
        return False
    for c in range(B.shape[1]):
        for i in range(n):  # L y = b
            t = B[i, c]
            for k in range(i):
                t -= L[i, k] * Z[k, c]
            Z[i, c] = t / L[i, i]
        for i in range(n - 1, -1, -1):  # L^T z = y
            t = Z[i, c]
            for k in range(i + 1, n):
                t -= L[k, i] * Z[k, c]
            Z[i, c] = t / L[i, i]
    return True


@jit
def _step(
    X_n: np.ndarray,
    E_n: np.ndarray,
    Pm_n: np.ndarray,
    s_n: np.ndarray,
    Ps_n: np.ndarray,
    Pp: np.ndarray,
    s_out: np.ndarray,
    Ps_out: np.ndarray,
    work: np.ndarray,
    idx: np.ndarray,
) -> bool:
    """One backward step of a filter: from the next mark's transition ``I + X_n`` (and ``E_n``
    on its last states' diagonal), prior ``Pm_n``, smoothed prior error ``s_n`` and smoothed covariance ``Ps_n``, this mark's posterior
    ``Pp`` -> its smoothed error ``s_out`` and covariance ``Ps_out`` (module docstring). False
    (and ``s_out = 0``, ``Ps_out = Pp``: the smoother starts afresh) where ``Pm_n`` is not
    positive definite. ``work`` (4, n, n) scratch."""
    n = Pp.shape[0]
    a, b = X_n.shape[0], X_n.shape[1]
    B, Z, L, D = work[0], work[1], work[2], work[3]
    for i in range(n):  # B = Phi Pp
        for j in range(n):
            B[i, j] = Pp[i, j]
    for i in range(a):
        for j in range(n):
            t = 0.0
            for k in range(b):
                t += X_n[i, k] * Pp[k, j]
            B[i, j] += t
    for e in range(E_n.shape[0]):  # the sources' states: uncoupled, each its own phi
        for j in range(n):
            B[n - E_n.shape[0] + e, j] *= E_n[e]
    if not _solve_spd_into(Pm_n, B, Z, L, idx):
        for i in range(n):
            s_out[i] = 0.0
            for j in range(n):
                Ps_out[i, j] = Pp[i, j]
        return False
    for i in range(n):  # s+ = Z^T s-
        t = 0.0
        for k in range(n):
            t += Z[k, i] * s_n[k]
        s_out[i] = t
    for i in range(n):  # D = (Ps_n - Pm_n) Z
        for j in range(n):
            t = 0.0
            for k in range(n):
                t += (Ps_n[i, k] - Pm_n[i, k]) * Z[k, j]
            D[i, j] = t
    for i in range(n):  # Ps = Pp + Z^T D, upper triangle mirrored: exactly symmetric
        for j in range(i, n):
            t = 0.0
            for k in range(n):
                t += Z[k, i] * D[k, j]
            Ps_out[i, j] = Pp[i, j] + t
            Ps_out[j, i] = Ps_out[i, j]
    return True


class OutputMarks(NamedTuple):
    """A stretch's T output marks (no correction there: prior and posterior are one), B filters."""

    X: np.ndarray  # (T, B, a, b) the transition since the mark before, ``(Phi - I)[:a, :b]``
    E: np.ndarray  # (T, B, E) its last E states' diagonal
    P: np.ndarray  # (T, B, n, n) the covariance


class AidingMarks(NamedTuple):
    """A stretch's V aiding marks, B filters."""

    X: np.ndarray  # (V, B, a, b) the transition since the mark before
    E: np.ndarray  # (V, B, E) its last E states' diagonal
    Pm: np.ndarray  # (V, B, n, n) the covariance before the correction
    Pp: np.ndarray  # (V, B, n, n) after it
    d: np.ndarray  # (V, B, n) the correction injected into the nominal state
    pos: np.ndarray  # (V,) int64: mark j comes after the first pos[j] output marks (non-decreasing)


class CarriedMark(NamedTuple):
    """The mark after a stretch, per filter (B of them), written with the stretch's first on return."""

    has: np.ndarray  # (B,) bool; False: the stretch ends the mission
    X: np.ndarray  # (B, a, b) its transition
    E: np.ndarray  # (B, E)
    Pm: np.ndarray  # (B, n, n) its prior covariance
    s: np.ndarray  # (B, n) its smoothed prior error
    Ps: np.ndarray  # (B, n, n) its smoothed covariance


@jit
def smooth_backward(
    outputs: OutputMarks,
    aiding: AidingMarks,
    carry: CarriedMark,
    s_out: np.ndarray,
    Ps_out: np.ndarray,
    cuts: np.ndarray,
) -> None:
    """The backward pass over one stretch of marks of B filters (module docstring), latest first:
    its T ``outputs`` and V ``aiding`` marks (aiding mark j after the first ``aiding.pos[j]``
    output marks and before the rest), followed by the mark ``carry`` holds; on return the carry
    holds the stretch's first mark, for the stretch before it.

    Fills ``s_out`` (T, B, n), the smoothed error ``x_true (-) x+`` of each output mark's
    estimate, and ``Ps_out`` (T, B, n, n) its covariance; ``cuts`` (B,) counts the steps where a
    prior was not positive definite (the smoother started afresh there)."""
    out_X, out_E, out_P = outputs
    ev_X, ev_E, ev_Pm, ev_Pp, ev_d, ev_pos = aiding
    carry_has, carry_X, carry_E, carry_Pm, carry_s, carry_Ps = carry
    T, V = out_P.shape[0], ev_Pm.shape[0]
    Bn = out_P.shape[1] if T else ev_Pm.shape[1]
    n = carry_Ps.shape[1]
    work = np.empty((4, n, n))
    idx = np.arange(n)
    s_plus = np.empty(n)
    Ps = np.empty((n, n))
    zero_d = np.zeros(n)
    for f in range(Bn):
        t = T - 1
        j = V - 1
        while t >= 0 or j >= 0:
            event = j >= 0 and (t < 0 or ev_pos[j] > t)
            if event:
                Pp, Pm, d, X, E = ev_Pp[j, f], ev_Pm[j, f], ev_d[j, f], ev_X[j, f], ev_E[j, f]
            else:
                Pp, Pm, d, X, E = out_P[t, f], out_P[t, f], zero_d, out_X[t, f], out_E[t, f]
            if carry_has[f]:
                if not _step(
                    carry_X[f], carry_E[f], carry_Pm[f], carry_s[f], carry_Ps[f], Pp, s_plus, Ps, work, idx
                ):
                    cuts[f] += 1
            else:
                s_plus[:] = 0.0
                Ps[:, :] = Pp
            if not event:
                s_out[t, f] = s_plus
                Ps_out[t, f] = Ps
            carry_has[f] = True
            carry_X[f] = X
            carry_E[f] = E
            carry_Pm[f] = Pm
            for i in range(n):
                carry_s[f, i] = d[i] + s_plus[i]
            carry_Ps[f] = Ps
            if event:
                j -= 1
            else:
                t -= 1
