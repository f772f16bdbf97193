"""The compiled chunk loop of Yoo 2014's methods (numba): tauvcore.engine.yoo_bank's chunks, one
call per span of stops, with the smoother's marks when it keeps a tape (:class:`YooTape`).

A bank in numpy (tests/unit/yoo_reference.py, the reference this loop is held equal to, to 1e-9)
spends its time in numpy's per-call overhead on 3x3 and 12x12 batches at every DVL ping, covariance
step and output epoch; this loop and the formulas it calls (tauvcore.filter.yoo_kernels) do the
same arithmetic in machine code.

The chunk's stops (covariance steps, DVL pings, output epochs) come from the caller in order, with
the ping and output row of each (-1 for none); :func:`run_stops` processes stops ``s0 .. s1 - 1``,
so the caller can come back between output epochs (progress, stop requests).

With the states the sources add (the DVL's current, tauvcore.engine.yoo_velocity) the covariance
is (N, N), N = 17 + E: the velocity aids through the water, the VKF learning through the water
and the water-track beams are tauvcore.engine.yoo_velocity's, written out here.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from tauvcore import units
from tauvcore.aiding.echo_altitude import ALTITUDE
from tauvcore.aiding.propeller_rpm import RPM, TRUE_BIAS, TRUE_SCALE_FACTOR
from tauvcore.engine.results import STATE_FIELDS
from tauvcore.engine.rpm_aid import ECHO_SOURCE, RPM_LATERAL_SIGMA_MPS, RPM_SOURCE
from tauvcore.filter.kernels.common import jit, ned_offset
from tauvcore.filter.kernels.nees import add_reference_into, nees_blocks_into, nees_plan, quadratic_into
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

_RPM, _WATER = 1, 2  # what a fused velocity is through the water: the VKF's RPM, water-track

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
    extra: np.ndarray,
    extra_t: np.ndarray,
    est: np.ndarray,
    state_est: np.ndarray,
    state_sigma: np.ndarray,
    state_true: np.ndarray,
    ref_var: np.ndarray,
    tape_dx: np.ndarray,
) -> None:
    """One output epoch of every (method, run): errors ``true - estimate``,
    1-sigma, NEES of the estimated states (the 12 and the added, ``est`` their indices in P) and
    of each block (no position state: NaN), against their covariance and the covariance of the
    reference's own errors, ``ref_var`` (9,) at the reference's attitude ``C_t`` and NED velocity
    ``vel_t`` (tauvcore.filter.kernels.nees.add_reference_into), the estimates; when sensor_est (T, M, R, S) has rows,
    the sensor errors' estimate, ``sqrt(P_ii)`` and truth too (column j the state
    ``sensor_index[j]``, sensor_sigma and sensor_true alike); the added states' estimate (``extra``
    (M, R, E)), ``sqrt(P_ii)`` and truth (``extra_t`` (E,)) into state_est, state_sigma, state_true;
    when the smoother's ``tape_dx`` (T, M, R, 12 + E) has rows, the errors too."""
    M, R = pos.shape[0], pos.shape[1]
    with_sensors = sensor_est.shape[0] > 0
    n = est.shape[0]
    x_est = np.zeros(DIM)  # the bias states' estimate and truth, by state
    x_true = np.zeros(DIM)
    dx = np.empty(n)
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    L = np.empty((n, n))
    yv = np.empty(n)
    Pe = np.empty((n, n))
    A = np.empty((n, n))
    idx = np.arange(n)
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
            for e in range(n - DIM):
                dx[DIM + e] = extra_t[e] - extra[m, r, e]
            if tape_dx.shape[0] > 0:
                tape_dx[row, m, r, :] = dx
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
            for a in range(n):
                for b in range(n):
                    Pe[a, b] = Pm[est[a], est[b]]
            series[0, row, m, r] = math.sqrt(ev)
            series[1, row, m, r] = math.sqrt(rho[0] ** 2 + rho[1] ** 2 + rho[2] ** 2) * deg
            series[2, row, m, r] = math.sqrt(ep)
            series[3, row, m, r] = math.sqrt(Pm[0, 0] + Pm[1, 1] + Pm[2, 2])
            series[4, row, m, r] = math.sqrt(Pm[3, 3] + Pm[4, 4] + Pm[5, 5]) * deg
            series[5, row, m, r] = np.nan
            # the NEES's covariance: P and the reference's own (NED velocity, no position state), or P
            Q = A if add_reference_into(Pe, ref_var, C_t, vel_t, -1, ATT, VEL, False, A) else Pe
            series[6, row, m, r] = quadratic_into(Q, dx, idx, n, L, yv)
            series[7, row, m, r] = math.sqrt(rho[0] ** 2 + rho[1] ** 2) * deg
            series[8, row, m, r] = abs(rho[2]) * deg
            series[9, row, m, r] = math.sqrt(Pm[3, 3] + Pm[4, 4]) * deg
            series[10, row, m, r] = math.sqrt(Pm[5, 5]) * deg
            nees_blocks_into(Q, dx, members, sizes, lead, order, L, yv, blocks)
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
            for e in range(n - DIM):
                state_est[row, m, r, e] = extra[m, r, e]
                state_sigma[row, m, r, e] = math.sqrt(Pm[NA + e, NA + e])
                state_true[row, m, r, e] = extra_t[e]


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
    extra: np.ndarray  # (M, R, E) the added states
    learn_axis: np.ndarray  # (R, 3) the body x axis of the VKF's last update, NED (rpm_aid.RpmAid)
    learn_current: np.ndarray  # (R, 3) the current estimate it took then [m/s]


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
    y_water: np.ndarray  # (pings, R, 4) water-track beams (no pings: none)
    water_available: np.ndarray  # (pings, R, 4) bool
    extra_t: np.ndarray  # (K, E) the added states' truth at the chunk's samples


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
    extra_rate: np.ndarray  # (E,) the added states' -1/tau [1/s] (0: a random walk)
    extra_q: np.ndarray  # (E,) their driving noise PSD
    ref_var: np.ndarray  # (9,) the reference's own variances (tauvcore.filter.reference.ReferenceConfig
    # .variances), whose covariance the NEES adds to P; all zero: exact
    current: int  # the current's first index in P (north, then east); -1: no current states
    water_var: float  # a water-track beam's noise variance [m^2/s^2]; negative: water-track not fused
    est: np.ndarray  # (12 + E,) int64 the estimated states' indices in P


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
    state_est: np.ndarray  # (T, M, R, E)
    state_sigma: np.ndarray
    state_true: np.ndarray
    wt_z: np.ndarray  # (pings, M, R, 3) the water-track's records, as up_* (no rows: not fused)
    wt_nu: np.ndarray
    wt_S: np.ndarray
    wt_flags: np.ndarray
    wt_nis: np.ndarray


class YooTape(NamedTuple):
    """The smoother's marks the loop writes (tauvcore.engine.yoo_smoothing.YooTapeWriter, whose
    arrays these are); ``phi_acc`` without rows: no smoother, nothing written."""

    phi_acc: np.ndarray  # (M, R, 12, 12) Phi - I since the last mark, composed in place
    tape_X: np.ndarray  # (T, M, R, 12, 12) each output epoch's transition since the mark before it
    tape_P: np.ndarray  # (T, M, R, N, N) its covariance
    tape_dx: np.ndarray  # (T, M, R, 12 + E) its error against truth (the 12 states, then the added)
    tape_vel_b: np.ndarray  # (T, M, R, 3) the true body velocity [m/s]
    ev_X: np.ndarray  # (pings, M, R, 12, 12) each ping's mark: its transition since the mark before,
    ev_Pm: np.ndarray  # (pings, M, R, N, N) the covariance before its corrections,
    ev_P: np.ndarray  # (pings, M, R, N, N) after them,
    ev_d: np.ndarray  # (pings, M, R, N) the correction the nominal state took (zero: nothing fused),
    ev_pos: np.ndarray  # (pings,) int64 the chunk's output epochs recorded before it


@jit
def _aid(
    kind: int,
    Cm: np.ndarray,
    vel: np.ndarray,
    extra: np.ndarray,
    current: int,
    learn_axis: np.ndarray,
    learn_current: np.ndarray,
    h: np.ndarray,
    w: np.ndarray,
    Hx: np.ndarray,
) -> None:
    """A velocity aid's prediction ``h``, the vector ``w`` its attitude column rotates and its
    columns ``Hx`` (3, E) on the added states (tests/unit/yoo_reference.py's velocity_H): over ground (``kind`` 0)
    ``v``; through the water (the current's at ``current`` in P, :data:`_WATER`) ``v - c``; the
    VKF's RPM (:data:`_RPM`) also ``+ x (c - c_l) . a`` and ``x a_NE^T`` on the current."""
    Hx[:, :] = 0.0
    c = np.zeros(3)
    if kind != 0 and current >= 0:
        c[0], c[1] = extra[current - NA], extra[current - NA + 1]
    for i in range(3):
        h[i] = vel[i] - c[i]
        w[i] = h[i]
    if kind == 0 or current < 0:
        return
    for i in range(2):
        Hx[i, current - NA + i] = -1.0
    if kind == _RPM:
        along = 0.0
        for j in range(3):
            along += (c[j] - learn_current[j]) * learn_axis[j]
        for i in range(3):
            h[i] += Cm[i, 0] * along
            for j in range(2):
                Hx[i, current - NA + j] += Cm[i, 0] * learn_axis[j]


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
    tape: YooTape,
) -> None:
    """Stops ``s0 .. s1 - 1`` of a chunk (yoo_bank.YooBank.feed's loop): advance the nominal states
    to the stop, step the covariance, fuse a DVL ping (its row of the chunk's pings in
    ``ping_of_stop``; then its water-track beams, with current states), record an output epoch
    (its row in ``row_of_stop``); with the smoother's ``tape``, each ping's mark and each output
    epoch's. ``counters`` = (k_state, k_cov, the tape's output epochs so far), read and written."""
    stops, ping_of_stop, row_of_stop, k0 = schedule
    (pos, vel, C, ba, bg, P, dtheta_sum, vkf_x, vkf_P, vkf_use, vkf_alt, extra, learn_axis,
     learn_current) = state  # fmt: skip
    phi_raw, dv_raw, dtheta, y_beam, available = (
        chunk.phi_raw,
        chunk.dv_raw,
        chunk.dtheta,
        chunk.y_beam,
        chunk.available,
    )
    rpm_index, rpm_value, rpm_sf, rpm_b = chunk.rpm_index, chunk.rpm_value, chunk.rpm_sf, chunk.rpm_b
    echo_index, echo_alt, y_water, water_available = (
        chunk.echo_index,
        chunk.echo_alt,
        chunk.y_water,
        chunk.water_available,
    )
    dt, C_earth, C_earth_half, g_n, coriolis_T, geodetic = sd
    origin, w_ie_flat, q, method_code, A_b = (
        model.origin,
        model.w_ie_flat,
        model.q,
        model.method_code,
        model.A_b,
    )
    l_dvl_b, beam_var, qc, L4, gate = model.l_dvl_b, model.beam_var, model.qc, model.L4, model.gate
    vkf_Q, vkf_R, switch_altitude, forward_norm = (
        model.vkf_Q,
        model.vkf_R,
        model.switch_altitude,
        model.forward_norm,
    )
    lateral_var, extra_rate, extra_q, current = (
        model.lateral_var,
        model.extra_rate,
        model.extra_q,
        model.current,
    )
    water_var = model.water_var
    up_z, up_nu, up_S, up_flags, up_nis = (
        outputs.up_z,
        outputs.up_nu,
        outputs.up_S,
        outputs.up_flags,
        outputs.up_nis,
    )
    tr_x, tr_sigma, tr_truth, tr_use, tr_alt = (
        outputs.tr_x,
        outputs.tr_sigma,
        outputs.tr_truth,
        outputs.tr_use,
        outputs.tr_alt,
    )
    wt_z, wt_nu, wt_S, wt_flags, wt_nis = (
        outputs.wt_z,
        outputs.wt_nu,
        outputs.wt_S,
        outputs.wt_flags,
        outputs.wt_nis,
    )
    M, R = pos.shape[0], pos.shape[1]
    N = P.shape[-1]
    E = N - NA
    F = np.empty((DIM, DIM))
    Phi = np.empty((DIM, DIM))
    tmp = np.empty((DIM, DIM))
    out = np.empty((N, N))
    v_b = np.empty((R, 3))
    cov_b = np.empty((R, 3, 3))
    gain = np.empty((R, 3, 4))
    Hb = np.empty((3, NC))
    Hc = np.empty((3, NC))
    Hx = np.empty((3, E))
    h = np.empty(3)
    w = np.empty(3)
    ok = np.empty(R, dtype=np.bool_)
    have_rpm = np.empty(R, dtype=np.bool_)
    z = np.empty(3)
    Rm = np.empty((3, 3))
    Cc = np.empty((3, 3))
    nu = np.empty(3)
    S_diag = np.empty(3)
    vb = np.empty(3)
    water = water_var >= 0.0 and y_water.shape[0] > 0
    phi_acc = tape.phi_acc
    taping = phi_acc.shape[0] > 0
    held = (M, R) if taping else (0, 0)  # the nominal state before a ping's corrections
    vel0, C0 = np.empty(held + (3,)), np.empty(held + (3, 3))
    ba0, bg0, extra0 = np.empty(held + (3,)), np.empty(held + (3,)), np.empty(held + (E,))
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
                extra_rate,
                extra_q,
                F,
                Phi,
                tmp,
                out,
                phi_acc,
            )
            dtheta_sum[:, :] = 0.0
            counters[1] = k
        p = ping_of_stop[s]
        if p >= 0:
            if taping:
                _mark_before(p, counters[2], tape, P, vel, C, ba, bg, extra, vel0, C0, ba0, bg0, extra0)
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
                        for j in range(3):
                            vb[j] = v_b[r, j]
                        cx = 0.0  # the current's part along the body x axis (learning through the water)
                        if current >= 0:
                            cx = (
                                Cm[0, 0] * extra[m, r, current - NA]
                                + Cm[1, 0] * extra[m, r, current - NA + 1]
                            )
                        vb[0] -= cx
                        if forward_norm:
                            z_fwd = math.sqrt(vb[0] ** 2 + vb[1] ** 2 + vb[2] ** 2)
                        else:
                            z_fwd = vb[0]
                        use_rpm, got_rpm = vkf_step(
                            vkf_x[r], vkf_P[r], rpm_now, altitude, z_fwd, ok[r], vkf_Q, vkf_R, switch_altitude
                        )
                        if current >= 0 and not use_rpm and ok[r] and got_rpm:  # learnt: its axis, current
                            for j in range(3):
                                learn_axis[r, j] = Cm[j, 0]
                                learn_current[r, j] = 0.0
                            learn_current[r, 0] = extra[m, r, current - NA]
                            learn_current[r, 1] = extra[m, r, current - NA + 1]
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
                        _rotated_into(Cm, v_b[r], cov_b[r], z, Cc, Rm)
                    for a in range(3):
                        for c in range(NC):
                            Hc[a, c] = Cm[a, 0] * Hb[0, c] + Cm[a, 1] * Hb[1, c] + Cm[a, 2] * Hb[2, c]
                    _aid(_RPM if use_rpm else 0, Cm, vel[m, r], extra[m, r], current, learn_axis[r],
                         learn_current[r], h, w, Hx)  # fmt: skip
                    fused, passed, nis = fuse(
                        P[m, r], vel[m, r], C[m, r], ba[m, r], bg[m, r], extra[m, r], z, h, w, Rm, Hc, Hx, valid,
                        gate, S_diag, nu,
                    )  # fmt: skip
                    _write_update(p, m, r, z, nu, S_diag, valid, fused, passed, nis, up_z, up_nu, up_S,
                                  up_flags, up_nis)  # fmt: skip
            if water:  # the water-track beams, after the ping's bottom-track
                for r in range(R):
                    lat = pos[0, r, 0] if geodetic else origin[0]
                    ok[r] = dvl_body_velocity_into(
                        y_water[p, r], water_available[p, r], dtheta[i, r], dt, C[0, r], lat, A_b, l_dvl_b,
                        water_var, v_b[r], cov_b[r], gain[r],
                    )  # fmt: skip
                for m in range(M):
                    for r in range(R):
                        Cm = C[m, r]
                        _aid(_WATER, Cm, vel[m, r], extra[m, r], current, learn_axis[r], learn_current[r],
                             h, w, Hx)  # fmt: skip
                        for a in range(3):  # the scale factor scales the estimated velocity through the water
                            Hb[a, 0] = Cm[0, a] * h[0] + Cm[1, a] * h[1] + Cm[2, a] * h[2]
                            for c in range(4):
                                Hb[a, 1 + c] = gain[r, a, c]
                        for a in range(3):
                            for c in range(NC):
                                Hc[a, c] = Cm[a, 0] * Hb[0, c] + Cm[a, 1] * Hb[1, c] + Cm[a, 2] * Hb[2, c]
                        _rotated_into(Cm, v_b[r], cov_b[r], z, Cc, Rm)
                        fused, passed, nis = fuse(
                            P[m, r], vel[m, r], C[m, r], ba[m, r], bg[m, r], extra[m, r], z, h, w, Rm, Hc, Hx,
                            ok[r], gate, S_diag, nu,
                        )  # fmt: skip
                        _write_update(p, m, r, z, nu, S_diag, ok[r], fused, passed, nis, wt_z, wt_nu, wt_S,
                                      wt_flags, wt_nis)  # fmt: skip
            if taping:
                _mark_after(p, tape, P, vel, C, ba, bg, extra, vel0, C0, ba0, bg0, extra0)
        row = row_of_stop[s]
        if row >= 0:
            _record_row(row, i, state, chunk, model, outputs, tape, geodetic, counters)


@jit
def _record_row(
    row: int,
    i: int,
    state: YooState,
    chunk: YooChunk,
    model: YooModel,
    outputs: YooOutputs,
    tape: YooTape,
    geodetic: bool,
    counters: np.ndarray,
) -> None:
    """Output epoch ``row`` at sample ``i`` of the chunk (:func:`record`), and with the smoother's
    ``tape`` its mark: the transition since the last mark (then restarted), the covariance, the
    true body velocity; ``counters[2]`` the chunk's output epochs recorded so far."""
    pos, vel, C, ba, bg, P, extra = state.pos, state.vel, state.C, state.ba, state.bg, state.P, state.extra
    C_t, vel_t = chunk.C_t, chunk.vel_t
    record(
        row, chunk.pos_t[i], vel_t[i], C_t[i], chunk.ba_t[i], chunk.bg_t[i], pos, vel, C, ba, bg, P, geodetic,
        model.origin, model.block_of_state, model.num_blocks, model.deg, outputs.series, outputs.nees_block,
        outputs.est_pos, outputs.est_vel, outputs.est_euler, model.sensor_index, outputs.sensor_est,
        outputs.sensor_sigma, outputs.sensor_true, extra, chunk.extra_t[i], model.est, outputs.state_est,
        outputs.state_sigma, outputs.state_true, model.ref_var, tape.tape_dx,
    )  # fmt: skip
    if tape.phi_acc.shape[0] == 0:
        return
    tape.tape_X[row] = tape.phi_acc
    tape.phi_acc[...] = 0.0
    tape.tape_P[row] = P
    for j in range(3):
        tape.tape_vel_b[row, :, :, j] = (
            C_t[i, 0, j] * vel_t[i, 0] + C_t[i, 1, j] * vel_t[i, 1] + C_t[i, 2, j] * vel_t[i, 2]
        )
    counters[2] = max(counters[2], row + 1)


@jit
def _mark_before(
    p: int,
    rows: int,
    tape: YooTape,
    P: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    extra: np.ndarray,
    vel0: np.ndarray,
    C0: np.ndarray,
    ba0: np.ndarray,
    bg0: np.ndarray,
    extra0: np.ndarray,
) -> None:
    """Ping ``p``'s mark before its corrections (yoo_smoothing.YooTapeWriter.before): the
    transition since the last mark (then restarted), the covariance and, kept in ``vel0`` ..
    ``extra0``, the nominal state; ``rows`` the chunk's output epochs recorded so far."""
    tape.ev_X[p] = tape.phi_acc
    tape.phi_acc[...] = 0.0
    tape.ev_Pm[p] = P
    tape.ev_pos[p] = rows
    vel0[...] = vel
    C0[...] = C
    ba0[...] = ba
    bg0[...] = bg
    extra0[...] = extra


@jit
def _mark_after(
    p: int,
    tape: YooTape,
    P: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    ba: np.ndarray,
    bg: np.ndarray,
    extra: np.ndarray,
    vel0: np.ndarray,
    C0: np.ndarray,
    ba0: np.ndarray,
    bg0: np.ndarray,
    extra0: np.ndarray,
) -> None:
    """Ping ``p``'s mark after its corrections (yoo_smoothing.YooTapeWriter.after): the covariance
    and the correction the nominal state took, ``x+ - x-`` (the attitude's ``log(C+ C-^T)``; the
    consider states never corrected), zero for a filter whose covariance did not change (nothing
    fused: round-off, not a correction)."""
    M, R, N = P.shape[0], P.shape[1], P.shape[2]
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    tape.ev_P[p] = P
    for m in range(M):
        for r in range(R):
            d = tape.ev_d[p, m, r]
            d[:] = 0.0
            if np.all(P[m, r] == tape.ev_Pm[p, m, r]):
                continue
            for a in range(3):
                for b in range(3):
                    Ce[a, b] = (
                        C[m, r, a, 0] * C0[m, r, b, 0]
                        + C[m, r, a, 1] * C0[m, r, b, 1]
                        + (C[m, r, a, 2] * C0[m, r, b, 2])
                    )
            log_so3_into(Ce, rho)
            for a in range(3):
                d[VEL + a] = vel[m, r, a] - vel0[m, r, a]
                d[ATT + a] = rho[a]
                d[BA + a] = ba[m, r, a] - ba0[m, r, a]
                d[BG + a] = bg[m, r, a] - bg0[m, r, a]
            for e in range(N - NA):
                d[NA + e] = extra[m, r, e] - extra0[m, r, e]


@jit
def _rotated_into(
    Cm: np.ndarray, v_b: np.ndarray, cov_b: np.ndarray, z: np.ndarray, Cc: np.ndarray, Rm: np.ndarray
) -> None:
    """A body velocity ``v_b`` (3,) and its covariance ``cov_b`` (3, 3) rotated into n with ``Cm``:
    ``z`` and ``Rm`` written (``Cc`` work space)."""
    for a in range(3):
        z[a] = Cm[a, 0] * v_b[0] + Cm[a, 1] * v_b[1] + Cm[a, 2] * v_b[2]
        for b in range(3):
            Cc[a, b] = Cm[a, 0] * cov_b[0, b] + Cm[a, 1] * cov_b[1, b] + Cm[a, 2] * cov_b[2, b]
    for a in range(3):
        for b in range(3):
            Rm[a, b] = Cc[a, 0] * Cm[b, 0] + Cc[a, 1] * Cm[b, 1] + Cc[a, 2] * Cm[b, 2]


@jit
def _write_update(
    p: int,
    m: int,
    r: int,
    z: np.ndarray,
    nu: np.ndarray,
    S_diag: np.ndarray,
    valid: bool,
    fused: bool,
    passed: bool,
    nis: float,
    out_z: np.ndarray,
    out_nu: np.ndarray,
    out_S: np.ndarray,
    out_flags: np.ndarray,
    out_nis: np.ndarray,
) -> None:
    """One fused velocity's record at ping ``p`` of method ``m``, run ``r`` (NaN where not valid)."""
    for a in range(3):
        out_z[p, m, r, a] = z[a]
        out_nu[p, m, r, a] = nu[a] if valid else np.nan
        out_S[p, m, r, a] = S_diag[a] if valid else np.nan
    out_flags[p, m, r, U_VALID] = valid
    out_flags[p, m, r, U_FUSED] = fused
    out_flags[p, m, r, U_REJECTED] = valid and not passed
    out_nis[p, m, r] = nis if valid else np.nan


def run_chunk(
    bank: Any,
    chunk: Any,
    s0: int,
    s1: int,
    stops: np.ndarray,
    ping_of_stop: np.ndarray,
    row_of_stop: np.ndarray,
    inputs: Any,
    store: dict[str, np.ndarray],
    method_codes: dict[str, int],
    sensor_index: np.ndarray,
) -> None:
    """Stops ``s0 .. s1 - 1`` of a chunk of the Yoo bank ``bank`` (tauvcore.engine.yoo_bank.YooBank)
    in :func:`run_stops`, which is handed the bank's states, the chunk's inputs and truth, the
    filters' constants and the chunk's store as the compiled loop takes them (:func:`loop_args`).

    Parameters
    ----------
    bank : YooBank
        The bank: its states (written in place) and constants.
    chunk : SimChunk
        The chunk: its IMU, DVL, RPM and echo sounder data and its truth.
    s0, s1 : int
        The stops run.
    stops, ping_of_stop, row_of_stop : numpy.ndarray
        The chunk's stops and, at each, its ping's and output epoch's row (-1: none).
    inputs : ChunkInputs
        The chunk's IMU increments.
    store : dict[str, numpy.ndarray]
        The chunk's store, written.
    method_codes : dict[str, int]
        Each method's code (:data:`INS_DVL`, :data:`VKF`).
    sensor_index : numpy.ndarray
        The state of each sensor-error column.
    """
    state, data, model, outputs, tape = loop_args(bank, chunk, inputs, store, method_codes, sensor_index)
    taping = bank.taping
    counters = np.array([bank.k_state, bank.k_cov, taping.rows if taping is not None else 0], dtype=np.int64)
    schedule = YooSchedule(stops, ping_of_stop, row_of_stop, chunk.k0)
    run_stops(s0, s1, schedule, counters, state, data, bank.sd_consts, model, outputs, tape)
    bank.rpm_aid.use_rpm, bank.rpm_aid.altitude = state.vkf_use, state.vkf_alt
    bank.k_state, bank.k_cov = int(counters[0]), int(counters[1])
    if taping is not None:
        taping.rows = int(counters[2])
        fused = ping_of_stop[s0:s1] >= 0
        taping.pings_marked(ping_of_stop[s0:s1][fused], chunk.truth.t_s[stops[s0:s1][fused] - chunk.k0])


def record_again(
    bank: Any,
    chunk: Any,
    i: int,
    row: int,
    inputs: Any,
    store: dict[str, np.ndarray],
    method_codes: dict[str, int],
    sensor_index: np.ndarray,
) -> None:
    """Output epoch ``row`` at sample ``i`` of the chunk recorded again (after the sources'
    corrections at it, tauvcore.engine.yoo_bank.YooBank._fuse_sources), with its smoother's mark;
    the arguments as :func:`run_chunk`'s."""
    state, data, model, outputs, tape = loop_args(bank, chunk, inputs, store, method_codes, sensor_index)
    taping = bank.taping
    counters = np.array([bank.k_state, bank.k_cov, taping.rows if taping is not None else 0], dtype=np.int64)
    _record_row(row, i, state, data, model, outputs, tape, bank.sd_consts.geodetic, counters)
    if taping is not None:
        taping.rows = int(counters[2])


def loop_args(
    bank: Any,
    chunk: Any,
    inputs: Any,
    store: dict[str, np.ndarray],
    method_codes: dict[str, int],
    sensor_index: np.ndarray,
) -> tuple[YooState, YooChunk, YooModel, YooOutputs, YooTape]:
    """The bank's states, the chunk's inputs and truth, the filters' constants, the chunk's store
    and the smoother's tape as the compiled loop takes them (the arguments as :func:`run_chunk`'s):
    the bank's and the store's own arrays, written in place; the VKF's switch and altitude copies
    (:func:`run_chunk` puts them back)."""
    phi_raw, dv_raw, dtheta = inputs.phi_raw, inputs.dv_raw, inputs.dtheta
    config, R = bank.config, bank.batch[1]
    cfg = config.vkf
    truth, imu = chunk.truth, chunk.imu
    rpm, echo = chunk.sources.get(RPM_SOURCE), chunk.sources.get(ECHO_SOURCE)
    empty_k, empty_v = np.zeros(0, np.int64), np.zeros((0, R))
    aid = bank.rpm_aid
    dvl = chunk.dvl
    if bank.added.water_var is not None and dvl.y_water_mps is not None:
        water = (np.ascontiguousarray(dvl.y_water_mps, dtype=float),
                 np.ascontiguousarray(dvl.water_available, dtype=bool))  # fmt: skip
    else:
        water = (np.zeros((0, R, 4)), np.zeros((0, R, 4), bool))
    return (
        YooState(
            bank.pos,
            bank.vel,
            bank.C,
            bank.ba,
            bank.bg,
            bank.P,
            bank.dtheta_sum,
            aid.x,
            aid.P,
            aid.use_rpm.copy(),
            aid.altitude.copy(),
            bank.extra,
            aid.learn_axis_n,
            aid.learn_current_n_mps,
        ),
        YooChunk(
            phi_raw,
            dv_raw,
            dtheta,
            np.ascontiguousarray(chunk.dvl.y_beam_mps, dtype=float),
            np.ascontiguousarray(chunk.dvl.available, bool),
            np.asarray(rpm.index, np.int64) if rpm is not None else empty_k,
            np.ascontiguousarray(rpm.values[RPM], dtype=float) if rpm is not None else empty_v,
            np.ascontiguousarray(rpm.truth[TRUE_SCALE_FACTOR], dtype=float) if rpm is not None else empty_v,
            np.ascontiguousarray(rpm.truth[TRUE_BIAS], dtype=float) if rpm is not None else empty_v,
            np.asarray(echo.index, np.int64) if echo is not None else empty_k,
            np.ascontiguousarray(echo.values[ALTITUDE], dtype=float) if echo is not None else empty_v,
            np.ascontiguousarray(truth.pos_n, dtype=float),
            np.ascontiguousarray(truth.vel_n, dtype=float),
            np.ascontiguousarray(truth.C_nb, dtype=float),
            np.ascontiguousarray(imu.accel_bias, dtype=float),
            np.ascontiguousarray(imu.gyro_bias, dtype=float),
            *water,
            np.ascontiguousarray(bank._added_truth(chunk), dtype=float),
        ),
        YooModel(
            np.asarray(bank.origin),
            bank.w_ie,
            bank.q,
            np.array([method_codes[m] for m in bank.methods], np.int64),
            np.ascontiguousarray(bank.A_b, dtype=float),
            np.ascontiguousarray(bank.l_dvl_b, dtype=float),
            bank.beam_var,
            bank.qc,
            np.ascontiguousarray(bank.L4),
            float(bank.gate),
            np.ascontiguousarray(cfg.Q, dtype=float),
            float(cfg.R),
            float(cfg.switch_altitude_m),
            cfg.forward_speed == "norm",
            RPM_LATERAL_SIGMA_MPS**2,
            bank.block_of_state,
            bank.num_blocks,
            1.0 / units.DEG,
            sensor_index,
            np.ascontiguousarray(bank.added.rate, dtype=float),
            np.ascontiguousarray(bank.added.q, dtype=float),
            bank.ref_var,
            bank.added.current.start if bank.added.current is not None else -1,
            bank.added.water_var if bank.added.water_var is not None else -1.0,
            bank.added.estimated,
        ),
        YooOutputs(
            store["series"],
            store["nees_block"],
            store["est_pos_n"],
            store["est_vel_n"],
            store["est_euler"],
            store["sensor_est"],
            store["sensor_sigma"],
            store["sensor_true"],
            store["up_z"],
            store["up_nu"],
            store["up_S"],
            store["up_flags"],
            store["up_nis"],
            store["tr_x"],
            store["tr_sigma"],
            store["tr_truth"],
            store["tr_use"],
            store["tr_alt"],
            *(store[name] for name in STATE_FIELDS),
            *(store[f"wt_{name}"] for name in ("z", "nu", "S", "flags", "nis")),
        ),
        _tape(bank.taping, bank.batch),
    )


def _tape(taping: Any, batch: tuple[int, int]) -> YooTape:
    """The smoother's arrays the compiled loop writes (tauvcore.engine.yoo_smoothing.YooTapeWriter's
    own, the chunk's); None: arrays without rows, nothing written."""
    if taping is None:
        none = np.zeros((0,) + batch + (DIM, DIM))
        return YooTape(
            np.zeros((0, 0, DIM, DIM)), none, np.zeros((0, 0, 0, 0, 0)), np.zeros((0, 0, 0, 0)),
            np.zeros((0, 0, 0, 3)), none, np.zeros((0, 0, 0, 0, 0)), np.zeros((0, 0, 0, 0, 0)),
            np.zeros((0, 0, 0, 0)), np.zeros(0, np.int64),
        )  # fmt: skip
    out, marks = taping.out, taping.marks
    return YooTape(
        taping.phi_acc, out["tape_X"], out["tape_P"], out["tape_dx"], out["tape_vel_b_mps"],
        marks["ev_X"], marks["ev_Pm"], marks["ev_P"], marks["ev_d"], marks["ev_pos"],
    )  # fmt: skip
