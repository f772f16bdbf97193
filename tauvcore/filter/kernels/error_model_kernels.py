"""The error model compiled: the earth terms F is built from, the continuous F and G
(tauvcore.ins.error_model, Tal et al. 2017 eq. 4-5, 9-10), the transition, the covariance
sandwich and the process noise, and :func:`propagate_bank`, the covariance step of a whole
(methods, runs) bank; with the batched entry points tauvcore.ins.error_model and
tauvcore.filter.eskf.propagate call for their numpy callers.

Structure exploited (Tal et al. 2017 eq. 4, 9; tauvcore.filter.layout): F is zero outside rows
0-8 (position, misalignment, velocity) and columns 0-14 (those plus the IMU biases), so
``Phi = I + A + A^2/2 + A^3/6`` (A = F dt) differs from I only in rows 0-8, and
``Phi P Phi^T`` touches 9 rows and columns of P through 15 columns of Phi. The process noise
enters as ``P <- Phi (P + GQG/2) Phi^T + GQG/2`` (the trapezoid Qd of ``discretise``, one sandwich
instead of two).
"""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import (
    ATT,
    BA,
    BG,
    CORE,
    NAV,
    POS,
    VEL,
    N,
    earth_rate,
    gravity_north,
    jit,
    normal_gravity,
    radii_nav,
    transport_rate,
)
from tauvcore.filter.kernels.rotation_kernels import skew_entry
from tauvcore.geo import earth

# ---------------------------------------------------------------- earth terms
# Rows of the (18, 3) array of earth terms F is built from (:func:`flat_terms_into`,
# :func:`geodetic_terms_into`): vectors in n, then 3x3 Jacobians by rows.
T_G, T_WIE, T_WEN = 0, 1, 2  # plumb-bob gravity, earth rate, transport rate in n
T_DG, T_DWIE, T_DWEN = 3, 6, 9  # d g_n / d pos, d omega_ie_n / d pos, d omega_en_n / d pos
T_DWENV = 12  # d omega_en_n / d vel_n
T_FPP = 15  # d pos_err' / d pos_err (the position-error metrics' own change)
NUM_TERMS = 18


@jit
def flat_terms_into(g_n: np.ndarray, w_ie: np.ndarray, T: np.ndarray) -> None:
    """Earth terms of the flat model (tauvcore.geo.earth.Earth): constant gravity and earth
    rate, no transport rate, no dependence on position. T (18, 3), every entry written."""
    T[:, :] = 0.0
    for i in range(3):
        T[T_G, i] = g_n[i]
        T[T_WIE, i] = w_ie[i]


@jit
def geodetic_terms_into(
    lat: float, h: float, v_north: float, v_east: float, v_down: float, T: np.ndarray
) -> None:
    """Earth terms on the WGS-84 ellipsoid at latitude ``lat``, height ``h`` and NED velocity
    (tauvcore.geo.earth), with their Jacobians with respect to the position error in metres
    ``dpos = ((R_N + h) dlat, (R_E + h) cos(lat) dlon, -dh)`` and the NED velocity error.
    T (18, 3), every entry written. Derivations in tauvcore.ins.error_model.
    """
    T[:, :] = 0.0
    s, c = math.sin(lat), math.cos(lat)
    t = s / c
    R_N, R_E = radii_nav(lat)
    rho_n, rho_e = R_N + h, R_E + h
    w2 = 1.0 - earth._E2 * s * s
    dR_N = (
        3.0 * earth.A_M * (1.0 - earth._E2) * earth._E2 * s * c / (w2 * w2 * math.sqrt(w2))
    )  # d R_N / d lat
    dR_E = earth.A_M * earth._E2 * s * c / (w2 * math.sqrt(w2))  # d R_E / d lat
    # gravity: (-K h sin 2lat, 0, gamma(lat, h))
    K = earth._GRAVITY_NORTH_PER_M
    gamma_0 = normal_gravity(lat, 0.0)
    h_a = h / earth.A_M
    f, m = earth.FLATTENING, earth._M_GRAVITY
    P = 1.0 - 2.0 * h_a * (1.0 + f + m - 2.0 * f * s * s) + 3.0 * h_a * h_a
    T[T_G, 0] = gravity_north(lat, h)
    T[T_G, 2] = normal_gravity(lat, h)
    u = s * s
    dgamma0_du = earth._GE * (
        earth._K_SOMIGLIANA / math.sqrt(1.0 - earth._E2 * u)
        + (1.0 + earth._K_SOMIGLIANA * u) * earth._E2 / (2.0 * (1.0 - earth._E2 * u) ** 1.5)
    )
    dgamma_dlat = dgamma0_du * 2.0 * s * c * P + gamma_0 * 8.0 * f * h_a * s * c
    dgamma_dh = gamma_0 * (-2.0 / earth.A_M * (1.0 + f + m - 2.0 * f * s * s) + 6.0 * h_a / earth.A_M)
    T[T_DG + 0, 0] = -2.0 * K * h * math.cos(2.0 * lat) / rho_n
    T[T_DG + 0, 2] = K * math.sin(2.0 * lat)  # - d/dh
    T[T_DG + 2, 0] = dgamma_dlat / rho_n
    T[T_DG + 2, 2] = -dgamma_dh
    # earth rate: Omega (cos lat, 0, -sin lat)
    W = earth.OMEGA_IE_RPS
    T[T_WIE, 0], T[T_WIE, 1], T[T_WIE, 2] = earth_rate(lat)
    T[T_DWIE + 0, 0], T[T_DWIE + 2, 0] = -W * s / rho_n, -W * c / rho_n
    # transport rate: (v_E / rho_E, -v_N / rho_N, -v_E tan / rho_E)
    T[T_WEN, 0], T[T_WEN, 1], T[T_WEN, 2] = transport_rate(R_N, R_E, lat, h, v_north, v_east)
    T[T_DWEN + 0, 0] = -v_east * dR_E / (rho_e * rho_e) / rho_n
    T[T_DWEN + 1, 0] = v_north * dR_N / (rho_n * rho_n) / rho_n
    T[T_DWEN + 2, 0] = -v_east * (rho_e / (c * c) - t * dR_E) / (rho_e * rho_e) / rho_n
    T[T_DWEN + 0, 2] = v_east / (rho_e * rho_e)  # - d/dh
    T[T_DWEN + 1, 2] = -v_north / (rho_n * rho_n)
    T[T_DWEN + 2, 2] = -v_east * t / (rho_e * rho_e)
    T[T_DWENV + 0, 1] = 1.0 / rho_e
    T[T_DWENV + 1, 0] = -1.0 / rho_n
    T[T_DWENV + 2, 1] = -t / rho_e
    # the position-error metrics change as the vehicle moves (error_model docstring)
    T[T_FPP + 0, 0] = -v_down / rho_n
    T[T_FPP + 0, 2] = v_north / rho_n
    T[T_FPP + 1, 0] = -v_east * (dR_E / rho_e - t) / rho_n
    T[T_FPP + 1, 1] = dR_E * v_north / (rho_n * rho_e) - v_down / rho_e - t * v_north / rho_n
    T[T_FPP + 1, 2] = v_east / rho_e


# ---------------------------------------------------------------- F, G, Phi, Qd
@jit
def F_core_into(C: np.ndarray, v: np.ndarray, om: np.ndarray, T: np.ndarray, A: np.ndarray) -> None:
    """The block of the continuous F (tauvcore.ins.error_model, eq. 4 and 9) that is not zero,
    rows 0-8 and columns 0-14, into ``A`` (9, 15) (every entry written; no allocation).

    C (3, 3) nominal C_nb, v (3,) nominal body velocity, om (3,) bias-corrected rate, T (18, 3)
    the earth terms at the nominal position (:func:`flat_terms_into` or
    :func:`geodetic_terms_into`; in the flat model the position columns stay zero).
    """
    A[:, :] = 0.0
    vn0 = C[0, 0] * v[0] + C[0, 1] * v[1] + C[0, 2] * v[2]
    vn1 = C[1, 0] * v[0] + C[1, 1] * v[1] + C[1, 2] * v[2]
    vn2 = C[2, 0] * v[0] + C[2, 1] * v[1] + C[2, 2] * v[2]
    # d pos' = F_pp d pos - [(C v) x] rho + C dv
    A[POS + 0, ATT + 1], A[POS + 0, ATT + 2] = vn2, -vn1
    A[POS + 1, ATT + 0], A[POS + 1, ATT + 2] = -vn2, vn0
    A[POS + 2, ATT + 0], A[POS + 2, ATT + 1] = vn1, -vn0
    for i in range(3):
        for j in range(3):
            A[POS + i, POS + j] = T[T_FPP + i, j]
            A[POS + i, VEL + j] = C[i, j]
            A[ATT + i, BG + j] = -C[i, j]
    # rho' = -[omega_in x] rho + Wv [v_n x] rho - Wv C dv - (W_ie,p + W_en,p) dpos - C dbg
    # (Wv = d omega_en / d vel_n; flat model: omega_in = omega_ie, the rest zero)
    w0 = T[T_WIE, 0] + T[T_WEN, 0]
    w1 = T[T_WIE, 1] + T[T_WEN, 1]
    w2 = T[T_WIE, 2] + T[T_WEN, 2]
    A[ATT + 0, ATT + 1], A[ATT + 0, ATT + 2] = w2, -w1
    A[ATT + 1, ATT + 0], A[ATT + 1, ATT + 2] = -w2, w0
    A[ATT + 2, ATT + 0], A[ATT + 2, ATT + 1] = w1, -w0
    for i in range(3):
        for j in range(3):
            sv = 0.0
            sc = 0.0
            for k in range(3):
                sv += T[T_DWENV + i, k] * skew_entry(vn0, vn1, vn2, k, j)
                sc += T[T_DWENV + i, k] * C[k, j]
            A[ATT + i, ATT + j] += sv
            A[ATT + i, VEL + j] = -sc
            A[ATT + i, POS + j] = -(T[T_DWIE + i, j] + T[T_DWEN + i, j])
    # dv' = (C^T [g x] + [v x] C^T W) rho - [(om + C^T w_ie) x] dv - dba - [v x] dbg
    #       + (C^T G_p + [v x] C^T W_ie,p) dpos
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += C[k, i] * skew_entry(T[T_G, 0], T[T_G, 1], T[T_G, 2], k, j)
            A[VEL + i, ATT + j] = s
    for i in range(3):
        for j in range(3):
            s = 0.0
            sp = 0.0
            for k in range(3):
                ctw = 0.0  # (C^T W)[k, j]
                ctp = 0.0  # (C^T W_ie,p)[k, j]
                for m in range(3):
                    ctw += C[m, k] * skew_entry(T[T_WIE, 0], T[T_WIE, 1], T[T_WIE, 2], m, j)
                    ctp += C[m, k] * T[T_DWIE + m, j]
                s += skew_entry(v[0], v[1], v[2], i, k) * ctw
                sp += skew_entry(v[0], v[1], v[2], i, k) * ctp + C[k, i] * T[T_DG + k, j]
            A[VEL + i, ATT + j] += s
            A[VEL + i, POS + j] = sp
    a0 = om[0] + C[0, 0] * T[T_WIE, 0] + C[1, 0] * T[T_WIE, 1] + C[2, 0] * T[T_WIE, 2]
    a1 = om[1] + C[0, 1] * T[T_WIE, 0] + C[1, 1] * T[T_WIE, 1] + C[2, 1] * T[T_WIE, 2]
    a2 = om[2] + C[0, 2] * T[T_WIE, 0] + C[1, 2] * T[T_WIE, 1] + C[2, 2] * T[T_WIE, 2]
    A[VEL + 0, VEL + 1], A[VEL + 0, VEL + 2] = a2, -a1
    A[VEL + 1, VEL + 0], A[VEL + 1, VEL + 2] = -a2, a0
    A[VEL + 2, VEL + 0], A[VEL + 2, VEL + 1] = a1, -a0
    for i in range(3):
        A[VEL + i, BA + i] = -1.0
        for j in range(3):
            A[VEL + i, BG + j] = -skew_entry(v[0], v[1], v[2], i, j)


@jit
def F_into(C: np.ndarray, v: np.ndarray, om: np.ndarray, T: np.ndarray, F: np.ndarray) -> None:
    """Continuous F (tauvcore.ins.error_model, eq. 4 and 9) into ``F`` (20, 20): zero but for the
    block :func:`F_core_into` writes."""
    F[:, :] = 0.0
    A = np.empty((NAV, CORE))
    F_core_into(C, v, om, T, A)
    for i in range(NAV):
        for j in range(CORE):
            F[i, j] = A[i, j]


@jit
def G_imu_into(C: np.ndarray, v: np.ndarray, Gm: np.ndarray) -> None:
    """Rows 3-8 (misalignment, velocity) of G's columns 0-5 (accelerometer, gyro noise) into
    ``Gm`` (6, 6): the only non-zero entries of G besides the identity of the random walks."""
    for i in range(3):
        for j in range(3):
            Gm[i, j] = 0.0  # misalignment <- accelerometer
            Gm[i, 3 + j] = -C[i, j]  # misalignment <- gyro
            Gm[3 + i, j] = -1.0 if i == j else 0.0  # velocity <- accelerometer
            Gm[3 + i, 3 + j] = -skew_entry(v[0], v[1], v[2], i, j)  # velocity <- gyro


@jit
def G_into(C: np.ndarray, v: np.ndarray, G: np.ndarray) -> None:
    """Continuous G (eq. 5 and 10) into ``G`` (20, 17), zeroed here."""
    G[:, :] = 0.0
    Gm = np.empty((6, 6))
    G_imu_into(C, v, Gm)
    for i in range(6):
        for j in range(6):
            G[ATT + i, j] = Gm[i, j]
    for i in range(N - BA):
        G[BA + i, 6 + i] = 1.0


@jit
def noise_imu_into(Gm: np.ndarray, q: np.ndarray, dt: float, Q6: np.ndarray) -> None:
    """The misalignment-velocity block (rows and columns 3-8) of ``G diag(q) G^T dt`` into ``Q6``
    (6, 6), from :func:`G_imu_into`'s ``Gm``; the rest of ``G diag(q) G^T dt`` is zero but for
    the diagonal ``q[6:] dt`` of the random walks (rows 9-19). Exactly symmetric."""
    for a in range(6):
        for b in range(a, 6):
            s = 0.0
            for k in range(6):
                s += Gm[a, k] * (q[k] * dt) * Gm[b, k]
            Q6[a, b] = s
            Q6[b, a] = s


@jit
def _series_step_into(A: np.ndarray, B: np.ndarray, scale: float, out: np.ndarray) -> None:
    """``out = A + scale * A[:, :9] B`` for (9, 15) blocks: one Horner step of
    :func:`transition_core_into`, five columns at a time in registers (five independent sums:
    the loop is bound by the latency of one multiply-add, not by its count)."""
    for i in range(NAV):
        for j in range(0, CORE, 5):
            s0 = s1 = s2 = s3 = s4 = 0.0
            for k in range(NAV):
                a = A[i, k]
                s0 += a * B[k, j]
                s1 += a * B[k, j + 1]
                s2 += a * B[k, j + 2]
                s3 += a * B[k, j + 3]
                s4 += a * B[k, j + 4]
            out[i, j] = A[i, j] + scale * s0
            out[i, j + 1] = A[i, j + 1] + scale * s1
            out[i, j + 2] = A[i, j + 2] + scale * s2
            out[i, j + 3] = A[i, j + 3] + scale * s3
            out[i, j + 4] = A[i, j + 4] + scale * s4


@jit
def transition_core_into(A: np.ndarray, X: np.ndarray, Y: np.ndarray) -> None:
    """``X = Phi - I`` on rows 0-8 and columns 0-14 (where alone Phi differs from I), for
    ``Phi = I + A + A^2/2 + A^3/6`` and ``A = F dt`` given as its non-zero block (9, 15): with F
    zero outside that block, ``A^2 = A[:, :9] A``. Horner form: ``Y = A + A[:, :9] A / 3``,
    ``X = A + A[:, :9] Y / 2`` (:func:`_series_step_into`). Y (9, 15) scratch."""
    _series_step_into(A, A, 1.0 / 3.0, Y)
    _series_step_into(A, Y, 0.5, X)


@jit
def transition_into(F: np.ndarray, dt: float, Phi: np.ndarray) -> None:
    """``Phi = I + A + A^2/2 + A^3/6``, ``A = F dt``, for an F that is zero outside rows 0-8 and
    columns 0-14 (checked by the tests against the dense series): :func:`transition_core_into`."""
    A = np.empty((NAV, CORE))
    X = np.empty((NAV, CORE))
    Y = np.empty((NAV, CORE))
    for i in range(NAV):
        for j in range(CORE):
            A[i, j] = F[i, j] * dt
    transition_core_into(A, X, Y)
    Phi[:, :] = 0.0
    for i in range(N):
        Phi[i, i] = 1.0
    for i in range(NAV):
        for j in range(CORE):
            Phi[i, j] += X[i, j]


@jit
def sandwich_core_into(P: np.ndarray, X: np.ndarray, W: np.ndarray) -> None:
    """``P <- Phi P Phi^T`` in place for a symmetric P and ``Phi = I + X`` with X (9, 15) on rows
    0-8 and columns 0-14 (:func:`transition_core_into`). Only rows and columns 0-8 change:
    ``W = (Phi P)[0:9]`` (9, d scratch), ``(Phi P Phi^T)[0:9, 0:9] = W[:, :9] + W[:, :15] X^T``
    (upper triangle, mirrored: exactly symmetric), ``(Phi P Phi^T)[0:9, 9:] = W[:, 9:]``.
    P is (d, d): the 20 states of the layout and the sources' own after them (columns 20 on,
    which the transition leaves as they are). Sums run five (W) or three (the 9 x 9 block) at a
    time in registers."""
    d = P.shape[0]
    for i in range(NAV):
        for j in range(0, N, 5):
            s0, s1, s2, s3, s4 = P[i, j], P[i, j + 1], P[i, j + 2], P[i, j + 3], P[i, j + 4]
            for k in range(CORE):
                a = X[i, k]
                s0 += a * P[k, j]
                s1 += a * P[k, j + 1]
                s2 += a * P[k, j + 2]
                s3 += a * P[k, j + 3]
                s4 += a * P[k, j + 4]
            W[i, j], W[i, j + 1], W[i, j + 2], W[i, j + 3], W[i, j + 4] = s0, s1, s2, s3, s4
        for j in range(N, d):
            s0 = P[i, j]
            for k in range(CORE):
                s0 += X[i, k] * P[k, j]
            W[i, j] = s0
    for i in range(NAV):
        for j in range(3 * (i // 3), NAV, 3):
            s0, s1, s2 = W[i, j], W[i, j + 1], W[i, j + 2]
            for k in range(CORE):
                w = W[i, k]
                s0 += w * X[j, k]
                s1 += w * X[j + 1, k]
                s2 += w * X[j + 2, k]
            if j >= i:
                P[i, j] = P[j, i] = s0
            if j + 1 >= i:
                P[i, j + 1] = P[j + 1, i] = s1
            P[i, j + 2] = P[j + 2, i] = s2
        for j in range(NAV, d):
            P[i, j] = W[i, j]
            P[j, i] = W[i, j]


@jit
def extra_step_into(P: np.ndarray, rate: np.ndarray, q: np.ndarray, dt: float, first: int = N) -> None:
    """The sources' own states over ``dt``, each a first-order Gauss-Markov process (``rate`` =
    -1/tau < 0) or a random walk (``rate`` = 0) driven by white noise of PSD ``q``, uncoupled from
    the rest in F: their rows and columns of P scale by ``phi = exp(rate dt)`` and each variance
    gains the exact discrete noise ``q (1 - phi^2) / (-2 rate)`` (``q dt`` for a walk). P (d, d),
    rate and q (E,), states ``first .. first + E - 1`` (20 .. 20 + E - 1 in the 20-state bank)."""
    d = P.shape[0]
    for e in range(rate.shape[0]):
        a = first + e
        if rate[e] != 0.0:
            phi = math.exp(rate[e] * dt)
            for j in range(d):
                P[a, j] *= phi
            for j in range(d):
                P[j, a] *= phi
            P[a, a] += q[e] * (1.0 - phi * phi) / (-2.0 * rate[e])
        else:
            P[a, a] += q[e] * dt


@jit
def sandwich_into(Phi: np.ndarray, P: np.ndarray, out: np.ndarray) -> None:
    """``out = Phi P Phi^T`` for a symmetric P and a Phi that is I outside rows 0-8 and zero
    beyond column 14 in those rows (:func:`sandwich_core_into`)."""
    X = np.empty((NAV, CORE))
    for i in range(NAV):
        for j in range(CORE):
            X[i, j] = Phi[i, j] - (1.0 if i == j else 0.0)
    for i in range(N):
        for j in range(N):
            out[i, j] = P[i, j]
    sandwich_core_into(out, X, np.empty((NAV, N)))


@jit
def noise_into(G: np.ndarray, q: np.ndarray, dt: float, out: np.ndarray) -> None:
    """``out = G diag(q) G^T dt`` (20, 20) for any G, one noise column at a time over its non-zero
    rows (the filter bank's own G takes :func:`noise_imu_into`)."""
    out[:, :] = 0.0
    rows = np.empty(N, dtype=np.int64)
    for k in range(G.shape[1]):
        n = 0
        for i in range(N):
            if G[i, k] != 0.0:
                rows[n] = i
                n += 1
        w = q[k] * dt
        for a in range(n):
            ga = G[rows[a], k] * w
            for b in range(a, n):
                value = ga * G[rows[b], k]
                out[rows[a], rows[b]] += value
                if b != a:
                    out[rows[b], rows[a]] += value  # exactly symmetric


@jit
def _add_half_noise(P: np.ndarray, Q6: np.ndarray, q: np.ndarray, dt: float) -> None:
    """``P += G diag(q) G^T dt / 2`` of the structure :func:`noise_imu_into` describes."""
    for i in range(6):
        for j in range(6):
            P[ATT + i, ATT + j] += 0.5 * Q6[i, j]
    for i in range(N - BA):
        P[BA + i, BA + i] += 0.5 * (q[6 + i] * dt)


@jit
def _compose_transition(X: np.ndarray, Z: np.ndarray, Y: np.ndarray) -> None:
    """``Z <- X + Z + X[:, :9] Z`` in place (Y (9, 15) scratch): ``(I + X)(I + Z) - I`` for two
    transitions of the form :func:`transition_core_into` describes (only rows 0-8 of Z are not
    zero, so ``X Z`` needs X's first nine columns)."""
    for i in range(NAV):
        for j in range(CORE):
            s = X[i, j] + Z[i, j]
            for k in range(NAV):
                s += X[i, k] * Z[k, j]
            Y[i, j] = s
    for i in range(NAV):
        for j in range(CORE):
            Z[i, j] = Y[i, j]


@jit
def propagate_bank(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    P: np.ndarray,
    pos: np.ndarray,
    C: np.ndarray,
    vel_n: np.ndarray,
    gyro_bias: np.ndarray,
    dtheta_sum: np.ndarray,
    dt_c: float,
    g_n: np.ndarray,
    w_ie: np.ndarray,
    q: np.ndarray,
    geodetic: bool,
    phi_acc: np.ndarray,
    extra_rate: np.ndarray,
    extra_q: np.ndarray,
) -> None:
    """Covariance step of every (method, run) over ``dt_c``: F at the nominal attitude and body
    velocity and the mean bias-corrected rate ``dtheta_sum[r] / dt_c - b_g``; its earth terms the
    flat model's (``g_n``, ``w_ie``) or, ``geodetic``, those at each nominal position (latitude,
    longitude, depth) and velocity. P (M, R, d, d): the 20 states of the layout, then the sources'
    own (``d = 20 + E``; :func:`extra_step_into` with ``extra_rate``, ``extra_q`` (E,)).

    ``P <- Phi P Phi^T + Qd`` with the trapezoid ``Qd = (Phi GQG Phi^T + GQG) / 2``
    (tauvcore.ins.error_model.discretise) folded into one sandwich:
    ``P <- Phi (P + GQG/2) Phi^T + GQG/2``, every product over the non-zero blocks only.

    ``phi_acc`` (M, R, 9, 15): the product of the steps' transitions since the smoother's last
    mark, ``Phi_acc - I`` on its non-zero block (tauvcore.filter.kernels.smoother), updated to
    ``Phi Phi_acc``; with no rows (the smoother off) it is left alone."""
    A = np.empty((NAV, CORE))
    X = np.empty((NAV, CORE))
    Y = np.empty((NAV, CORE))
    W = np.empty((NAV, P.shape[-1]))
    Gm = np.empty((6, 6))
    Q6 = np.empty((6, 6))
    v = np.empty(3)
    om = np.empty(3)
    T = np.empty((NUM_TERMS, 3))
    flat_terms_into(g_n, w_ie, T)
    for m in range(P.shape[0]):
        for r in range(P.shape[1]):
            Cm = C[m, r]
            for i in range(3):
                v[i] = Cm[0, i] * vel_n[m, r, 0] + Cm[1, i] * vel_n[m, r, 1] + Cm[2, i] * vel_n[m, r, 2]
                om[i] = dtheta_sum[r, i] / dt_c - gyro_bias[m, r, i]
            if geodetic:
                geodetic_terms_into(
                    pos[m, r, 0], -pos[m, r, 2], vel_n[m, r, 0], vel_n[m, r, 1], vel_n[m, r, 2], T
                )
            F_core_into(Cm, v, om, T, A)
            for i in range(NAV):
                for j in range(CORE):
                    A[i, j] *= dt_c
            transition_core_into(A, X, Y)
            G_imu_into(Cm, v, Gm)
            noise_imu_into(Gm, q, dt_c, Q6)
            Pmr = P[m, r]
            _add_half_noise(Pmr, Q6, q, dt_c)
            sandwich_core_into(Pmr, X, W)
            _add_half_noise(Pmr, Q6, q, dt_c)
            if extra_rate.shape[0]:
                extra_step_into(Pmr, extra_rate, extra_q, dt_c)
            if phi_acc.shape[0]:
                _compose_transition(X, phi_acc[m, r], Y)


# ---------------------------------------------------------------- batched entry points for numpy callers
@jit
def F_batch(C: np.ndarray, v: np.ndarray, om: np.ndarray, T: np.ndarray) -> np.ndarray:
    """:func:`F_into` for n points: (n, 3, 3), (n, 3), (n, 3), earth terms (n, 18, 3) -> (n, 20, 20)."""
    out = np.empty((C.shape[0], N, N))
    for i in range(C.shape[0]):
        F_into(C[i], v[i], om[i], T[i], out[i])
    return out


@jit
def flat_terms_batch(g_n: np.ndarray, w_ie: np.ndarray, n: int) -> np.ndarray:
    """:func:`flat_terms_into` repeated for n points -> (n, 18, 3)."""
    out = np.empty((n, NUM_TERMS, 3))
    for i in range(n):
        flat_terms_into(g_n, w_ie, out[i])
    return out


@jit
def geodetic_terms_batch(lat: np.ndarray, h: np.ndarray, vel_n: np.ndarray) -> np.ndarray:
    """:func:`geodetic_terms_into` for n points: (n,), (n,), (n, 3) -> (n, 18, 3)."""
    out = np.empty((lat.shape[0], NUM_TERMS, 3))
    for i in range(lat.shape[0]):
        geodetic_terms_into(lat[i], h[i], vel_n[i, 0], vel_n[i, 1], vel_n[i, 2], out[i])
    return out


@jit
def G_batch(C: np.ndarray, v: np.ndarray, num_noise: int) -> np.ndarray:
    """:func:`G_into` for n points -> (n, 20, num_noise)."""
    out = np.empty((C.shape[0], N, num_noise))
    for i in range(C.shape[0]):
        G_into(C[i], v[i], out[i])
    return out


@jit
def discretise_batch(F: np.ndarray, G: np.ndarray, q: np.ndarray, dt: float) -> tuple:
    """``Phi = expm(F dt)`` to third order and the trapezoid ``Qd = (Phi GQG Phi^T + GQG) / 2`` for
    n points (F of the structure :func:`transition_into` requires) -> Phi, Qd (n, 20, 20)."""
    n = F.shape[0]
    Phi = np.empty((n, N, N))
    Qd = np.empty((n, N, N))
    GQG = np.empty((N, N))
    for i in range(n):
        transition_into(F[i], dt, Phi[i])
        noise_into(G[i], q, dt, GQG)
        sandwich_into(Phi[i], GQG, Qd[i])
        for r in range(N):
            for c in range(N):
                Qd[i, r, c] = 0.5 * (Qd[i, r, c] + GQG[r, c])
    return Phi, Qd


@jit
def propagate_batch(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """``Phi P Phi^T + Qd`` for n filters (Phi of the structure :func:`sandwich_into` requires)."""
    out = np.empty(P.shape)
    for i in range(P.shape[0]):
        sandwich_into(Phi[i], P[i], out[i])
        for r in range(N):
            for c in range(N):
                out[i, r, c] += 0.5 * (Qd[i, r, c] + Qd[i, c, r])
    return out
