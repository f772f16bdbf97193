"""The strapdown mechanization (tauvcore.ins.strapdown) compiled: one IMU interval in place
(:func:`strapdown_step_into`, with the WGS-84 earth terms of :func:`geodetic_step_terms_into`),
and :func:`advance`, the nominal states of a whole (methods, runs) bank over a stretch of samples,
each corrected by its own bias estimates."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from tauvcore.filter.kernels.common import (
    earth_rate,
    gravity_north,
    jit,
    normal_gravity,
    radii_nav,
    transport_rate,
)
from tauvcore.filter.kernels.rotation_kernels import exp_so3_into, skew_entry


class StrapdownConstants(NamedTuple):
    """What every strapdown step of a mission shares (tauvcore.ins.strapdown.Strapdown), as
    :func:`strapdown_step_into`, :func:`strapdown_batch` and :func:`advance` take it (a plain
    tuple from Python: tauvcore.filter.kernels.common.plain)."""

    dt: float  # IMU interval [s]
    C_earth: np.ndarray  # (3, 3) the flat model's local-level turn over one interval
    C_earth_half: np.ndarray  # (3, 3) and over half of one
    g_n: np.ndarray  # (3,) the flat model's gravity [m/s^2]
    coriolis_T: np.ndarray  # (3, 3) the flat model's Coriolis term, transposed
    geodetic: bool  # WGS-84 position (latitude, longitude, depth) instead of the flat NED model


@jit
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
    R_N0, _ = radii_nav(pos[0])
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
    R_N, R_E = radii_nav(lat_m)
    w_ie0, w_ie1, w_ie2 = earth_rate(lat_m)
    w_en0, w_en1, w_en2 = transport_rate(R_N, R_E, lat_m, h_m, v_mid0, v_mid1)
    a0, a1, a2 = w_ie0 + w_en0, w_ie1 + w_en1, w_ie2 + w_en2
    exp_so3_into(-a0 * dt, -a1 * dt, -a2 * dt, S[0])
    exp_so3_into(-0.5 * a0 * dt, -0.5 * a1 * dt, -0.5 * a2 * dt, S[1])
    c0, c1, c2 = 2.0 * w_ie0 + w_en0, 2.0 * w_ie1 + w_en1, 2.0 * w_ie2 + w_en2
    for i in range(3):
        for j in range(3):
            S[2, j, i] = -skew_entry(c0, c1, c2, i, j)
    S[3, 0, 0], S[3, 0, 1], S[3, 0, 2] = gravity_north(lat_m, h_m), 0.0, normal_gravity(lat_m, h_m)
    return lat_m, R_N, R_E


@jit
def strapdown_step_into(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    phi0: float,
    phi1: float,
    phi2: float,
    dv: np.ndarray,
    sd: StrapdownConstants,
    work: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """One IMU interval of the mechanization (tauvcore.ins.strapdown), in place.

    ``C <- C_earth C exp([phi x])``; ``dv_n = C_earth/2 C dv + g dt``;
    ``v_mid = v + (dv_n + (-2 omega_ie x v) dt) / 2``; ``v <- v + dv_n + (-2 omega_ie x v_mid) dt``;
    ``pos <- pos + dt (v_old + v_new) / 2``. ``coriolis_T``: ``(-2 [omega_ie_n x])^T`` (row form).
    Those are the flat model's constants, ``sd``'s. With ``sd.geodetic`` (WGS-84; ``pos`` = latitude,
    longitude, depth) they are replaced for this interval by :func:`geodetic_step_terms_into`'s,
    in ``S`` (4, 3, 3), and the position integrates the geodetic rates with the trapezoid of the
    NED velocity (depth first, then latitude, then longitude at the mean latitude; Groves 5.56).
    ``work`` is scratch: ``S`` (4, 3, 3), ``E`` (3, 3) and ``tmp`` (3, 3) (no allocation per step).
    """
    dt, C_earth, C_earth_half, g_n, coriolis_T, geodetic = sd
    S, E, tmp = work
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


@jit
def strapdown_batch(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    phi: np.ndarray,
    dv: np.ndarray,
    sd: StrapdownConstants,
) -> None:
    """One step for n entries in place: pos, vel (n, 3), C (n, 3, 3), phi, dv (n, 3)."""
    work = (np.empty((4, 3, 3)), np.empty((3, 3)), np.empty((3, 3)))
    for i in range(pos.shape[0]):
        strapdown_step_into(pos[i], vel[i], C[i], phi[i, 0], phi[i, 1], phi[i, 2], dv[i], sd, work)


@jit
def advance(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    increments: tuple[np.ndarray, np.ndarray, np.ndarray],
    dtheta_sum: np.ndarray,
    k_from: int,
    k_to: int,
    sd: StrapdownConstants,
) -> None:
    """Advance the (M, R) nominal states over samples ``k_from + 1 .. k_to`` of the chunk's
    ``increments`` ``(phi_raw, dv_raw, dtheta_raw)`` (K, R, 3) each: the compensated ``phi_raw``,
    ``dv_raw``, each corrected by its own bias estimate, and the raw gyro increments
    ``dtheta_raw``, those samples' added to ``dtheta_sum`` (R, 3) one by one (the same sum however
    the samples are split between calls)."""
    phi_raw, dv_raw, dtheta_raw = increments
    dt = sd[0]
    work = (np.empty((4, 3, 3)), np.empty((3, 3)), np.empty((3, 3)))
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
                    sd,
                    work,
                )
