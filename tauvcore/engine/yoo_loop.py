"""The compiled chunk loop of Yoo 2014's methods (numba): tauvcore.engine.yoo_bank's chunks, one
call per span of stops, with the smoother's marks when it keeps a tape (:class:`YooTape`).

A bank in numpy (tests/unit/tauvcore/engine/yoo_reference.py, the reference this loop is held equal to, to 1e-9)
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
from typing import Any

import numpy as np

from tauvcore import units
from tauvcore.aiding.echo_altitude import ALTITUDE
from tauvcore.aiding.propeller_rpm import RPM, TRUE_BIAS, TRUE_SCALE_FACTOR
from tauvcore.engine.results import STATE_FIELDS
from tauvcore.engine.rpm_aid import ECHO_SOURCE, RPM_LATERAL_SIGMA_MPS, RPM_SOURCE
from tauvcore.engine.yoo_records import (
    YooChunk,
    YooModel,
    YooNominal,
    YooOutputs,
    YooSchedule,
    YooState,
    YooTape,
    mark_after,
    mark_before,
    record_row,
)
from tauvcore.filter.kernels.common import jit
from tauvcore.filter.kernels.strapdown_kernels import StrapdownConstants, advance
from tauvcore.filter.yoo_kernels import (
    DIM,
    NA,
    NC,
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
    columns ``Hx`` (3, E) on the added states (tests/unit/tauvcore/engine/yoo_reference.py's velocity_H): over ground (``kind`` 0)
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
    dt, geodetic = sd[0], sd[5]
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
    up_rows = (  # the DVL's (or RPM's) velocity updates' records
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
    wt_rows = (  # the water-track's
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
    shape = (M, R) if taping else (0, 0)  # the nominal state before a ping's corrections
    held = YooNominal(
        np.empty(shape + (3,)), np.empty(shape + (3, 3)), np.empty(shape + (3,)), np.empty(shape + (3,)),
        np.empty(shape + (E,)),
    )  # fmt: skip
    now = YooNominal(vel, C, ba, bg, extra)
    for s in range(s0, s1):
        k = stops[s]
        if k < k0:
            continue
        i = k - k0
        if k > counters[0]:
            advance(pos, vel, C, ba, bg, (phi_raw, dv_raw, dtheta), dtheta_sum, counters[0] - k0, i, sd)
            counters[0] = k
        if k > counters[1]:
            dt_c = (k - counters[1]) * dt
            noise, work = (q, qc, extra_rate, extra_q), (F, Phi, tmp, out)
            propagate(P, (pos, vel, C, ba), dv_raw[i], dt, dt_c, geodetic, w_ie_flat, noise, work, phi_acc)
            dtheta_sum[:, :] = 0.0
            counters[1] = k
        p = ping_of_stop[s]
        if p >= 0:
            if taping:
                mark_before(p, counters[2], tape, P, now, held)
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
                        P[m, r], (vel[m, r], C[m, r], ba[m, r], bg[m, r], extra[m, r]), (z, h, w, Rm, Hc, Hx),
                        valid, gate, (S_diag, nu),
                    )  # fmt: skip
                    _write_update(p, m, r, (z, nu, S_diag), (valid, fused, passed, nis), up_rows)
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
                            P[m, r], (vel[m, r], C[m, r], ba[m, r], bg[m, r], extra[m, r]), (z, h, w, Rm, Hc, Hx),
                            ok[r], gate, (S_diag, nu),
                        )  # fmt: skip
                        _write_update(p, m, r, (z, nu, S_diag), (ok[r], fused, passed, nis), wt_rows)
            if taping:
                mark_after(p, tape, P, now, held)
        row = row_of_stop[s]
        if row >= 0:
            record_row(row, i, state, chunk, model, outputs, tape, geodetic, counters)


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
def _write_update(p: int, m: int, r: int, fused_rows: tuple, outcome: tuple, rows: tuple) -> None:
    """One fused velocity's record at ping ``p`` of method ``m``, run ``r``: its ``(z, nu,
    S_diag)`` (3,) each and ``(valid, fused, passed, nis)`` into the records ``rows`` (``(z, nu,
    S, flags, nis)``, :class:`~tauvcore.engine.yoo_records.YooOutputs`' ``up_*`` or ``wt_*``);
    NaN where not valid."""
    z, nu, S_diag = fused_rows
    valid, fused, passed, nis = outcome
    out_z, out_nu, out_S, out_flags, out_nis = rows
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
    schedule: YooSchedule,
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
    schedule : YooSchedule
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
    counters = np.array([bank.k_state, bank.k_cov, bank.rows], dtype=np.int64)
    run_stops(s0, s1, schedule, counters, state, data, bank.sd_consts, model, outputs, tape)
    bank.rpm_aid.use_rpm, bank.rpm_aid.altitude = state.vkf_use, state.vkf_alt
    bank.k_state, bank.k_cov, bank.rows = int(counters[0]), int(counters[1]), int(counters[2])
    if taping is not None:
        pings, stops = schedule.ping_of_stop[s0:s1], schedule.stops[s0:s1]
        taping.pings_marked(pings[pings >= 0], chunk.truth.t_s[stops[pings >= 0] - chunk.k0])


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
    corrections at it, tauvcore.engine.yoo_bank.YooBank._fuse_sources), with its smoother's mark.

    Parameters
    ----------
    bank : YooBank
        The bank: its states and constants.
    chunk : SimChunk
        The chunk: its truth.
    i : int
        The sample within the chunk.
    row : int
        The output epoch's row in the chunk's store.
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
    counters = np.array([bank.k_state, bank.k_cov, bank.rows], dtype=np.int64)
    record_row(row, i, state, data, model, outputs, tape, bank.sd_consts.geodetic, counters)
    bank.rows = int(counters[2])


def loop_args(
    bank: Any,
    chunk: Any,
    inputs: Any,
    store: dict[str, np.ndarray],
    method_codes: dict[str, int],
    sensor_index: np.ndarray,
) -> tuple[YooState, YooChunk, YooModel, YooOutputs, YooTape]:
    """The bank's states, the chunk's inputs and truth, the filters' constants, the chunk's store
    and the smoother's tape as the compiled loop takes them: the bank's and the store's own arrays,
    written in place; the VKF's switch and altitude copies (:func:`run_chunk` puts them back).

    Parameters
    ----------
    bank : YooBank
        The bank: its states and constants.
    chunk : SimChunk
        The chunk: its IMU, DVL, RPM and echo sounder data and its truth.
    inputs : ChunkInputs
        The chunk's IMU increments.
    store : dict[str, numpy.ndarray]
        The chunk's store.
    method_codes : dict[str, int]
        Each method's code (:data:`INS_DVL`, :data:`VKF`).
    sensor_index : numpy.ndarray
        The state of each sensor-error column.

    Returns
    -------
    tuple
        :class:`YooState`, :class:`YooChunk`, :class:`YooModel`, :class:`YooOutputs`,
        :class:`YooTape`.
    """
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
        _tape(bank),
    )


def _tape(bank: Any) -> YooTape:
    """The smoother's arrays the compiled loop writes: the bank's transition since the last mark,
    its tape writer's rows and marks of the chunk (tauvcore.engine.smoothing.TapeWriter); without
    a writer, arrays without rows, nothing written."""
    taping = bank.taping
    if taping is None:
        none = np.zeros((0,) + bank.batch + (DIM, DIM))
        return YooTape(
            np.zeros((0, 0, DIM, DIM)), none, np.zeros((0, 0, 0, 0, 0)), np.zeros((0, 0, 0, 0)),
            np.zeros((0, 0, 0, 3)), none, np.zeros((0, 0, 0, 0, 0)), np.zeros((0, 0, 0, 0, 0)),
            np.zeros((0, 0, 0, 0)), np.zeros(0, np.int64),
        )  # fmt: skip
    out, marks = taping.out, taping.marks
    return YooTape(
        bank.phi_acc, out["tape_X"], out["tape_P"], out["tape_dx"], out["tape_vel_b_mps"],
        marks["ev_X"], marks["ev_Pm"], marks["ev_P"], marks["ev_d"], marks["ev_pos"],
    )  # fmt: skip
