"""The compiled filter bank's kernels (numba): the one implementation of the hot formulas.

Why numba: the filter bank's work is many small (3x3 to 20x20) operations per IMU sample and per
covariance step, for every method and Monte Carlo run; numpy's per-call overhead (microseconds)
dominated them. numba compiles plain loops over the batch to machine code, keeps the formulas
readable, and with ``cache=True`` the compilation is paid once per install (the machine code is
stored beside this file, or in numba's user cache when that is read-only).

These kernels ARE the formulas: :class:`tauvcore.ins.strapdown.Strapdown`,
:func:`tauvcore.ins.error_model.F_matrix` / :func:`~tauvcore.ins.error_model.G_matrix` /
:func:`~tauvcore.ins.error_model.discretise`, :func:`tauvcore.filter.eskf.propagate` and
:func:`tauvcore.filter.statistics.nees` / :func:`~tauvcore.filter.statistics.block_nees` call them for their
batched numpy callers, so the tests that check those functions (finite differences, known answers)
check these kernels; the runner calls them directly on its (methods, runs) batch.

Structure exploited (Tal et al. 2017 eq. 4, 9; tauvcore.filter.layout): F is zero outside rows
0-8 (position, misalignment, velocity) and columns 0-14 (those plus the IMU biases), so
``Phi = I + A + A^2/2 + A^3/6`` (A = F dt) differs from I only in rows 0-8, and
``Phi P Phi^T`` touches 9 rows and columns of P through 15 columns of Phi. The process noise
enters as ``P <- Phi (P + GQG/2) Phi^T + GQG/2`` (the trapezoid Qd of ``discretise``, one sandwich
instead of two). NEES use a Cholesky factorisation (20^3/6 operations), not a general solve.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import cast

import numba
import numpy as np

from tauvcore.geo import earth

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

N = 20  # error states
NAV = 9  # rows of F that are not zero: position, misalignment, velocity
CORE = 15  # columns of F that are not zero: those plus accelerometer and gyro biases
POS, ATT, VEL, BA, BG, BDVL, SF = 0, 3, 6, 9, 12, 15, 19  # tauvcore.filter.layout.STATE starts
NOISE_ACCEL, NOISE_GYRO = 0, 3  # tauvcore.filter.layout.NOISE starts
SERIES_ANGLE2 = 1e-4  # below (1e-2 rad)^2 exp_so3 uses its Taylor series (exact to double precision)
LOG_SMALL_ANGLE_RAD = 1e-6


def flat(a: np.ndarray, batch: tuple[int, ...], tail: tuple[int, ...], dtype: type = float) -> np.ndarray:
    """``a`` broadcast to ``batch + tail`` as a C-contiguous array with one leading axis: the
    layout the batched kernels take from their numpy callers."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=dtype), batch + tail)).reshape(
        (-1,) + tail
    )


# ---------------------------------------------------------------- rotations
@_jit
def exp_so3_into(p0: float, p1: float, p2: float, out: np.ndarray) -> None:
    """Rodrigues ``exp([phi x])`` (tauvcore.geo.rotations.exp_so3) into ``out`` (3, 3)."""
    a2 = p0 * p0 + p1 * p1 + p2 * p2
    if a2 < SERIES_ANGLE2:
        a = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0)
        b = 0.5 - a2 / 24.0 * (1.0 - a2 / 30.0)
    else:
        angle = math.sqrt(a2)
        a = math.sin(angle) / angle
        b = (1.0 - math.cos(angle)) / a2
    d = 1.0 - b * a2
    out[0, 0] = d + b * (p0 * p0)
    out[0, 1] = a * -p2 + b * (p0 * p1)
    out[0, 2] = a * p1 + b * (p0 * p2)
    out[1, 0] = a * p2 + b * (p1 * p0)
    out[1, 1] = d + b * (p1 * p1)
    out[1, 2] = a * -p0 + b * (p1 * p2)
    out[2, 0] = a * -p1 + b * (p2 * p0)
    out[2, 1] = a * p0 + b * (p2 * p1)
    out[2, 2] = d + b * (p2 * p2)


@_jit
def log_so3_into(C: np.ndarray, out: np.ndarray) -> None:
    """Rotation vector of ``C`` (angle < pi; tauvcore.geo.rotations.log_so3) into ``out`` (3,)."""
    c = (C[0, 0] + C[1, 1] + C[2, 2] - 1.0) * 0.5
    c = min(1.0, max(-1.0, c))
    angle = math.acos(c)
    scale = 1.0 + angle * angle / 6.0 if angle < LOG_SMALL_ANGLE_RAD else angle / math.sin(angle)
    out[0] = scale * 0.5 * (C[2, 1] - C[1, 2])
    out[1] = scale * 0.5 * (C[0, 2] - C[2, 0])
    out[2] = scale * 0.5 * (C[1, 0] - C[0, 1])


@_jit
def exp_so3_batch(phi: np.ndarray) -> np.ndarray:
    """(n, 3) -> (n, 3, 3)."""
    out = np.empty((phi.shape[0], 3, 3))
    for i in range(phi.shape[0]):
        exp_so3_into(phi[i, 0], phi[i, 1], phi[i, 2], out[i])
    return out


@_jit
def log_so3_batch(C: np.ndarray) -> np.ndarray:
    """(n, 3, 3) -> (n, 3)."""
    out = np.empty((C.shape[0], 3))
    for i in range(C.shape[0]):
        log_so3_into(C[i], out[i])
    return out


# ---------------------------------------------------------------- strapdown
# the earth functions the bank compiles as they are (tauvcore.geo.earth: those that call no other);
# earth's functions take floats or arrays, the kernels call them on floats only: typed so here
_F2 = tuple[float, float]
_F3 = tuple[float, float, float]
_radii_nav = cast(Callable[[float], _F2], _jit(earth.radii_of_curvature_m))
_ned_offset = cast(
    Callable[[float, float, float, float, float, float], _F3], _jit(earth.ned_offset_components)
)
_normal_gravity = cast(Callable[[float, float], float], _jit(earth.normal_gravity_mps2))
_gravity_north = cast(Callable[[float, float], float], _jit(earth.gravity_north_mps2))
_earth_rate = cast(Callable[[float], _F3], _jit(earth.earth_rate_n_rps))
_transport_rate = cast(
    Callable[[float, float, float, float, float, float], _F3], _jit(earth.transport_rate_with_radii)
)


@_jit
def geodetic_step_terms_into(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    dv: np.ndarray,
    g_guess: np.ndarray,
    coriolis_guess_T: np.ndarray,
    dt: float,
    S: np.ndarray,
) -> tuple:
    """The earth terms of one IMU interval on the WGS-84 ellipsoid, at the interval's middle as
    predicted from its start (position ``pos`` = latitude [rad], longitude [rad], depth [m];
    NED velocity ``vel``; attitude ``C`` and velocity increment ``dv`` of the interval, gravity
    ``g_guess`` and Coriolis ``coriolis_guess_T`` near the true ones: the flat model's at the
    origin), into the scratch ``S`` (4, 3, 3):
    ``S[0] = exp(-[omega_in x] dt)``, ``S[1] = exp(-[omega_in x] dt / 2)`` (the local-level
    frame's turn: earth rate plus transport rate), ``S[2] = (-[(2 omega_ie + omega_en) x])^T``
    (Coriolis, row form), ``S[3, 0]`` gravity. The transport rate is taken at the predicted
    middle velocity ``vel + (C dv + g dt - 2 omega_ie x vel dt) / 2``: at the start one it lags
    half a step, an error
    of the first order in dt (3e-4 m in 250 s of figure eights at 150 Hz). Returns the predicted
    middle latitude, the radii there (R_N, R_E)."""
    h = -pos[2]
    R_N0, _ = _radii_nav(pos[0])
    v0, v1, v2 = vel[0], vel[1], vel[2]
    K = coriolis_guess_T
    v_mid0 = v0 + 0.5 * (
        C[0, 0] * dv[0]
        + C[0, 1] * dv[1]
        + C[0, 2] * dv[2]
        + (g_guess[0] + v0 * K[0, 0] + v1 * K[1, 0] + v2 * K[2, 0]) * dt
    )
    v_mid1 = v1 + 0.5 * (
        C[1, 0] * dv[0]
        + C[1, 1] * dv[1]
        + C[1, 2] * dv[2]
        + (g_guess[1] + v0 * K[0, 1] + v1 * K[1, 1] + v2 * K[2, 1]) * dt
    )
    v_mid2 = v2 + 0.5 * (
        C[2, 0] * dv[0]
        + C[2, 1] * dv[1]
        + C[2, 2] * dv[2]
        + (g_guess[2] + v0 * K[0, 2] + v1 * K[1, 2] + v2 * K[2, 2]) * dt
    )
    lat_m = pos[0] + 0.25 * dt * (vel[0] + v_mid0) / (R_N0 + h)
    h_m = h - 0.25 * dt * (vel[2] + v_mid2)
    R_N, R_E = _radii_nav(lat_m)
    w_ie0, w_ie1, w_ie2 = _earth_rate(lat_m)
    w_en0, w_en1, w_en2 = _transport_rate(R_N, R_E, lat_m, h_m, v_mid0, v_mid1)
    a0, a1, a2 = w_ie0 + w_en0, w_ie1 + w_en1, w_ie2 + w_en2
    exp_so3_into(-a0 * dt, -a1 * dt, -a2 * dt, S[0])
    exp_so3_into(-0.5 * a0 * dt, -0.5 * a1 * dt, -0.5 * a2 * dt, S[1])
    c0, c1, c2 = 2.0 * w_ie0 + w_en0, 2.0 * w_ie1 + w_en1, 2.0 * w_ie2 + w_en2
    for i in range(3):
        for j in range(3):
            S[2, j, i] = -_skew(c0, c1, c2, i, j)
    S[3, 0, 0], S[3, 0, 1], S[3, 0, 2] = _gravity_north(lat_m, h_m), 0.0, _normal_gravity(lat_m, h_m)
    return lat_m, R_N, R_E


@_jit
def strapdown_step_into(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    phi0: float,
    phi1: float,
    phi2: float,
    dv: np.ndarray,
    dt: float,
    C_earth: np.ndarray,
    C_earth_half: np.ndarray,
    g_n: np.ndarray,
    coriolis_T: np.ndarray,
    geodetic: bool,
    S: np.ndarray,
    E: np.ndarray,
    tmp: np.ndarray,
) -> None:
    """One IMU interval of the mechanization (tauvcore.ins.strapdown), in place.

    ``C <- C_earth C exp([phi x])``; ``dv_n = C_earth/2 C dv + g dt``;
    ``v_mid = v + (dv_n + (-2 omega_ie x v) dt) / 2``; ``v <- v + dv_n + (-2 omega_ie x v_mid) dt``;
    ``pos <- pos + dt (v_old + v_new) / 2``. ``coriolis_T``: ``(-2 [omega_ie_n x])^T`` (row form).
    Those are the flat model's constants. With ``geodetic`` (WGS-84; ``pos`` = latitude,
    longitude, depth) they are replaced for this interval by :func:`geodetic_step_terms_into`'s,
    in ``S`` (4, 3, 3), and the position integrates the geodetic rates with the trapezoid of the
    NED velocity (depth first, then latitude, then longitude at the mean latitude; Groves 5.56).
    ``E`` (3, 3) and ``tmp`` (3, 3) are scratch (no allocation per step).
    """
    R_N = R_E = 0.0
    if geodetic:
        _, R_N, R_E = geodetic_step_terms_into(pos, vel, C, dv, g_n, coriolis_T, dt, S)
        C_earth, C_earth_half, coriolis_T, g_n = S[0], S[1], S[2], S[3, 0]
    exp_so3_into(phi0, phi1, phi2, E)
    d0 = d1 = d2 = 0.0
    for i in range(3):
        s = 0.0
        for j in range(3):
            h = 0.0
            for k in range(3):
                h += C_earth_half[i, k] * C[k, j]
            s += h * dv[j]
        if i == 0:
            d0 = s + g_n[0] * dt
        elif i == 1:
            d1 = s + g_n[1] * dt
        else:
            d2 = s + g_n[2] * dt
    # C_earth @ C @ E (left to right)
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += C_earth[i, k] * C[k, j]
            tmp[i, j] = s
    for i in range(3):
        for j in range(3):
            s = 0.0
            for k in range(3):
                s += tmp[i, k] * E[k, j]
            C[i, j] = s
    v0, v1, v2 = vel[0], vel[1], vel[2]
    m0 = v0 + 0.5 * (d0 + (v0 * coriolis_T[0, 0] + v1 * coriolis_T[1, 0] + v2 * coriolis_T[2, 0]) * dt)
    m1 = v1 + 0.5 * (d1 + (v0 * coriolis_T[0, 1] + v1 * coriolis_T[1, 1] + v2 * coriolis_T[2, 1]) * dt)
    m2 = v2 + 0.5 * (d2 + (v0 * coriolis_T[0, 2] + v1 * coriolis_T[1, 2] + v2 * coriolis_T[2, 2]) * dt)
    n0 = v0 + d0 + (m0 * coriolis_T[0, 0] + m1 * coriolis_T[1, 0] + m2 * coriolis_T[2, 0]) * dt
    n1 = v1 + d1 + (m0 * coriolis_T[0, 1] + m1 * coriolis_T[1, 1] + m2 * coriolis_T[2, 1]) * dt
    n2 = v2 + d2 + (m0 * coriolis_T[0, 2] + m1 * coriolis_T[1, 2] + m2 * coriolis_T[2, 2]) * dt
    if geodetic:
        depth = pos[2] + 0.5 * dt * (v2 + n2)
        h_mid = -0.5 * (pos[2] + depth)
        lat = pos[0] + 0.5 * dt * (v0 + n0) / (R_N + h_mid)
        lat_mid = 0.5 * (pos[0] + lat)
        pos[1] = pos[1] + 0.5 * dt * (v1 + n1) / ((R_E + h_mid) * math.cos(lat_mid))
        pos[0], pos[2] = lat, depth
    else:
        pos[0] = pos[0] + 0.5 * dt * (v0 + n0)
        pos[1] = pos[1] + 0.5 * dt * (v1 + n1)
        pos[2] = pos[2] + 0.5 * dt * (v2 + n2)
    vel[0], vel[1], vel[2] = n0, n1, n2


@_jit
def strapdown_batch(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    phi: np.ndarray,
    dv: np.ndarray,
    dt: float,
    C_earth: np.ndarray,
    C_earth_half: np.ndarray,
    g_n: np.ndarray,
    coriolis_T: np.ndarray,
    geodetic: bool,
) -> None:
    """One step for n entries in place: pos, vel (n, 3), C (n, 3, 3), phi, dv (n, 3)."""
    S = np.empty((4, 3, 3))
    E = np.empty((3, 3))
    tmp = np.empty((3, 3))
    for i in range(pos.shape[0]):
        strapdown_step_into(
            pos[i],
            vel[i],
            C[i],
            phi[i, 0],
            phi[i, 1],
            phi[i, 2],
            dv[i],
            dt,
            C_earth,
            C_earth_half,
            g_n,
            coriolis_T,
            geodetic,
            S,
            E,
            tmp,
        )


@_jit
def advance(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    phi_raw: np.ndarray,
    dv_raw: np.ndarray,
    dtheta_raw: np.ndarray,
    dtheta_sum: np.ndarray,
    k_from: int,
    k_to: int,
    dt: float,
    C_earth: np.ndarray,
    C_earth_half: np.ndarray,
    g_n: np.ndarray,
    coriolis_T: np.ndarray,
    geodetic: bool,
) -> None:
    """Advance the (M, R) nominal states over samples ``k_from + 1 .. k_to`` of the compensated
    increments ``phi_raw``, ``dv_raw`` (K, R, 3), each corrected by its own bias estimate, and add
    the raw gyro increments ``dtheta_raw`` (K, R, 3) of those samples to ``dtheta_sum`` (R, 3) one
    by one (the same sum however the samples are split between calls)."""
    S = np.empty((4, 3, 3))
    E = np.empty((3, 3))
    tmp = np.empty((3, 3))
    dv = np.empty(3)
    for r in range(pos.shape[1]):
        for k in range(k_from + 1, k_to + 1):
            for i in range(3):
                dtheta_sum[r, i] += dtheta_raw[k, r, i]
    for m in range(pos.shape[0]):
        for r in range(pos.shape[1]):
            for k in range(k_from + 1, k_to + 1):
                for i in range(3):
                    dv[i] = dv_raw[k, r, i] - accel_bias[m, r, i] * dt
                strapdown_step_into(
                    pos[m, r],
                    vel[m, r],
                    C[m, r],
                    phi_raw[k, r, 0] - gyro_bias[m, r, 0] * dt,
                    phi_raw[k, r, 1] - gyro_bias[m, r, 1] * dt,
                    phi_raw[k, r, 2] - gyro_bias[m, r, 2] * dt,
                    dv,
                    dt,
                    C_earth,
                    C_earth_half,
                    g_n,
                    coriolis_T,
                    geodetic,
                    S,
                    E,
                    tmp,
                )


# ---------------------------------------------------------------- earth terms of the error model
# Rows of the (18, 3) array of earth terms F is built from (:func:`flat_terms_into`,
# :func:`geodetic_terms_into`): vectors in n, then 3x3 Jacobians by rows.
T_G, T_WIE, T_WEN = 0, 1, 2  # plumb-bob gravity, earth rate, transport rate in n
T_DG, T_DWIE, T_DWEN = 3, 6, 9  # d g_n / d pos, d omega_ie_n / d pos, d omega_en_n / d pos
T_DWENV = 12  # d omega_en_n / d vel_n
T_FPP = 15  # d pos_err' / d pos_err (the position-error metrics' own change)
NUM_TERMS = 18


@_jit
def flat_terms_into(g_n: np.ndarray, w_ie: np.ndarray, T: np.ndarray) -> None:
    """Earth terms of the flat model (tauvcore.geo.earth.Earth): constant gravity and earth
    rate, no transport rate, no dependence on position. T (18, 3), every entry written."""
    T[:, :] = 0.0
    for i in range(3):
        T[T_G, i] = g_n[i]
        T[T_WIE, i] = w_ie[i]


@_jit
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
    R_N, R_E = _radii_nav(lat)
    rho_n, rho_e = R_N + h, R_E + h
    w2 = 1.0 - earth._E2 * s * s
    dR_N = (
        3.0 * earth.A_M * (1.0 - earth._E2) * earth._E2 * s * c / (w2 * w2 * math.sqrt(w2))
    )  # d R_N / d lat
    dR_E = earth.A_M * earth._E2 * s * c / (w2 * math.sqrt(w2))  # d R_E / d lat
    # gravity: (-K h sin 2lat, 0, gamma(lat, h))
    K = earth._GRAVITY_NORTH_PER_M
    gamma_0 = _normal_gravity(lat, 0.0)
    h_a = h / earth.A_M
    f, m = earth.FLATTENING, earth._M_GRAVITY
    P = 1.0 - 2.0 * h_a * (1.0 + f + m - 2.0 * f * s * s) + 3.0 * h_a * h_a
    T[T_G, 0] = _gravity_north(lat, h)
    T[T_G, 2] = _normal_gravity(lat, h)
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
    T[T_WIE, 0], T[T_WIE, 1], T[T_WIE, 2] = _earth_rate(lat)
    T[T_DWIE + 0, 0], T[T_DWIE + 2, 0] = -W * s / rho_n, -W * c / rho_n
    # transport rate: (v_E / rho_E, -v_N / rho_N, -v_E tan / rho_E)
    T[T_WEN, 0], T[T_WEN, 1], T[T_WEN, 2] = _transport_rate(R_N, R_E, lat, h, v_north, v_east)
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


# ---------------------------------------------------------------- error model
@_jit
def _skew(a0: float, a1: float, a2: float, i: int, j: int) -> float:
    """Entry (i, j) of ``[a x]``."""
    if i == 0:
        return -a2 if j == 1 else (a1 if j == 2 else 0.0)
    if i == 1:
        return a2 if j == 0 else (-a0 if j == 2 else 0.0)
    return -a1 if j == 0 else (a0 if j == 1 else 0.0)


@_jit
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
                sv += T[T_DWENV + i, k] * _skew(vn0, vn1, vn2, k, j)
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
                s += C[k, i] * _skew(T[T_G, 0], T[T_G, 1], T[T_G, 2], k, j)
            A[VEL + i, ATT + j] = s
    for i in range(3):
        for j in range(3):
            s = 0.0
            sp = 0.0
            for k in range(3):
                ctw = 0.0  # (C^T W)[k, j]
                ctp = 0.0  # (C^T W_ie,p)[k, j]
                for m in range(3):
                    ctw += C[m, k] * _skew(T[T_WIE, 0], T[T_WIE, 1], T[T_WIE, 2], m, j)
                    ctp += C[m, k] * T[T_DWIE + m, j]
                s += _skew(v[0], v[1], v[2], i, k) * ctw
                sp += _skew(v[0], v[1], v[2], i, k) * ctp + C[k, i] * T[T_DG + k, j]
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
            A[VEL + i, BG + j] = -_skew(v[0], v[1], v[2], i, j)


@_jit
def F_into(C: np.ndarray, v: np.ndarray, om: np.ndarray, T: np.ndarray, F: np.ndarray) -> None:
    """Continuous F (tauvcore.ins.error_model, eq. 4 and 9) into ``F`` (20, 20): zero but for the
    block :func:`F_core_into` writes."""
    F[:, :] = 0.0
    A = np.empty((NAV, CORE))
    F_core_into(C, v, om, T, A)
    for i in range(NAV):
        for j in range(CORE):
            F[i, j] = A[i, j]


@_jit
def G_imu_into(C: np.ndarray, v: np.ndarray, Gm: np.ndarray) -> None:
    """Rows 3-8 (misalignment, velocity) of G's columns 0-5 (accelerometer, gyro noise) into
    ``Gm`` (6, 6): the only non-zero entries of G besides the identity of the random walks."""
    for i in range(3):
        for j in range(3):
            Gm[i, j] = 0.0  # misalignment <- accelerometer
            Gm[i, 3 + j] = -C[i, j]  # misalignment <- gyro
            Gm[3 + i, j] = -1.0 if i == j else 0.0  # velocity <- accelerometer
            Gm[3 + i, 3 + j] = -_skew(v[0], v[1], v[2], i, j)  # velocity <- gyro


@_jit
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


@_jit
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


@_jit
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


@_jit
def transition_core_into(A: np.ndarray, X: np.ndarray, Y: np.ndarray) -> None:
    """``X = Phi - I`` on rows 0-8 and columns 0-14 (where alone Phi differs from I), for
    ``Phi = I + A + A^2/2 + A^3/6`` and ``A = F dt`` given as its non-zero block (9, 15): with F
    zero outside that block, ``A^2 = A[:, :9] A``. Horner form: ``Y = A + A[:, :9] A / 3``,
    ``X = A + A[:, :9] Y / 2`` (:func:`_series_step_into`). Y (9, 15) scratch."""
    _series_step_into(A, A, 1.0 / 3.0, Y)
    _series_step_into(A, Y, 0.5, X)


@_jit
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


@_jit
def sandwich_core_into(P: np.ndarray, X: np.ndarray, W: np.ndarray) -> None:
    """``P <- Phi P Phi^T`` in place for a symmetric P and ``Phi = I + X`` with X (9, 15) on rows
    0-8 and columns 0-14 (:func:`transition_core_into`). Only rows and columns 0-8 change:
    ``W = (Phi P)[0:9]`` (9, 20 scratch), ``(Phi P Phi^T)[0:9, 0:9] = W[:, :9] + W[:, :15] X^T``
    (upper triangle, mirrored: exactly symmetric), ``(Phi P Phi^T)[0:9, 9:] = W[:, 9:]``.
    Sums run five (W) or three (the 9 x 9 block) at a time in registers."""
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
        for j in range(NAV, N):
            P[i, j] = W[i, j]
            P[j, i] = W[i, j]


@_jit
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


@_jit
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


@_jit
def _add_half_noise(P: np.ndarray, Q6: np.ndarray, q: np.ndarray, dt: float) -> None:
    """``P += G diag(q) G^T dt / 2`` of the structure :func:`noise_imu_into` describes."""
    for i in range(6):
        for j in range(6):
            P[ATT + i, ATT + j] += 0.5 * Q6[i, j]
    for i in range(N - BA):
        P[BA + i, BA + i] += 0.5 * (q[6 + i] * dt)


@_jit
def propagate_bank(
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
) -> None:
    """Covariance step of every (method, run) over ``dt_c``: F at the nominal attitude and body
    velocity and the mean bias-corrected rate ``dtheta_sum[r] / dt_c - b_g``; its earth terms the
    flat model's (``g_n``, ``w_ie``) or, ``geodetic``, those at each nominal position (latitude,
    longitude, depth) and velocity. P (M, R, 20, 20).

    ``P <- Phi P Phi^T + Qd`` with the trapezoid ``Qd = (Phi GQG Phi^T + GQG) / 2``
    (tauvcore.ins.error_model.discretise) folded into one sandwich:
    ``P <- Phi (P + GQG/2) Phi^T + GQG/2``, every product over the non-zero blocks only."""
    A = np.empty((NAV, CORE))
    X = np.empty((NAV, CORE))
    Y = np.empty((NAV, CORE))
    W = np.empty((NAV, N))
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


# ---------------------------------------------------------------- NEES by Cholesky
@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


# ---------------------------------------------------------------- corrections
@_jit
def _solve_chol(L: np.ndarray, n: int, b: np.ndarray, x: np.ndarray) -> None:
    """Solve ``L L^T x = b`` (n,) with the factor in ``L[:n, :n]``."""
    for i in range(n):
        t = b[i]
        for k in range(i):
            t -= L[i, k] * x[k]
        x[i] = t / L[i, i]
    for i in range(n - 1, -1, -1):
        t = x[i]
        for k in range(i + 1, n):
            t -= L[k, i] * x[k]
        x[i] = t / L[i, i]


@_jit
def correct_into(
    P: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: bool,
    gate_sigma: float,
    dx: np.ndarray,
    s_diag: np.ndarray,
    keep: np.ndarray,
) -> tuple[float, float, bool]:
    """Gated Joseph-form correction of one filter (tauvcore.filter.eskf.correct), P in place.

    Rows with ``active`` False are dropped exactly. ``S`` over the active rows must factorise
    (else: unusable, nothing fused). The paper's gate keeps a row if ``nu_i^2 <= gate^2 S_ii``
    (all rows or none unless ``gate_rows``). Fills ``dx`` (20,), ``s_diag`` (m,; NaN where not
    used), ``keep`` (m,); returns ``(nis, test_ratio, unusable)`` (NaN when no row was used).
    """
    m = nu.shape[0]
    rows = np.empty(m, dtype=np.int64)
    n_a = 0
    for i in range(m):
        keep[i] = False
        s_diag[i] = np.nan
        if active[i]:
            rows[n_a] = i
            n_a += 1
    dx[:] = 0.0
    if n_a == 0:
        return np.nan, np.nan, False
    U = np.empty((m, N))  # H P over the rows in use
    S = np.empty((m, m))
    L = np.empty((m, m))
    for a in range(n_a):
        for j in range(N):
            s = 0.0
            for k in range(N):
                s += H[rows[a], k] * P[k, j]
            U[a, j] = s
    for a in range(n_a):
        for b in range(n_a):
            s = Rm[rows[a], rows[b]]
            for k in range(N):
                s += U[a, k] * H[rows[b], k]
            S[a, b] = s
    ident = np.arange(m)
    if not cholesky_into(S, ident, n_a, L):
        return np.nan, np.nan, True
    nu_a = np.empty(m)
    sol = np.empty(m)
    for a in range(n_a):
        nu_a[a] = nu[rows[a]]
    _solve_chol(L, n_a, nu_a, sol)
    nis = 0.0
    ratio_max = 0.0
    all_pass = True
    for a in range(n_a):
        nis += nu_a[a] * sol[a]
        s_diag[rows[a]] = S[a, a]
        ratio = nu_a[a] * nu_a[a] / (gate_sigma * gate_sigma * S[a, a])
        ratio_max = max(ratio_max, ratio)
        keep[rows[a]] = ratio <= 1.0
        all_pass = all_pass and ratio <= 1.0
    if not gate_rows and not all_pass:
        for a in range(n_a):
            keep[rows[a]] = False
    n_k = 0
    for a in range(n_a):
        if keep[rows[a]]:
            if n_k != a:  # compact the kept rows to the front
                rows[n_k] = rows[a]
                for j in range(N):
                    U[n_k, j] = U[a, j]
                nu_a[n_k] = nu_a[a]
            n_k += 1
    if n_k == 0:
        return nis, ratio_max, False
    if n_k != n_a:  # S over the kept rows
        for a in range(n_k):
            for b in range(n_k):
                s = Rm[rows[a], rows[b]]
                for k in range(N):
                    s += U[a, k] * H[rows[b], k]
                S[a, b] = s
        if not cholesky_into(S, ident, n_k, L):
            return nis, ratio_max, True
    # K = P H^T S^-1 = (S^-1 U)^T: column j of U through the factor
    K = np.empty((N, m))
    col = np.empty(m)
    out = np.empty(m)
    for j in range(N):
        for a in range(n_k):
            col[a] = U[a, j]
        _solve_chol(L, n_k, col, out)
        for a in range(n_k):
            K[j, a] = out[a]
    # Joseph: P = (I - K H) P (I - K H)^T + K R K^T
    IKH = np.empty((N, N))
    for i in range(N):
        for j in range(N):
            s = 1.0 if i == j else 0.0
            for a in range(n_k):
                s -= K[i, a] * H[rows[a], j]
            IKH[i, j] = s
    W = np.empty((N, N))
    for i in range(N):
        for j in range(N):
            s = 0.0
            for k in range(N):
                s += IKH[i, k] * P[k, j]
            W[i, j] = s
    KR = np.empty((N, m))
    for i in range(N):
        for b in range(n_k):
            s = 0.0
            for a in range(n_k):
                s += K[i, a] * Rm[rows[a], rows[b]]
            KR[i, b] = s
    for i in range(N):
        for j in range(i, N):
            s = 0.0
            for k in range(N):
                s += W[i, k] * IKH[j, k]
            t = 0.0
            for b in range(n_k):
                t += KR[i, b] * K[j, b]
            P[i, j] = s + t
    for i in range(N):
        for j in range(i):
            P[i, j] = P[j, i]
    for i in range(N):
        s = 0.0
        for a in range(n_k):
            s += K[i, a] * nu_a[a]
        dx[i] = s
    return nis, ratio_max, False


@_jit
def correct_batch(
    P: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: np.ndarray,
    gate_sigma: float,
) -> tuple:
    """:func:`correct_into` for n filters: P (n, 20, 20) in place, H (n, m, 20), Rm (n, m, m), nu,
    active (n, m), gate_rows (n,). -> dx (n, 20), s_diag (n, m), keep (n, m), nis, test_ratio,
    unusable (n,)."""
    n, m = nu.shape
    dx = np.empty((n, N))
    s_diag = np.empty((n, m))
    keep = np.empty((n, m), dtype=np.bool_)
    nis = np.empty(n)
    ratio = np.empty(n)
    unusable = np.empty(n, dtype=np.bool_)
    for i in range(n):
        nis[i], ratio[i], unusable[i] = correct_into(
            P[i], H[i], Rm[i], nu[i], active[i], gate_rows[i], gate_sigma, dx[i], s_diag[i], keep[i]
        )
    return dx, s_diag, keep, nis, ratio, unusable


@_jit
def add_position_into(pos: np.ndarray, d_north: float, d_east: float, d_down: float, geodetic: bool) -> None:
    """Move a position by (north, east, down) metres in place: added as they are in the flat model;
    on WGS-84 (latitude, longitude, depth) through the metric at the position itself, the inverse
    of :func:`nav_difference_into`'s position error."""
    if geodetic:
        R_N, R_E = _radii_nav(pos[0])
        lat = pos[0]
        pos[0] = lat + d_north / (R_N - pos[2])
        pos[1] = pos[1] + d_east / ((R_E - pos[2]) * math.cos(lat))
        pos[2] = pos[2] + d_down
    else:
        pos[0] += d_north
        pos[1] += d_east
        pos[2] += d_down


@_jit
def add_position_batch(pos: np.ndarray, d: np.ndarray, geodetic: bool) -> np.ndarray:
    """:func:`add_position_into` for n positions (n, 3) and offsets (n, 3) -> new positions (n, 3)."""
    out = pos.copy()
    for i in range(pos.shape[0]):
        add_position_into(out[i], d[i, 0], d[i, 1], d[i, 2], geodetic)
    return out


@_jit
def inject_batch(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    dvl_bias: np.ndarray,
    dvl_sf: np.ndarray,
    dx: np.ndarray,
    geodetic: bool,
) -> None:
    """Closed-loop injection ``x_hat <- x_hat (+) dx`` (tauvcore.filter.eskf.inject) for n filters in
    place: position and biases add, ``C <- exp([rho x]) C``, the body velocity adds and ``vel_n`` is
    rebuilt with the corrected attitude. pos, vel (n, 3), C (n, 3, 3), biases (n, 3), (n, 3), (n, 4),
    dvl_sf (n,), dx (n, 20). On WGS-84 (``geodetic``) the position error in metres moves latitude,
    longitude and depth by the metric at the estimate (:func:`add_position_into`)."""
    E = np.empty((3, 3))
    C1 = np.empty((3, 3))
    vb = np.empty(3)
    for i in range(pos.shape[0]):
        exp_so3_into(dx[i, ATT], dx[i, ATT + 1], dx[i, ATT + 2], E)
        for r in range(3):
            for c in range(3):
                C1[r, c] = E[r, 0] * C[i, 0, c] + E[r, 1] * C[i, 1, c] + E[r, 2] * C[i, 2, c]
        for c in range(3):
            vb[c] = C[i, 0, c] * vel[i, 0] + C[i, 1, c] * vel[i, 1] + C[i, 2, c] * vel[i, 2] + dx[i, VEL + c]
        add_position_into(pos[i], dx[i, POS], dx[i, POS + 1], dx[i, POS + 2], geodetic)
        for r in range(3):
            vel[i, r] = C1[r, 0] * vb[0] + C1[r, 1] * vb[1] + C1[r, 2] * vb[2]
            accel_bias[i, r] += dx[i, BA + r]
            gyro_bias[i, r] += dx[i, BG + r]
            for c in range(3):
                C[i, r, c] = C1[r, c]
        for b in range(4):
            dvl_bias[i, b] += dx[i, BDVL + b]
        dvl_sf[i] += dx[i, SF]


# ---------------------------------------------------------------- records
SERIES_NAMES = (
    "vel_err",
    "att_err",
    "pos_err",
    "vel_sigma",
    "att_sigma",
    "pos_sigma",
    "nees",
    "tilt_err",
    "heading_err",
    "tilt_sigma",
    "heading_sigma",
)
"""Rows of the ``series`` array :func:`record_bank` fills (norms, 1-sigma, NEES; attitude in deg)."""


@_jit
def record_bank(
    slot: int,
    t_s: float,
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    ba_t: np.ndarray,
    bg_t: np.ndarray,
    bdvl_t: np.ndarray,
    sf_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    bdvl: np.ndarray,
    sf: np.ndarray,
    P: np.ndarray,
    block_of_state: np.ndarray,
    num_blocks: int,
    deg: float,
    series: np.ndarray,
    nees_block: np.ndarray,
    est_pos: np.ndarray,
    nonfinite_at: np.ndarray,
    geodetic: bool,
    origin: np.ndarray,
    est_vel: np.ndarray,
    est_euler: np.ndarray,
) -> None:
    """One output epoch of every (method, run): the error ``true (-) estimate``
    (tauvcore.filter.eskf.difference) and its norms, the filter's 1-sigma, the NEES of the full
    state and of each block, the estimated position; and the health check without truth (a
    non-finite navigation state or P's variances sets ``nonfinite_at`` once).

    Truth: pos_t, vel_t (3,), C_t (3, 3) shared; the true sensor errors per run ba_t, bg_t (R, 3),
    bdvl_t (R, 4), sf_t (R,). series (11, T, M, R) in :data:`SERIES_NAMES` order. On WGS-84
    (``geodetic``) the estimated position is recorded in NED metres from ``origin`` (latitude,
    longitude [rad] of the sea-surface point; tauvcore.geo.earth.ned_offset_components). The
    estimated NED velocity and roll, pitch, yaw [rad] go to est_vel, est_euler (T, M, R, 3)."""
    M, R = pos.shape[0], pos.shape[1]
    dx = np.empty(N)
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    L = np.empty((N, N))
    y = np.empty(N)
    members, sizes, lead, order = nees_plan(block_of_state, num_blocks)
    for m in range(M):
        for r in range(R):
            nav_difference_into(pos_t, vel_t, C_t, pos[m, r], vel[m, r], C[m, r], Ce, rho, dx, geodetic)
            for i in range(3):
                dx[BA + i] = ba_t[r, i] - ba[m, r, i]
                dx[BG + i] = bg_t[r, i] - bg[m, r, i]
            for i in range(4):
                dx[BDVL + i] = bdvl_t[r, i] - bdvl[m, r, i]
            dx[SF] = sf_t[r] - sf[m, r]
            Pm = P[m, r]
            ev = ea = ep = sv = sa = sp = 0.0
            for i in range(3):
                ev += dx[VEL + i] ** 2
                ea += dx[ATT + i] ** 2
                ep += dx[POS + i] ** 2
                sv += Pm[VEL + i, VEL + i]
                sa += Pm[ATT + i, ATT + i]
                sp += Pm[POS + i, POS + i]
            series[0, slot, m, r] = math.sqrt(ev)
            series[1, slot, m, r] = math.sqrt(ea) / deg
            series[2, slot, m, r] = math.sqrt(ep)
            series[3, slot, m, r] = math.sqrt(sv)
            series[4, slot, m, r] = math.sqrt(sa) / deg
            series[5, slot, m, r] = math.sqrt(sp)
            series[6, slot, m, r] = nees_blocks_into(
                Pm, dx, members, sizes, lead, order, L, y, nees_block[slot, m, r]
            )
            series[7, slot, m, r] = math.sqrt(dx[ATT] ** 2 + dx[ATT + 1] ** 2) / deg
            series[8, slot, m, r] = abs(dx[ATT + 2]) / deg
            series[9, slot, m, r] = math.sqrt(Pm[ATT, ATT] + Pm[ATT + 1, ATT + 1]) / deg
            series[10, slot, m, r] = math.sqrt(Pm[ATT + 2, ATT + 2]) / deg
            total = 0.0
            for i in range(N):
                total += Pm[i, i]
            if geodetic:
                n0, n1, n2 = _ned_offset(pos[m, r, 0], pos[m, r, 1], -pos[m, r, 2], origin[0], origin[1], 0.0)
                est_pos[slot, m, r, 0], est_pos[slot, m, r, 1], est_pos[slot, m, r, 2] = n0, n1, n2
            for i in range(3):
                if not geodetic:
                    est_pos[slot, m, r, i] = pos[m, r, i]
                est_vel[slot, m, r, i] = vel[m, r, i]
                total += pos[m, r, i] + vel[m, r, i]
            Cm = C[m, r]
            est_euler[slot, m, r, 0] = math.atan2(Cm[2, 1], Cm[2, 2])
            est_euler[slot, m, r, 1] = -math.asin(min(1.0, max(-1.0, Cm[2, 0])))
            est_euler[slot, m, r, 2] = math.atan2(Cm[1, 0], Cm[0, 0])
            if not math.isfinite(total) and math.isnan(nonfinite_at[m, r]):
                nonfinite_at[m, r] = t_s


@_jit
def positive_definite_bank(P: np.ndarray) -> np.ndarray:
    """(M, R) bool: each P (M, R, 20, 20) is finite and its Cholesky factorisation succeeds."""
    out = np.empty(P.shape[:2], dtype=np.bool_)
    L = np.empty((N, N))
    idx = np.arange(N)
    for m in range(P.shape[0]):
        for r in range(P.shape[1]):
            out[m, r] = cholesky_into(P[m, r], idx, N, L)
    return out


STOPS_DONE, STOPS_EVENT, STOPS_REPAIR, STOPS_YIELD = 0, 1, 2, 3
"""Why :func:`run_stops` returned: every stop done; an aiding epoch (the caller corrects, records
and goes on after it); a covariance failed its check (the caller repairs it, then as for an
event); an output epoch was recorded at which the caller asked to be called back."""


@_jit
def run_stops(
    stops: np.ndarray,
    is_event: np.ndarray,
    out_row: np.ndarray,
    s_from: int,
    s_to: int,
    k0: int,
    check_step: int,
    yield_every: int,
    counters: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    bdvl: np.ndarray,
    sf: np.ndarray,
    P: np.ndarray,
    dtheta_sum: np.ndarray,
    ping_bias: np.ndarray,
    ping_sf: np.ndarray,
    nonfinite_at: np.ndarray,
    phi_raw: np.ndarray,
    dv_raw: np.ndarray,
    dtheta: np.ndarray,
    t_s: np.ndarray,
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    ba_t: np.ndarray,
    bg_t: np.ndarray,
    ping_rows: np.ndarray,
    ping_bias_all: np.ndarray,
    ping_sf_all: np.ndarray,
    dt: float,
    C_earth: np.ndarray,
    C_earth_half: np.ndarray,
    g_n: np.ndarray,
    coriolis_T: np.ndarray,
    geodetic: bool,
    origin: np.ndarray,
    w_ie: np.ndarray,
    q: np.ndarray,
    block_of_state: np.ndarray,
    num_blocks: int,
    deg: float,
    series: np.ndarray,
    nees_block: np.ndarray,
    est_pos: np.ndarray,
    out_t: np.ndarray,
    est_vel: np.ndarray,
    est_euler: np.ndarray,
) -> tuple:
    """The filter bank between aiding epochs, in one call: for each covariance stop
    ``stops[s_from:s_to]`` (global samples; the chunk starts at ``k0``) advance the nominal states
    (:func:`advance`), propagate the covariances (:func:`propagate_bank`), check them once every
    ``check_step`` samples (:func:`positive_definite_bank`) and, at an output epoch
    (``out_row[s] >= 0``), record it (:func:`record_bank`, with the true DVL errors of the latest
    ping at or before it). Returns ``(s, why)`` at the first stop the caller must finish
    (:data:`STOPS_EVENT`, :data:`STOPS_REPAIR`, :data:`STOPS_YIELD` every ``yield_every``
    recorded epochs if positive) or ``(s_to, STOPS_DONE)``.

    ``counters`` (int64, in place): the sample the nominal state is at, the covariance's, the
    last check's, and the output epochs recorded. The same kernels the caller would call one by
    one, in the same order, so the numbers are those of the step-by-step loop."""
    M, R = pos.shape[0], pos.shape[1]
    k_state, k_cov, k_checked, slot = counters[0], counters[1], counters[2], counters[3]
    why = STOPS_DONE
    s = s_from
    while s < s_to:
        k = stops[s]
        i: int = k - k0
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
            k_state - k0,
            i,
            dt,
            C_earth,
            C_earth_half,
            g_n,
            coriolis_T,
            geodetic,
        )
        k_state = k
        propagate_bank(P, pos, C, vel, bg, dtheta_sum, (k - k_cov) * dt, g_n, w_ie, q, geodetic)
        for r in range(R):
            for j in range(3):
                dtheta_sum[r, j] = 0.0
        k_cov = k
        if k - k_checked >= check_step:
            k_checked = k
            ok = positive_definite_bank(P)
            for m in range(M):
                for r in range(R):
                    if not ok[m, r]:
                        why = STOPS_REPAIR
        if why == STOPS_DONE and is_event[s]:
            why = STOPS_EVENT
        if why == STOPS_DONE and out_row[s] >= 0:
            latest = np.searchsorted(ping_rows, k, side="right") - 1
            if latest >= 0:
                for r in range(R):
                    for j in range(ping_bias.shape[1]):
                        ping_bias[r, j] = ping_bias_all[latest, r, j]
                    ping_sf[r] = ping_sf_all[latest, r]
            row = out_row[s]
            record_bank(
                row,
                t_s[i],
                pos_t[i],
                vel_t[i],
                C_t[i],
                ba_t[i],
                bg_t[i],
                ping_bias,
                ping_sf,
                pos,
                vel,
                C,
                ba,
                bg,
                bdvl,
                sf,
                P,
                block_of_state,
                num_blocks,
                deg,
                series,
                nees_block,
                est_pos,
                nonfinite_at,
                geodetic,
                origin,
                est_vel,
                est_euler,
            )
            out_t[row] = t_s[i]
            slot += 1
            if yield_every > 0 and slot % yield_every == 0:
                why = STOPS_YIELD
        if why != STOPS_DONE:
            break
        s += 1
    counters[0], counters[1], counters[2], counters[3] = k_state, k_cov, k_checked, slot
    return s, why


# ---------------------------------------------------------------- batched entry points for numpy callers
@_jit
def F_batch(C: np.ndarray, v: np.ndarray, om: np.ndarray, T: np.ndarray) -> np.ndarray:
    """:func:`F_into` for n points: (n, 3, 3), (n, 3), (n, 3), earth terms (n, 18, 3) -> (n, 20, 20)."""
    out = np.empty((C.shape[0], N, N))
    for i in range(C.shape[0]):
        F_into(C[i], v[i], om[i], T[i], out[i])
    return out


@_jit
def flat_terms_batch(g_n: np.ndarray, w_ie: np.ndarray, n: int) -> np.ndarray:
    """:func:`flat_terms_into` repeated for n points -> (n, 18, 3)."""
    out = np.empty((n, NUM_TERMS, 3))
    for i in range(n):
        flat_terms_into(g_n, w_ie, out[i])
    return out


@_jit
def geodetic_terms_batch(lat: np.ndarray, h: np.ndarray, vel_n: np.ndarray) -> np.ndarray:
    """:func:`geodetic_terms_into` for n points: (n,), (n,), (n, 3) -> (n, 18, 3)."""
    out = np.empty((lat.shape[0], NUM_TERMS, 3))
    for i in range(lat.shape[0]):
        geodetic_terms_into(lat[i], h[i], vel_n[i, 0], vel_n[i, 1], vel_n[i, 2], out[i])
    return out


@_jit
def G_batch(C: np.ndarray, v: np.ndarray, num_noise: int) -> np.ndarray:
    """:func:`G_into` for n points -> (n, 20, num_noise)."""
    out = np.empty((C.shape[0], N, num_noise))
    for i in range(C.shape[0]):
        G_into(C[i], v[i], out[i])
    return out


@_jit
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


@_jit
def propagate_batch(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """``Phi P Phi^T + Qd`` for n filters (Phi of the structure :func:`sandwich_into` requires)."""
    out = np.empty(P.shape)
    for i in range(P.shape[0]):
        sandwich_into(Phi[i], P[i], out[i])
        for r in range(N):
            for c in range(N):
                out[i, r, c] += 0.5 * (Qd[i, r, c] + Qd[i, c, r])
    return out


@_jit
def nav_difference_into(
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    Ce: np.ndarray,
    rho: np.ndarray,
    dx: np.ndarray,
    geodetic: bool,
) -> None:
    """Navigation part of ``true (-) estimate`` (tauvcore.filter.eskf.difference) into ``dx[0:9]``:
    position, misalignment ``log(C_t C^T)``, body velocity ``C_t^T v_t - C^T v``. Ce (3, 3), rho (3,)
    scratch. On WGS-84 (``geodetic``; positions latitude, longitude, depth) the position error is
    in metres at the estimate, the filter's own definition (tauvcore.ins.error_model):
    ``((R_N + h) dlat, (R_E + h) cos(lat) dlon, d depth)``."""
    for i in range(3):
        for j in range(3):
            Ce[i, j] = C_t[i, 0] * C[j, 0] + C_t[i, 1] * C[j, 1] + C_t[i, 2] * C[j, 2]
    log_so3_into(Ce, rho)
    if geodetic:
        R_N, R_E = _radii_nav(pos[0])
        dx[POS] = (R_N - pos[2]) * (pos_t[0] - pos[0])
        dx[POS + 1] = (R_E - pos[2]) * math.cos(pos[0]) * (pos_t[1] - pos[1])
        dx[POS + 2] = pos_t[2] - pos[2]
    for i in range(3):
        if not geodetic:
            dx[POS + i] = pos_t[i] - pos[i]
        dx[ATT + i] = rho[i]
        dx[VEL + i] = (C_t[0, i] * vel_t[0] + C_t[1, i] * vel_t[1] + C_t[2, i] * vel_t[2]) - (
            C[0, i] * vel[0] + C[1, i] * vel[1] + C[2, i] * vel[2]
        )


@_jit
def difference_batch(
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    geodetic: bool,
) -> np.ndarray:
    """:func:`nav_difference_into` for n pairs -> (n, 9)."""
    out = np.empty((pos.shape[0], NAV))
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    for n in range(pos.shape[0]):
        nav_difference_into(pos_t[n], vel_t[n], C_t[n], pos[n], vel[n], C[n], Ce, rho, out[n], geodetic)
    return out


# ---------------------------------------------------------------- DVL measurement models
# The loosely and tightly coupled DVL models of tauvcore.aiding.dvl_loose / dvl_tight (their
# docstrings derive them): those classes call these kernels, and the filter bank calls them for
# every (method, run) of a ping at once.


@_jit
def omega_comp_into(
    omega_meas: np.ndarray, gyro_bias: np.ndarray, C: np.ndarray, w_ie: np.ndarray, out: np.ndarray
) -> None:
    """``omega_hat_nb = omega_meas - b_g - C^T omega_ie``: the body rate the lever arm uses."""
    for i in range(3):
        out[i] = omega_meas[i] - gyro_bias[i] - (C[0, i] * w_ie[0] + C[1, i] * w_ie[1] + C[2, i] * w_ie[2])


@_jit
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


@_jit
def lc_prepare_into(
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


@_jit
def lc_predict_into(
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
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


@_jit
def lc_jacobian_batch(
    C: np.ndarray, vel_n: np.ndarray, sf: np.ndarray, A_pinv: np.ndarray, w_ie: np.ndarray, l: np.ndarray
) -> np.ndarray:
    out = np.empty((C.shape[0], 3, N))
    for i in range(C.shape[0]):
        lc_jacobian_into(C[i], vel_n[i], sf[i], A_pinv[i], w_ie, l, out[i])
    return out


@_jit
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


@_jit
def tc_jacobian_batch(
    A: np.ndarray, C: np.ndarray, vel_n: np.ndarray, sf: np.ndarray, w_ie: np.ndarray, l: np.ndarray
) -> np.ndarray:
    out = np.empty((C.shape[0], 4, N))
    for i in range(C.shape[0]):
        tc_jacobian_into(A, C[i], vel_n[i], sf[i], w_ie, l, out[i])
    return out


@_jit
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


@_jit
def dvl_measure_bank(
    methods: np.ndarray,
    codes: np.ndarray,
    y: np.ndarray,
    available: np.ndarray,
    omega_meas: np.ndarray,
    C: np.ndarray,
    vel_n: np.ndarray,
    gyro_bias: np.ndarray,
    dvl_bias: np.ndarray,
    sf: np.ndarray,
    P: np.ndarray,
    A: np.ndarray,
    l: np.ndarray,
    sigma2: float,
    gyro_var: float,
    w_ie: np.ndarray,
    n_cand: np.ndarray,
    ok: np.ndarray,
    Cc: np.ndarray,
    Dc: np.ndarray,
    gc: np.ndarray,
    ac: np.ndarray,
    mc: np.ndarray,
    mode_codes: np.ndarray,
    z: np.ndarray,
    nu: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    active: np.ndarray,
    valid: np.ndarray,
    mode: np.ndarray,
    measured_axes: np.ndarray,
    choice: np.ndarray,
) -> None:
    """One DVL ping measured by every DVL method ``methods[i]`` (code ``codes[i]``) of the bank
    and every run: fills rows of z, nu (M, R, 4), H (M, R, 4, 20), Rm (M, R, 4, 4), active (M, R,
    4), valid (M, R) (rows beyond a measurement's width inactive, with a unit variance), and the
    record's mode (``mode_codes``: coast, lc, partial, tc), measured axes and selector choice.

    An extended method (``DVL_ELC``) with three or four beams is loosely coupled; with exactly two
    it builds its velocity from the tables ``n_cand[i]``, ``ok``, ``Cc``, ``Dc``, ``gc``, ``ac``,
    ``mc`` [i, pattern, candidate] (pattern = sum of 2^k over the returned beams k), fused on its
    measured axes with ``H = [0 0 I 0 0 0 0]`` (tauvcore.aiding.dvl_partial)."""
    A_pinv = np.empty((3, 4))
    omega_comp = np.empty(3)
    h = np.empty(4)
    S = np.empty((4, 4))
    y_c = np.empty(4)
    v_hat = np.empty(3)
    meas = np.empty(3, dtype=np.bool_)
    pick = np.empty(3, dtype=np.int64)
    for i in range(methods.shape[0]):
        m = methods[i]
        for r in range(y.shape[0]):
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
                omega_comp_into(omega_meas[r], gyro_bias[m, r], C[m, r], w_ie, omega_comp)
                compensated_beams_into(A, y[r], available[r], dvl_bias[m, r], sf[m, r], omega_comp, l, y_c)
                beam_noise_into(A, sigma2, gyro_var, l, sf[m, r], S)
                for k in range(3):
                    v_hat[k] = (
                        C[m, r, 0, k] * vel_n[m, r, 0]
                        + C[m, r, 1, k] * vel_n[m, r, 1]
                        + C[m, r, 2, k] * vel_n[m, r, 2]
                    )
                partial_into(
                    n_cand[i],
                    ok[i, pattern],
                    Cc[i, pattern],
                    Dc[i, pattern],
                    gc[i, pattern],
                    ac[i, pattern],
                    mc[i, pattern],
                    y_c,
                    S,
                    v_hat,
                    P[m, r, VEL : VEL + 3, VEL : VEL + 3],
                    z[m, r, :3],
                    Rm[m, r, :3, :3],
                    meas,
                    pick,
                )
                any_axis = False
                for k in range(3):
                    nu[m, r, k] = z[m, r, k] - v_hat[k]
                    H[m, r, k, VEL + k] = 1.0
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
            elif codes[i] != DVL_TC:
                good = lc_prepare_into(
                    A,
                    l,
                    sigma2,
                    gyro_var,
                    w_ie,
                    y[r],
                    available[r],
                    omega_meas[r],
                    C[m, r],
                    gyro_bias[m, r],
                    z[m, r, :3],
                    Rm[m, r, :3, :3],
                    A_pinv,
                    omega_comp,
                )
                lc_predict_into(
                    C[m, r],
                    vel_n[m, r],
                    sf[m, r],
                    dvl_bias[m, r],
                    gyro_bias[m, r],
                    A_pinv,
                    omega_meas[r],
                    omega_comp,
                    w_ie,
                    l,
                    h,
                )
                for k in range(3):
                    nu[m, r, k] = z[m, r, k] - h[k]
                    active[m, r, k] = good
                    measured_axes[m, r, k] = good
                active[m, r, 3] = False
                Rm[m, r, 3, 3] = 1.0
                lc_jacobian_into(C[m, r], vel_n[m, r], sf[m, r], A_pinv, w_ie, l, H[m, r, :3])
                valid[m, r] = good
                mode[m, r] = mode_codes[1] if good else mode_codes[0]
            else:
                beam_noise_into(A, sigma2, gyro_var, l, 0.0, S)
                tc_predict_into(
                    A,
                    C[m, r],
                    vel_n[m, r],
                    sf[m, r],
                    dvl_bias[m, r],
                    gyro_bias[m, r],
                    omega_meas[r],
                    w_ie,
                    l,
                    h,
                )
                for k in range(4):
                    if available[r, k]:
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


# ---------------------------------------------------------------- two-beam constructions
# tauvcore.aiding.dvl_partial derives them: every extended method is affine in the compensated
# beams and the predicted velocity, v = C y_c + D v_hat; its C, D, per-row gain g and assumption
# error a depend only on the beam geometry and which two beams returned, so the filter bank looks
# them up in tables built once (DVL_PATTERNS availability patterns x up to four candidates).

DVL_ELC = 3
"""Code of :func:`dvl_measure_bank`: an extended method (loosely coupled with three or four beams,
its two-beam construction with two, the tables say which)."""
MAX_CANDIDATES = 4
SELECT_TIE_REL = 1e-12
"""The selector takes a later candidate's row only if its variance is smaller by more than this
(relative): rows that several methods build identically tie within round-off."""


@_jit
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


@_jit
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


@_jit
def partial_into(
    n_cand: int,
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
    v: np.ndarray,
    R: np.ndarray,
    measured: np.ndarray,
    choice: np.ndarray,
) -> None:
    """A method's two-beam velocity from its candidates (one for VB, NSV, PLCF, VHV; four for the
    selector, eq. 48-49: per axis the candidate with the smallest variance, the earlier one on a
    tie within :data:`SELECT_TIE_REL`; rows recombined so that R keeps their cross terms).
    Candidate c: ok[c], C (3, 4), D (3, 3), g, a, measured (3,).
    ``choice`` (3,): the candidate of each measured axis, -1 none (selector only; else -1)."""
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


@_jit
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


@_jit
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


@_jit
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
        partial_into(
            ok.shape[0],
            ok,
            Cc,
            Dc,
            gc,
            ac,
            mc,
            y_c[i],
            S[i],
            v_hat[i],
            P_vel[i],
            v[i],
            R[i],
            measured[i],
            choice[i],
        )
    return v, R, measured, choice


@_jit
def flag_implausible_bank(
    ba: np.ndarray,
    bg: np.ndarray,
    bdvl: np.ndarray,
    sf: np.ndarray,
    prior_var0: np.ndarray,
    prior_rate: np.ndarray,
    t: float,
    bound: float,
    flagged_at: np.ndarray,
) -> None:
    """tauvcore.engine.monitor.implausible_sensor_errors over the bank's sensor-error estimates
    (ba, bg (M, R, 3), bdvl (M, R, 4), sf (M, R): 11 states in that order) at time ``t``: an entry
    not yet flagged whose estimate has a component with ``x^2 > bound (sigma_0^2 + q t)`` gets
    ``flagged_at = t``."""
    est = np.empty(11)
    for m in range(ba.shape[0]):
        for r in range(ba.shape[1]):
            if not math.isnan(flagged_at[m, r]):
                continue
            for i in range(3):
                est[i] = ba[m, r, i]
                est[3 + i] = bg[m, r, i]
            for i in range(4):
                est[6 + i] = bdvl[m, r, i]
            est[10] = sf[m, r]
            for i in range(11):
                if est[i] * est[i] > bound * (prior_var0[i] + prior_rate[i] * t):
                    flagged_at[m, r] = t
                    break
