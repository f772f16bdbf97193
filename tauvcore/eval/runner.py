"""Run a scenario: simulate truth and sensors once, then every selected method side by side.

The nominal state runs at the IMU rate; the covariance is propagated at
``filter.covariance_rate_hz`` (and always up to an aiding or output epoch) with F evaluated at
the current nominal state and the mean rate over the interval, ``Phi = expm(F dt_c)`` to third
order. At 10 Hz the rotation over one interval is < 0.02 rad, so this costs nothing in accuracy
(the NEES test checks it) and a fifteenth of the work.

Methods and Monte Carlo runs are array dimensions of one filter bank (batch ``(M, R)``): the
IMU-rate loop (strapdown step and covariance propagation) runs once for all of them, and each
aiding epoch applies its update only to the methods that use it ("when" lives here, "how" in
tauvcore.aiding). Every update leaves an :class:`UpdateRecord`; every output epoch leaves the
error norms (attitude also split into tilt and heading), the filter's own 1-sigma, and the NEES
against truth of the full state and of each block of :data:`~tauvcore.filter.layout.NEES_BLOCKS`
(position, velocity, tilt, heading, sensor errors); every update record carries its NIS.

Numerical health (issue 7): after the corrections of every aiding epoch, and at least once per
second of propagation (:data:`CONDITION_CHECK_RATE_HZ`), P goes through
:func:`~tauvcore.filter.eskf.condition_covariance` (one batched Cholesky for all methods and
runs; an eigenvalue floor only where it fails, counted per run in ``MethodResult.p_floor_count``). The divergence
monitor flags a run's solution (``MethodResult.diverged``, ``diverged_at_s``) at the first of

- an output epoch where its state or P is not finite;
- an aiding epoch after which an estimated sensor error (IMU or DVL bias, DVL scale factor) lies far
  outside the filter's own prior (:func:`~tauvcore.eval.metrics.implausible_sensor_errors`);
- an innovation inconsistency of any of its aiding sources
  (:func:`~tauvcore.eval.metrics.innovation_divergence_s`: windowed NIS above its chi-square
  bound, or the source locked out by the gate).

It uses no truth, as a real filter could not; so it cannot see an error in a direction nothing
measures (heading on a straight line with the DVL alone, or VB's self-confirming virtual beam on
a fixed pair at a small n_f): the NEES against truth in the records shows those. The standalone
INS has no innovations and estimates no sensor error: it is flagged only if not finite.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from tauvcore import units
from tauvcore.aiding import Depth, DvlLoose, MagAttitude
from tauvcore.aiding.dvl_extended import (
    ELC_METHODS,
    MODE_COAST,
    MODE_LC,
    MODE_TC,
    DvlExtended,
    DvlInfo,
)
from tauvcore.aiding.dvl_tight import DvlTight
from tauvcore.config import Config
from tauvcore.eval.metrics import implausible_sensor_errors, innovation_divergence_s
from tauvcore.filter import kernels
from tauvcore.filter.eskf import (
    Measurement,
    Nominal,
    UpdateOutcome,
    condition_covariance,
    fuse_in_place,
    make_outcome,
)
from tauvcore.filter.layout import NEES_BLOCKS, NOISE, STATE
from tauvcore.geo.rotations import (
    C_nb_from_euler,
    euler_from_misalignment_jacobian,
    exp_so3,
)
from tauvcore.ins.error_model import noise_psd
from tauvcore.ins.strapdown import NavState, Strapdown, body_increments, mv
from tauvcore.sensors import dvl as dvl_sensor
from tauvcore.sensors import imu as imu_sensor
from tauvcore.sensors import magnetometer as mag_sensor
from tauvcore.sensors import pressure as pressure_sensor
from tauvcore.truth import Truth, generate

CONDITION_CHECK_RATE_HZ = 1.0
"""P is checked (and repaired if need be) after the corrections of every aiding epoch, where
updates can lose definiteness to round-off, and at least this often in between (propagation
alone, e.g. the standalone INS or a DVL outage, only carries a positive definite P forward)."""

DVL_FUSION = {"ins": None, "lc": "lc", "tc": "tc", **{m: "elc" for m in ELC_METHODS}}
"""How each method fuses the DVL (None: not at all)."""


@dataclass(frozen=True)
class Simulation:
    """Truth and every sensor's output for R Monte Carlo runs (run axis after time)."""

    truth: Truth
    imu: imu_sensor.ImuData
    dvl: dvl_sensor.DvlData
    pressure: pressure_sensor.PressureData
    mag: mag_sensor.MagnetometerData
    num_runs: int


def simulate(config: Config, rng: np.random.Generator, num_runs: int = 1, truth: Truth | None = None) -> Simulation:
    """Generate the truth (unless given) and the sensor outputs (errors zeroed if ``config.run.ideal``)."""
    ideal = config.run.ideal
    if truth is None:
        truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    imu_cfg = config.imu.ideal() if ideal else config.imu
    dvl_cfg = config.dvl.ideal() if ideal else config.dvl
    p_cfg = config.pressure.ideal() if ideal else config.pressure
    m_cfg = config.magnetometer.ideal() if ideal else config.magnetometer
    return Simulation(truth=truth,
                      imu=imu_sensor.simulate(truth, imu_cfg, rng, num_runs),
                      dvl=dvl_sensor.simulate(truth, dvl_cfg, rng, num_runs),
                      pressure=pressure_sensor.simulate(truth, p_cfg, rng, num_runs),
                      mag=mag_sensor.simulate(truth, m_cfg, rng, num_runs),
                      num_runs=num_runs)


@dataclass(frozen=True)
class UpdateRecord:
    """Every update of one aiding source for one method: U epochs x R runs."""

    t_s: np.ndarray             # (U,)
    z: np.ndarray               # (U, R, m) observation
    innovation: np.ndarray      # (U, R, m)
    innovation_var: np.ndarray  # (U, R, m) diagonal of S
    test_ratio: np.ndarray      # (U, R) max_i nu_i^2 / (gate^2 S_ii)
    fused: np.ndarray           # (U, R) bool
    rejected: np.ndarray        # (U, R) bool (failed the gate)
    valid: np.ndarray           # (U, R) bool (the source produced a measurement)
    fused_rows: np.ndarray      # (U, R, m) bool
    rejected_rows: np.ndarray   # (U, R, m) bool
    nis: np.ndarray             # (U, R) normalised innovation squared over the active rows, before the gate
    nis_dof: np.ndarray         # (U, R) int: its degrees of freedom (active rows)
    unusable: np.ndarray        # (U, R) bool: S not finite or not positive definite, nothing fused
    beams_available: np.ndarray | None = None  # (U, R, 4) DVL only: beams that returned
    mode: np.ndarray | None = None             # (U, R) DVL only: MODE_* code (coast, lc, partial, tc)
    measured_axes: np.ndarray | None = None    # (U, R, 3) DVL only: body axes the velocity carried
    elc_choice: np.ndarray | None = None       # (U, R, 3) ELC only: index into elc_select.CANDIDATES


@dataclass(frozen=True)
class MethodResult:
    """Per-epoch results of one method over R runs (time first)."""

    method: str
    t_s: np.ndarray             # (T,) output epochs [s]
    vel_err_mps: np.ndarray     # (T, R) |body velocity error|
    att_err_deg: np.ndarray     # (T, R) |misalignment| (tilt and heading together)
    pos_err_m: np.ndarray       # (T, R) |position error|
    vel_sigma_mps: np.ndarray   # (T, R) sqrt(trace P_vel), the filter's own 1-sigma of the norm
    att_sigma_deg: np.ndarray   # (T, R)
    pos_sigma_m: np.ndarray     # (T, R)
    nees: np.ndarray            # (T, R) full 20-state NEES against truth
    tilt_err_deg: np.ndarray    # (T, R) |(rho_N, rho_E)|: roll/pitch (levelling) error
    heading_err_deg: np.ndarray  # (T, R) |rho_D|: heading (azimuth) error
    tilt_sigma_deg: np.ndarray  # (T, R) sqrt(P_NN + P_EE) of the misalignment
    heading_sigma_deg: np.ndarray  # (T, R) sqrt(P_DD) of the misalignment
    nees_block: np.ndarray      # (T, R, B) NEES of each block of layout.NEES_BLOCKS (in its order)
    est_pos_n: np.ndarray       # (T, R, 3) estimated position, NED [m]
    diverged: np.ndarray        # (R,) bool: the divergence monitor flagged this run's solution
    diverged_at_s: np.ndarray   # (R,) time of the first flag [s], NaN if never
    p_floor_count: np.ndarray   # (R,) times an eigenvalue of P was raised to the floor
    updates: dict[str, UpdateRecord] = field(default_factory=dict)


def _initial_draws(rng: np.random.Generator | Sequence[np.random.Generator], R: int) -> tuple[np.ndarray, ...]:
    """Standard normals of the random initial errors (position, misalignment, velocity), (R, 3)
    each: from one generator for the whole batch, or one per run (a study's runs, each its own
    seeded unit: tauvcore.eval.study)."""
    if isinstance(rng, np.random.Generator):
        return rng.standard_normal((R, 3)), rng.standard_normal((R, 3)), rng.standard_normal((R, 3))
    if len(rng) != R:
        raise ValueError(f"one generator per run expected ({R}), got {len(rng)}")
    draws = [(g.standard_normal(3), g.standard_normal(3), g.standard_normal(3)) for g in rng]
    return tuple(np.stack([d[i] for d in draws]) for i in range(3))


def _initial_nominal(config: Config, truth: Truth, rng: np.random.Generator | Sequence[np.random.Generator],
                     batch: tuple[int, int], P0_nav_att: np.ndarray) -> Nominal:
    """Estimate at t = 0: truth with the initial errors (fixed, or drawn per run), biases zero."""
    _, R = batch
    ie = config.initial_error.ideal() if config.run.ideal else config.initial_error
    pos_true, C_true, v_true_b = truth.pos_n[0], truth.C_nb[0], truth.vel_b[0]
    if ie.mode == "fixed":
        pos = np.broadcast_to(pos_true + np.asarray(ie.pos_m), (R, 3))
        C = np.broadcast_to(C_nb_from_euler(truth.euler[0] + np.asarray(ie.euler_rad)), (R, 3, 3))
        vel_b = np.broadcast_to(v_true_b + np.asarray(ie.vel_mps), (R, 3))
    else:
        n_pos, n_rho, n_vel = _initial_draws(rng, R)
        pos = pos_true + n_pos * np.asarray(ie.pos_m)
        rho = (np.linalg.cholesky(P0_nav_att) @ n_rho[..., None])[..., 0]
        C = exp_so3(-rho) @ C_true  # C_true = exp(rho) C_hat
        vel_b = v_true_b + n_vel * np.asarray(ie.vel_mps)
    vel_n = mv(C, vel_b)
    nav = NavState(pos_n=np.broadcast_to(pos, batch + (3,)).copy(),
                   vel_n=np.broadcast_to(vel_n, batch + (3,)).copy(),
                   C_nb=np.broadcast_to(C, batch + (3, 3)).copy())
    return Nominal(nav=nav, accel_bias=np.zeros(batch + (3,)), gyro_bias=np.zeros(batch + (3,)),
                   dvl_bias=np.zeros(batch + (4,)), dvl_sf=np.zeros(batch))


def initial_covariance(config: Config, euler0: np.ndarray) -> np.ndarray:
    """P0 (20, 20) from the initial-error and sensor sections (Table 2 values as 1-sigma).

    The attitude block maps the Euler-angle sigmas into the n-frame misalignment:
    ``P_rho = J^-1 diag(sigma_euler^2) J^-T``, ``J = d euler / d rho`` at the initial attitude.
    """
    ie, imu, dvl = config.initial_error, config.imu, config.dvl
    P0 = np.zeros((STATE.dim, STATE.dim))
    P0[STATE.pos, STATE.pos] = np.diag(np.square(ie.pos_m))
    J_inv = np.linalg.inv(euler_from_misalignment_jacobian(euler0))
    P0[STATE.att, STATE.att] = J_inv @ np.diag(np.square(ie.euler_rad)) @ J_inv.T
    P0[STATE.vel, STATE.vel] = np.diag(np.square(ie.vel_mps))
    P0[STATE.ba, STATE.ba] = np.eye(3) * imu.accel_bias_mps2**2
    P0[STATE.bg, STATE.bg] = np.eye(3) * imu.gyro_bias_rps**2
    P0[STATE.b_dvl, STATE.b_dvl] = np.eye(4) * dvl.bias_mps**2
    P0[STATE.sf_dvl, STATE.sf_dvl] = dvl.scale_factor**2
    # a zero tuning value would make P0 singular; keep a floor far below any real error
    return P0 + np.eye(STATE.dim) * 1e-16


def _epoch_map(indices: np.ndarray) -> dict[int, int]:
    return {int(k): i for i, k in enumerate(indices)}


class _Recorder:
    """Collects the updates of one source for one method."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.rows: list[dict[str, np.ndarray]] = []

    def add(self, t: float, outcome: UpdateOutcome, valid: np.ndarray, **extra: np.ndarray) -> None:
        self.t.append(t)
        self.rows.append({"z": outcome.z, "innovation": outcome.innovation, "innovation_var": outcome.innovation_var,
                          "test_ratio": outcome.test_ratio, "fused": outcome.fused, "rejected": outcome.rejected,
                          "valid": valid, "fused_rows": outcome.fused_rows, "rejected_rows": outcome.rejected_rows,
                          "nis": outcome.nis, "nis_dof": outcome.nis_dof, "unusable": outcome.unusable, **extra})

    def build(self) -> UpdateRecord:
        keys = self.rows[0].keys()
        return UpdateRecord(t_s=np.asarray(self.t), **{k: np.stack([r[k] for r in self.rows]) for k in keys})


def run(config: Config, sim: Simulation, rng: np.random.Generator | Sequence[np.random.Generator],
        progress: Callable[[float, dict[str, MethodResult]], None] | None = None, progress_interval_s: float = 5.0,
        should_stop: Callable[[], bool] | None = None) -> dict[str, MethodResult]:
    """Run every method of ``config.run.methods`` on the simulation; results keyed by method.

    ``progress(t_s, partial_results)`` is called every ``progress_interval_s`` of simulated time
    with the results so far (for live displays); ``should_stop()`` is polled at every output
    epoch (10 Hz of simulated time, a few milliseconds of wall time) and ends the run early,
    returning the results up to that epoch.
    """
    methods = tuple(config.run.methods)
    truth, imu = sim.truth, sim.imu
    M, R = len(methods), sim.num_runs
    batch = (M, R)
    dt = truth.dt_s
    earth = config.earth
    strapdown = Strapdown(earth, dt)
    sd_consts = (dt, strapdown.C_earth, strapdown.C_earth_half, strapdown.g_n, strapdown.coriolis_T)
    g_n, w_ie = np.ascontiguousarray(earth.g_n), np.ascontiguousarray(earth.omega_ie_n)
    phi_raw, dv_raw = (np.ascontiguousarray(a) for a in body_increments(imu.dtheta_b, imu.dv_b))  # (K, R, 3)
    dtheta_b = np.ascontiguousarray(imu.dtheta_b)
    q_psd = noise_psd(config.imu, config.dvl)
    P0 = initial_covariance(config, truth.euler[0])
    P = np.broadcast_to(P0, batch + P0.shape).copy()
    # the (M, R) nominal states, contiguous so that the kernels update them in place
    nom = _initial_nominal(config, truth, rng, batch, P0[STATE.att, STATE.att])
    pos, vel, C = (np.array(a, dtype=float, order="C") for a in (nom.nav.pos_n, nom.nav.vel_n, nom.nav.C_nb))
    ba, bg, bdvl = (np.array(a, dtype=float, order="C") for a in (nom.accel_bias, nom.gyro_bias, nom.dvl_bias))
    sf = np.array(nom.dvl_sf, dtype=float, order="C")
    flat = (pos.reshape(-1, 3), vel.reshape(-1, 3), C.reshape(-1, 3, 3), ba.reshape(-1, 3), bg.reshape(-1, 3),
            bdvl.reshape(-1, 4), sf.reshape(-1))

    def nominal(m: int | None = None) -> Nominal:
        """The current estimate (views): of method m, or of the whole bank."""
        sel = slice(None) if m is None else m
        return Nominal(NavState(pos[sel], vel[sel], C[sel]), ba[sel], bg[sel], bdvl[sel], sf[sel])

    aiding = set(config.run.aiding)
    gyro_rate_noise = config.imu.gyro_noise_rad_per_sqrt_s / np.sqrt(dt) * np.sqrt(2.5)
    dvl_models = {
        "lc": DvlLoose(config.dvl, earth, gyro_rate_noise),
        "tc": DvlTight(config.dvl, earth, gyro_rate_noise),
        **{m: DvlExtended(m, config.dvl, earth, gyro_rate_noise, config.partial.vb_nf,
                          config.nsv_epsilon_value_m2_per_s2()) for m in ELC_METHODS},
    }
    other_mask = np.array([DVL_FUSION[m] is not None for m in methods])[:, None] & np.ones(batch, bool)
    depth_model = Depth(config.pressure)
    mag_model = MagAttitude(config.magnetometer)
    dvl_methods = [(i, m) for i, m in enumerate(methods) if DVL_FUSION[m] is not None]
    dvl_at = _epoch_map(sim.dvl.index) if "dvl" in aiding and dvl_methods else {}
    depth_at = _epoch_map(sim.pressure.index) if "depth" in aiding and other_mask.any() else {}
    mag_at = _epoch_map(sim.mag.index) if "mag" in aiding and other_mask.any() else {}
    recorders = {(src, m): _Recorder() for src in ("dvl", "depth", "mag") for m in range(M)}

    out_step = max(1, int(round(config.imu.rate_hz / config.filter.output_rate_hz)))
    out_idx = np.arange(0, truth.num_samples, out_step)
    T = out_idx.size
    series_all = np.zeros((len(kernels.SERIES_NAMES), T, M, R))
    series = dict(zip(kernels.SERIES_NAMES, series_all))
    nees_block = np.zeros((T, M, R, len(NEES_BLOCKS)))
    block_of_state = np.full(STATE.dim, -1)
    for b, ix in enumerate(NEES_BLOCKS.values()):
        block_of_state[list(ix)] = b
    est_pos_n = np.zeros((T, M, R, 3))
    # true DVL errors at a sample: those of the latest ping (the first before it; zero without pings)
    dvl_ping_of_sample = np.clip(np.searchsorted(sim.dvl.index, np.arange(truth.num_samples), side="right") - 1,
                                 0, max(len(sim.dvl.index) - 1, 0))
    dvl_bias_true = sim.dvl.bias_mps if len(sim.dvl.index) else np.zeros((1, R, 4))
    dvl_sf_true = sim.dvl.scale_factor if len(sim.dvl.index) else np.zeros((1, R))
    gate = config.filter.gate_sigma
    p_floor_count = np.zeros(batch, dtype=int)
    nonfinite_at_s = np.full(batch, np.nan)   # first output epoch with a non-finite state or P
    implausible_at_s = np.full(batch, np.nan)  # first output epoch with a sensor error outside its prior
    sensor_states = (STATE.ba, STATE.bg, STATE.b_dvl, STATE.sf_dvl)
    prior_var0 = np.concatenate([np.diag(P0)[s] for s in sensor_states])
    prior_rate = np.concatenate([q_psd[n] for n in (NOISE.ba, NOISE.bg, NOISE.b_dvl, NOISE.sf_dvl)])

    def condition() -> None:
        """Keep every P positive definite (one compiled Cholesky per filter; numpy repair if one fails)."""
        ok = kernels.positive_definite_bank(P)
        if not ok.all():
            P_new, repaired = condition_covariance(P)
            P[...] = P_new
            p_floor_count[...] += repaired

    def record(slot: int, k: int) -> None:
        p = int(dvl_ping_of_sample[k])
        kernels.record_bank(slot, float(truth.t_s[k]), truth.pos_n[k], truth.vel_n[k], truth.C_nb[k],
                            np.ascontiguousarray(imu.accel_bias[k]), np.ascontiguousarray(imu.gyro_bias[k]),
                            np.ascontiguousarray(dvl_bias_true[p]), np.ascontiguousarray(dvl_sf_true[p]),
                            pos, vel, C, ba, bg, bdvl, sf, P, block_of_state, len(NEES_BLOCKS), units.DEG,
                            series_all, nees_block, est_pos_n, nonfinite_at_s)

    def check_sensor_errors(t: float) -> None:
        """After the corrections of an aiding epoch (the only moments the estimates change)."""
        sensor_est = np.concatenate((ba, bg, bdvl, sf[..., None]), axis=-1)
        wild = implausible_sensor_errors(sensor_est, prior_var0 + prior_rate * t)
        implausible_at_s[wild & np.isnan(implausible_at_s)] = t

    def fuse(H: np.ndarray, Rm: np.ndarray, nu: np.ndarray, active: np.ndarray, gate_rows: np.ndarray
             ) -> tuple[np.ndarray, ...]:
        """One compiled gated correction and injection of the whole bank in place (inactive rows
        and entries untouched). Arrays (M, R, m, ...); returns the per-entry outcome (M, R, ...)."""
        fused = fuse_in_place(P.reshape(-1, STATE.dim, STATE.dim), flat, H, Rm, nu, active, gate_rows.reshape(-1),
                              gate)
        return tuple(a.reshape(batch + a.shape[1:]) for a in fused)

    def outcome_of(z: np.ndarray, nu: np.ndarray, active: np.ndarray, fused: tuple[np.ndarray, ...]
                   ) -> UpdateOutcome:
        return make_outcome(z, nu, active, *fused)

    def update_all(source: str, meas: Measurement, t: float) -> None:
        """A source every aided method takes (depth, magnetometer): one batched correction."""
        valid = meas.valid & other_mask
        m_rows = meas.R.shape[-1]
        active = np.ones(batch + (m_rows,), bool) if meas.active is None else meas.active.astype(bool)
        active = active & valid[..., None]
        fused = fuse(meas.H, meas.R, meas.innovation, active, np.full(batch, meas.gate_rows))
        outcome = outcome_of(meas.z, meas.innovation, active, fused)
        for m in range(M):
            if other_mask[m].any():
                part = UpdateOutcome(**{f: getattr(outcome, f)[m] for f in UpdateOutcome.__dataclass_fields__})
                recorders[(source, m)].add(t, part, meas.valid[m] & other_mask[m])

    DVL_ROWS = 4   # the widest DVL measurement (tightly coupled: one row per beam); narrower ones padded

    def update_dvl(i: int, k: int, t: float) -> None:
        """Every DVL-aided method measures the ping its own way (lc, tc, or an ELC method); one
        compiled correction then fuses them all."""
        y, available = sim.dvl.y_beam_mps[i], sim.dvl.available[i]
        omega_meas = (3.0 * dtheta_b[k] - dtheta_b[k - 1]) / (2.0 * dt)  # rate at t_k, 2nd order
        H = np.zeros(batch + (DVL_ROWS, STATE.dim))
        Rm = np.zeros(batch + (DVL_ROWS, DVL_ROWS))
        nu = np.zeros(batch + (DVL_ROWS,))
        active = np.zeros(batch + (DVL_ROWS,), bool)
        gate_rows = np.zeros(batch, bool)
        taken = []
        for m, method in dvl_methods:
            part = nominal(m)
            kind = DVL_FUSION[method]
            if kind == "elc":
                meas, info = dvl_models[method].measure(part, P[m][..., STATE.vel, STATE.vel], y, available,
                                                        omega_meas)
            else:
                meas = dvl_models[kind].measure(part, y, available, omega_meas)
                code = MODE_LC if kind == "lc" else MODE_TC
                info = DvlInfo(mode=np.where(meas.valid, code, MODE_COAST),
                               measured_axes=np.broadcast_to(meas.valid[:, None] & (kind == "lc"), (R, 3)),
                               elc_choice=np.full((R, 3), -1))
            rows = meas.R.shape[-1]
            act = np.ones((R, rows), bool) if meas.active is None else meas.active.astype(bool)
            H[m, :, :rows], Rm[m, :, :rows, :rows], nu[m, :, :rows] = meas.H, meas.R, meas.innovation
            Rm[m, :, rows:, rows:] = np.eye(DVL_ROWS - rows)
            active[m, :, :rows] = act & meas.valid[:, None]
            gate_rows[m] = meas.gate_rows
            taken.append((m, meas, info, rows))
        fused = fuse(H, Rm, nu, active, gate_rows)
        for m, meas, info, rows in taken:
            s_diag, keep, nis, ratio, unusable = (a[m] for a in fused)
            act = active[m, :, :rows]
            outcome = outcome_of(meas.z, meas.innovation, act, (s_diag[:, :rows], keep[:, :rows], nis, ratio, unusable))
            recorders[("dvl", m)].add(t, outcome, meas.valid, beams_available=available, mode=info.mode,
                                      measured_axes=info.measured_axes, elc_choice=info.elc_choice)

    cov_step = max(1, int(round(config.imu.rate_hz / config.filter.covariance_rate_hz)))
    events = np.zeros(truth.num_samples, dtype=bool)
    for keys in (dvl_at, depth_at, mag_at):
        events[list(keys)] = True
    events[out_idx] = True
    check_step = max(1, int(round(config.imu.rate_hz / CONDITION_CHECK_RATE_HZ)))

    def results_upto(n: int) -> dict[str, MethodResult]:
        out = {}
        for m, method in enumerate(methods):
            updates = {src: rec.build() for (src, mm), rec in recorders.items() if mm == m and rec.rows}
            flagged = [nonfinite_at_s[m], implausible_at_s[m]] + [
                innovation_divergence_s(u.t_s, u.nis, u.nis_dof, u.fused, u.valid) for u in updates.values()]
            diverged_at = np.fmin.reduce(np.stack(flagged), axis=0)
            out[method] = MethodResult(
                method=method, t_s=truth.t_s[out_idx[:n]],
                vel_err_mps=series["vel_err"][:n, m], att_err_deg=series["att_err"][:n, m],
                pos_err_m=series["pos_err"][:n, m], vel_sigma_mps=series["vel_sigma"][:n, m],
                att_sigma_deg=series["att_sigma"][:n, m], pos_sigma_m=series["pos_sigma"][:n, m],
                nees=series["nees"][:n, m], est_pos_n=est_pos_n[:n, m],
                tilt_err_deg=series["tilt_err"][:n, m], heading_err_deg=series["heading_err"][:n, m],
                tilt_sigma_deg=series["tilt_sigma"][:n, m], heading_sigma_deg=series["heading_sigma"][:n, m],
                nees_block=nees_block[:n, m],
                diverged=~np.isnan(diverged_at), diverged_at_s=diverged_at,
                p_floor_count=p_floor_count[m].copy(), updates=updates)
        return out

    progress_every = max(1, int(round(progress_interval_s * config.filter.output_rate_hz)))
    record(0, 0)
    slot = 1
    k_cov = 0                       # sample the covariance was last propagated to (and the state advanced to)
    k_checked = 0                   # sample P was last checked (positive definite) at
    for k in covariance_stops(np.flatnonzero(events), truth.num_samples, cov_step):
        kernels.advance(pos, vel, C, ba, bg, phi_raw, dv_raw, k_cov, k, *sd_consts)
        dt_c = (k - k_cov) * dt
        dtheta_sum = dtheta_b[k_cov + 1:k + 1].sum(axis=0)
        kernels.propagate_bank(P, C, vel, bg, dtheta_sum, dt_c, g_n, w_ie, q_psd)
        if k - k_checked >= check_step:
            condition()
            k_checked = k
        k_cov = k
        if not events[k]:
            continue
        t = float(truth.t_s[k])
        if k in dvl_at:
            update_dvl(dvl_at[k], k, t)
        if k in depth_at:
            update_all("depth", depth_model.measure(nominal(), sim.pressure.depth_m[depth_at[k]]), t)
        if k in mag_at:
            update_all("mag", mag_model.measure(nominal(), sim.mag.euler[mag_at[k]]), t)
        if k in dvl_at or k in depth_at or k in mag_at:
            condition()
            k_checked = k
            check_sensor_errors(t)
        if slot < T and k == out_idx[slot]:
            record(slot, k)
            slot += 1
            if should_stop is not None and should_stop():
                break
            if progress is not None and slot % progress_every == 0 and slot < T:
                progress(t, results_upto(slot))
    return results_upto(slot)


def covariance_stops(event_idx: np.ndarray, num_samples: int, cov_step: int) -> list[int]:
    """Samples at which the covariance is propagated (and the nominal state stops): every event
    (aiding or output epoch, ``event_idx`` sorted) and every ``cov_step`` samples in between."""
    stops: list[int] = []
    prev = 0
    for e in [int(e) for e in event_idx if e > 0] + [num_samples]:
        stops.extend(range(prev + cov_step, e, cov_step))
        if e < num_samples:
            stops.append(e)
        prev = e
    return stops
