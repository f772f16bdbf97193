"""Our filter bank against the plain per-step filterpy ``KalmanFilter`` loop, on the same inputs.

    python benchmarks/filterpy_compare.py

The reference is the loosely coupled DVL method (``lc``, :class:`tauvcore.aiding.DvlLoose`) written
the plain way: one ``filterpy.kalman.KalmanFilter(dim_x=20, dim_z=3)`` per Monte Carlo run, stepped
sample by sample in Python, doing what :func:`tauvcore.engine.mission.run` does, in the same order and
with our public model functions (not copies of their formulas):

- the nominal state at the IMU rate: :meth:`Strapdown.step` with the coning/sculling-compensated
  increments (:func:`body_increments`) minus the estimated biases times dt;
- the covariance at ``filter.covariance_rate_hz`` and at every DVL or output epoch (run()'s
  schedule), with ``Phi, Qd = discretise(F_matrix, G_matrix, noise_psd)`` at the mean gyro rate over
  the interval, fed to filterpy as ``kf.F = Phi; kf.Q = Qd; kf.predict()``; the error state ``x``
  stays zero between updates (closed loop);
- at each DVL ping: ``DvlLoose.measure`` gives the innovation, H and R; the paper's gate rejects the
  whole vector if any row has ``nu_i^2 > gate^2 S_ii`` (``S = H P H^T + R``, as
  :func:`tauvcore.filter.eskf.correct`); otherwise ``kf.update(z=nu, R=R, H=H)`` (filterpy's
  Joseph form, as ours) from ``x = 0``, and the resulting ``dx`` goes through
  :func:`tauvcore.filter.eskf.inject`; ``x`` is reset to zero.

What the plain loop leaves out, and why that changes no number here:

- :func:`~tauvcore.filter.eskf.condition_covariance` (after every aiding epoch and once a second):
  a no-op on a positive definite P. The comparison checks that ours repaired nothing
  (``MethodResult.p_floor_count == 0``), so the reference is the same filter.
- the ``unusable`` branch of ``correct`` (S not positive definite) and the divergence monitor:
  neither acts on a healthy filter; the loop raises if S is ever not finite.
- the symmetrisation ``P <- (P + P^T) / 2`` after each propagation and correction: filterpy does not
  symmetrise, and the plain loop does not either; P's asymmetry stays at round-off (the loop's
  final P is returned to show it) and moves nothing at 1e-9.

The initial estimate is the engine's own (:func:`~tauvcore.engine.start.initial_covariance` and the runner's draw of
the initial errors from the same generator state), so both filters start from identical inputs;
what is compared is everything after t = 0.

Compared at every output epoch (10 Hz) and run: position, velocity and attitude error norms, the
full 20-state NEES against truth, the filter's own 1-sigma of position, velocity and attitude (P's
diagonal), the estimated position; at every ping the innovation and the gate's decision. Equal
means within 1e-9, relative above 1 in the series' SI unit and absolute below (:func:`check`).
The final P is compared only as far as ``run()`` exposes it: ``MethodResult`` keeps the per-epoch
sigmas, not the matrix, so at the last epoch the traces of its position, velocity and attitude
blocks are checked, its other terms only through the NEES (the loop's whole final P is in :attr:`LoopResult.P_final`).

What differs is the round-off of two orders of the same sums (filterpy ``inv(S)`` and ``dot``,
ours a solve and compiled loops), integrated by the INS. The measured differences and timings go
to docs/results/filterpy_compare.md (benchmarks/fragment.py), which docs/performance.md includes.
"""

from __future__ import annotations

import copy
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from filterpy.kalman import KalmanFilter

from tauvcore import units
from tauvcore.aiding import DvlLoose
from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import Simulation, simulate
from tauvcore.engine.start import initial_covariance, initial_nominal
from tauvcore.filter.eskf import Nominal, difference, inject
from tauvcore.filter.layout import STATE, NavState
from tauvcore.filter.statistics import nees
from tauvcore.ins.error_model import F_matrix, G_matrix, discretise, noise_psd
from tauvcore.ins.strapdown import Strapdown, body_increments

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

TOLERANCE = 1e-9
"""Largest difference allowed between ours and the filterpy loop, relative to each series' scale."""


@dataclass(frozen=True)
class LoopResult:
    """What the filterpy loop leaves per output epoch (T epochs, R runs) and per DVL ping (U pings)."""

    t_s: np.ndarray            # (T,) output epochs [s]
    pos_err_m: np.ndarray      # (T, R) |position error|
    vel_err_mps: np.ndarray    # (T, R) |body velocity error|
    att_err_deg: np.ndarray    # (T, R) |misalignment|
    nees: np.ndarray           # (T, R) full 20-state NEES against truth
    pos_sigma_m: np.ndarray    # (T, R) sqrt(trace P_pos)
    vel_sigma_mps: np.ndarray  # (T, R)
    att_sigma_deg: np.ndarray  # (T, R)
    est_pos_n: np.ndarray      # (T, R, 3) estimated position, NED [m]
    innovation: np.ndarray     # (U, R, 3) DVL innovation (NaN where the ping gave no measurement)
    fused: np.ndarray          # (U, R) bool: the ping passed the gate and was fused
    P_final: np.ndarray        # (R, 20, 20) P at the last sample, as filterpy holds it (not symmetrised)


def lc_config(trajectory: str, duration_s: float, mode: str, seed: int = 0) -> Config:
    """The compared scenario: ``lc`` alone, DVL aiding only, ``mode`` fixed or random initial errors,
    on the paper's flat earth (the plain loop writes out that mechanization, not the ellipsoid's),
    with the paper's gate and nothing after a lock-out (the loop has no velocity reset:
    tests/unit/tauvcore/engine/test_lockout.py holds that on its own)."""
    return (Config().replace("trajectory", name=trajectory, duration_s=duration_s).replace("earth", model="flat")
            .replace("initial_error", mode=mode).replace("run", methods=("lc",), aiding=("dvl",), seed=seed)
            .replace("filter", lockout_reset_updates=0, scale_factor_velocity_tau_s=0.0))


def filterpy_loop(config: Config, sim: Simulation, rng: np.random.Generator) -> LoopResult:
    """Run ``lc`` on ``sim`` the plain way: one filterpy KalmanFilter per run, stepped per IMU sample.

    ``rng`` must be in the state ``run(config, sim, rng)`` would receive (the initial errors are
    drawn from it exactly as the runner draws them). Only ``config.run.aiding = ("dvl",)`` and
    ``config.run.methods = ("lc",)`` are supported (the reference of one method, not a second engine).
    """
    if tuple(config.run.methods) != ("lc",) or tuple(config.run.aiding) != ("dvl",):
        raise ValueError(f"the filterpy loop runs lc with DVL aiding only, got methods {config.run.methods} "
                         f"and aiding {config.run.aiding}")
    truth, imu, dvl = sim.truth, sim.imu, sim.dvl
    R, K = sim.num_runs, truth.num_samples
    dt = truth.dt_s
    earth = config.earth
    strapdown = Strapdown(earth, dt)
    phi_raw, dv_raw = body_increments(imu.dtheta_b, imu.dv_b)       # (K, R, 3)
    q_psd = noise_psd(config.imu, config.dvl)
    P0 = initial_covariance(config, truth.euler[0])
    # the engine's own initial estimate from the same generator state: identical inputs at t = 0
    nom0 = initial_nominal(config, truth, rng, (1, R), P0[STATE.att, STATE.att])
    gyro_rate_noise = config.imu.gyro_noise_rad_per_sqrt_s / np.sqrt(dt) * np.sqrt(2.5)
    model = DvlLoose(config.dvl, earth, gyro_rate_noise)
    gate = config.filter.gate_sigma

    # run()'s schedule: output epochs, DVL epochs, and every cov_step samples in between
    out_step = max(1, int(round(config.imu.rate_hz / config.filter.output_rate_hz)))
    out_idx = np.arange(0, K, out_step)
    is_output = np.zeros(K, dtype=bool)
    is_output[out_idx] = True
    ping_at = {int(k): i for i, k in enumerate(dvl.index)}
    events = is_output.copy()
    events[list(ping_at)] = True
    cov_step = max(1, int(round(config.imu.rate_hz / config.filter.covariance_rate_hz)))
    dvl_ping_of_sample = np.clip(np.searchsorted(dvl.index, np.arange(K), side="right") - 1, 0, max(len(dvl.index) - 1, 0))
    dvl_bias_true = dvl.bias_mps if len(dvl.index) else np.zeros((1, R, 4))
    dvl_sf_true = dvl.scale_factor if len(dvl.index) else np.zeros((1, R))

    T, U = out_idx.size, len(dvl.index)
    series = {name: np.zeros((T, R)) for name in
              ("pos_err", "vel_err", "att_err", "nees", "pos_sigma", "vel_sigma", "att_sigma")}
    est_pos_n = np.zeros((T, R, 3))
    innovations = np.full((U, R, 3), np.nan)
    fused = np.zeros((U, R), dtype=bool)
    P_final = np.zeros((R, STATE.dim, STATE.dim))

    for r in range(R):
        nom = Nominal(NavState(nom0.nav.pos_n[0, r].copy(), nom0.nav.vel_n[0, r].copy(), nom0.nav.C_nb[0, r].copy()),
                      nom0.accel_bias[0, r].copy(), nom0.gyro_bias[0, r].copy(), nom0.dvl_bias[0, r].copy(),
                      nom0.dvl_sf[0, r].copy())
        kf = KalmanFilter(dim_x=STATE.dim, dim_z=3)
        kf.P = P0.copy()
        kf.x = np.zeros((STATE.dim, 1))
        phi_r, dv_r, dtheta_r = phi_raw[:, r], dv_raw[:, r], imu.dtheta_b[:, r]

        def record(slot: int, k: int, nom: Nominal, P: np.ndarray) -> None:
            p = int(dvl_ping_of_sample[k])
            true = Nominal(NavState(truth.pos_n[k], truth.vel_n[k], truth.C_nb[k]), imu.accel_bias[k, r],
                           imu.gyro_bias[k, r], dvl_bias_true[p, r], dvl_sf_true[p, r])
            dx = difference(true, nom)
            diag = np.diag(P)
            series["pos_err"][slot, r] = np.linalg.norm(dx[STATE.pos])
            series["vel_err"][slot, r] = np.linalg.norm(dx[STATE.vel])
            series["att_err"][slot, r] = np.linalg.norm(dx[STATE.att]) / units.DEG
            series["nees"][slot, r] = nees(dx, P)
            series["pos_sigma"][slot, r] = np.sqrt(diag[STATE.pos].sum())
            series["vel_sigma"][slot, r] = np.sqrt(diag[STATE.vel].sum())
            series["att_sigma"][slot, r] = np.sqrt(diag[STATE.att].sum()) / units.DEG
            est_pos_n[slot, r] = nom.nav.pos_n

        record(0, 0, nom, kf.P)
        slot = 1
        k_cov = 0
        dtheta_sum = np.zeros(3)
        for k in range(1, K):
            nav = strapdown.step(nom.nav, phi_r[k] - nom.gyro_bias * dt, dv_r[k] - nom.accel_bias * dt)
            nom = nom.with_nav(nav)
            dtheta_sum += dtheta_r[k]
            if events[k] or k - k_cov >= cov_step:
                dt_c = (k - k_cov) * dt
                omega_hat = dtheta_sum / dt_c - nom.gyro_bias
                Phi, Qd = discretise(F_matrix(nav.C_nb, nom.vel_b, omega_hat, earth), G_matrix(nav.C_nb, nom.vel_b),
                                     q_psd, dt_c)
                kf.F, kf.Q = Phi, Qd
                kf.predict()                    # x stays 0: P <- Phi P Phi^T + Qd
                k_cov = k
                dtheta_sum[:] = 0.0
            if not events[k]:
                continue
            if k in ping_at:
                i = ping_at[k]
                omega_meas = (3.0 * dtheta_r[k] - dtheta_r[k - 1]) / (2.0 * dt)  # run()'s 2nd-order rate at t_k
                meas = model.measure(nom, dvl.y_beam_mps[i, r], dvl.available[i, r], omega_meas)
                if meas.valid:
                    innovations[i, r] = meas.innovation
                    S = meas.H @ kf.P @ meas.H.T + meas.R
                    if not np.isfinite(S).all():
                        raise FloatingPointError(f"run {r}: innovation covariance not finite at t = {truth.t_s[k]} s")
                    # the paper's gate on the whole vector (section 2.1.1), as tauvcore.filter.eskf.correct
                    if np.all(meas.innovation**2 <= gate**2 * np.diag(S)):
                        kf.x = np.zeros((STATE.dim, 1))
                        kf.update(z=meas.innovation[:, None], R=meas.R, H=meas.H)
                        nom = inject(nom, kf.x[:, 0])
                        kf.x = np.zeros((STATE.dim, 1))
                        fused[i, r] = True
            if is_output[k] and slot < T:
                record(slot, k, nom, kf.P)
                slot += 1
        P_final[r] = kf.P
    return LoopResult(t_s=truth.t_s[out_idx], pos_err_m=series["pos_err"], vel_err_mps=series["vel_err"],
                      att_err_deg=series["att_err"], nees=series["nees"], pos_sigma_m=series["pos_sigma"],
                      vel_sigma_mps=series["vel_sigma"], att_sigma_deg=series["att_sigma"], est_pos_n=est_pos_n,
                      innovation=innovations, fused=fused, P_final=P_final)


COMPARED = ("pos_err_m", "vel_err_mps", "att_err_deg", "nees", "pos_sigma_m", "vel_sigma_mps", "att_sigma_deg",
            "est_pos_n")


def _differences(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """``(max |a - b|, max |a - b| / max(|b|, 1))`` over the elements: relative where a value
    exceeds 1 in its SI unit, absolute below (a norm or a coordinate passing through zero)."""
    d = np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))
    if not d.size:
        return 0.0, 0.0
    return float(d.max()), float((d / np.maximum(np.abs(b), 1.0)).max())


def compare(ours: MethodResult, theirs: LoopResult) -> dict[str, tuple[float, float]]:
    """Largest differences between the engine's ``lc`` results and the loop's.

    Returns ``{series: (max |difference|, max relative difference)}`` for every series of
    :data:`COMPARED` (every output epoch and run), ``innovation`` (every ping that gave a
    measurement), both as :func:`_differences`, and ``gate``: the number of pings the gate
    decided differently (in both columns).
    """
    out: dict[str, tuple[float, float]] = {}
    for name in COMPARED:
        a, b = np.asarray(getattr(ours, name)), np.asarray(getattr(theirs, name))
        if a.shape != b.shape:
            raise ValueError(f"{name}: ours {a.shape}, filterpy loop {b.shape}")
        out[name] = _differences(a, b)
    dvl_rec = ours.updates["dvl"]
    if dvl_rec.fused.shape != theirs.fused.shape:
        raise ValueError(f"DVL pings: ours {dvl_rec.fused.shape}, filterpy loop {theirs.fused.shape}")
    out["innovation"] = _differences(dvl_rec.innovation[dvl_rec.valid], theirs.innovation[dvl_rec.valid])
    wrong = float(np.count_nonzero(dvl_rec.fused != theirs.fused))
    out["gate"] = (wrong, wrong)
    return out


def check(ours: MethodResult, theirs: LoopResult, tolerance: float = TOLERANCE) -> dict[str, tuple[float, float]]:
    """:func:`compare`, raising AssertionError if any difference exceeds ``tolerance`` (relative
    above 1 SI unit, absolute below), a ping is decided differently, or ours repaired P (the
    loop does not condition it)."""
    diffs = compare(ours, theirs)
    bad = {name: d for name, d in diffs.items() if not d[1] <= (0.0 if name == "gate" else tolerance)}
    if bad:
        raise AssertionError(f"ours and the filterpy loop differ beyond {tolerance:g}: {bad}")
    if np.any(ours.p_floor_count):
        raise AssertionError(f"ours repaired P {ours.p_floor_count} times; the filterpy loop does not condition P")
    return diffs


def prepare(config: Config, num_runs: int) -> tuple[Callable[[], MethodResult], Callable[[], LoopResult]]:
    """Simulate once (seed ``config.run.seed``); return the two calls to compare on these inputs:
    ours (``run(config, sim, rng)["lc"]``) and the filterpy loop, each given a copy of the
    generator in the state run() receives after the simulation (it draws the initial errors)."""
    rng = np.random.default_rng(config.run.seed)
    sim = simulate(config, rng, num_runs)

    def ours() -> MethodResult:
        return run(config, sim, copy.deepcopy(rng))["lc"]

    def loop() -> LoopResult:
        return filterpy_loop(config, sim, copy.deepcopy(rng))
    return ours, loop


def best_of(fn: Callable[[], object], repeats: int = 3) -> tuple[float, object]:
    """Shortest wall time of ``repeats`` calls (time.perf_counter), and the last call's result."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return min(times), result


def main() -> None:
    with fragment.capture() as shown:
        print("Ours: tauvcore.engine.mission.run (simulation excluded); filterpy loop: one filterpy KalmanFilter per run, "
              "stepped per IMU sample in Python; the same simulation and initial errors. Best of 3, time.perf_counter.\n")
        print("| workload | ours [s] | filterpy loop [s] | ratio | max abs. difference | max rel. difference "
              "| gate decisions differing |")
        print("|---|---|---|---|---|---|---|")
        for duration_s, mode, num_runs in ((250.0, "fixed", 1), (250.0, "random", 10)):
            config = lc_config("figure8", duration_s, mode)
            ours, loop = prepare(config, num_runs)
            t_ours, ours_res = best_of(ours)
            t_loop, loop_res = best_of(loop)
            diffs = check(ours_res, loop_res)
            values = {name: d for name, d in diffs.items() if name != "gate"}
            worst_abs = max(values.items(), key=lambda d: d[1][0])
            worst_rel = max(values.items(), key=lambda d: d[1][1])
            print(f"| {duration_s:g} s figure8, lc, {num_runs} run{'s' if num_runs > 1 else ''}, {mode} initial errors "
                  f"| {t_ours:.3f} | {t_loop:.2f} | {t_loop / t_ours:.0f}x | {worst_abs[1][0]:.1e} ({worst_abs[0]}) "
                  f"| {worst_rel[1][1]:.1e} ({worst_rel[0]}) | {diffs['gate'][0]:.0f} |")
        print(f"\nEvery series at every output epoch and run equal to {TOLERANCE:g} (relative above 1 SI unit, "
              "absolute below: position, velocity and attitude error norms, NEES, the 1-sigmas from P's diagonal, "
              "the estimated position, the DVL innovations); the gate decided every ping alike; ours repaired no P.")

    print(f"written to {fragment.write('filterpy_compare', shown.getvalue())}")

if __name__ == "__main__":
    main()
