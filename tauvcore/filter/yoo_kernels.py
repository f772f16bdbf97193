"""The compiled chunk loop of Yoo 2014's methods (numba): tauvcore.engine.yoo_bank's numpy methods
as one call per chunk.

Why: the numpy bank (``YooBank(..., compiled=False)``, kept as the reference) spends its time in
numpy's per-call overhead on 3x3 and 12x12 batches at every DVL ping, covariance step and output
epoch (the 24-minute ``longrange`` mission took 10 s); these loops do the same arithmetic in
machine code. The formulas are the numpy bank's, written out entry by entry, in the same order
of operations where it matters (``tests/unit/test_yoo_bank.py`` holds every result of both equal
to 1e-9); the strapdown, rotations and NEES are the 20-state bank's own kernels
(tauvcore.filter.kernels), so those are bit for bit the same.

Layout: the bank's states are (M, R, ...) arrays (methods, runs); the VKF's (R, ...). The chunk's
stops (covariance steps, DVL pings, output epochs) come from the caller in order, with the ping
and output row of each (-1 for none); :func:`run_stops` processes stops ``s0 .. s1 - 1``, so the
caller can come back between output epochs (progress, stop requests).
"""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels import (
    _jit,
    _ned_offset,
    _radii_nav,
    advance,
    exp_so3_into,
    log_so3_into,
    nees_blocks_into,
    nees_plan,
    quadratic_into,
)
from tauvcore.geo.earth import OMEGA_IE_RPS

DIM = 12
NC = 5  # consider states (tauvcore.engine.yoo_bank.NC): DVL scale factor, 4 beam biases
NA = DIM + NC
VEL, ATT, BA, BG = 0, 3, 6, 9  # tauvcore.filter.yoo's blocks
INS_DVL, VKF = 0, 1  # method codes (tauvcore.engine.yoo_bank.METHOD_CODES)
MIN_BEAMS = 3
# rows of the per-epoch series (tauvcore.engine.yoo_bank.SERIES)
NUM_SERIES = 11
# flags of an update
U_VALID, U_FUSED, U_REJECTED = 0, 1, 2


@_jit
def _inv3_into(A: np.ndarray, out: np.ndarray) -> bool:
    """Inverse of a 3x3 matrix by its adjugate; False (out untouched) if singular or not finite."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    if not (math.isfinite(det) and det != 0.0):
        return False
    inv = 1.0 / det
    out[0, 0] = c00 * inv
    out[1, 0] = c01 * inv
    out[2, 0] = c02 * inv
    out[0, 1] = (A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]) * inv
    out[1, 1] = (A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]) * inv
    out[2, 1] = (A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]) * inv
    out[0, 2] = (A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]) * inv
    out[1, 2] = (A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]) * inv
    out[2, 2] = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]) * inv
    return True


@_jit
def _skew_into(v0: float, v1: float, v2: float, out: np.ndarray) -> None:
    out[0, 0], out[0, 1], out[0, 2] = 0.0, -v2, v1
    out[1, 0], out[1, 1], out[1, 2] = v2, 0.0, -v0
    out[2, 0], out[2, 1], out[2, 2] = -v1, v0, 0.0


@_jit
def _sandwich_into(A: np.ndarray, P: np.ndarray, tmp: np.ndarray, out: np.ndarray) -> None:
    """``out = A P A^T`` (n x n)."""
    n = P.shape[0]
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += A[i, k] * P[k, j]
            tmp[i, j] = s
    for i in range(n):
        for j in range(n):
            s = 0.0
            for k in range(n):
                s += tmp[i, k] * A[j, k]
            out[i, j] = s


@_jit
def _symmetrise_into(A: np.ndarray, out: np.ndarray) -> None:
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (A[i, j] + A[j, i])


@_jit
def propagate(
    P: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    dv_raw_i: np.ndarray,
    dt: float,
    dt_c: float,
    geodetic: bool,
    w_ie_flat: np.ndarray,
    q: np.ndarray,
    qc: np.ndarray,
    F: np.ndarray,
    Phi: np.ndarray,
    tmp: np.ndarray,
    out: np.ndarray,
) -> None:
    """One covariance step of every (method, run) over ``dt_c`` (yoo_bank.YooBank._propagate):
    ``Phi = I + F dt_c + (F dt_c)^2 / 2``, ``P_xx <- Phi P_xx Phi^T + diag(q) dt_c``, the consider
    states' cross terms ``P_xc <- Phi P_xc`` and ``P_cc += diag(qc) dt_c``, symmetrised; F of
    tauvcore.filter.yoo.F_matrix at the nominal state and the latest specific force. P (M, R, NA,
    NA); out (NA, NA), tmp (DIM, DIM) work space."""
    M, R = P.shape[0], P.shape[1]
    f_b = np.empty(3)
    f_n = np.empty(3)
    w_ie = np.empty(3)
    w_en = np.empty(3)
    J = np.empty((3, 3))
    Sa = np.empty((3, 3))
    Sb = np.empty((3, 3))
    for m in range(M):
        for r in range(R):
            Cm = C[m, r]
            v = vel[m, r]
            for i in range(3):
                f_b[i] = dv_raw_i[r, i] / dt - ba[m, r, i]
            for i in range(3):
                f_n[i] = Cm[i, 0] * f_b[0] + Cm[i, 1] * f_b[1] + Cm[i, 2] * f_b[2]
            J[:, :] = 0.0
            if geodetic:
                lat, h = pos[m, r, 0], -pos[m, r, 2]
                R_N, R_E = _radii_nav(lat)
                rn, re = R_N + h, R_E + h
                t = math.tan(lat)
                w_ie[0], w_ie[1], w_ie[2] = OMEGA_IE_RPS * math.cos(lat), 0.0, -OMEGA_IE_RPS * math.sin(lat)
                w_en[0], w_en[1], w_en[2] = v[1] / re, -v[0] / rn, -v[1] * t / re
                J[0, 1], J[1, 0], J[2, 1] = 1.0 / re, -1.0 / rn, -t / re
            else:
                for i in range(3):
                    w_ie[i] = w_ie_flat[i]
                    w_en[i] = 0.0
            F[:, :] = 0.0
            _skew_into(2.0 * w_ie[0] + w_en[0], 2.0 * w_ie[1] + w_en[1], 2.0 * w_ie[2] + w_en[2], Sa)
            _skew_into(v[0], v[1], v[2], Sb)
            for i in range(3):
                for j in range(3):
                    sj = Sb[i, 0] * J[0, j] + Sb[i, 1] * J[1, j] + Sb[i, 2] * J[2, j]
                    F[VEL + i, VEL + j] = (-Sa[i, j] + sj) * dt_c
            _skew_into(f_n[0], f_n[1], f_n[2], Sa)
            for i in range(3):
                for j in range(3):
                    F[VEL + i, ATT + j] = -Sa[i, j] * dt_c
                    F[VEL + i, BA + j] = -Cm[i, j] * dt_c
                    F[ATT + i, VEL + j] = -J[i, j] * dt_c
                    F[ATT + i, BG + j] = -Cm[i, j] * dt_c
            _skew_into(w_ie[0] + w_en[0], w_ie[1] + w_en[1], w_ie[2] + w_en[2], Sa)
            for i in range(3):
                for j in range(3):
                    F[ATT + i, ATT + j] = -Sa[i, j] * dt_c
            for i in range(DIM):
                for j in range(DIM):
                    s = 0.0
                    for k in range(DIM):
                        s += F[i, k] * F[k, j]
                    Phi[i, j] = (1.0 if i == j else 0.0) + F[i, j] + 0.5 * s
            Pm = P[m, r]
            _sandwich_into(Phi, Pm[:DIM, :DIM], tmp, out[:DIM, :DIM])
            for i in range(DIM):
                out[i, i] += q[i] * dt_c
                for c in range(NC):
                    s = 0.0
                    for k in range(DIM):
                        s += Phi[i, k] * Pm[k, DIM + c]
                    out[i, DIM + c] = s
                    out[DIM + c, i] = s
            for a in range(NC):
                for c in range(NC):
                    out[DIM + a, DIM + c] = Pm[DIM + a, DIM + c]
                out[DIM + a, DIM + a] += qc[a] * dt_c
            _symmetrise_into(out, Pm)


@_jit
def dvl_body_velocity_into(
    y: np.ndarray,
    available: np.ndarray,
    dtheta_i: np.ndarray,
    dt: float,
    C_nb: np.ndarray,
    lat: float,
    A_b: np.ndarray,
    l_dvl_b: np.ndarray,
    beam_var: float,
    v_b: np.ndarray,
    cov_b: np.ndarray,
    gain: np.ndarray,
) -> bool:
    """One run's DVL body velocity by least squares over the beams that returned, its covariance,
    the least squares' gain from the beams (3, 4), and whether at least MIN_BEAMS returned
    (rpm_aid.dvl_body_velocity with ``with_gain``; with fewer the normal matrix is replaced by I,
    as there)."""
    Nm = np.zeros((3, 3))
    b = np.zeros(3)
    count = 0
    for k in range(A_b.shape[0]):
        if available[k] and math.isfinite(y[k]):
            count += 1
            for i in range(3):
                b[i] += A_b[k, i] * y[k]
                for j in range(3):
                    Nm[i, j] += A_b[k, i] * A_b[k, j]
    ok = count >= MIN_BEAMS
    Ninv = np.zeros((3, 3))
    if not (ok and _inv3_into(Nm, Ninv)):
        for i in range(3):
            Ninv[i, i] = 1.0
    w0, w2 = math.cos(lat) * OMEGA_IE_RPS, -math.sin(lat) * OMEGA_IE_RPS
    om = np.empty(3)
    for i in range(3):
        om[i] = dtheta_i[i] / dt - (C_nb[0, i] * w0 + C_nb[2, i] * w2)
    for i in range(3):
        v_b[i] = Ninv[i, 0] * b[0] + Ninv[i, 1] * b[1] + Ninv[i, 2] * b[2]
        for j in range(3):
            cov_b[i, j] = beam_var * Ninv[i, j]
        for k in range(A_b.shape[0]):
            used = 1.0 if available[k] and math.isfinite(y[k]) else 0.0
            gain[i, k] = (Ninv[i, 0] * A_b[k, 0] + Ninv[i, 1] * A_b[k, 1] + Ninv[i, 2] * A_b[k, 2]) * used
    v_b[0] -= om[1] * l_dvl_b[2] - om[2] * l_dvl_b[1]
    v_b[1] -= om[2] * l_dvl_b[0] - om[0] * l_dvl_b[2]
    v_b[2] -= om[0] * l_dvl_b[1] - om[1] * l_dvl_b[0]
    return ok


@_jit
def _latest(index: np.ndarray, k: int) -> np.intp:
    """Row of the last epoch at or before sample ``k`` (-1 before the first)."""
    return np.searchsorted(index, k, side="right") - 1


@_jit
def vkf_step(
    x: np.ndarray,
    P: np.ndarray,
    rpm: float,
    altitude: float,
    z_fwd: float,
    ok: bool,
    Q: np.ndarray,
    noise_var: float,
    switch_altitude: float,
) -> tuple:
    """One run's VKF at a ping (rpm_aid.RpmAid.step): predict with the RPM (if one was read),
    update with the DVL's forward speed where eq. 29 picks the DVL and it has a velocity.
    -> (RPM chosen, an RPM was read)."""
    use_rpm = (not (altitude <= switch_altitude)) or (not ok)
    have_rpm = math.isfinite(rpm)
    F = np.zeros((3, 3))
    tmp = np.empty((3, 3))
    out = np.empty((3, 3))
    if have_rpm:
        F[0, 1], F[0, 2], F[1, 1], F[2, 2] = rpm, -1.0, 1.0, 1.0
        x0 = F[0, 0] * x[0] + F[0, 1] * x[1] + F[0, 2] * x[2]
        x[0] = x0
        _sandwich_into(F, P, tmp, out)
        for i in range(3):
            for j in range(3):
                out[i, j] += Q[i, j]
        _symmetrise_into(out, P)
    if (not use_rpm) and ok and have_rpm:
        innov = z_fwd - x[0]
        S = P[0, 0] + noise_var
        g = np.empty(3)
        for i in range(3):
            g[i] = P[i, 0] / S
        I_KH = np.zeros((3, 3))
        for i in range(3):
            I_KH[i, i] = 1.0
            I_KH[i, 0] -= g[i]
        _sandwich_into(I_KH, P, tmp, out)
        for i in range(3):
            for j in range(3):
                out[i, j] += noise_var * g[i] * g[j]
        _symmetrise_into(out, P)
        for i in range(3):
            x[i] += g[i] * innov
    return use_rpm, have_rpm


@_jit
def fuse(
    P: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    z: np.ndarray,
    Rm: np.ndarray,
    Hc: np.ndarray,
    valid: bool,
    gate: float,
    S_diag: np.ndarray,
    nu: np.ndarray,
) -> tuple:
    """Fuse one NED velocity ``z`` into one filter (yoo_bank.YooBank._fuse): ``H = [I, [v x], 0, 0,
    Hc]`` (v the estimated velocity, Hc (3, NC) on the consider states, whose gain is zero), every
    row gated, Joseph form over the NA states, inject and reset. -> (fused, passed the gate, NIS
    before the gate (NaN if S cannot be inverted)); ``S_diag`` and ``nu`` written."""
    H = np.zeros((3, NA))
    for i in range(3):
        H[i, VEL + i] = 1.0
        nu[i] = z[i] - vel[i]
        for c in range(NC):
            H[i, DIM + c] = Hc[i, c] if math.isfinite(Hc[i, c]) else 0.0
    Sk = np.empty((3, 3))
    _skew_into(vel[0], vel[1], vel[2], Sk)
    for i in range(3):
        for j in range(3):
            H[i, ATT + j] = Sk[i, j]
    PHt = np.empty((NA, 3))
    for i in range(NA):
        for j in range(3):
            s = 0.0
            for k in range(NA):
                s += P[i, k] * H[j, k]
            PHt[i, j] = s
    S = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(NA):
                s += H[i, k] * PHt[k, j]
            S[i, j] = s + Rm[i, j]
    passed = True
    finite = True
    for i in range(3):
        S_diag[i] = S[i, i]
        if not (nu[i] * nu[i] <= gate * gate * S[i, i]):
            passed = False
        if not math.isfinite(nu[i]):
            finite = False
    use = valid and passed and finite
    Sinv = np.empty((3, 3))
    nis = np.nan
    if _inv3_into(S, Sinv):
        nis = 0.0
        for i in range(3):
            for j in range(3):
                nis += nu[i] * Sinv[i, j] * nu[j]
    else:
        use = False
    if use:
        K = np.zeros((NA, 3))  # the consider rows stay zero
        for i in range(DIM):
            for j in range(3):
                K[i, j] = PHt[i, 0] * Sinv[0, j] + PHt[i, 1] * Sinv[1, j] + PHt[i, 2] * Sinv[2, j]
        dx = np.empty(DIM)
        for i in range(DIM):
            dx[i] = K[i, 0] * nu[0] + K[i, 1] * nu[1] + K[i, 2] * nu[2]
        I_KH = np.empty((NA, NA))
        for i in range(NA):
            for j in range(NA):
                I_KH[i, j] = (1.0 if i == j else 0.0) - (
                    K[i, 0] * H[0, j] + K[i, 1] * H[1, j] + K[i, 2] * H[2, j]
                )
        tmp = np.empty((NA, NA))
        out = np.empty((NA, NA))
        _sandwich_into(I_KH, P, tmp, out)
        KR = np.empty((NA, 3))
        for i in range(NA):
            for j in range(3):
                KR[i, j] = K[i, 0] * Rm[0, j] + K[i, 1] * Rm[1, j] + K[i, 2] * Rm[2, j]
        for i in range(NA):
            for j in range(NA):
                out[i, j] += KR[i, 0] * K[j, 0] + KR[i, 1] * K[j, 1] + KR[i, 2] * K[j, 2]
        _symmetrise_into(out, P)
        for i in range(3):
            vel[i] += dx[VEL + i]
            ba[i] += dx[BA + i]
            bg[i] += dx[BG + i]
        E = np.empty((3, 3))
        exp_so3_into(dx[ATT], dx[ATT + 1], dx[ATT + 2], E)
        Cn = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                Cn[i, j] = E[i, 0] * C[0, j] + E[i, 1] * C[1, j] + E[i, 2] * C[2, j]
        C[:, :] = Cn
    return use, passed, nis


@_jit
def record(
    row: int,
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    ba_t: np.ndarray,
    bg_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    P: np.ndarray,
    geodetic: bool,
    origin: np.ndarray,
    block_of_state: np.ndarray,
    num_blocks: int,
    deg: float,
    series: np.ndarray,
    nees_block: np.ndarray,
    est_pos: np.ndarray,
    est_vel: np.ndarray,
    est_euler: np.ndarray,
) -> None:
    """One output epoch of every (method, run) (yoo_bank.YooBank._record): errors ``true - estimate``,
    1-sigma, NEES of the 12 states and of each block (no position state: NaN), the estimates."""
    M, R = pos.shape[0], pos.shape[1]
    dx = np.empty(DIM)
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    L = np.empty((DIM, DIM))
    yv = np.empty(DIM)
    idx = np.arange(DIM)
    members, sizes, lead, order = nees_plan(block_of_state, num_blocks)
    blocks = np.empty(num_blocks)
    for m in range(M):
        for r in range(R):
            Cm = C[m, r]
            for i in range(3):
                for j in range(3):
                    Ce[i, j] = C_t[i, 0] * Cm[j, 0] + C_t[i, 1] * Cm[j, 1] + C_t[i, 2] * Cm[j, 2]
            log_so3_into(Ce, rho)
            for i in range(3):
                dx[VEL + i] = vel_t[i] - vel[m, r, i]
                dx[ATT + i] = rho[i]
                dx[BA + i] = ba_t[r, i] - ba[m, r, i]
                dx[BG + i] = bg_t[r, i] - bg[m, r, i]
            if geodetic:
                e0, e1, e2 = _ned_offset(
                    pos[m, r, 0], pos[m, r, 1], -pos[m, r, 2], origin[0], origin[1], origin[2]
                )
                est_pos[row, m, r, 0], est_pos[row, m, r, 1], est_pos[row, m, r, 2] = e0, e1, e2
            else:
                for i in range(3):
                    est_pos[row, m, r, i] = pos[m, r, i]
            ep = 0.0
            ev = 0.0
            for i in range(3):
                ep += (est_pos[row, m, r, i] - pos_t[i]) ** 2
                vb = (C_t[0, i] * vel_t[0] + C_t[1, i] * vel_t[1] + C_t[2, i] * vel_t[2]) - (
                    Cm[0, i] * vel[m, r, 0] + Cm[1, i] * vel[m, r, 1] + Cm[2, i] * vel[m, r, 2]
                )
                ev += vb * vb
                est_vel[row, m, r, i] = vel[m, r, i]
            Pm = P[m, r]
            series[0, row, m, r] = math.sqrt(ev)
            series[1, row, m, r] = math.sqrt(rho[0] ** 2 + rho[1] ** 2 + rho[2] ** 2) * deg
            series[2, row, m, r] = math.sqrt(ep)
            series[3, row, m, r] = math.sqrt(Pm[0, 0] + Pm[1, 1] + Pm[2, 2])
            series[4, row, m, r] = math.sqrt(Pm[3, 3] + Pm[4, 4] + Pm[5, 5]) * deg
            series[5, row, m, r] = np.nan
            series[6, row, m, r] = quadratic_into(Pm, dx, idx, DIM, L, yv)
            series[7, row, m, r] = math.sqrt(rho[0] ** 2 + rho[1] ** 2) * deg
            series[8, row, m, r] = abs(rho[2]) * deg
            series[9, row, m, r] = math.sqrt(Pm[3, 3] + Pm[4, 4]) * deg
            series[10, row, m, r] = math.sqrt(Pm[5, 5]) * deg
            nees_blocks_into(Pm, dx, members, sizes, lead, order, L, yv, blocks)
            for b in range(num_blocks):
                nees_block[row, m, r, b] = blocks[b] if sizes[b] > 0 else np.nan
            est_euler[row, m, r, 0] = math.atan2(Cm[2, 1], Cm[2, 2])
            est_euler[row, m, r, 1] = -math.asin(min(1.0, max(-1.0, Cm[2, 0])))
            est_euler[row, m, r, 2] = math.atan2(Cm[1, 0], Cm[0, 0])


@_jit
def run_stops(
    s0: int,
    s1: int,
    stops: np.ndarray,
    ping_of_stop: np.ndarray,
    row_of_stop: np.ndarray,
    k0: int,
    counters: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    P: np.ndarray,
    dtheta_sum: np.ndarray,
    vkf_x: np.ndarray,
    vkf_P: np.ndarray,
    vkf_use: np.ndarray,
    vkf_alt: np.ndarray,
    phi_raw: np.ndarray,
    dv_raw: np.ndarray,
    dtheta: np.ndarray,
    dt: float,
    C_earth: np.ndarray,
    C_earth_half: np.ndarray,
    g_n: np.ndarray,
    coriolis_T: np.ndarray,
    geodetic: bool,
    origin: np.ndarray,
    w_ie_flat: np.ndarray,
    q: np.ndarray,
    method_code: np.ndarray,
    y_beam: np.ndarray,
    available: np.ndarray,
    A_b: np.ndarray,
    l_dvl_b: np.ndarray,
    beam_var: float,
    qc: np.ndarray,
    L4: np.ndarray,
    gate: float,
    rpm_index: np.ndarray,
    rpm_value: np.ndarray,
    rpm_sf: np.ndarray,
    rpm_b: np.ndarray,
    echo_index: np.ndarray,
    echo_alt: np.ndarray,
    vkf_Q: np.ndarray,
    vkf_R: float,
    switch_altitude: float,
    forward_norm: bool,
    lateral_var: float,
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    ba_t: np.ndarray,
    bg_t: np.ndarray,
    block_of_state: np.ndarray,
    num_blocks: int,
    deg: float,
    series: np.ndarray,
    nees_block: np.ndarray,
    est_pos: np.ndarray,
    est_vel: np.ndarray,
    est_euler: np.ndarray,
    up_z: np.ndarray,
    up_nu: np.ndarray,
    up_S: np.ndarray,
    up_flags: np.ndarray,
    up_nis: np.ndarray,
    tr_x: np.ndarray,
    tr_sigma: np.ndarray,
    tr_truth: np.ndarray,
    tr_use: np.ndarray,
    tr_alt: np.ndarray,
) -> None:
    """Stops ``s0 .. s1 - 1`` of a chunk (yoo_bank.YooBank.feed's loop): advance the nominal states
    to the stop, step the covariance, fuse a DVL ping (its row of the chunk's pings in
    ``ping_of_stop``), record an output epoch (its row in ``row_of_stop``). ``counters`` =
    (k_state, k_cov), read and written."""
    M, R = pos.shape[0], pos.shape[1]
    F = np.empty((DIM, DIM))
    Phi = np.empty((DIM, DIM))
    tmp = np.empty((DIM, DIM))
    out = np.empty((NA, NA))
    v_b = np.empty((R, 3))
    cov_b = np.empty((R, 3, 3))
    gain = np.empty((R, 3, 4))
    Hb = np.empty((3, NC))
    Hc = np.empty((3, NC))
    ok = np.empty(R, dtype=np.bool_)
    have_rpm = np.empty(R, dtype=np.bool_)
    z = np.empty(3)
    Rm = np.empty((3, 3))
    Cc = np.empty((3, 3))
    nu = np.empty(3)
    S_diag = np.empty(3)
    for s in range(s0, s1):
        k = stops[s]
        if k < k0:
            continue
        i = k - k0
        if k > counters[0]:
            advance(
                pos,
                vel,
                C,
                ba,
                bg,
                phi_raw,
                dv_raw,
                dtheta,
                dtheta_sum,
                counters[0] - k0,
                i,
                dt,
                C_earth,
                C_earth_half,
                g_n,
                coriolis_T,
                geodetic,
            )
            counters[0] = k
        if k > counters[1]:
            propagate(
                P,
                pos,
                vel,
                C,
                ba,
                dv_raw[i],
                dt,
                (k - counters[1]) * dt,
                geodetic,
                w_ie_flat,
                q,
                qc,
                F,
                Phi,
                tmp,
                out,
            )
            dtheta_sum[:, :] = 0.0
            counters[1] = k
        p = ping_of_stop[s]
        if p >= 0:
            for r in range(R):
                lat = pos[0, r, 0] if geodetic else origin[0]
                ok[r] = dvl_body_velocity_into(
                    y_beam[p, r],
                    available[p, r],
                    dtheta[i, r],
                    dt,
                    C[0, r],
                    lat,
                    A_b,
                    l_dvl_b,
                    beam_var,
                    v_b[r],
                    cov_b[r],
                    gain[r],
                )
            for m in range(M):
                for r in range(R):
                    Cm = C[m, r]
                    # the consider states' columns in b: the scale factor scales the estimated body
                    # velocity, a beam bias goes through the least squares of the beams that returned
                    for a in range(3):
                        Hb[a, 0] = Cm[0, a] * vel[m, r, 0] + Cm[1, a] * vel[m, r, 1] + Cm[2, a] * vel[m, r, 2]
                        for c in range(4):
                            Hb[a, 1 + c] = gain[r, a, c]
                    use_rpm = False
                    if method_code[m] == VKF:
                        jr = _latest(rpm_index, k)
                        je = _latest(echo_index, k)
                        rpm_now = rpm_value[jr, r] if jr >= 0 else np.nan
                        altitude = echo_alt[je, r] if je >= 0 else np.nan
                        if forward_norm:
                            z_fwd = math.sqrt(v_b[r, 0] ** 2 + v_b[r, 1] ** 2 + v_b[r, 2] ** 2)
                        else:
                            z_fwd = v_b[r, 0]
                        use_rpm, got_rpm = vkf_step(
                            vkf_x[r], vkf_P[r], rpm_now, altitude, z_fwd, ok[r], vkf_Q, vkf_R, switch_altitude
                        )
                        have_rpm[r] = got_rpm
                        vkf_use[r], vkf_alt[r] = use_rpm, altitude
                        for j in range(3):
                            tr_x[p, r, j] = vkf_x[r, j]
                            tr_sigma[p, r, j] = math.sqrt(vkf_P[r, j, j])
                        tr_truth[p, r, 0] = rpm_sf[jr, r] if jr >= 0 else np.nan
                        tr_truth[p, r, 1] = rpm_b[jr, r] if jr >= 0 else np.nan
                        tr_use[p, r], tr_alt[p, r] = use_rpm, altitude
                    if use_rpm:  # C [V_rpm, 0, 0] with diag(P_VV, lateral, lateral) rotated
                        valid = have_rpm[r]
                        Hb[:, :] = 0.0  # its surge was learnt from the DVL's (4 beams)
                        Hb[0, 0] = vkf_x[r, 0]
                        for c in range(4):
                            Hb[0, 1 + c] = L4[0, c]
                        for a in range(3):
                            z[a] = Cm[a, 0] * vkf_x[r, 0]
                            for b in range(3):
                                Rm[a, b] = (
                                    Cm[a, 0] * vkf_P[r, 0, 0] * Cm[b, 0]
                                    + Cm[a, 1] * lateral_var * Cm[b, 1]
                                    + Cm[a, 2] * lateral_var * Cm[b, 2]
                                )
                    else:
                        valid = ok[r]
                        for a in range(3):
                            z[a] = Cm[a, 0] * v_b[r, 0] + Cm[a, 1] * v_b[r, 1] + Cm[a, 2] * v_b[r, 2]
                            for b in range(3):
                                Cc[a, b] = (
                                    Cm[a, 0] * cov_b[r, 0, b]
                                    + Cm[a, 1] * cov_b[r, 1, b]
                                    + Cm[a, 2] * cov_b[r, 2, b]
                                )
                        for a in range(3):
                            for b in range(3):
                                Rm[a, b] = Cc[a, 0] * Cm[b, 0] + Cc[a, 1] * Cm[b, 1] + Cc[a, 2] * Cm[b, 2]
                    for a in range(3):
                        for c in range(NC):
                            Hc[a, c] = Cm[a, 0] * Hb[0, c] + Cm[a, 1] * Hb[1, c] + Cm[a, 2] * Hb[2, c]
                    fused, passed, nis = fuse(
                        P[m, r], vel[m, r], C[m, r], ba[m, r], bg[m, r], z, Rm, Hc, valid, gate, S_diag, nu
                    )
                    for a in range(3):
                        up_z[p, m, r, a] = z[a]
                        up_nu[p, m, r, a] = nu[a] if valid else np.nan
                        up_S[p, m, r, a] = S_diag[a] if valid else np.nan
                    up_flags[p, m, r, U_VALID] = valid
                    up_flags[p, m, r, U_FUSED] = fused
                    up_flags[p, m, r, U_REJECTED] = valid and not passed
                    up_nis[p, m, r] = nis if valid else np.nan
        row = row_of_stop[s]
        if row >= 0:
            record(
                row,
                pos_t[i],
                vel_t[i],
                C_t[i],
                ba_t[i],
                bg_t[i],
                pos,
                vel,
                C,
                ba,
                bg,
                P,
                geodetic,
                origin,
                block_of_state,
                num_blocks,
                deg,
                series,
                nees_block,
                est_pos,
                est_vel,
                est_euler,
            )
