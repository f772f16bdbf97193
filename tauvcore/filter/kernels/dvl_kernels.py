"""The DVL measurement models, compiled: the loosely and tightly coupled models of
tauvcore.aiding.dvl_loose / dvl_tight (their docstrings derive them; those classes call these
kernels), and :func:`dvl_measure_bank`, one ping measured by every DVL method and run of the
filter bank at once (an extended method through tauvcore.filter.kernels.two_beam)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from tauvcore.filter.kernels.common import ATT, BDVL, BG, SF, VEL, N, jit
from tauvcore.filter.kernels.two_beam import compensated_beams_into, partial_into


@jit
def omega_comp_into(
    omega_meas: np.ndarray, gyro_bias: np.ndarray, C: np.ndarray, w_ie: np.ndarray, out: np.ndarray
) -> None:
    """``omega_hat_nb = omega_meas - b_g - C^T omega_ie``: the body rate the lever arm uses."""
    for i in range(3):
        out[i] = omega_meas[i] - gyro_bias[i] - (C[0, i] * w_ie[0] + C[1, i] * w_ie[1] + C[2, i] * w_ie[2])


@jit
def lc_solve_into(
    A: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    sigma2: float,
    cov: np.ndarray,
    A_pinv: np.ndarray,
    v: np.ndarray,
) -> bool:
    """Weighted least squares over the returned beams (eq. 17, 19, 21): ``cov = (A^T W A)^-1``,
    ``A+ = cov A^T W`` (zero columns for missing beams), ``v = A+ y``; False with fewer than three
    beams (then cov = I)."""
    n = 0
    for k in range(4):
        if available[k]:
            n += 1
    M = np.zeros((3, 3))
    if n >= 3:
        for k in range(4):
            if available[k]:
                for i in range(3):
                    for j in range(3):
                        M[i, j] += A[k, i] * (1.0 / sigma2) * A[k, j]
    else:
        for i in range(3):
            M[i, i] = 1.0
    det = (
        M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1])
        - M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
        + M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0])
    )
    cov[0, 0] = (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]) / det
    cov[0, 1] = (M[0, 2] * M[2, 1] - M[0, 1] * M[2, 2]) / det
    cov[0, 2] = (M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]) / det
    cov[1, 0] = (M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]) / det
    cov[1, 1] = (M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]) / det
    cov[1, 2] = (M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]) / det
    cov[2, 0] = (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]) / det
    cov[2, 1] = (M[0, 1] * M[2, 0] - M[0, 0] * M[2, 1]) / det
    cov[2, 2] = (M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]) / det
    for i in range(3):
        s = 0.0
        for k in range(4):
            w = (1.0 / sigma2) if available[k] else 0.0
            a = (cov[i, 0] * A[k, 0] + cov[i, 1] * A[k, 1] + cov[i, 2] * A[k, 2]) * w
            A_pinv[i, k] = a
            s += a * (y[k] if available[k] else 0.0)
        v[i] = s
    return n >= 3


@jit
def lc_prepare_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    A: np.ndarray,
    l: np.ndarray,
    sigma2: float,
    gyro_var: float,
    w_ie: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    omega_meas: np.ndarray,
    C: np.ndarray,
    gyro_bias: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    A_pinv: np.ndarray,
    omega_comp: np.ndarray,
) -> bool:
    """The loosely coupled measurement's data side: ``z = v_head - omega_hat_nb x l`` and
    ``R = (A^T W A)^-1 + sigma_w^2 [l x][l x]^T``; returns valid (three or more beams)."""
    v = np.empty(3)
    valid = lc_solve_into(A, y, available, sigma2, R, A_pinv, v)
    omega_comp_into(omega_meas, gyro_bias, C, w_ie, omega_comp)
    z[0] = v[0] - (omega_comp[1] * l[2] - omega_comp[2] * l[1])
    z[1] = v[1] - (omega_comp[2] * l[0] - omega_comp[0] * l[2])
    z[2] = v[2] - (omega_comp[0] * l[1] - omega_comp[1] * l[0])
    # [l x][l x]^T = |l|^2 I - l l^T
    ll = l[0] * l[0] + l[1] * l[1] + l[2] * l[2]
    for i in range(3):
        for j in range(3):
            R[i, j] += gyro_var * ((ll if i == j else 0.0) - l[i] * l[j])
    return valid


@jit
def lc_predict_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    C: np.ndarray,
    vel_n: np.ndarray,
    sf: float,
    dvl_bias: np.ndarray,
    gyro_bias: np.ndarray,
    A_pinv: np.ndarray,
    omega_meas: np.ndarray,
    omega_comp: np.ndarray,
    w_ie: np.ndarray,
    l: np.ndarray,
    out: np.ndarray,
) -> None:
    """Nonlinear ``h(x) = (1 + SF) v_b + (omega_nb - omega_hat_nb) x l + A+ b_dvl`` at a state,
    the measurement side (``A+``, the rates) held fixed."""
    om = np.empty(3)
    omega_comp_into(omega_meas, gyro_bias, C, w_ie, om)
    for i in range(3):
        om[i] -= omega_comp[i]
    cx = (om[1] * l[2] - om[2] * l[1], om[2] * l[0] - om[0] * l[2], om[0] * l[1] - om[1] * l[0])
    for i in range(3):
        vb = C[0, i] * vel_n[0] + C[1, i] * vel_n[1] + C[2, i] * vel_n[2]
        out[i] = (
            (1.0 + sf) * vb
            + cx[i]
            + (
                A_pinv[i, 0] * dvl_bias[0]
                + A_pinv[i, 1] * dvl_bias[1]
                + A_pinv[i, 2] * dvl_bias[2]
                + A_pinv[i, 3] * dvl_bias[3]
            )
        )


@jit
def lever_rows_into(
    A: np.ndarray, C: np.ndarray, w_ie: np.ndarray, l: np.ndarray, rows: int, att: np.ndarray, bg: np.ndarray
) -> None:
    """``B [l x] C^T [omega_ie x]`` and ``B [l x]`` for ``B`` = the first ``rows`` rows of ``A``
    (the beams, tightly coupled) or I (``A`` = identity, loosely coupled)."""
    lx = np.zeros((3, 3))
    lx[0, 1], lx[0, 2], lx[1, 0], lx[1, 2], lx[2, 0], lx[2, 1] = -l[2], l[1], l[2], -l[0], -l[1], l[0]
    W = np.zeros((3, 3))
    W[0, 1], W[0, 2], W[1, 0], W[1, 2], W[2, 0], W[2, 1] = (
        -w_ie[2],
        w_ie[1],
        w_ie[2],
        -w_ie[0],
        -w_ie[1],
        w_ie[0],
    )
    CtW = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            CtW[i, j] = C[0, i] * W[0, j] + C[1, i] * W[1, j] + C[2, i] * W[2, j]
    for r in range(rows):
        for j in range(3):
            blx = A[r, 0] * lx[0, j] + A[r, 1] * lx[1, j] + A[r, 2] * lx[2, j]
            bg[r, j] = blx
        for j in range(3):
            att[r, j] = bg[r, 0] * CtW[0, j] + bg[r, 1] * CtW[1, j] + bg[r, 2] * CtW[2, j]


@jit
def lc_jacobian_into(
    C: np.ndarray,
    vel_n: np.ndarray,
    sf: float,
    A_pinv: np.ndarray,
    w_ie: np.ndarray,
    l: np.ndarray,
    H: np.ndarray,
) -> None:
    """``H = [0, [l x] C^T [omega_ie x], (1 + SF) I, 0, [l x], A+, v_b]`` (3, 20), zeroed here."""
    H[:, :] = 0.0
    att = np.empty((3, 3))
    bg = np.empty((3, 3))
    lever_rows_into(np.eye(3), C, w_ie, l, 3, att, bg)
    for i in range(3):
        for j in range(3):
            H[i, ATT + j] = att[i, j]
            H[i, BG + j] = bg[i, j]
        H[i, VEL + i] = 1.0 + sf
        for k in range(4):
            H[i, BDVL + k] = A_pinv[i, k]
        H[i, SF] = C[0, i] * vel_n[0] + C[1, i] * vel_n[1] + C[2, i] * vel_n[2]


@jit
def partial_sensor_row_into(
    c: np.ndarray, A: np.ndarray, v_b: np.ndarray, sf: float, row: np.ndarray
) -> None:
    """The DVL errors' columns of one two-beam row ``c . y_c`` (``c`` (4,) its weights on the compensated
    beams ``y_c = (y - b_hat - lever) / (1 + SF_hat)``, ``y = (1 + SF) A v_b + b + lever + noise``):
    ``c / (1 + SF_hat)`` on the beam biases, ``c . A v_b / (1 + SF_hat)`` on the scale factor."""
    s = 0.0
    for k in range(4):
        row[BDVL + k] = c[k] / (1.0 + sf)
        s += c[k] * (A[k, 0] * v_b[0] + A[k, 1] * v_b[1] + A[k, 2] * v_b[2])
    row[SF] = s / (1.0 + sf)


@jit
def beam_noise_into(
    A: np.ndarray, sigma2: float, gyro_var: float, l: np.ndarray, sf: float, S: np.ndarray
) -> None:
    """Covariance of the four (compensated) beams: ``(sigma^2 I + sigma_w^2 (A [l x])(A [l x])^T) / (1 + SF)^2``."""
    L = np.empty((4, 3))
    for k in range(4):
        L[k, 0] = A[k, 1] * l[2] - A[k, 2] * l[1]  # row k of A [l x]
        L[k, 1] = A[k, 2] * l[0] - A[k, 0] * l[2]
        L[k, 2] = A[k, 0] * l[1] - A[k, 1] * l[0]
    d = (1.0 + sf) * (1.0 + sf)
    for i in range(4):
        for j in range(4):
            S[i, j] = (
                (sigma2 if i == j else 0.0)
                + gyro_var * (L[i, 0] * L[j, 0] + L[i, 1] * L[j, 1] + L[i, 2] * L[j, 2])
            ) / d


@jit
def tc_predict_into(
    A: np.ndarray,
    C: np.ndarray,
    vel_n: np.ndarray,
    sf: float,
    dvl_bias: np.ndarray,
    gyro_bias: np.ndarray,
    omega_meas: np.ndarray,
    w_ie: np.ndarray,
    l: np.ndarray,
    out: np.ndarray,
) -> None:
    """``h_k = b_k . ((1 + SF) v_b + omega_nb x l) + b_dvl,k`` for the four beams."""
    om = np.empty(3)
    omega_comp_into(omega_meas, gyro_bias, C, w_ie, om)
    head = np.empty(3)
    head[0] = om[1] * l[2] - om[2] * l[1]
    head[1] = om[2] * l[0] - om[0] * l[2]
    head[2] = om[0] * l[1] - om[1] * l[0]
    for i in range(3):
        head[i] += (1.0 + sf) * (C[0, i] * vel_n[0] + C[1, i] * vel_n[1] + C[2, i] * vel_n[2])
    for k in range(4):
        out[k] = A[k, 0] * head[0] + A[k, 1] * head[1] + A[k, 2] * head[2] + dvl_bias[k]


@jit
def tc_jacobian_into(
    A: np.ndarray, C: np.ndarray, vel_n: np.ndarray, sf: float, w_ie: np.ndarray, l: np.ndarray, H: np.ndarray
) -> None:
    """``H_k = [0, b_k^T [l x] C^T [omega_ie x], (1 + SF) b_k^T, 0, b_k^T [l x], e_k^T, b_k^T v_b]`` (4, 20)."""
    H[:, :] = 0.0
    att = np.empty((4, 3))
    bg = np.empty((4, 3))
    lever_rows_into(A, C, w_ie, l, 4, att, bg)
    vb = np.empty(3)
    for i in range(3):
        vb[i] = C[0, i] * vel_n[0] + C[1, i] * vel_n[1] + C[2, i] * vel_n[2]
    for k in range(4):
        for j in range(3):
            H[k, ATT + j] = att[k, j]
            H[k, BG + j] = bg[k, j]
            H[k, VEL + j] = (1.0 + sf) * A[k, j]
        H[k, BDVL + k] = 1.0
        H[k, SF] = A[k, 0] * vb[0] + A[k, 1] * vb[1] + A[k, 2] * vb[2]


@jit
def lc_prepare_batch(
    A: np.ndarray,
    l: np.ndarray,
    sigma2: float,
    gyro_var: float,
    w_ie: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    omega_meas: np.ndarray,
    C: np.ndarray,
    gyro_bias: np.ndarray,
) -> tuple:
    """:func:`lc_prepare_into` for n entries -> z (n, 3), R (n, 3, 3), A+ (n, 3, 4), omega_hat_nb (n, 3), valid (n,)."""
    n = y.shape[0]
    z = np.empty((n, 3))
    R = np.empty((n, 3, 3))
    A_pinv = np.empty((n, 3, 4))
    omega_comp = np.empty((n, 3))
    valid = np.empty(n, dtype=np.bool_)
    for i in range(n):
        valid[i] = lc_prepare_into(
            A,
            l,
            sigma2,
            gyro_var,
            w_ie,
            y[i],
            available[i],
            omega_meas[i],
            C[i],
            gyro_bias[i],
            z[i],
            R[i],
            A_pinv[i],
            omega_comp[i],
        )
    return z, R, A_pinv, omega_comp, valid


@jit
def lc_solve_batch(A: np.ndarray, y: np.ndarray, available: np.ndarray, sigma2: float) -> tuple:
    """:func:`lc_solve_into` for n entries -> v (n, 3), cov (n, 3, 3), A+ (n, 3, 4), valid (n,)."""
    n = y.shape[0]
    v = np.empty((n, 3))
    cov = np.empty((n, 3, 3))
    A_pinv = np.empty((n, 3, 4))
    valid = np.empty(n, dtype=np.bool_)
    for i in range(n):
        valid[i] = lc_solve_into(A, y[i], available[i], sigma2, cov[i], A_pinv[i], v[i])
    return v, cov, A_pinv, valid


@jit
def lc_predict_batch(
    C: np.ndarray,
    vel_n: np.ndarray,
    sf: np.ndarray,
    dvl_bias: np.ndarray,
    gyro_bias: np.ndarray,
    A_pinv: np.ndarray,
    omega_meas: np.ndarray,
    omega_comp: np.ndarray,
    w_ie: np.ndarray,
    l: np.ndarray,
) -> np.ndarray:
    out = np.empty((C.shape[0], 3))
    for i in range(C.shape[0]):
        lc_predict_into(
            C[i],
            vel_n[i],
            sf[i],
            dvl_bias[i],
            gyro_bias[i],
            A_pinv[i],
            omega_meas[i],
            omega_comp[i],
            w_ie,
            l,
            out[i],
        )
    return out


@jit
def lc_jacobian_batch(
    C: np.ndarray, vel_n: np.ndarray, sf: np.ndarray, A_pinv: np.ndarray, w_ie: np.ndarray, l: np.ndarray
) -> np.ndarray:
    out = np.empty((C.shape[0], 3, N))
    for i in range(C.shape[0]):
        lc_jacobian_into(C[i], vel_n[i], sf[i], A_pinv[i], w_ie, l, out[i])
    return out


@jit
def tc_predict_batch(
    A: np.ndarray,
    C: np.ndarray,
    vel_n: np.ndarray,
    sf: np.ndarray,
    dvl_bias: np.ndarray,
    gyro_bias: np.ndarray,
    omega_meas: np.ndarray,
    w_ie: np.ndarray,
    l: np.ndarray,
) -> np.ndarray:
    out = np.empty((C.shape[0], 4))
    for i in range(C.shape[0]):
        tc_predict_into(A, C[i], vel_n[i], sf[i], dvl_bias[i], gyro_bias[i], omega_meas[i], w_ie, l, out[i])
    return out


@jit
def tc_jacobian_batch(
    A: np.ndarray, C: np.ndarray, vel_n: np.ndarray, sf: np.ndarray, w_ie: np.ndarray, l: np.ndarray
) -> np.ndarray:
    out = np.empty((C.shape[0], 4, N))
    for i in range(C.shape[0]):
        tc_jacobian_into(A, C[i], vel_n[i], sf[i], w_ie, l, out[i])
    return out


@jit
def beam_noise_batch(
    A: np.ndarray, sigma2: float, gyro_var: float, l: np.ndarray, sf: np.ndarray
) -> np.ndarray:
    out = np.empty((sf.shape[0], 4, 4))
    for i in range(sf.shape[0]):
        beam_noise_into(A, sigma2, gyro_var, l, sf[i], out[i])
    return out


DVL_LC, DVL_TC = 1, 2
"""Codes of :func:`dvl_measure_bank`: a loosely coupled velocity (lc), or one row per beam (tc);
:data:`DVL_ELC` an extended method."""
DVL_ELC = 3
"""Code of :func:`dvl_measure_bank`: an extended method (loosely coupled with three or four beams,
its two-beam construction with two, the tables say which)."""


class DvlMethods(NamedTuple):
    """The bank's DVL methods and the constants of their measurements (:func:`dvl_measure_bank`)."""

    methods: np.ndarray  # (D,) int64: the bank's rows (methods) that fuse the DVL
    codes: np.ndarray  # (D,) int64: each one's DVL_LC, DVL_TC or DVL_ELC
    A: np.ndarray  # (4, 3) the beams' unit vectors in b
    l: np.ndarray  # (3,) the DVL's lever arm in b [m]
    sigma2: float  # a beam's noise variance [m^2/s^2]
    gyro_var: float  # the gyro rate's noise variance [rad^2/s^2] (through the lever arm)
    w_ie: np.ndarray  # (3,) the earth rate in n [rad/s]
    mode_codes: np.ndarray  # (4,) int64: the record's mode codes of coast, lc, partial, tc
    partial_sensor_columns: bool  # the two-beam rows carry the beam biases' and scale factor's columns


class TwoBeamTables(NamedTuple):
    """The two-beam constructions of each DVL method [i, pattern, candidate] (pattern = sum of
    2^k over the returned beams k; tauvcore.engine.dvl_fusion.partial_tables)."""

    n_cand: np.ndarray  # (D,) int64: candidates (1, or the selector's)
    ok: np.ndarray  # (D, 16, K) bool
    Cc: np.ndarray  # (D, 16, K, 3, 4): velocity from the compensated beams
    Dc: np.ndarray  # (D, 16, K, 3, 3): velocity from the predicted velocity
    gc: np.ndarray  # (D, 16, K, 3): prediction gain
    ac: np.ndarray  # (D, 16, K, 3): assumption error [m/s]
    mc: np.ndarray  # (D, 16, K, 3) bool: measured rows


class Ping(NamedTuple):
    """One DVL ping of every run."""

    y: np.ndarray  # (R, 4) beam velocities [m/s]
    available: np.ndarray  # (R, 4) bool: the beams that returned
    omega_meas: np.ndarray  # (R, 3) the measured body rate at the ping [rad/s]


class DvlState(NamedTuple):
    """The bank's estimates a ping is predicted from, (methods, runs, ...), read only."""

    C: np.ndarray  # (M, R, 3, 3) C_nb
    vel_n: np.ndarray  # (M, R, 3) [m/s]
    gyro_bias: np.ndarray  # (M, R, 3) [rad/s]
    dvl_bias: np.ndarray  # (M, R, 4) [m/s]
    sf: np.ndarray  # (M, R) the DVL scale factor
    P: np.ndarray  # (M, R, 20, 20)


class DvlRows(NamedTuple):
    """What :func:`dvl_measure_bank` fills, (methods, runs, ...): the measurement rows and the record."""

    z: np.ndarray  # (M, R, 4)
    nu: np.ndarray  # (M, R, 4) innovation
    H: np.ndarray  # (M, R, 4, 20)
    Rm: np.ndarray  # (M, R, 4, 4)
    active: np.ndarray  # (M, R, 4) bool
    valid: np.ndarray  # (M, R) bool
    mode: np.ndarray  # (M, R) int64: a mode code
    measured_axes: np.ndarray  # (M, R, 3) bool
    choice: np.ndarray  # (M, R, 3) int64: the selector's candidate per axis, -1 for none


@jit
def _two_beam_rows(
    dvl: DvlMethods,
    tables: TwoBeamTables,
    ping: Ping,
    state: DvlState,
    out: DvlRows,
    at: tuple[int, int, int, int],
    work: tuple,
) -> None:
    """Run ``r``'s rows of an extended method ``i`` (bank row ``m``) with exactly two beams
    (pattern ``pattern``), ``at = (i, m, r, pattern)``: its construction's velocity on its
    measured axes (:func:`dvl_measure_bank`)."""
    _, _, A, l, sigma2, gyro_var, w_ie, mode_codes, sensor_columns = dvl
    n_cand, ok, Cc, Dc, gc, ac, mc = tables
    y, available, omega_meas = ping
    C, vel_n, gyro_bias, dvl_bias, sf, P = state
    z, nu, H, Rm, active, valid, mode, measured_axes, choice = out
    _, omega_comp, _, S, y_c, v_hat, meas, pick = work
    i, m, r, pattern = at
    omega_comp_into(omega_meas[r], gyro_bias[m, r], C[m, r], w_ie, omega_comp)
    compensated_beams_into(A, y[r], available[r], dvl_bias[m, r], sf[m, r], omega_comp, l, y_c)
    beam_noise_into(A, sigma2, gyro_var, l, sf[m, r], S)
    for k in range(3):
        v_hat[k] = (
            C[m, r, 0, k] * vel_n[m, r, 0] + C[m, r, 1, k] * vel_n[m, r, 1] + C[m, r, 2, k] * vel_n[m, r, 2]
        )
    candidates = (
        n_cand[i],
        ok[i, pattern],
        Cc[i, pattern],
        Dc[i, pattern],
        gc[i, pattern],
        ac[i, pattern],
        mc[i, pattern],
    )
    P_vel = P[m, r, VEL : VEL + 3, VEL : VEL + 3]
    partial_into(candidates, y_c, S, v_hat, P_vel, (z[m, r, :3], Rm[m, r, :3, :3], meas, pick))
    any_axis = False
    for k in range(3):
        nu[m, r, k] = z[m, r, k] - v_hat[k]
        H[m, r, k, VEL + k] = 1.0
        if sensor_columns and meas[k]:
            partial_sensor_row_into(
                Cc[i, pattern, pick[k] if n_cand[i] > 1 else 0, k], A, v_hat, sf[m, r], H[m, r, k]
            )
        active[m, r, k] = meas[k]
        any_axis = any_axis or meas[k]
        if n_cand[i] > 1:
            choice[m, r, k] = pick[k]
    active[m, r, 3] = False
    Rm[m, r, 3, 3] = 1.0
    valid[m, r] = any_axis
    mode[m, r] = mode_codes[2] if any_axis else mode_codes[0]
    for k in range(3):
        measured_axes[m, r, k] = meas[k] and any_axis


@jit
def _lc_rows(dvl: DvlMethods, ping: Ping, state: DvlState, out: DvlRows, m: int, r: int, work: tuple) -> None:
    """Run ``r``'s rows of a loosely coupled method (bank row ``m``): the velocity of three or four
    beams (:func:`dvl_measure_bank`)."""
    _, _, A, l, sigma2, gyro_var, w_ie, mode_codes, _ = dvl
    y, available, omega_meas = ping
    C, vel_n, gyro_bias, dvl_bias, sf, _ = state
    z, nu, H, Rm, active, valid, mode, measured_axes, _ = out
    A_pinv, omega_comp, h = work[0], work[1], work[2]
    good = lc_prepare_into(
        A, l, sigma2, gyro_var, w_ie, y[r], available[r], omega_meas[r], C[m, r], gyro_bias[m, r], z[m, r, :3],
        Rm[m, r, :3, :3], A_pinv, omega_comp,
    )  # fmt: skip
    lc_predict_into(
        C[m, r], vel_n[m, r], sf[m, r], dvl_bias[m, r], gyro_bias[m, r], A_pinv, omega_meas[r], omega_comp, w_ie, l, h
    )  # fmt: skip
    for k in range(3):
        nu[m, r, k] = z[m, r, k] - h[k]
        active[m, r, k] = good
        measured_axes[m, r, k] = good
    active[m, r, 3] = False
    Rm[m, r, 3, 3] = 1.0
    lc_jacobian_into(C[m, r], vel_n[m, r], sf[m, r], A_pinv, w_ie, l, H[m, r, :3])
    valid[m, r] = good
    mode[m, r] = mode_codes[1] if good else mode_codes[0]


@jit
def _tc_rows(dvl: DvlMethods, ping: Ping, state: DvlState, out: DvlRows, m: int, r: int, work: tuple) -> None:
    """Run ``r``'s rows of a tightly coupled method (bank row ``m``): one row per returned beam
    (:func:`dvl_measure_bank`)."""
    _, _, A, l, sigma2, gyro_var, w_ie, mode_codes, _ = dvl
    y, available, omega_meas = ping
    C, vel_n, gyro_bias, dvl_bias, sf, _ = state
    z, nu, H, Rm, active, valid, mode, measured_axes, _ = out
    h, S = work[2], work[3]
    beam_noise_into(A, sigma2, gyro_var, l, 0.0, S)
    tc_predict_into(
        A, C[m, r], vel_n[m, r], sf[m, r], dvl_bias[m, r], gyro_bias[m, r], omega_meas[r], w_ie, l, h
    )
    n_beams = 0
    for k in range(4):
        if available[r, k]:
            n_beams += 1
            z[m, r, k] = y[r, k]
            nu[m, r, k] = y[r, k] - h[k]
        active[m, r, k] = available[r, k]
        for j in range(4):
            Rm[m, r, k, j] = S[k, j]
    for k in range(3):
        measured_axes[m, r, k] = False
    tc_jacobian_into(A, C[m, r], vel_n[m, r], sf[m, r], w_ie, l, H[m, r])
    valid[m, r] = n_beams > 0
    mode[m, r] = mode_codes[3] if n_beams > 0 else mode_codes[0]


@jit
def dvl_measure_bank(
    dvl: DvlMethods, tables: TwoBeamTables, ping: Ping, state: DvlState, out: DvlRows
) -> None:
    """One DVL ping measured by every DVL method ``methods[i]`` (code ``codes[i]``) of the bank
    and every run: fills rows of z, nu (M, R, 4), H (M, R, 4, 20), Rm (M, R, 4, 4), active (M, R,
    4), valid (M, R) (rows beyond a measurement's width inactive, with a unit variance), and the
    record's mode (``mode_codes``: coast, lc, partial, tc), measured axes and selector choice.

    An extended method (``DVL_ELC``) with three or four beams is loosely coupled; with exactly two
    it builds its velocity from the tables ``n_cand[i]``, ``ok``, ``Cc``, ``Dc``, ``gc``, ``ac``,
    ``mc`` [i, pattern, candidate] (pattern = sum of 2^k over the returned beams k), fused on its
    measured axes with ``H = [0 0 I 0 0 0 0]`` (tauvcore.aiding.dvl_partial), and with
    ``partial_sensor_columns`` the columns of the DVL errors its compensated beams carry:
    ``C / (1 + SF_hat)`` on the beam biases and ``C A v_hat / (1 + SF_hat)`` on the scale factor,
    ``C`` the construction's (the selector's chosen) rows."""
    methods, codes = dvl[0], dvl[1]  # plain tuples from Python (common.plain): by position
    available = ping[1]
    z, nu, H, Rm, _, _, _, _, choice = out
    work = (  # A_pinv, omega_comp, h, S, y_c, v_hat, meas, pick
        np.empty((3, 4)),
        np.empty(3),
        np.empty(4),
        np.empty((4, 4)),
        np.empty(4),
        np.empty(3),
        np.empty(3, dtype=np.bool_),
        np.empty(3, dtype=np.int64),
    )
    for i in range(methods.shape[0]):
        m = methods[i]
        for r in range(available.shape[0]):
            H[m, r, :, :] = 0.0
            Rm[m, r, :, :] = 0.0
            z[m, r, :] = 0.0
            nu[m, r, :] = 0.0
            for k in range(3):
                choice[m, r, k] = -1
            n_beams = 0
            pattern = 0
            for k in range(4):
                if available[r, k]:
                    n_beams += 1
                    pattern += 1 << k
            if codes[i] == DVL_ELC and n_beams == 2:
                _two_beam_rows(dvl, tables, ping, state, out, (i, m, r, pattern), work)
            elif codes[i] != DVL_TC:
                _lc_rows(dvl, ping, state, out, m, r, work)
            else:
                _tc_rows(dvl, ping, state, out, m, r, work)
