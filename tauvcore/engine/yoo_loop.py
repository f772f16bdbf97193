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
from typing import Any, NamedTuple

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
from tauvcore.filter.families.yoo.model_kernels import (
    DIM,
    NA,
    NC,
    dvl_body_velocity_into,
    fuse,
    propagate,
    vkf_step,
)
from tauvcore.filter.kernels.common import jit
from tauvcore.filter.kernels.strapdown_kernels import StrapdownConstants, advance

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


class _PingWork(NamedTuple):
    """The work space of a ping's velocity updates in :func:`run_stops`, allocated once per call
    (:func:`_ping_work`): each run's DVL body velocity from the least squares, and one update's
    columns, prediction and measurement."""

    v_b: np.ndarray  # (R, 3) each run's DVL body velocity [m/s]
    cov_b: np.ndarray  # (R, 3, 3) its covariance [m^2/s^2]
    gain: np.ndarray  # (R, 3, 4) the least squares' gain from the beams
    ok: np.ndarray  # (R,) bool: at least three beams returned
    have_rpm: np.ndarray  # (R,) bool: the VKF read an RPM at the ping
    Hb: np.ndarray  # (3, NC) the consider states' columns in b
    Hc: np.ndarray  # (3, NC) and in n
    Hx: np.ndarray  # (3, E) the columns on the added states
    h: np.ndarray  # (3,) the prediction [m/s]
    w: np.ndarray  # (3,) the vector the attitude column rotates [m/s]
    z: np.ndarray  # (3,) the NED velocity fused [m/s]
    Rm: np.ndarray  # (3, 3) its covariance [m^2/s^2]
    Cc: np.ndarray  # (3, 3) work space of _rotated_into
    nu: np.ndarray  # (3,) the innovation [m/s]
    S_diag: np.ndarray  # (3,) its variances [m^2/s^2]
    vb: np.ndarray  # (3,) the DVL's body velocity through the water the VKF learns from [m/s]


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
    ``ping_of_stop``, :func:`_fuse_ping`; then its water-track beams, with current states,
    :func:`_fuse_water_track`), record an output epoch (its row in ``row_of_stop``); with the
    smoother's ``tape``, each ping's mark and each output epoch's. ``counters`` = (k_state, k_cov,
    the tape's output epochs so far), read and written."""
    stops, ping_of_stop, row_of_stop, k0 = schedule
    pos, vel, C, ba, bg, P, dtheta_sum, extra = (
        state.pos, state.vel, state.C, state.ba, state.bg, state.P, state.dtheta_sum, state.extra,
    )  # fmt: skip
    phi_raw, dv_raw, dtheta = chunk.phi_raw, chunk.dv_raw, chunk.dtheta
    dt, geodetic = sd[0], sd[5]
    noise = (model.q, model.qc, model.extra_rate, model.extra_q)
    M, R = pos.shape[0], pos.shape[1]
    N = P.shape[-1]
    cov_work = (np.empty((DIM, DIM)), np.empty((DIM, DIM)), np.empty((DIM, DIM)), np.empty((N, N)))
    work = _ping_work(R, N - NA)
    water = model.water_var >= 0.0 and chunk.y_water.shape[0] > 0
    phi_acc = tape.phi_acc
    taping = phi_acc.shape[0] > 0
    shape = (M, R) if taping else (0, 0)  # the nominal state before a ping's corrections
    held = YooNominal(
        np.empty(shape + (3,)), np.empty(shape + (3, 3)), np.empty(shape + (3,)), np.empty(shape + (3,)),
        np.empty(shape + (N - NA,)),
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
            propagate(
                P, (pos, vel, C, ba), dv_raw[i], dt, dt_c, geodetic, model.w_ie_flat, noise, cov_work, phi_acc
            )
            dtheta_sum[:, :] = 0.0
            counters[1] = k
        p = ping_of_stop[s]
        if p >= 0:
            if taping:
                mark_before(p, counters[2], tape, P, now, held)
            _fuse_ping(p, i, k, state, chunk, sd, model, outputs, work)
            if water:  # the water-track beams, after the ping's bottom-track
                _fuse_water_track(p, i, state, chunk, sd, model, outputs, work)
            if taping:
                mark_after(p, tape, P, now, held)
        row = row_of_stop[s]
        if row >= 0:
            record_row(row, i, state, chunk, model, outputs, tape, geodetic, counters)


@jit
def _ping_work(R: int, E: int) -> _PingWork:
    """The work space of :func:`run_stops`' velocity updates for ``R`` runs and ``E`` added states."""
    return _PingWork(
        np.empty((R, 3)), np.empty((R, 3, 3)), np.empty((R, 3, 4)), np.empty(R, dtype=np.bool_),
        np.empty(R, dtype=np.bool_), np.empty((3, NC)), np.empty((3, NC)), np.empty((3, E)), np.empty(3),
        np.empty(3), np.empty(3), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), np.empty(3), np.empty(3),
    )  # fmt: skip


@jit
def _fuse_ping(
    p: int,
    i: int,
    k: int,
    state: YooState,
    chunk: YooChunk,
    sd: StrapdownConstants,
    model: YooModel,
    outputs: YooOutputs,
    work: _PingWork,
) -> None:
    """Ping ``p`` (sample ``i`` of the chunk, ``k`` of the mission) fused by every (method, run):
    each run's DVL body velocity from its bottom-track beams (:func:`_body_velocities_into`), the
    VKF's step (:func:`_vkf_at_ping`), then each filter's NED velocity, the DVL's or, for the VKF
    where it switched, its RPM velocity (:func:`_rpm_velocity_into`), fused and recorded in
    ``outputs.up_*``."""
    pos, vel, C, ba, bg, P, extra = state.pos, state.vel, state.C, state.ba, state.bg, state.P, state.extra
    vkf_x, vkf_P, vkf_use, learn_axis, learn_current = (
        state.vkf_x, state.vkf_P, state.vkf_use, state.learn_axis, state.learn_current,
    )  # fmt: skip
    v_b, cov_b, gain, ok, have_rpm, Hb, Hc, Hx, h, w, z, Rm, Cc, nu, S_diag, vb = work
    method_code, current, gate = model.method_code, model.current, model.gate
    y, available = chunk.y_beam[p], chunk.available[p]
    geometry, out = (model.origin, model.A_b, model.l_dvl_b), (v_b, cov_b, gain, ok)
    _body_velocities_into(y, available, model.beam_var, chunk.dtheta[i], pos, C, sd, geometry, out)
    readings = (chunk.rpm_index, chunk.rpm_value, chunk.rpm_sf, chunk.rpm_b, chunk.echo_index, chunk.echo_alt)
    tuning = (model.vkf_Q, model.vkf_R, model.switch_altitude, model.forward_norm, current)
    trace = (outputs.tr_x, outputs.tr_sigma, outputs.tr_truth, outputs.tr_use, outputs.tr_alt)
    up_rows = (outputs.up_z, outputs.up_nu, outputs.up_S, outputs.up_flags, outputs.up_nis)
    for m in range(pos.shape[0]):
        if method_code[m] == VKF:  # each run's VKF, before the method's updates
            _vkf_at_ping(p, k, m, state, readings, tuning, trace, (v_b, ok, have_rpm, vb))
        for r in range(pos.shape[1]):
            Cm = C[m, r]
            # the consider states' columns in b: the scale factor scales the estimated body velocity, a
            # beam bias goes through the least squares of the beams that returned
            for a in range(3):
                Hb[a, 0] = Cm[0, a] * vel[m, r, 0] + Cm[1, a] * vel[m, r, 1] + Cm[2, a] * vel[m, r, 2]
                for c in range(4):
                    Hb[a, 1 + c] = gain[r, a, c]
            use_rpm = vkf_use[r] if method_code[m] == VKF else False  # the VKF's switch
            if use_rpm:
                valid = have_rpm[r]
                _rpm_velocity_into(Cm, vkf_x[r], vkf_P[r], model.lateral_var, model.L4, (Hb, z, Rm))
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


@jit
def _body_velocities_into(
    y: np.ndarray,
    available: np.ndarray,
    beam_var: float,
    dtheta: np.ndarray,
    pos: np.ndarray,
    C: np.ndarray,
    sd: StrapdownConstants,
    geometry: tuple,
    out: tuple,
) -> None:
    """Each run's DVL body velocity from its beams ``y`` (R, 4) [m/s] that returned
    (``available`` (R, 4)), of noise variance ``beam_var`` [m^2/s^2], with the gyro's increments
    ``dtheta`` (R, 3) [rad] at the ping and the first filter's position ``pos`` and attitude ``C``
    (M, R, ...) (tauvcore.filter.yoo_kernels.dvl_body_velocity_into). ``geometry`` ``(origin, A_b,
    l_dvl_b)``; ``out`` ``(v_b, cov_b, gain, ok)`` (:class:`_PingWork`'s), written."""
    origin, A_b, l_dvl_b = geometry
    v_b, cov_b, gain, ok = out
    dt, geodetic = sd[0], sd[5]
    for r in range(pos.shape[1]):
        lat = pos[0, r, 0] if geodetic else origin[0]
        ok[r] = dvl_body_velocity_into(
            y[r], available[r], dtheta[r], dt, C[0, r], lat, A_b, l_dvl_b, beam_var, v_b[r], cov_b[r], gain[r]
        )


@jit
def _vkf_at_ping(
    p: int, k: int, m: int, state: YooState, readings: tuple, tuning: tuple, trace: tuple, dvl: tuple
) -> None:
    """Each run's VKF at ping ``p``, sample ``k`` of the mission, for method ``m``
    (tauvcore.filter.yoo_kernels.vkf_step): predicted with the latest RPM, updated with the DVL's
    forward speed through the water (the current estimate's part along the body x axis taken
    out) where eq. 29 picks the DVL; where it learnt, its axis and current estimate kept; its
    switch (``state.vkf_use``), altitude and trace written.

    ``readings`` ``(rpm_index, rpm_value, rpm_sf, rpm_b, echo_index, echo_alt)``
    (:class:`~tauvcore.engine.yoo_records.YooChunk`'s); ``tuning`` ``(vkf_Q, vkf_R,
    switch_altitude, forward_norm, current)`` (:class:`~tauvcore.engine.yoo_records.YooModel`'s);
    ``trace`` ``(tr_x, tr_sigma, tr_truth, tr_use, tr_alt)``
    (:class:`~tauvcore.engine.yoo_records.YooOutputs`'); ``dvl`` ``(v_b, ok, have_rpm, vb)``
    (:class:`_PingWork`'s: the DVL's body velocities, whether each holds, whether the VKF read an
    RPM (written), work space): the arrays it uses rather than the records that hold them, as a
    compiled call pays for every array it is handed."""
    C, extra, vkf_x, vkf_P, vkf_use, vkf_alt, learn_axis, learn_current = (
        state.C, state.extra, state.vkf_x, state.vkf_P, state.vkf_use, state.vkf_alt, state.learn_axis,
        state.learn_current,
    )  # fmt: skip
    rpm_index, rpm_value, rpm_sf, rpm_b, echo_index, echo_alt = readings
    vkf_Q, vkf_R, switch_altitude, forward_norm, current = tuning
    tr_x, tr_sigma, tr_truth, tr_use, tr_alt = trace
    v_b, ok, have_rpm, vb = dvl
    for r in range(C.shape[1]):
        Cm = C[m, r]
        jr = _latest(rpm_index, k)
        je = _latest(echo_index, k)
        rpm_now = rpm_value[jr, r] if jr >= 0 else np.nan
        altitude = echo_alt[je, r] if je >= 0 else np.nan
        for j in range(3):
            vb[j] = v_b[r, j]
        cx = 0.0  # the current's part along the body x axis (learning through the water)
        if current >= 0:
            cx = Cm[0, 0] * extra[m, r, current - NA] + Cm[1, 0] * extra[m, r, current - NA + 1]
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


@jit
def _rpm_velocity_into(
    Cm: np.ndarray, x: np.ndarray, P_vkf: np.ndarray, lateral_var: float, L4: np.ndarray, out: tuple
) -> None:
    """The VKF's RPM velocity in n, ``z = C [V_rpm, 0, 0]``, its covariance ``Rm``, ``diag(P_VV,
    lateral_var, lateral_var)`` rotated by ``Cm``, and its consider columns ``Hb`` in b (its surge
    was learnt from the DVL's 4 beams: ``L4``'s first row), from the VKF's state ``x`` (3,) and
    covariance ``P_vkf`` (3, 3); ``out`` ``(Hb, z, Rm)``, written."""
    Hb, z, Rm = out
    Hb[:, :] = 0.0
    Hb[0, 0] = x[0]
    for c in range(4):
        Hb[0, 1 + c] = L4[0, c]
    for a in range(3):
        z[a] = Cm[a, 0] * x[0]
        for b in range(3):
            Rm[a, b] = (
                Cm[a, 0] * P_vkf[0, 0] * Cm[b, 0]
                + Cm[a, 1] * lateral_var * Cm[b, 1]
                + Cm[a, 2] * lateral_var * Cm[b, 2]
            )


@jit
def _fuse_water_track(
    p: int,
    i: int,
    state: YooState,
    chunk: YooChunk,
    sd: StrapdownConstants,
    model: YooModel,
    outputs: YooOutputs,
    work: _PingWork,
) -> None:
    """Ping ``p``'s water-track beams (sample ``i`` of the chunk) fused by every (method, run): the
    DVL's velocity through the water, ``v - c`` (the current's states at ``model.current``),
    recorded in ``outputs.wt_*``."""
    pos, vel, C, ba, bg, P, extra = state.pos, state.vel, state.C, state.ba, state.bg, state.P, state.extra
    v_b, cov_b, gain, ok, _, Hb, Hc, Hx, h, w, z, Rm, Cc, nu, S_diag, _ = work
    current, learn_axis, learn_current = model.current, state.learn_axis, state.learn_current
    y, available = chunk.y_water[p], chunk.water_available[p]
    geometry, out = (model.origin, model.A_b, model.l_dvl_b), (v_b, cov_b, gain, ok)
    _body_velocities_into(y, available, model.water_var, chunk.dtheta[i], pos, C, sd, geometry, out)
    wt_rows = (outputs.wt_z, outputs.wt_nu, outputs.wt_S, outputs.wt_flags, outputs.wt_nis)
    for m in range(pos.shape[0]):
        for r in range(pos.shape[1]):
            Cm = C[m, r]
            _aid(_WATER, Cm, vel[m, r], extra[m, r], current, learn_axis[r], learn_current[r], h, w, Hx)
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
                ok[r], model.gate, (S_diag, nu),
            )  # fmt: skip
            _write_update(p, m, r, (z, nu, S_diag), (ok[r], fused, passed, nis), wt_rows)


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
    return (
        _state_record(bank),
        _chunk_record(bank, chunk, inputs),
        _model_record(bank, method_codes, sensor_index),
        _outputs_record(store),
        _tape(bank),
    )


def _state_record(bank: Any) -> YooState:
    """The bank's states and its VKF's (tauvcore.engine.rpm_aid.RpmAid): their own arrays, written
    in place, but for copies of the VKF's switch and altitude (:func:`run_chunk` puts them back)."""
    aid = bank.rpm_aid
    return YooState(
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
    )


def _chunk_record(bank: Any, chunk: Any, inputs: Any) -> YooChunk:
    """The chunk's IMU increments (``inputs``), DVL beams, RPM and echo sounder epochs (none:
    arrays without rows), water-track beams where the bank fuses them (else none) and truth,
    C-contiguous."""
    R = bank.batch[1]
    truth, imu, dvl = chunk.truth, chunk.imu, chunk.dvl
    rpm, echo = chunk.sources.get(RPM_SOURCE), chunk.sources.get(ECHO_SOURCE)
    empty_k, empty_v = np.zeros(0, np.int64), np.zeros((0, R))
    if bank.added.water_var is not None and dvl.y_water_mps is not None:
        water = (np.ascontiguousarray(dvl.y_water_mps, dtype=float),
                 np.ascontiguousarray(dvl.water_available, dtype=bool))  # fmt: skip
    else:
        water = (np.zeros((0, R, 4)), np.zeros((0, R, 4), bool))
    return YooChunk(
        inputs.phi_raw,
        inputs.dv_raw,
        inputs.dtheta,
        np.ascontiguousarray(dvl.y_beam_mps, dtype=float),
        np.ascontiguousarray(dvl.available, bool),
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
    )


def _model_record(bank: Any, method_codes: dict[str, int], sensor_index: np.ndarray) -> YooModel:
    """The filters' constants of the bank: its methods' codes (``method_codes``), the VKF's tuning
    (``config.vkf``), the added states' and the sensor-error columns' states (``sensor_index``)."""
    cfg, added = bank.config.vkf, bank.added
    return YooModel(
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
        np.ascontiguousarray(added.rate, dtype=float),
        np.ascontiguousarray(added.q, dtype=float),
        bank.ref_var,
        added.current.start if added.current is not None else -1,
        added.water_var if added.water_var is not None else -1.0,
        added.estimated,
    )


def _outputs_record(store: dict[str, np.ndarray]) -> YooOutputs:
    """The chunk's store (tauvcore.engine.yoo_bank.YooBank._store), its own arrays, in the order of
    :class:`YooOutputs`."""
    return YooOutputs(
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
    )


def _tape(bank: Any) -> YooTape:
    """The smoother's arrays the compiled loop writes: the bank's transition since the last mark,
    its tape writer's rows and marks of the chunk (tauvcore.engine.tape.TapeWriter); without
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
