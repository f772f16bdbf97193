"""Quadratic forms ``x^T A^-1 x`` by Cholesky (20^3/6 operations, not a general solve): the NEES
of the full state and of each block of tauvcore.filter.layout.NEES_BLOCKS (from one factorisation
in the right order), as tauvcore.filter.statistics.nees / block_nees and the banks' records
compute them; and the covariance a NEES against an uncertain reference takes
(:func:`add_reference_into`)."""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import jit


@jit
def cholesky_into(A: np.ndarray, idx: np.ndarray, n: int, L: np.ndarray) -> bool:
    """Lower Cholesky factor of ``A[idx[:n]][:, idx[:n]]`` into ``L[:n, :n]``; False if that
    matrix is not (numerically) positive definite or not finite.

    Column by column; the rows below the pivot four at a time, so that four independent sums are
    in flight (one row's sum is a chain of dependent multiply-adds, bound by their latency)."""
    for j in range(n):
        s0 = A[idx[j], idx[j]]
        s1 = 0.0
        k = 0
        while k + 1 < j:
            s0 -= L[j, k] * L[j, k]
            s1 -= L[j, k + 1] * L[j, k + 1]
            k += 2
        if k < j:
            s0 -= L[j, k] * L[j, k]
        s = s0 + s1
        if not s > 0.0 or not math.isfinite(s):
            return False
        d = math.sqrt(s)
        L[j, j] = d
        inv = 1.0 / d
        cj = idx[j]
        i = j + 1
        while i + 3 < n:
            t0 = A[idx[i], cj]
            t1 = A[idx[i + 1], cj]
            t2 = A[idx[i + 2], cj]
            t3 = A[idx[i + 3], cj]
            for k in range(j):
                ljk = L[j, k]
                t0 -= L[i, k] * ljk
                t1 -= L[i + 1, k] * ljk
                t2 -= L[i + 2, k] * ljk
                t3 -= L[i + 3, k] * ljk
            L[i, j] = t0 * inv
            L[i + 1, j] = t1 * inv
            L[i + 2, j] = t2 * inv
            L[i + 3, j] = t3 * inv
            i += 4
        while i < n:
            t = A[idx[i], cj]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t * inv
            i += 1
    return True


@jit
def whiten_into(A: np.ndarray, x: np.ndarray, idx: np.ndarray, n: int, L: np.ndarray, y: np.ndarray) -> bool:
    """``y = L^-1 x_s`` over the states ``s = idx[:n]``, with ``A_ss = L L^T`` (Cholesky, into L):
    ``y^T y = x_s^T (A_ss)^-1 x_s``, and the first k entries alone give that of ``s[:k]`` (the
    leading block's factor is the factor's leading block). False if ``A_ss`` is not positive
    definite or not finite."""
    if not cholesky_into(A, idx, n, L):
        return False
    for i in range(n):
        t0 = x[idx[i]]
        t1 = 0.0
        k = 0
        while k + 1 < i:
            t0 -= L[i, k] * y[k]
            t1 -= L[i, k + 1] * y[k + 1]
            k += 2
        if k < i:
            t0 -= L[i, k] * y[k]
        y[i] = (t0 + t1) / L[i, i]
    return True


@jit
def quadratic_into(
    A: np.ndarray, x: np.ndarray, idx: np.ndarray, n: int, L: np.ndarray, y: np.ndarray
) -> float:
    """``x_s^T (A_ss)^-1 x_s`` over the states ``s = idx[:n]`` by Cholesky; NaN if ``A_ss`` is not
    positive definite or anything is not finite."""
    if not whiten_into(A, x, idx, n, L, y):
        return np.nan
    total = 0.0
    for i in range(n):
        total += y[i] * y[i]
    return total


@jit
def block_members(block_of_state: np.ndarray, num_blocks: int) -> tuple:
    """State indices of each block (num_blocks, d) and their counts, from each state's block (d,)."""
    d = block_of_state.shape[0]
    members = np.empty((num_blocks, d), dtype=np.int64)
    sizes = np.zeros(num_blocks, dtype=np.int64)
    for s in range(d):
        b = block_of_state[s]
        if b >= 0:
            members[b, sizes[b]] = s
            sizes[b] += 1
    return members, sizes


@jit
def nees_plan(block_of_state: np.ndarray, num_blocks: int) -> tuple:
    """How :func:`nees_blocks_into` factorises: the blocks' members and sizes, the largest block
    (``lead``), and the state order with that block first and every other state after it."""
    members, sizes = block_members(block_of_state, num_blocks)
    lead = 0
    for b in range(num_blocks):
        if sizes[b] > sizes[lead]:
            lead = b
    d = block_of_state.shape[0]
    order = np.empty(d, dtype=np.int64)
    n = 0
    for i in range(sizes[lead]):
        order[n] = members[lead, i]
        n += 1
    for s in range(d):
        if block_of_state[s] != lead:
            order[n] = s
            n += 1
    return members, sizes, lead, order


@jit
def nees_blocks_into(
    P: np.ndarray,
    dx: np.ndarray,
    members: np.ndarray,
    sizes: np.ndarray,
    lead: int,
    order: np.ndarray,
    L: np.ndarray,
    y: np.ndarray,
    out: np.ndarray,
) -> float:
    """NEES of the full state (returned) and of every block (its marginal covariance, into
    ``out``), from :func:`nees_plan`: one Cholesky of the whole P in ``order`` gives the full NEES
    and, from its leading rows, the largest block's (11 sensor states: a quarter of the work of
    factorising it again); the small blocks are factorised on their own. NaN where a covariance
    is not positive definite."""
    n_lead = sizes[lead]
    if whiten_into(P, dx, order, order.shape[0], L, y):
        full = 0.0
        for i in range(order.shape[0]):
            full += y[i] * y[i]
            if i == n_lead - 1:
                out[lead] = full
    else:
        full = np.nan
        out[lead] = quadratic_into(P, dx, members[lead], n_lead, L, y)
    for b in range(sizes.shape[0]):
        if b != lead:
            out[b] = quadratic_into(P, dx, members[b], sizes[b], L, y)
    return full


@jit
def add_reference_into(
    P: np.ndarray,
    ref_var: np.ndarray,
    C_nb: np.ndarray,
    vel_n: np.ndarray,
    pos: int,
    att: int,
    vel: int,
    body: bool,
    A: np.ndarray,
) -> bool:
    """``A = P + P_ref``: the covariance of a filter's error against a reference whose own errors,
    independent of the filter's, have the variances ``ref_var`` (9,): position north, east, down
    [m^2], velocity north, east, down [m^2/s^2], roll, pitch, yaw [rad^2]
    (tauvcore.filter.reference.ReferenceConfig.variances). False, A untouched, when every one is
    zero: the reference is exact, the NEES takes P itself and its numbers are P's bit for bit.

    ``P_ref`` is the reference's error carried into the filter's error state (``dx = x_ref (-)
    x_hat``) to first order at the reference's attitude ``C_nb`` (3, 3) and NED velocity ``vel_n``
    (3,), on the states from ``pos`` (-1: no position state), ``att`` and ``vel`` of P (d, d):

    - position (n frame): ``diag(ref_var[0:3])``;
    - misalignment ``rho`` (n frame, ``C_ref = exp([e x]) C``): ``e = J (dphi, dtheta, dpsi)`` with
      ``J = [C_nb e_x, Rz(psi) e_y, e_z]``, the Euler angles' rates as a rotation vector in n
      (``C_nb = Rz(psi) Ry(theta) Rx(phi)``), so ``S_att = J diag(ref_var[6:9]) J^T``;
    - velocity: in NED (``body`` False, Yoo's filter) ``diag(ref_var[3:6])``; in the body frame
      (the 20-state filter's ``C^T v``) the reference's body velocity ``C_ref^T v_ref`` errs by
      ``C^T (dv + [v x] e)``, so ``S_vel = C^T (diag(ref_var[3:6]) + [v x] S_att [v x]^T) C`` and
      it is correlated with the misalignment: ``S_vel,att = C^T [v x] S_att``.
    """
    exact = True
    for i in range(9):
        if ref_var[i] != 0.0:
            exact = False
            break
    if exact:
        return False
    d = P.shape[0]
    for i in range(d):
        for j in range(d):
            A[i, j] = P[i, j]
    if pos >= 0:
        for i in range(3):
            A[pos + i, pos + i] += ref_var[i]
    # J's columns: the roll axis (the body x axis in n), the pitch axis (east turned by the yaw), down
    psi = math.atan2(C_nb[1, 0], C_nb[0, 0])
    J = np.zeros((3, 3))
    for i in range(3):
        J[i, 0] = C_nb[i, 0]
    J[0, 1], J[1, 1] = -math.sin(psi), math.cos(psi)
    J[2, 2] = 1.0
    S_att = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                S_att[i, j] += J[i, k] * ref_var[6 + k] * J[j, k]
    for i in range(3):
        for j in range(3):
            A[att + i, att + j] += S_att[i, j]
    if not body:
        for i in range(3):
            A[vel + i, vel + i] += ref_var[3 + i]
        return True
    # M = C^T [v x]: the body velocity's error per unit of misalignment
    vx = np.array([[0.0, -vel_n[2], vel_n[1]], [vel_n[2], 0.0, -vel_n[0]], [-vel_n[1], vel_n[0], 0.0]])
    M = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                M[i, j] += C_nb[k, i] * vx[k, j]
    MS = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                MS[i, j] += M[i, k] * S_att[k, j]
    for i in range(3):
        for j in range(3):
            s_vel = 0.0
            for k in range(3):
                s_vel += C_nb[k, i] * ref_var[3 + k] * C_nb[k, j] + MS[i, k] * M[j, k]
            A[vel + i, vel + j] += s_vel
            A[vel + i, att + j] += MS[i, j]
            A[att + j, vel + i] += MS[i, j]
    return True


@jit
def add_reference_batch(
    P: np.ndarray,
    ref_var: np.ndarray,
    C_nb: np.ndarray,
    vel_n: np.ndarray,
    pos: int,
    att: int,
    vel: int,
    body: bool,
) -> np.ndarray:
    """:func:`add_reference_into` for n covariances (n, d, d) at the reference's attitudes (n, 3, 3)
    and velocities (n, 3) -> (n, d, d): P + P_ref (P's own copy when the reference is exact)."""
    out = P.copy()
    for i in range(P.shape[0]):
        add_reference_into(P[i], ref_var, C_nb[i], vel_n[i], pos, att, vel, body, out[i])
    return out


@jit
def nees_batch(dx: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``dx^T P^-1 dx`` for (n, d), (n, d, d) -> (n,)."""
    d = dx.shape[1]
    idx = np.arange(d)
    L = np.empty((d, d))
    y = np.empty(d)
    out = np.empty(dx.shape[0])
    for i in range(dx.shape[0]):
        out[i] = quadratic_into(P[i], dx[i], idx, d, L, y)
    return out


@jit
def block_nees_batch(
    dx: np.ndarray, P: np.ndarray, block_of_state: np.ndarray, num_blocks: int
) -> np.ndarray:
    """NEES of every block (its marginal covariance) for (n, d), (n, d, d) -> (n, num_blocks):
    :func:`nees_blocks_into`, as the filter bank's records compute them."""
    d = dx.shape[1]
    L = np.empty((d, d))
    y = np.empty(d)
    out = np.empty((dx.shape[0], num_blocks))
    members, sizes, lead, order = nees_plan(block_of_state, num_blocks)
    for i in range(dx.shape[0]):
        nees_blocks_into(P[i], dx[i], members, sizes, lead, order, L, y, out[i])
    return out
