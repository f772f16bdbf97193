"""Yoo 2014's formulas compiled (numba): the 12-state filter's covariance step (with the DVL's
consider states), the DVL's body velocity by least squares, the VKF's step and the fusion of a
NED velocity, written out entry by entry, in the order of operations of the numpy reference
(tests/unit/tauvcore/engine/yoo_reference.py; ``tests/unit/tauvcore/engine/test_yoo_bank.py`` holds every result of both equal to
1e-9). The chunk loop that drives them is tauvcore.engine.yoo_loop; the strapdown,
rotations and NEES are the 20-state bank's own kernels (tauvcore.filter.kernels), so those are
bit for bit the same.

Layout: the bank's states are (M, R, ...) arrays (methods, runs); the VKF's (R, ...). The
covariance is over the 12 states, the 5 consider states and the E states the sources add
(tauvcore.engine.yoo_velocity), N = 17 + E.
"""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import jit, radii_nav
from tauvcore.filter.kernels.correction import correct_into
from tauvcore.filter.kernels.dvl_kernels import lc_solve_into
from tauvcore.filter.kernels.error_model_kernels import extra_step_into
from tauvcore.filter.kernels.rotation_kernels import exp_so3_into, skew_into
from tauvcore.geo.earth import OMEGA_IE_RPS

DIM = 12
NC = 5  # consider states (tauvcore.engine.yoo_bank.NC): DVL scale factor, 4 beam biases
NA = DIM + NC
VEL, ATT, BA, BG = 0, 3, 6, 9  # tauvcore.filter.families.yoo.model's blocks


@jit
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


@jit
def _symmetrise_into(A: np.ndarray, out: np.ndarray) -> None:
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (A[i, j] + A[j, i])


@jit
def _compose_into(Phi: np.ndarray, A: np.ndarray, tmp: np.ndarray) -> None:
    """``A <- X + A + X A``, ``X = Phi - I`` (DIM, DIM): the transition since a mark, ``I + A``,
    followed by the step ``Phi`` (``tmp`` work space)."""
    for i in range(DIM):
        for j in range(DIM):
            s = 0.0
            for k in range(DIM):
                s += (Phi[i, k] - (1.0 if i == k else 0.0)) * A[k, j]
            tmp[i, j] = (Phi[i, j] - (1.0 if i == j else 0.0)) + A[i, j] + s
    A[:, :] = tmp


@jit
def propagate(
    P: np.ndarray,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    dv_raw_i: np.ndarray,
    dt: float,
    dt_c: float,
    geodetic: bool,
    w_ie_flat: np.ndarray,
    noise: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    work: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    phi_acc: np.ndarray,
) -> None:
    """One covariance step of every (method, run) over ``dt_c``:
    ``Phi = I + F dt_c + (F dt_c)^2 / 2``, ``P_xx <- Phi P_xx Phi^T + diag(q) dt_c``, the other
    states' cross terms ``P_xc <- Phi P_xc``, ``P_cc += diag(qc) dt_c`` on the consider states,
    and the added states' own step (``extra_rate``, ``extra_q`` (E,), the 20-state kernels' exact discrete step),
    symmetrised; F of tauvcore.filter.families.yoo.model.F_matrix at the ``nominal`` state ``(pos, vel, C, ba)``
    and the latest specific force. P (M, R, N, N); ``noise`` ``(q, qc, extra_rate, extra_q)``;
    ``work`` ``(F, Phi, tmp, out)``: F, Phi, tmp (DIM, DIM), out (N, N) work space. With rows, ``phi_acc`` (M, R,
    DIM, DIM) holds ``Phi - I`` since the smoother's last mark and takes this step's:
    ``X + A + X A`` (the smoother's transition since its mark, tauvcore.engine.yoo_smoothing)."""
    pos, vel, C, ba = nominal
    q, qc, extra_rate, extra_q = noise
    F, Phi, tmp, out = work
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
                R_N, R_E = radii_nav(lat)
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
            skew_into(2.0 * w_ie[0] + w_en[0], 2.0 * w_ie[1] + w_en[1], 2.0 * w_ie[2] + w_en[2], Sa)
            skew_into(v[0], v[1], v[2], Sb)
            for i in range(3):
                for j in range(3):
                    sj = Sb[i, 0] * J[0, j] + Sb[i, 1] * J[1, j] + Sb[i, 2] * J[2, j]
                    F[VEL + i, VEL + j] = (-Sa[i, j] + sj) * dt_c
            skew_into(f_n[0], f_n[1], f_n[2], Sa)
            for i in range(3):
                for j in range(3):
                    F[VEL + i, ATT + j] = -Sa[i, j] * dt_c
                    F[VEL + i, BA + j] = -Cm[i, j] * dt_c
                    F[ATT + i, VEL + j] = -J[i, j] * dt_c
                    F[ATT + i, BG + j] = -Cm[i, j] * dt_c
            skew_into(w_ie[0] + w_en[0], w_ie[1] + w_en[1], w_ie[2] + w_en[2], Sa)
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
            N = Pm.shape[0]
            _sandwich_into(Phi, Pm[:DIM, :DIM], tmp, out[:DIM, :DIM])
            for i in range(DIM):
                out[i, i] += q[i] * dt_c
                for c in range(N - DIM):
                    s = 0.0
                    for k in range(DIM):
                        s += Phi[i, k] * Pm[k, DIM + c]
                    out[i, DIM + c] = s
                    out[DIM + c, i] = s
            for a in range(N - DIM):
                for c in range(N - DIM):
                    out[DIM + a, DIM + c] = Pm[DIM + a, DIM + c]
            for a in range(NC):
                out[DIM + a, DIM + a] += qc[a] * dt_c
            extra_step_into(out, extra_rate, extra_q, dt_c, NA)
            _symmetrise_into(out, Pm)
            if phi_acc.shape[0] > 0:
                _compose_into(Phi, phi_acc[m, r], tmp)


@jit
def dvl_body_velocity_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
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
    """One run's DVL body velocity by least squares over the beams that returned (finite), its
    covariance, the least squares' gain from the beams (3, 4), and whether at least three returned
    (rpm_aid.dvl_body_velocity with ``with_gain``): the loosely coupled filter's least squares
    (tauvcore.filter.kernels.dvl_kernels.lc_solve_into), then the head's own motion taken out with
    the gyro rate less the earth's (first order). With fewer beams the velocity is NaN."""
    used = np.empty(A_b.shape[0], dtype=np.bool_)
    for k in range(A_b.shape[0]):
        used[k] = available[k] and math.isfinite(y[k])
    ok = lc_solve_into(A_b, y, used, beam_var, cov_b, gain, v_b)
    w0, w2 = math.cos(lat) * OMEGA_IE_RPS, -math.sin(lat) * OMEGA_IE_RPS
    om = np.empty(3)
    for i in range(3):
        om[i] = dtheta_i[i] / dt - (C_nb[0, i] * w0 + C_nb[2, i] * w2)
    v_b[0] -= om[1] * l_dvl_b[2] - om[2] * l_dvl_b[1]
    v_b[1] -= om[2] * l_dvl_b[0] - om[0] * l_dvl_b[2]
    v_b[2] -= om[0] * l_dvl_b[1] - om[1] * l_dvl_b[0]
    if not ok:
        v_b[:] = np.nan
    return ok


@jit
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


@jit
def fuse(
    P: np.ndarray,
    nominal: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    measurement: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    valid: bool,
    gate: float,
    out: tuple[np.ndarray, np.ndarray],
) -> tuple:
    """Fuse one NED velocity ``z`` into one filter (its ``nominal`` ``(vel, C, ba, bg, extra)``,
    written; the ``measurement`` ``(z, h, w, Rm, Hc, Hx)``; ``out`` ``(S_diag, nu)``, written) (the numpy reference's fuse_velocity, tests/unit/tauvcore/engine/yoo_reference.py): its prediction
    ``h`` (the estimated velocity, or through the water ``v - c``), ``H = [I, [w x], 0, 0, Hc,
    Hx]`` (``w`` the vector the attitude rotated, Hc (3, NC) on the consider states, whose gain
    is zero, Hx (3, E) on the added states), through the one gated Joseph correction of every
    family (tauvcore.filter.kernels.correction.correct_into: every row passes the gate or none is
    fused), inject and reset. -> (fused, passed the gate, NIS before the gate (NaN if S cannot be
    inverted))."""
    vel, C, ba, bg, extra = nominal
    z, h, w, Rm, Hc, Hx = measurement
    S_diag, nu = out
    NN = P.shape[0]
    H = np.zeros((3, NN))
    for i in range(3):
        H[i, VEL + i] = 1.0
        nu[i] = z[i] - h[i]
        for c in range(NC):
            H[i, DIM + c] = Hc[i, c] if math.isfinite(Hc[i, c]) else 0.0
        for e in range(NN - NA):
            H[i, NA + e] = Hx[i, e]
    Sk = np.empty((3, 3))
    skew_into(w[0], w[1], w[2], Sk)
    for i in range(3):
        for j in range(3):
            H[i, ATT + j] = Sk[i, j]
    active = np.empty(3, dtype=np.bool_)
    for i in range(3):
        active[i] = valid
    dx = np.zeros(NN)
    keep = np.empty(3, dtype=np.bool_)
    # the one gated Joseph correction (every row or none), the consider states' gain zero
    nis, ratio, _, _ = correct_into(P, H, Rm, nu, active, False, gate, dx, S_diag, keep, DIM, NA)
    use = keep[0]
    passed = ratio <= 1.0
    if use:
        for i in range(3):
            vel[i] += dx[VEL + i]
            ba[i] += dx[BA + i]
            bg[i] += dx[BG + i]
        for e in range(NN - NA):
            extra[e] += dx[NA + e]
        E = np.empty((3, 3))
        exp_so3_into(dx[ATT], dx[ATT + 1], dx[ATT + 2], E)
        Cn = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                Cn[i, j] = E[i, 0] * C[0, j] + E[i, 1] * C[1, j] + E[i, 2] * C[2, j]
        C[:, :] = Cn
    return use, passed, nis
