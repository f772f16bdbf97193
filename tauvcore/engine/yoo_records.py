"""The named records of Yoo 2014's compiled loop (tauvcore.engine.yoo_loop: its arguments as the
tuples numba takes) and what it writes at an output epoch: the record of every (method, run)
(:func:`record`) and, with the smoother, its marks on the tape (:func:`record_row`,
:func:`mark_before`, :func:`mark_after`; the bank's tauvcore.engine.tape.TapeWriter holds
the arrays)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from tauvcore.filter.families.yoo.model_kernels import ATT, BA, BG, DIM, NA, VEL
from tauvcore.filter.kernels.common import jit, ned_offset
from tauvcore.filter.kernels.nees import add_reference_into, nees_blocks_into, nees_plan, quadratic_into
from tauvcore.filter.kernels.rotation_kernels import log_so3_into


@jit
def record(
    row: int,
    k: int,
    state: YooState,
    chunk: YooChunk,
    model: YooModel,
    outputs: YooOutputs,
    tape_dx: np.ndarray,
    geodetic: bool,
) -> None:
    """Output epoch ``row`` at sample ``k`` of the chunk, of every (method, run): errors ``true -
    estimate``, 1-sigma, NEES of the estimated states (the 12 and the added, ``model.est`` their
    indices in P) and of each block (no position state: NaN), against their covariance and the
    covariance of the reference's own errors, ``model.ref_var`` (9,) at the reference's attitude
    and NED velocity (tauvcore.filter.kernels.nees.add_reference_into), the estimates; when
    ``outputs.sensor_est`` (T, M, R, S) has rows, the sensor errors' estimate, ``sqrt(P_ii)`` and
    truth too (column j the state ``model.sensor_index[j]``); the added states' estimate
    (``state.extra`` (M, R, E)), ``sqrt(P_ii)`` and truth into ``outputs.state_*``; when the
    smoother's ``tape_dx`` (T, M, R, 12 + E) has rows, the errors too. The Euler angles, the sensor
    errors and the added states come from :func:`_state_estimates_into`."""
    pos_t, vel_t, C_t, ba_t, bg_t = chunk.pos_t[k], chunk.vel_t[k], chunk.C_t[k], chunk.ba_t[k], chunk.bg_t[k]
    extra_t = chunk.extra_t[k]
    pos, vel, C, ba, bg, P, extra = state.pos, state.vel, state.C, state.ba, state.bg, state.P, state.extra
    origin, num_blocks, deg, est, ref_var = (
        model.origin,
        model.num_blocks,
        model.deg,
        model.est,
        model.ref_var,
    )
    series, nees_block, est_pos, est_vel = (
        outputs.series,
        outputs.nees_block,
        outputs.est_pos,
        outputs.est_vel,
    )
    n = est.shape[0]
    dx, yv, Ce, rho, idx = np.empty(n), np.empty(n), np.empty((3, 3)), np.empty(3), np.arange(n)
    L, Pe, A = np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    members, sizes, lead, order = nees_plan(model.block_of_state, num_blocks)
    blocks = np.empty(num_blocks)
    for m in range(pos.shape[0]):
        for r in range(pos.shape[1]):
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
    estimates = (outputs.est_euler, outputs.sensor_est, outputs.sensor_sigma, outputs.sensor_true,
                 outputs.state_est, outputs.state_sigma, outputs.state_true)  # fmt: skip
    _state_estimates_into(row, (C, ba, bg, P, extra), (ba_t, bg_t, extra_t), model.sensor_index, estimates)


@jit
def _state_estimates_into(
    row: int, nominal: tuple, truth: tuple, sensor_index: np.ndarray, estimates: tuple
) -> None:
    """Output epoch ``row``'s estimated states of every (method, run) (:func:`record`): the Euler
    angles of the attitude [rad]; when ``sensor_est`` (T, M, R, S) has rows, the sensor errors'
    estimate, ``sqrt(P_ii)`` and truth (column j the state ``sensor_index[j]``); the added states'
    estimate, ``sqrt(P_ii)`` and truth. ``nominal`` ``(C, ba, bg, P, extra)`` (M, R, ...), their
    ``truth`` ``(ba_t, bg_t, extra_t)`` at the epoch; ``estimates`` ``(est_euler, sensor_est,
    sensor_sigma, sensor_true, state_est, state_sigma, state_true)`` (:class:`YooOutputs`'),
    written: the arrays it uses rather than the records that hold them, as a compiled call pays
    for every array it is handed."""
    ba_t, bg_t, extra_t = truth
    C, ba, bg, P, extra = nominal
    est_euler, sensor_est, sensor_sigma, sensor_true, state_est, state_sigma, state_true = estimates
    with_sensors = sensor_est.shape[0] > 0
    x_est = np.zeros(DIM)  # the bias states' estimate and truth, by state
    x_true = np.zeros(DIM)
    for m in range(C.shape[0]):
        for r in range(C.shape[1]):
            Cm, Pm = C[m, r], P[m, r]
            est_euler[row, m, r, 0] = math.atan2(Cm[2, 1], Cm[2, 2])
            est_euler[row, m, r, 1] = -math.asin(min(1.0, max(-1.0, Cm[2, 0])))
            est_euler[row, m, r, 2] = math.atan2(Cm[1, 0], Cm[0, 0])
            if with_sensors:
                for i in range(3):
                    x_est[BA + i], x_true[BA + i] = ba[m, r, i], ba_t[r, i]
                    x_est[BG + i], x_true[BG + i] = bg[m, r, i], bg_t[r, i]
                for j in range(sensor_index.size):
                    s = sensor_index[j]
                    sensor_est[row, m, r, j] = x_est[s]
                    sensor_sigma[row, m, r, j] = math.sqrt(Pm[s, s])
                    sensor_true[row, m, r, j] = x_true[s]
            for e in range(extra.shape[2]):
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


class YooNominal(NamedTuple):
    """The nominal states a ping's mark compares before and after its corrections, (M, R, ...)."""

    vel: np.ndarray
    C: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    extra: np.ndarray


class YooTape(NamedTuple):
    """The smoother's marks the loop writes (the bank's ``phi_acc`` and its
    tauvcore.engine.tape.TapeWriter's arrays); ``phi_acc`` without rows: no smoother, nothing
    written."""

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
def record_row(
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
    record(row, i, state, chunk, model, outputs, tape.tape_dx, geodetic)
    P, C_t, vel_t = state.P, chunk.C_t, chunk.vel_t
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
def mark_before(p: int, rows: int, tape: YooTape, P: np.ndarray, now: YooNominal, held: YooNominal) -> None:
    """Ping ``p``'s mark before its corrections (as tauvcore.engine.tape.TapeWriter.before): the
    transition since the last mark (then restarted), the covariance and, kept in ``held``, the
    nominal state ``now``; ``rows`` the chunk's output epochs recorded so far."""
    tape.ev_X[p] = tape.phi_acc
    tape.phi_acc[...] = 0.0
    tape.ev_Pm[p] = P
    tape.ev_pos[p] = rows
    held.vel[...] = now.vel
    held.C[...] = now.C
    held.ba[...] = now.ba
    held.bg[...] = now.bg
    held.extra[...] = now.extra


@jit
def mark_after(p: int, tape: YooTape, P: np.ndarray, now: YooNominal, held: YooNominal) -> None:
    """Ping ``p``'s mark after its corrections (as tauvcore.engine.tape.TapeWriter.after): the covariance
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
                        now.C[m, r, a, 0] * held.C[m, r, b, 0]
                        + now.C[m, r, a, 1] * held.C[m, r, b, 1]
                        + now.C[m, r, a, 2] * held.C[m, r, b, 2]
                    )
            log_so3_into(Ce, rho)
            for a in range(3):
                d[VEL + a] = now.vel[m, r, a] - held.vel[m, r, a]
                d[ATT + a] = rho[a]
                d[BA + a] = now.ba[m, r, a] - held.ba[m, r, a]
                d[BG + a] = now.bg[m, r, a] - held.bg[m, r, a]
            for e in range(N - NA):
                d[NA + e] = now.extra[m, r, e] - held.extra[m, r, e]
