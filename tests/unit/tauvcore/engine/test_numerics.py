"""Numerics at the edges of the legal configurations: zero noise handled exactly by
documented floors, P kept symmetric positive definite, unusable updates skipped and recorded,
and the divergence monitor flagging broken filters (and only those)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats

from tauvcore.aiding import noise_floors
from tauvcore.aiding.dvl_loose import solve_velocity
from tauvcore.config import Config
from tauvcore.engine import filter_bank, loop
from tauvcore.engine.mission import run
from tauvcore.engine.monitor import (
    LOCKOUT_UPDATES,
    NIS_WINDOW_UPDATES,
    implausible_sensor_errors,
    innovation_divergence_s,
)
from tauvcore.engine.simulation import simulate
from tauvcore.filter import eskf
from tauvcore.filter.eskf import Measurement, condition_covariance, correct
from tauvcore.filter.layout import STATE
from tauvcore.filter.statistics import nees
from tauvcore.ins import error_model
from tauvcore.ins.error_model import PROCESS_NOISE_PSD_FLOOR, noise_psd
from tauvcore.sensors.dvl import beam_directions_b
from tauvcore.sensors.imu import ERROR_LIMITS
from tests.unit.tauvcore.filter.test_eskf import _nominal, _spd

AIDED = ("lc", "tc", "vb", "elc")
IMU_NOISES = {"accel_noise_mps_per_sqrt_h": 0.0, "gyro_noise_deg_per_sqrt_h": 0.0,
              "accel_bias_rw_mps2_per_sqrt_s": 0.0, "gyro_bias_rw_deg_per_s_per_sqrt_s": 0.0}
DVL_ERRORS = ("bias_mps", "bias_rw_mps_per_sqrt_s", "scale_factor_pct", "scale_factor_rw_pct_per_sqrt_s")


def _config(duration_s: float, **run_changes: object) -> Config:
    return Config().replace("trajectory", duration_s=duration_s).replace("run", **run_changes)


def _zero_noise(config: Config) -> Config:
    """Every white noise and random walk zero (the issue's case); turn-on errors kept."""
    return config.replace("dvl", noise_mps=0.0).replace("pressure", noise_pa=0.0).replace("imu", **IMU_NOISES)


def _run(config: Config, num_runs: int = 1, seed: int = 0, truth_config: Config | None = None):
    rng = np.random.default_rng(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error")            # no overflow, division or invalid-value warning either
        return run(config, simulate(truth_config or config, rng, num_runs), rng)


def _assert_healthy(res) -> None:
    for name in ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m", "nees"):
        assert np.isfinite(getattr(res, name)).all(), (res.method, name)
    assert (res.nees > 0).all(), res.method                       # P positive definite at every epoch
    assert not res.diverged.any(), (res.method, res.diverged_at_s)


# ------------------------------------------------------------------------------------------ zero noise

def test_zero_noise_dvl_and_depth_fuse_and_stay_consistent():
    """The issue's case: LC NaN from the first ping, depth fusion LinAlgError (singular S)."""
    config = _zero_noise(_config(60.0, methods=("ins",) + AIDED, aiding=("dvl", "depth")))
    results = _run(config)
    for method in AIDED:
        res = results[method]
        _assert_healthy(res)
        assert res.updates["dvl"].fused.mean() > 0.95, method
        assert res.updates["depth"].fused.all(), method
        assert res.vel_err_mps[-1, 0] < 4.0 * res.vel_sigma_mps[-1, 0], method
    assert np.isfinite(results["ins"].vel_err_mps).all()


def test_zero_noise_everywhere_gives_the_exact_solution():
    """No sensor error at all, every noise zero, with the magnetometer: the floors keep every update
    defined and the solution is the truth to well within the floors (1 mm/s, 1 mm, 1e-4 rad)."""
    config = (_zero_noise(_config(60.0, methods=AIDED, aiding=("dvl", "depth", "mag")))
              .replace("imu", accel_bias_mg=0.0, gyro_bias_deg_per_h=0.0)
              .replace("dvl", **{f: 0.0 for f in DVL_ERRORS})
              .replace("magnetometer", roll_pitch_noise_deg=0.0, yaw_noise_deg=0.0)
              .replace("initial_error", vel_mps=(0.0, 0.0, 0.0), roll_pitch_deg=0.0, yaw_deg=0.0))
    for method, res in _run(config).items():
        _assert_healthy(res)
        assert res.vel_err_mps[-1, 0] < 1e-4, method
        assert res.att_err_deg[-1, 0] < 1e-3, method
        assert res.p_floor_count[0] == 0, method


def test_floors_keep_realistic_noises_bit_for_bit_and_replace_zero():
    table2 = Config()
    assert noise_floors.dvl_beam_sigma_mps(table2.dvl.noise_mps) == table2.dvl.noise_mps
    assert noise_floors.depth_sigma_m(table2.pressure.depth_noise_m) == table2.pressure.depth_noise_m
    np.testing.assert_array_equal(noise_floors.mag_attitude_sigma_rad(table2.magnetometer.noise_rad),
                                  table2.magnetometer.noise_rad)
    assert noise_floors.dvl_beam_sigma_mps(0.0) == noise_floors.DVL_BEAM_NOISE_FLOOR_MPS == 1e-3
    assert noise_floors.depth_sigma_m(0.0) == noise_floors.DEPTH_NOISE_FLOOR_M == 1e-3
    np.testing.assert_array_equal(noise_floors.mag_attitude_sigma_rad(np.zeros(3)), np.full(3, 1e-4))
    # each floor is far below the Table 2 noise it stands in for
    assert noise_floors.DVL_BEAM_NOISE_FLOOR_MPS < table2.dvl.noise_mps / 20
    assert noise_floors.DEPTH_NOISE_FLOOR_M < table2.pressure.depth_noise_m / 10
    assert noise_floors.MAG_ATTITUDE_NOISE_FLOOR_RAD < table2.magnetometer.noise_rad.min() / 100


def test_process_noise_floor_only_replaces_zero_densities():
    table2 = Config()
    q = noise_psd(table2.imu, table2.dvl)
    assert (q > 100 * PROCESS_NOISE_PSD_FLOOR).all()              # Table 2 is untouched, with a wide margin
    zero = table2.imu.ideal()
    np.testing.assert_array_equal(noise_psd(zero, table2.dvl.ideal()), PROCESS_NOISE_PSD_FLOOR)
    assert (PROCESS_NOISE_PSD_FLOOR > 0).all()


def test_loose_velocity_with_zero_beam_noise_is_the_floored_solution():
    A = beam_directions_b(np.deg2rad(20.0))
    v_true = np.array([[2.0, 0.1, -0.05], [1.0, -0.2, 0.3]])
    y = v_true @ A.T
    available = np.array([[True] * 4, [True, True, False, True]])
    v, cov, A_pinv, valid = solve_velocity(A, y, available, 0.0)
    v1, cov1, _, _ = solve_velocity(A, y, available, noise_floors.DVL_BEAM_NOISE_FLOOR_MPS)
    assert valid.all()
    np.testing.assert_allclose(v, v_true, rtol=0, atol=1e-12)        # noise-free beams: the exact velocity
    np.testing.assert_array_equal(cov, cov1)
    assert np.all(np.linalg.eigvalsh(cov) > 0)


# ------------------------------------------------------------------------------------------ guarded update

def _toy_measurement(R_diag: tuple[float, float], H_rows: np.ndarray, nu: np.ndarray, batch: int = 1) -> Measurement:
    H = np.broadcast_to(H_rows, (batch,) + H_rows.shape).copy()
    R = np.broadcast_to(np.diag(R_diag), (batch, 2, 2)).copy()
    nu = np.broadcast_to(nu, (batch, 2)).copy()
    return Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.ones(batch, bool))


def _rows(*cols: tuple[slice, float]) -> np.ndarray:
    H = np.zeros((2, STATE.dim))
    for row, (block, value) in enumerate(cols):
        H[row, block.start] = value
    return H


def test_singular_innovation_covariance_fuses_nothing_and_is_recorded():
    """A zero-noise measurement of a state P knows exactly (S singular): LinAlgError before."""
    rng = np.random.default_rng(1)
    nom = _nominal(rng, (2,))
    P = np.broadcast_to(_spd(rng, STATE.dim, 0.05), (2, STATE.dim, STATE.dim)).copy()
    H = _rows((STATE.vel, 1.0), (STATE.pos, 1.0))
    meas = _toy_measurement((0.0, 0.0), H, np.array([0.01, -0.02]), batch=2)
    # entry 0: its row-2 state is known exactly (zero row and column), so S has a zero row
    P[0, STATE.pos.start, :] = 0.0
    P[0, :, STATE.pos.start] = 0.0
    P1, nom1, out = correct(P, nom, meas, 3.0)
    assert out.unusable.tolist() == [True, False]
    assert not out.fused[0] and out.rejected[0] and np.isnan(out.nis[0])
    np.testing.assert_array_equal(P1[0], P[0])
    np.testing.assert_array_equal(nom1.nav.pos_n[0], nom.nav.pos_n[0])
    np.testing.assert_array_equal(nom1.nav.C_nb[0], nom.nav.C_nb[0])
    # the other entry is updated as usual, and its NIS is nu^T S^-1 nu
    assert out.fused[1] and not out.rejected[1]
    S = H @ P[1] @ H.T
    assert out.nis[1] == pytest.approx(meas.innovation[1] @ np.linalg.solve(S, meas.innovation[1]), rel=1e-12)
    assert out.nis_dof.tolist() == [2, 2]


@pytest.mark.parametrize("bad", ["negative_R", "nan_P", "inf_R"])
def test_indefinite_or_non_finite_update_fuses_nothing(bad):
    rng = np.random.default_rng(2)
    nom = _nominal(rng, (1,))
    P = _spd(rng, STATE.dim, 0.05)[None]
    meas = _toy_measurement((0.01, 0.02), _rows((STATE.vel, 1.0), (STATE.pos, 1.0)), np.array([0.01, 0.0]))
    if bad == "negative_R":
        meas.R[0, 1, 1] = -10.0
    elif bad == "inf_R":
        meas.R[0, 0, 0] = np.inf
    else:
        P[0, 3, 3] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        P1, nom1, out = correct(P, nom, meas, 3.0)
    assert out.unusable[0] and not out.fused[0]
    np.testing.assert_array_equal(P1, P)
    np.testing.assert_array_equal(nom1.nav.pos_n, nom.nav.pos_n)
    np.testing.assert_array_equal(nom1.nav.C_nb, nom.nav.C_nb)
    np.testing.assert_allclose(nom1.vel_b, nom.vel_b, rtol=0, atol=1e-14)   # rebuilt from vel_n: round-off only


# ------------------------------------------------------------------------------------------ P conditioning

def test_condition_covariance_leaves_a_healthy_P_untouched():
    rng = np.random.default_rng(3)
    P = np.stack([_spd(rng, STATE.dim, s) for s in (1e-6, 1.0, 1e3)])
    P_out, repaired = condition_covariance(P)
    assert P_out is P and not repaired.any()


def test_condition_covariance_repairs_an_indefinite_P_and_counts_it():
    rng = np.random.default_rng(4)
    healthy = _spd(rng, STATE.dim, 0.05)
    lam, V = np.linalg.eigh(healthy)
    broken = (V * np.where(np.arange(STATE.dim) == 0, -1e-3 * lam.max(), lam)) @ V.T  # one negative eigenvalue
    scaled = np.diag(np.logspace(-5, 3, STATE.dim)) @ broken @ np.diag(np.logspace(-5, 3, STATE.dim))  # mixed units
    P = np.stack([healthy, broken, scaled, np.full((STATE.dim, STATE.dim), np.nan)])
    P_out, repaired = condition_covariance(P)
    assert repaired.tolist() == [False, True, True, False]       # the NaN entry cannot be repaired: left to the monitor
    np.testing.assert_array_equal(P_out[0], healthy)
    assert np.isnan(P_out[3]).all()
    for i in (1, 2):
        np.linalg.cholesky(P_out[i])                              # positive definite now
        np.testing.assert_array_equal(P_out[i], P_out[i].T)
        d = np.sqrt(np.diag(P_out[i]))
        corr_eig = np.linalg.eigvalsh(P_out[i] / np.outer(d, d))
        assert corr_eig.min() >= 0.5 * eskf.P_CORRELATION_EIGEN_FLOOR
        # a small repair: in correlation units P moves by about the negative eigenvalue it removed
        d0 = np.sqrt(np.abs(np.diag(P[i])))
        assert np.abs((P_out[i] - P[i]) / np.outer(d0, d0)).max() < 0.01


def test_condition_covariance_raises_a_negative_variance():
    P = np.diag(np.r_[-1e-3, np.ones(STATE.dim - 1)])[None]
    P_out, repaired = condition_covariance(P)
    assert repaired[0]
    np.linalg.cholesky(P_out[0])
    assert P_out[0, 0, 0] >= eskf.P_VARIANCE_FLOOR
    np.testing.assert_allclose(np.diag(P_out[0])[1:], 1.0, rtol=1e-8)


def test_safeguards_are_inert_on_a_healthy_run(monkeypatch):
    """On the normal path the floors, the S check and the P conditioning change nothing: the
    run equals, to 1e-9, the same run with every safeguard switched off (the code without them;
    measured against that commit: bit-identical, see benchmarks/numerics_regression.py)."""
    config = (Config().replace("trajectory", name="figure8", duration_s=120.0)
              .replace("run", methods=("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc"),
                       aiding=("dvl", "depth", "mag"))
              .replace("dvl", dropout_probability=0.3).replace("initial_error", mode="random"))
    guarded = _run(config, num_runs=2, seed=7)
    monkeypatch.setattr(noise_floors, "DVL_BEAM_NOISE_FLOOR_MPS", 0.0)
    monkeypatch.setattr(noise_floors, "DEPTH_NOISE_FLOOR_M", 0.0)
    monkeypatch.setattr(noise_floors, "MAG_ATTITUDE_NOISE_FLOOR_RAD", 0.0)
    monkeypatch.setattr(error_model, "PROCESS_NOISE_PSD_FLOOR", np.zeros_like(PROCESS_NOISE_PSD_FLOOR))
    monkeypatch.setattr(eskf, "_is_positive_definite", lambda A: np.ones(A.shape[:-2], dtype=bool))
    monkeypatch.setattr(filter_bank, "condition_covariance", lambda P: (P, np.zeros(P.shape[:-2], dtype=bool)))
    bare = _run(config, num_runs=2, seed=7)
    assert (guarded["vb"].updates["dvl"].mode == 2).any()           # the partial constructions were exercised
    for method, res in guarded.items():
        for name in ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m",
                     "nees", "est_pos_n"):
            np.testing.assert_allclose(getattr(res, name), getattr(bare[method], name), rtol=0, atol=1e-9,
                                       err_msg=f"{method} {name}")
        assert res.p_floor_count.tolist() == [0, 0]


def _spy_on_covariances(monkeypatch) -> dict[str, int]:
    """Check every P the runner goes on with, after each covariance step of the bank and after each
    conditioning (aiding epochs; the once-a-second check inside the compiled stretch sends a failure
    to the repair below): finite and positive definite (numpy's own Cholesky factorisation
    succeeds, the scale-free test). The compiled stretch between aiding epochs
    (loop.run_stops) is made to return after every covariance stop, so that each step's P is
    seen. -> calls per kind."""
    calls = {"propagate": 0, "condition": 0}
    real_check, real_stops = loop.positive_definite_bank, loop.run_stops
    real_repair = filter_bank.condition_covariance

    def check(P: np.ndarray) -> None:
        assert np.isfinite(P).all()
        np.linalg.cholesky(P)

    def positive_definite_bank(P):      # the conditioning's test; a failure goes to the repair below
        ok = real_check(P)
        if ok.all():
            check(P)
            calls["condition"] += 1
        return ok

    def repair(P):
        P_out, repaired = real_repair(P)
        check(P_out)
        calls["condition"] += 1
        return P_out, repaired

    def run_stops(schedule, s_from, s_to, counters, bank, *args):
        s, why = s_from, loop.STOPS_DONE
        while s < s_to:
            s, why = real_stops(schedule, s, s + 1, counters, bank, *args)
            calls["propagate"] += 1
            if why != loop.STOPS_REPAIR:
                check(loop.BankState(*bank).P)  # a repair needs the caller first (bank: a plain tuple)
            if why != loop.STOPS_DONE:
                return s, why           # the counters are updated in place by each call
        return s_to, loop.STOPS_DONE
    monkeypatch.setattr(loop, "positive_definite_bank", positive_definite_bank)
    monkeypatch.setattr(loop, "run_stops", run_stops)
    monkeypatch.setattr(filter_bank, "condition_covariance", repair)
    return calls


def _worst_legal(config: Config) -> Config:
    """Every IMU and DVL error at the top of its legal range (100-1200x Table 2)."""
    return config.replace("imu", **ERROR_LIMITS).replace(
        "dvl", noise_mps=1.0, bias_mps=0.5, bias_rw_mps_per_sqrt_s=5e-3, scale_factor_pct=10.0,
        scale_factor_rw_pct_per_sqrt_s=0.5)


@pytest.mark.slow
def test_worst_legal_errors_keep_P_positive_definite_and_the_state_finite(monkeypatch):
    """The issue: noise x1000 made P indefinite (minimum eigenvalue -0.049), LC's velocity error 1.2e7 m/s."""
    calls = _spy_on_covariances(monkeypatch)
    config = _worst_legal(_config(900.0, methods=("ins", "lc", "tc", "elc")))
    results = _run(config, num_runs=2, seed=3)
    assert calls["propagate"] >= 9000 and calls["condition"] >= 900    # 10 Hz and (at least) 1 Hz
    for method, res in results.items():
        assert np.isfinite(res.vel_err_mps).all() and np.isfinite(res.est_pos_n).all(), method
        assert (res.nees > 0).all(), method
    # with the scale factor's column of H at the averaged velocity (tauvcore.engine.scale_factor) the
    # errors stay at the level of this 1 m/s DVL: 0.5 to 1.5 m/s at the end, not flagged
    for method in ("lc", "tc", "elc"):
        assert (results[method].vel_err_mps[-1] < 3.0).all(), method
    # with the column at the current estimate, finite is not healthy: velocity errors of a hundred m/s
    # and more, hidden behind a DVL scale factor estimate near -100 %, which the monitor catches
    # without truth (the innovations look fine)
    plain = _run(config.replace("filter", scale_factor_velocity_tau_s=0.0), num_runs=2, seed=3)
    for method in ("lc", "tc", "elc"):
        assert plain[method].diverged.all(), method
        assert (plain[method].nees[-1] > 1000.0).all(), method
        assert (plain[method].vel_err_mps[-1] > 50.0).all(), method


@pytest.mark.parametrize("changes", [("imu", {"accel_bias_mg": 100.0}), ("dvl", {"scale_factor_pct": 10.0}),
                                     ("imu", {"gyro_bias_deg_per_h": 3600.0})])
def test_largest_legal_bias_or_scale_factor_does_not_raise(changes):
    section, values = changes
    config = _config(40.0, methods=("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc"),
                     aiding=("dvl", "depth", "mag")).replace(section, **values)
    for method, res in _run(config, num_runs=2).items():
        assert np.isfinite(res.vel_err_mps).all() and (res.nees > 0).all(), method


# ------------------------------------------------------------------------------------------ divergence monitor

def _chi2_updates(rng: np.random.Generator, U: int, R: int, dof: int, scale: float = 1.0):
    t = np.arange(1, U + 1, dtype=float)
    nis = scale * rng.chisquare(dof, (U, R))
    return t, nis, np.full((U, R), dof), np.ones((U, R), bool), np.ones((U, R), bool)


def test_monitor_never_flags_consistent_innovations_over_ten_hours():
    t, nis, dof, fused, valid = _chi2_updates(np.random.default_rng(5), 36_000, 8, 3)
    assert np.isnan(innovation_divergence_s(t, nis, dof, fused, valid)).all()


def test_monitor_flags_inflated_innovations_at_the_first_full_window():
    t, nis, dof, fused, valid = _chi2_updates(np.random.default_rng(6), 200, 8, 3, scale=4.0)
    np.testing.assert_array_equal(innovation_divergence_s(t, nis, dof, fused, valid), t[NIS_WINDOW_UPDATES - 1])


def test_monitor_window_bound_is_the_chi_square_quantile():
    window = NIS_WINDOW_UPDATES
    bound = stats.chi2.isf(1e-6, 3 * window)
    t = np.arange(1.0, window + 1)
    nis = np.full((window, 2), 3.0)
    nis[:, 0] = bound / window * 0.999
    nis[:, 1] = bound / window * 1.001
    ones = np.ones((window, 2), bool)
    out = innovation_divergence_s(t, nis, np.full((window, 2), 3), ones, ones)
    assert np.isnan(out[0]) and out[1] == t[-1]


def test_monitor_lockout_needs_consecutive_rejections_of_valid_updates():
    U = 40
    t = np.arange(U, dtype=float) * 2.0
    fused = np.ones((U, 3), bool)
    valid = np.ones((U, 3), bool)
    fused[5:5 + LOCKOUT_UPDATES - 1, 0] = False              # one short of a lockout
    fused[5:5 + LOCKOUT_UPDATES, 1] = False                  # a lockout, complete at update 5 + 9
    fused[5:5 + LOCKOUT_UPDATES + 3, 2] = False              # ... with invalid epochs in between (skipped)
    valid[[8, 9, 10], 2] = False
    out = innovation_divergence_s(t, np.ones((U, 3)), np.ones((U, 3), int), fused, valid)
    assert np.isnan(out[0])
    assert out[1] == t[5 + LOCKOUT_UPDATES - 1]
    assert out[2] == t[5 + LOCKOUT_UPDATES + 2]


def test_nees_of_a_broken_entry_is_nan_and_the_others_exact():
    """A diverged run's record (NaN or singular P) must not raise or spoil the other runs'."""
    P = np.stack([np.diag([1.0, 4.0, 0.25]), np.full((3, 3), np.nan), np.zeros((3, 3)), np.diag([1.0, 2.0, np.inf])])
    dx = np.array([[1.0, 2.0, 0.5]] * 4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = nees(dx, P)
    assert out[0] == pytest.approx(1.0 + 1.0 + 1.0, rel=1e-15)
    assert np.isnan(out[1:]).all()


def test_sensor_error_prior_bound_is_the_bonferroni_chi_square_quantile():
    n = 11
    k = np.sqrt(stats.chi2.isf(1e-6 / n, 1))                  # 5.3 sigma for the 11 sensor-error states
    prior_var = np.linspace(1e-8, 1.0, n) ** 2
    sigma = np.sqrt(prior_var)
    est = np.zeros((4, n))
    est[1, 3] = 0.999 * k * sigma[3]
    est[2, 3] = -1.001 * k * sigma[3]
    est[3, -1] = 1.001 * k * sigma[-1]
    assert implausible_sensor_errors(est, prior_var).tolist() == [False, False, True, True]
    assert 5.3 < k < 5.5


def test_the_banks_compiled_sensor_check_flags_what_implausible_sensor_errors_flags():
    """tauvcore.engine.loop.flag_implausible_bank (the filter bank's check at every aiding
    epoch) against the numpy function: the same entries flagged, at the first time, NaN estimates
    never flagged, an entry flagged once keeps its first time."""
    from tauvcore.engine.loop import flag_implausible_bank
    from tauvcore.engine.monitor import sensor_prior_bound

    rng = np.random.default_rng(5)
    M, R = 3, 50
    var0, rate = np.linspace(1e-6, 1e-2, 11), np.linspace(1e-9, 1e-5, 11)
    flagged = np.full((M, R), np.nan)
    expected = np.full((M, R), np.nan)
    for t in (1.0, 10.0, 100.0):
        est = rng.normal(size=(M, R, 11)) * 2.5 * np.sqrt(var0 + rate * t)   # ~30 % of entries beyond 5.3 sigma
        est[0, 0, 1] = np.nan
        ba, bg, bdvl, sf = (np.ascontiguousarray(a) for a in (est[..., :3], est[..., 3:6], est[..., 6:10],
                                                              est[..., 10]))
        flag_implausible_bank(ba, bg, bdvl, sf, var0, rate, t, sensor_prior_bound(11), flagged)
        wild = implausible_sensor_errors(est, var0 + rate * t)
        expected[wild & np.isnan(expected)] = t
    np.testing.assert_array_equal(flagged, expected)
    assert np.isfinite(flagged).any() and np.isnan(flagged).any() and (flagged > 1.0).any()


def test_monitor_flags_a_filter_tuned_far_below_its_sensor():
    """DVL tuned at 2 mm/s while the sensor has Table 2's 42 mm/s: the gate rejects nearly every
    ping (NEES in the hundreds and thousands). INS has no innovations and is not judged."""
    tuning = _config(60.0, methods=("ins", "lc", "tc", "elc")).replace("dvl", noise_mps=0.002)
    results = _run(tuning, num_runs=3, seed=3, truth_config=tuning.replace("dvl", noise_mps=0.042))
    for method in ("lc", "tc", "elc"):
        res = results[method]
        assert res.diverged.all(), method
        assert (res.diverged_at_s <= 40.0).all(), (method, res.diverged_at_s)
        assert (res.nees[-1] > 40.0).all(), method               # the flag is right: the filter is inconsistent
    assert not results["ins"].diverged.any()


def test_monitor_flags_a_non_finite_solution_at_its_epoch():
    config = _config(20.0, methods=("ins", "lc", "tc"), aiding=("dvl", "depth", "mag"))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng, 2)
    k = int(round(10.05 * config.imu.rate_hz))
    sim.imu.dv_b[k, 1, 0] = np.nan                         # one corrupt IMU sample in run 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        results = run(config, sim, rng)
    for method, res in results.items():
        assert res.diverged.tolist() == [False, True], method
        assert res.diverged_at_s[1] == pytest.approx(10.1), method
        assert np.isnan(res.nees[-1, 1]) and np.isfinite(res.nees[-1, 0]), method


@pytest.mark.slow
@pytest.mark.parametrize("trajectory", ["straight", "figure8", "lawnmower"])
def test_monitor_never_flags_healthy_default_runs(trajectory):
    config = (Config().replace("trajectory", name=trajectory)
              .replace("run", methods=("lc", "tc", "nsv", "elc", "plcf")).replace("initial_error", mode="random"))
    for method, res in _run(config, num_runs=6, seed=11).items():
        assert not res.diverged.any(), (trajectory, method, res.diverged_at_s)
        assert res.p_floor_count.tolist() == [0] * 6
