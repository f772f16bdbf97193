"""The filter bank's compiled loop: what tauvcore.engine.filter_bank runs between aiding epochs in
one call (:func:`run_stops`: the nominal states advanced, the covariances propagated and checked,
the output epochs recorded), the record of an output epoch (:func:`record_bank`) and the bank's
health checks (:func:`positive_definite_bank`, :func:`flag_implausible_bank`). It calls the
filter's kernels (tauvcore.filter.kernels) in the order the step-by-step loop would."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from tauvcore.filter.kernels.common import ATT, BA, BDVL, BG, POS, SF, VEL, N, jit, ned_offset
from tauvcore.filter.kernels.correction import nav_difference_into
from tauvcore.filter.kernels.error_model_kernels import propagate_bank
from tauvcore.filter.kernels.nees import add_reference_into, cholesky_into, nees_blocks_into, nees_plan
from tauvcore.filter.kernels.strapdown_kernels import StrapdownConstants, advance

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


class BankState(NamedTuple):
    """The bank's states, (methods, runs, ...) unless said, written in place."""

    pos: np.ndarray
    vel: np.ndarray
    C: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    bdvl: np.ndarray
    sf: np.ndarray
    P: np.ndarray
    dtheta_sum: np.ndarray  # (R, 3) gyro increments since the last covariance step
    ping_bias: np.ndarray  # (R, 4) the true DVL beam biases of the latest ping (for the records)
    ping_sf: np.ndarray  # (R,) and its true scale factor
    nonfinite_at: np.ndarray  # (M, R) first output epoch [s] with a state or P not finite (NaN: none)
    phi_acc: np.ndarray  # (M, R, 9, 15) the smoother's transition since its last mark, Phi - I on its
    #                      non-zero block (tauvcore.filter.kernels.smoother); no rows: smoother off
    extra: np.ndarray  # (M, R, E) the estimates of the sources' own states (tauvcore.filter.layout.Layout)


class ChunkTruth(NamedTuple):
    """A chunk's IMU increments (tauvcore.engine.chunk_driver.ChunkInputs), its truth at the IMU
    samples and the DVL errors of its pings (for the records)."""

    phi_raw: np.ndarray
    dv_raw: np.ndarray
    dtheta: np.ndarray
    t_s: np.ndarray
    pos_t: np.ndarray
    vel_t: np.ndarray
    C_t: np.ndarray
    ba_t: np.ndarray
    bg_t: np.ndarray
    ping_rows: np.ndarray
    ping_bias_all: np.ndarray
    ping_sf_all: np.ndarray
    extra_t: np.ndarray  # (K, E) the true values of the sources' own states at the chunk's samples


class Model(NamedTuple):
    """The bank's constants of the covariance step and the records."""

    origin: np.ndarray  # (3,) the NED records' origin: latitude, longitude [rad], height [m]
    w_ie: np.ndarray  # (3,) the earth rate in n [rad/s]
    q: np.ndarray  # the process noise PSDs (tauvcore.ins.error_model.noise_psd)
    block_of_state: np.ndarray  # (N,) each state's NEES block, -1 for none
    num_blocks: int
    deg: float  # degrees per radian of the attitude series
    sensor_index: np.ndarray  # (S,) int64: the state of each sensor-error column
    # (tauvcore.engine.results.SENSOR_STATES, by tauvcore.engine.filter_bank.SENSOR_INDEX)
    extra_rate: np.ndarray  # (E,) each source state's -1/tau [1/s] (0: a random walk)
    extra_q: np.ndarray  # (E,) its driving noise's PSD [unit^2/s]
    ref_var: np.ndarray  # (9,) the reference's own variances (tauvcore.filter.reference.ReferenceConfig
    # .variances), whose covariance the NEES adds to P (tauvcore.filter.kernels.nees.add_reference_into);
    # all zero: the reference is exact


class Outputs(NamedTuple):
    """A chunk's store (tauvcore.engine.chunk_driver), the arrays :func:`record_bank` fills."""

    series: np.ndarray
    nees_block: np.ndarray
    est_pos: np.ndarray
    out_t: np.ndarray
    est_vel: np.ndarray
    est_euler: np.ndarray
    sensor_est: np.ndarray  # (T, M, R, S) the estimated sensor errors; no rows: not recorded
    sensor_sigma: np.ndarray  # (T, M, R, S) their 1-sigma (sqrt of P's diagonal)
    sensor_true: np.ndarray  # (T, M, R, S) their true values
    tape_X: np.ndarray  # (T, M, R, 9, 15) the smoother's tape: the transition since its last mark,
    tape_P: np.ndarray  # (T, M, R, d, d) P, and
    tape_dx: np.ndarray  # (T, M, R, d) the error against truth; no rows: the smoother is off
    state_est: np.ndarray  # (T, M, R, E) the estimates of the sources' states (E = 0: none)
    state_sigma: np.ndarray  # (T, M, R, E) their 1-sigma
    state_true: np.ndarray  # (T, M, R, E) their true values
    pos_cov_ne: np.ndarray  # (T, M, R, 3) the horizontal position error's covariance P_NN, P_NE,
    #                         P_EE [m^2] (tauvcore.engine.results.MethodResult.pos_cov_ne_m2)


@jit
def error_series_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    dx: np.ndarray,
    P: np.ndarray,
    Q: np.ndarray,
    deg: float,
    members: np.ndarray,
    sizes: np.ndarray,
    lead: int,
    order: np.ndarray,
    L: np.ndarray,
    y: np.ndarray,
    series: np.ndarray,
    nees_block: np.ndarray,
) -> None:
    """One filter's :data:`SERIES_NAMES` (11,) and block NEES (B,) at an epoch from its error
    against truth ``dx`` (d,) and covariance ``P`` (d, d): the error norms, 1-sigma, NEES,
    tilt and heading (attitude in ``1 / deg``). The 1-sigma are the filter's own (P); the NEES
    is taken against ``Q`` (d, d): P, or against an uncertain reference P and the reference's
    covariance (tauvcore.filter.kernels.nees.add_reference_into). The NEES plan (members, sizes, lead, order:
    tauvcore.filter.kernels.nees.nees_plan) and L (d, d), y (d,) scratch."""
    ev = ea = ep = sv = sa = sp = 0.0
    for i in range(3):
        ev += dx[VEL + i] ** 2
        ea += dx[ATT + i] ** 2
        ep += dx[POS + i] ** 2
        sv += P[VEL + i, VEL + i]
        sa += P[ATT + i, ATT + i]
        sp += P[POS + i, POS + i]
    series[0] = math.sqrt(ev)
    series[1] = math.sqrt(ea) / deg
    series[2] = math.sqrt(ep)
    series[3] = math.sqrt(sv)
    series[4] = math.sqrt(sa) / deg
    series[5] = math.sqrt(sp)
    series[6] = nees_blocks_into(Q, dx, members, sizes, lead, order, L, y, nees_block)
    series[7] = math.sqrt(dx[ATT] ** 2 + dx[ATT + 1] ** 2) / deg
    series[8] = abs(dx[ATT + 2]) / deg
    series[9] = math.sqrt(P[ATT, ATT] + P[ATT + 1, ATT + 1]) / deg
    series[10] = math.sqrt(P[ATT + 2, ATT + 2]) / deg


class EpochTruth(NamedTuple):
    """The truth at one output epoch that the records compare the bank's estimates with."""

    pos_t: np.ndarray  # (3,) position (tauvcore.filter.eskf.difference: NED metres or latitude,
    #                    longitude [rad], depth [m])
    vel_t: np.ndarray  # (3,) NED velocity [m/s]
    C_t: np.ndarray  # (3, 3) C_nb
    ba_t: np.ndarray  # (R, 3) each run's accelerometer bias [m/s^2]
    bg_t: np.ndarray  # (R, 3) each run's gyro bias [rad/s]
    bdvl_t: np.ndarray  # (R, 4) each run's DVL beam biases of the latest ping [m/s]
    sf_t: np.ndarray  # (R,) and its scale factor
    extra_t: np.ndarray  # (E,) the sources' own states


@jit
def _error_into(
    truth: EpochTruth,
    bank: BankState,
    m: int,
    r: int,
    geodetic: bool,
    dx: np.ndarray,
    Ce: np.ndarray,
    rho: np.ndarray,
) -> None:
    """The error ``true (-) estimate`` (tauvcore.filter.eskf.difference) of filter (m, r) into
    ``dx`` (d,): the navigation part (:func:`nav_difference_into`, Ce (3, 3), rho (3,) scratch),
    then the sensor errors and the sources' own states, each ``true - estimate``."""
    pos_t, vel_t, C_t, ba_t, bg_t, bdvl_t, sf_t, extra_t = truth
    pos, vel, C, ba, bg, bdvl, sf, _, _, _, _, _, _, extra = bank
    nav_difference_into(pos_t, vel_t, C_t, pos[m, r], vel[m, r], C[m, r], Ce, rho, dx, geodetic)
    for i in range(3):
        dx[BA + i] = ba_t[r, i] - ba[m, r, i]
        dx[BG + i] = bg_t[r, i] - bg[m, r, i]
    for i in range(4):
        dx[BDVL + i] = bdvl_t[r, i] - bdvl[m, r, i]
    dx[SF] = sf_t[r] - sf[m, r]
    for e in range(dx.shape[0] - N):
        dx[N + e] = extra_t[e] - extra[m, r, e]


@jit
def _record_navigation(
    slot: int, m: int, r: int, bank: BankState, origin: np.ndarray, geodetic: bool, outputs: Outputs
) -> None:
    """Filter (m, r)'s estimated position, NED velocity and roll, pitch, yaw [rad] into row
    ``slot`` of est_pos, est_vel, est_euler; on WGS-84 (``geodetic``) the position in NED metres
    from ``origin`` (tauvcore.geo.earth.ned_offset_components)."""
    pos, vel, C = bank[:3]
    _, _, est_pos, _, est_vel, est_euler = outputs[:6]
    if geodetic:
        n0, n1, n2 = ned_offset(pos[m, r, 0], pos[m, r, 1], -pos[m, r, 2], origin[0], origin[1], 0.0)
        est_pos[slot, m, r, 0], est_pos[slot, m, r, 1], est_pos[slot, m, r, 2] = n0, n1, n2
    for i in range(3):
        if not geodetic:
            est_pos[slot, m, r, i] = pos[m, r, i]
        est_vel[slot, m, r, i] = vel[m, r, i]
    Cm = C[m, r]
    est_euler[slot, m, r, 0] = math.atan2(Cm[2, 1], Cm[2, 2])
    est_euler[slot, m, r, 1] = -math.asin(min(1.0, max(-1.0, Cm[2, 0])))
    est_euler[slot, m, r, 2] = math.atan2(Cm[1, 0], Cm[0, 0])


@jit
def _record_states(slot: int, m: int, r: int, truth: EpochTruth, bank: BankState, outputs: Outputs) -> None:
    """Filter (m, r)'s sources' own states into row ``slot`` of state_est, state_sigma,
    state_true: the estimate, ``sqrt(P_ii)`` and the truth."""
    _, _, _, _, _, _, _, extra_t = truth
    _, _, _, _, _, _, _, P, _, _, _, _, _, extra = bank
    state_est, state_sigma, state_true = outputs[12:15]
    for e in range(P.shape[-1] - N):
        state_est[slot, m, r, e] = extra[m, r, e]
        state_sigma[slot, m, r, e] = math.sqrt(P[m, r, N + e, N + e])
        state_true[slot, m, r, e] = extra_t[e]


@jit
def _record_position_covariance(slot: int, m: int, r: int, P: np.ndarray, pos_cov_ne: np.ndarray) -> None:
    """Filter (m, r)'s horizontal position covariance P_NN, P_NE, P_EE [m^2] into row ``slot`` of
    ``pos_cov_ne`` (T, M, R, 3): the position error state is in NED metres on both earths
    (tauvcore.filter.kernels.correction.nav_difference_into), so no conversion."""
    pos_cov_ne[slot, m, r, 0] = P[m, r, POS, POS]
    pos_cov_ne[slot, m, r, 1] = P[m, r, POS, POS + 1]
    pos_cov_ne[slot, m, r, 2] = P[m, r, POS + 1, POS + 1]


@jit
def _record_sensor_errors(
    slot: int,
    m: int,
    r: int,
    truth: EpochTruth,
    bank: BankState,
    sensor_index: np.ndarray,
    outputs: Outputs,
    x_est: np.ndarray,
    x_true: np.ndarray,
) -> None:
    """Filter (m, r)'s sensor errors into row ``slot`` of sensor_est, sensor_sigma, sensor_true
    (column j the state ``sensor_index[j]``): the estimate, ``sqrt(P_ii)`` and the truth dx is
    formed of. x_est, x_true (d,) scratch: the states' estimate and truth, by state."""
    _, _, _, ba_t, bg_t, bdvl_t, sf_t, extra_t = truth
    _, _, _, ba, bg, bdvl, sf, P, _, _, _, _, _, extra = bank
    sensor_est, sensor_sigma, sensor_true = outputs[6:9]
    for i in range(3):
        x_est[BA + i], x_true[BA + i] = ba[m, r, i], ba_t[r, i]
        x_est[BG + i], x_true[BG + i] = bg[m, r, i], bg_t[r, i]
    for i in range(4):
        x_est[BDVL + i], x_true[BDVL + i] = bdvl[m, r, i], bdvl_t[r, i]
    x_est[SF], x_true[SF] = sf[m, r], sf_t[r]
    for e in range(P.shape[-1] - N):
        x_est[N + e], x_true[N + e] = extra[m, r, e], extra_t[e]
    for j in range(sensor_index.size):
        k = sensor_index[j]
        sensor_est[slot, m, r, j] = x_est[k]
        sensor_sigma[slot, m, r, j] = math.sqrt(P[m, r, k, k])
        sensor_true[slot, m, r, j] = x_true[k]


@jit
def _finite(P: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> bool:
    """Whether a filter's variances (P (d, d)'s diagonal), position and velocity (pos, vel (3,))
    add up to a finite number (a NaN or an infinity in any of them does not)."""
    total = 0.0
    for i in range(P.shape[0]):
        total += P[i, i]
    for i in range(3):
        total += pos[i] + vel[i]
    return math.isfinite(total)


@jit
def record_bank(
    slot: int,
    i_chunk: int,
    chunk: ChunkTruth,
    bank: BankState,
    constants: Model,
    geodetic: bool,
    outputs: Outputs,
) -> None:
    """Output epoch ``slot`` of every (method, run), at sample ``i_chunk`` of the chunk: the error
    ``true (-) estimate`` (tauvcore.filter.eskf.difference) and its norms, the filter's 1-sigma,
    the NEES of the full state and of each block (against P and the reference's own variance,
    ``constants.ref_var``), the horizontal position covariance (``pos_cov_ne`` (T, M, R, 3): P_NN,
    P_NE, P_EE [m^2]), the estimated position, the epoch's time (``out_t``); and the health check
    without truth (a non-finite navigation state or P's variances sets ``nonfinite_at`` once).

    Truth: the chunk's at sample ``i_chunk`` (pos_t, vel_t (3,), C_t (3, 3) shared; the true IMU
    errors per run ba_t, bg_t (R, 3)) and the bank's true DVL errors of the latest ping
    (ping_bias (R, 4), ping_sf (R,)). series (11, T, M, R) in :data:`SERIES_NAMES` order. On
    WGS-84 (``geodetic``) the estimated position is recorded in NED metres from ``origin``
    (latitude, longitude [rad] of the sea-surface point; tauvcore.geo.earth.ned_offset_components).
    The estimated NED velocity and roll, pitch, yaw [rad] go to est_vel, est_euler (T, M, R, 3).

    When the store has rows for them, the sensor errors too (sensor_est, sensor_sigma, sensor_true
    (T, M, R, S), column j the state ``sensor_index[j]``): the estimate, ``sqrt(P_ii)`` and the
    truth dx is formed of, so that ``sensor_true - sensor_est`` is dx's sensor part.

    When the store has rows for the smoother's tape (tape_X, tape_P, tape_dx), the epoch is one
    of its marks: the transition since the last mark (``phi_acc``, then reset to the identity), P
    and dx (tauvcore.engine.smoothing)."""
    _, _, _, t_all, pos_all, vel_all, C_all, ba_all, bg_all, _, _, _, extra_all = chunk
    t_s, vel_t, C_t = t_all[i_chunk], vel_all[i_chunk], C_all[i_chunk]
    pos, vel, _, _, _, _, _, P, _, bdvl_t, sf_t, nonfinite_at, phi_acc, _ = bank
    truth = EpochTruth(
        pos_all[i_chunk], vel_t, C_t, ba_all[i_chunk], bg_all[i_chunk], bdvl_t, sf_t, extra_all[i_chunk]
    )
    origin, _, _, block_of_state, num_blocks, deg, sensor_index, _, _, ref_var = constants
    series, nees_block, _, out_t, _, _, sensor_est = outputs[:7]
    tape_X, tape_P, tape_dx = outputs[9:12]
    with_sensors = sensor_est.shape[0] > 0
    taping = tape_P.shape[0] > 0
    d = P.shape[-1]  # the layout's 20 states and the sources' own
    x_est = np.zeros(d)  # the sensor states' estimate and truth, by state
    x_true = np.zeros(d)
    dx = np.empty(d)
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    L = np.empty((d, d))
    A = np.empty((d, d))
    y = np.empty(d)
    members, sizes, lead, order = nees_plan(block_of_state, num_blocks)
    for m in range(pos.shape[0]):
        for r in range(pos.shape[1]):
            _error_into(truth, bank, m, r, geodetic, dx, Ce, rho)
            _record_states(slot, m, r, truth, bank, outputs)
            _record_position_covariance(slot, m, r, P, outputs[15])
            Pm = P[m, r]
            Q = A if add_reference_into(Pm, ref_var, C_t, vel_t, POS, ATT, VEL, True, A) else Pm
            error_series_into(
                dx,
                Pm,
                Q,
                deg,
                members,
                sizes,
                lead,
                order,
                L,
                y,
                series[:, slot, m, r],
                nees_block[slot, m, r],
            )
            if taping:
                tape_P[slot, m, r] = Pm
                tape_dx[slot, m, r] = dx
                tape_X[slot, m, r] = phi_acc[m, r]
                phi_acc[m, r] = 0.0
            _record_navigation(slot, m, r, bank, origin, geodetic, outputs)
            if with_sensors:
                _record_sensor_errors(slot, m, r, truth, bank, sensor_index, outputs, x_est, x_true)
            if not _finite(Pm, pos[m, r], vel[m, r]) and math.isnan(nonfinite_at[m, r]):
                nonfinite_at[m, r] = t_s
    out_t[slot] = t_s


@jit
def positive_definite_bank(P: np.ndarray) -> np.ndarray:
    """(M, R) bool: each P (M, R, d, d) is finite and its Cholesky factorisation succeeds."""
    d = P.shape[-1]
    out = np.empty(P.shape[:2], dtype=np.bool_)
    L = np.empty((d, d))
    idx = np.arange(d)
    for m in range(P.shape[0]):
        for r in range(P.shape[1]):
            out[m, r] = cholesky_into(P[m, r], idx, d, L)
    return out


STOPS_DONE, STOPS_EVENT, STOPS_REPAIR, STOPS_YIELD = 0, 1, 2, 3
"""Why :func:`run_stops` returned: every stop done; an aiding epoch (the caller corrects, records
and goes on after it); a covariance failed its check (the caller repairs it, then as for an
event); an output epoch was recorded at which the caller asked to be called back."""


class Schedule(NamedTuple):
    """A chunk's stops for :func:`run_stops` (tauvcore.engine.filter_bank.FilterBank._run_chunk)."""

    stops: np.ndarray  # (S,) int64: the global samples the covariance is propagated at, in order
    is_event: np.ndarray  # (S,) bool: an aiding epoch (the caller corrects there)
    out_row: np.ndarray  # (S,) int64: the output row recorded at the stop, -1 for none
    k0: int  # the chunk's first sample
    check_step: int  # samples between two checks of P (positive definite)
    yield_every: int  # back to the caller every this many recorded epochs (0: never)


@jit
def run_stops(
    schedule: Schedule,
    s_from: int,
    s_to: int,
    counters: np.ndarray,
    bank: BankState,
    chunk: ChunkTruth,
    sd: StrapdownConstants,
    constants: Model,
    outputs: Outputs,
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
    stops, is_event, out_row, k0, check_step, yield_every = schedule
    pos, vel, C, ba, bg, _, _, P, dtheta_sum, ping_bias, ping_sf, _, phi_acc, _ = bank
    phi_raw, dv_raw, dtheta, _, _, _, _, _, _, ping_rows, ping_bias_all, ping_sf_all, _ = chunk
    dt, _, _, g_n, _, geodetic = sd
    _, w_ie, q, _, _, _, _, extra_rate, extra_q, _ = constants
    M, R = pos.shape[0], pos.shape[1]
    k_state, k_cov, k_checked, slot = counters[0], counters[1], counters[2], counters[3]
    why = STOPS_DONE
    s = s_from
    while s < s_to:
        k = stops[s]
        i: int = k - k0
        advance(pos, vel, C, ba, bg, (phi_raw, dv_raw, dtheta), dtheta_sum, k_state - k0, i, sd)
        k_state = k
        propagate_bank(
            P,
            pos,
            C,
            vel,
            bg,
            dtheta_sum,
            (k - k_cov) * dt,
            g_n,
            w_ie,
            q,
            geodetic,
            phi_acc,
            extra_rate,
            extra_q,
        )
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
            record_bank(row, i, chunk, bank, constants, geodetic, outputs)
            slot += 1
            if yield_every > 0 and slot % yield_every == 0:
                why = STOPS_YIELD
        if why != STOPS_DONE:
            break
        s += 1
    counters[0], counters[1], counters[2], counters[3] = k_state, k_cov, k_checked, slot
    return s, why


@jit
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
