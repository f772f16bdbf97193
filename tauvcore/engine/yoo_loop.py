"""The compiled chunk loop of Yoo 2014's methods (numba): tauvcore.engine.yoo_bank's numpy methods
as one call per chunk.

Why: the numpy bank (``YooBank(..., compiled=False)``, kept as the reference) spends its time in
numpy's per-call overhead on 3x3 and 12x12 batches at every DVL ping, covariance step and output
epoch (the 24-minute ``longrange`` mission took 10 s); this loop and the formulas it calls
(tauvcore.filter.yoo_kernels) do the same arithmetic in machine code.

The chunk's stops (covariance steps, DVL pings, output epochs) come from the caller in order, with
the ping and output row of each (-1 for none); :func:`run_stops` processes stops ``s0 .. s1 - 1``,
so the caller can come back between output epochs (progress, stop requests).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from tauvcore.filter.kernels.common import jit, ned_offset
from tauvcore.filter.kernels.nees import nees_blocks_into, nees_plan, quadratic_into
from tauvcore.filter.kernels.rotations import log_so3_into
from tauvcore.filter.kernels.strapdown import StrapdownConstants, advance
from tauvcore.filter.yoo_kernels import (
    ATT,
    BA,
    BG,
    DIM,
    NA,
    NC,
    VEL,
    dvl_body_velocity_into,
    fuse,
    propagate,
    vkf_step,
)

INS_DVL, VKF = 0, 1  # method codes (tauvcore.engine.yoo_bank.METHOD_CODES)
# rows of the per-epoch series (tauvcore.engine.yoo_bank.SERIES)
NUM_SERIES = 11
# flags of an update
U_VALID, U_FUSED, U_REJECTED = 0, 1, 2


@jit
def _latest(index: np.ndarray, k: int) -> np.intp:
    """Row of the last epoch at or before sample ``k`` (-1 before the first)."""
    return np.searchsorted(index, k, side="right") - 1


@jit
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
    sensor_index: np.ndarray,
    sensor_est: np.ndarray,
    sensor_sigma: np.ndarray,
    sensor_true: np.ndarray,
) -> None:
    """One output epoch of every (method, run) (yoo_bank.YooBank._record): errors ``true - estimate``,
    1-sigma, NEES of the 12 states and of each block (no position state: NaN), the estimates; when
    sensor_est (T, M, R, S) has rows, the sensor errors' estimate, ``sqrt(P_ii)`` and truth too
    (column j the state ``sensor_index[j]``, sensor_sigma and sensor_true alike)."""
    M, R = pos.shape[0], pos.shape[1]
    with_sensors = sensor_est.shape[0] > 0
    x_est = np.zeros(DIM)  # the bias states' estimate and truth, by state
    x_true = np.zeros(DIM)
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
                e0, e1, e2 = ned_offset(
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
            if with_sensors:
                for i in range(3):
                    x_est[BA + i], x_true[BA + i] = ba[m, r, i], ba_t[r, i]
                    x_est[BG + i], x_true[BG + i] = bg[m, r, i], bg_t[r, i]
                for j in range(sensor_index.size):
                    k = sensor_index[j]
                    sensor_est[row, m, r, j] = x_est[k]
                    sensor_sigma[row, m, r, j] = math.sqrt(Pm[k, k])
                    sensor_true[row, m, r, j] = x_true[k]


class YooSchedule(NamedTuple):
    """A chunk's stops (tauvcore.engine.yoo_bank.YooBank._run_chunk): the global samples, the row of the chunk's pings and of its output epochs at each (-1 for none), the chunk's first sample."""

    stops: np.ndarray
    ping_of_stop: np.ndarray
    row_of_stop: np.ndarray
    k0: int


class YooState(NamedTuple):
    """The bank's states, (methods, runs, ...), and the VKF's, (runs, ...), written in place."""

    pos: np.ndarray
    vel: np.ndarray
    C: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    P: np.ndarray
    dtheta_sum: np.ndarray
    vkf_x: np.ndarray
    vkf_P: np.ndarray
    vkf_use: np.ndarray
    vkf_alt: np.ndarray


class YooChunk(NamedTuple):
    """A chunk's IMU increments, DVL beams, RPM and echo sounder epochs, and its truth at the IMU samples (for the records and the VKF's trace)."""

    phi_raw: np.ndarray
    dv_raw: np.ndarray
    dtheta: np.ndarray
    y_beam: np.ndarray
    available: np.ndarray
    rpm_index: np.ndarray
    rpm_value: np.ndarray
    rpm_sf: np.ndarray
    rpm_b: np.ndarray
    echo_index: np.ndarray
    echo_alt: np.ndarray
    pos_t: np.ndarray
    vel_t: np.ndarray
    C_t: np.ndarray
    ba_t: np.ndarray
    bg_t: np.ndarray


class YooModel(NamedTuple):
    """The filters' constants: the records' origin, the earth rate, the process noise, the methods, the DVL geometry and noise, the consider states' walks, the gate, the VKF's tuning and switch, the NEES blocks."""

    origin: np.ndarray
    w_ie_flat: np.ndarray
    q: np.ndarray
    method_code: np.ndarray
    A_b: np.ndarray
    l_dvl_b: np.ndarray
    beam_var: float
    qc: np.ndarray
    L4: np.ndarray
    gate: float
    vkf_Q: np.ndarray
    vkf_R: float
    switch_altitude: float
    forward_norm: bool
    lateral_var: float
    block_of_state: np.ndarray
    num_blocks: int
    deg: float
    sensor_index: np.ndarray  # (S,) int64: the state of each sensor-error column (yoo_bank.SENSOR_INDEX)


class YooOutputs(NamedTuple):
    """A chunk's store (tauvcore.engine.yoo_bank.YooBank._store): the output epochs, the updates and the VKF's trace."""

    series: np.ndarray
    nees_block: np.ndarray
    est_pos: np.ndarray
    est_vel: np.ndarray
    est_euler: np.ndarray
    sensor_est: np.ndarray  # (T, M, R, S); no rows: the sensor errors are not recorded
    sensor_sigma: np.ndarray
    sensor_true: np.ndarray
    up_z: np.ndarray
    up_nu: np.ndarray
    up_S: np.ndarray
    up_flags: np.ndarray
    up_nis: np.ndarray
    tr_x: np.ndarray
    tr_sigma: np.ndarray
    tr_truth: np.ndarray
    tr_use: np.ndarray
    tr_alt: np.ndarray


@jit
def run_stops(
    s0: int,
    s1: int,
    schedule: YooSchedule,
    counters: np.ndarray,
    state: YooState,
    chunk: YooChunk,
    sd: StrapdownConstants,
    model: YooModel,
    outputs: YooOutputs,
) -> None:
    """Stops ``s0 .. s1 - 1`` of a chunk (yoo_bank.YooBank.feed's loop): advance the nominal states
    to the stop, step the covariance, fuse a DVL ping (its row of the chunk's pings in
    ``ping_of_stop``), record an output epoch (its row in ``row_of_stop``). ``counters`` =
    (k_state, k_cov), read and written."""
    stops, ping_of_stop, row_of_stop, k0 = schedule
    pos, vel, C, ba, bg, P, dtheta_sum, vkf_x, vkf_P, vkf_use, vkf_alt = state
    (
        phi_raw,
        dv_raw,
        dtheta,
        y_beam,
        available,
        rpm_index,
        rpm_value,
        rpm_sf,
        rpm_b,
        echo_index,
        echo_alt,
        pos_t,
        vel_t,
        C_t,
        ba_t,
        bg_t,
    ) = chunk
    dt, C_earth, C_earth_half, g_n, coriolis_T, geodetic = sd
    (
        origin,
        w_ie_flat,
        q,
        method_code,
        A_b,
        l_dvl_b,
        beam_var,
        qc,
        L4,
        gate,
        vkf_Q,
        vkf_R,
        switch_altitude,
        forward_norm,
        lateral_var,
        block_of_state,
        num_blocks,
        deg,
        sensor_index,
    ) = model
    (
        series,
        nees_block,
        est_pos,
        est_vel,
        est_euler,
        sensor_est,
        sensor_sigma,
        sensor_true,
        up_z,
        up_nu,
        up_S,
        up_flags,
        up_nis,
        tr_x,
        tr_sigma,
        tr_truth,
        tr_use,
        tr_alt,
    ) = outputs
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
                sensor_index,
                sensor_est,
                sensor_sigma,
                sensor_true,
            )
