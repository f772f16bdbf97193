"""Yoo 2014's navigation methods in the engine (tauvcore.engine.yoo_bank): ``ins-dvl`` and ``vkf``."""

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, merge, trajectory_preset
from tauvcore.engine.mission import Watch, run, run_streaming
from tauvcore.engine.simulation import simulate
from tauvcore.eval.consistency import method_consistency
from tests.unit.tauvcore.engine.yoo_reference import use_numpy_bank


def _longrange(duration_s: float, **run_section) -> Config:
    raw = merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange", "duration_s": duration_s},
                                                 "run": {"methods": ["ins", "lc", "ins-dvl", "vkf"], **run_section}})
    return from_dict(raw)


def test_with_ideal_sensors_both_follow_the_truth() -> None:
    """No sensor or initial error: every update agrees with the INS, over the trench too (the
    VKF's RPM velocity is exact once learnt: the kinematic truth's RPM is eq. 20 inverted). What
    remains (7e-7 m/s, 0.2 mm, 4e-6 deg over 400 s) is the lever arm's rate taken to first order."""
    config = _longrange(400.0, ideal=True)
    rng = np.random.default_rng(0)
    results = run(config, simulate(config, rng), rng)
    for method in ("ins-dvl", "vkf"):
        r = results[method]
        assert np.max(r.vel_err_mps) < 1e-5 and np.max(r.pos_err_m) < 1e-2 and np.max(r.att_err_deg) < 1e-4, method
    assert results["vkf"].updates["dvl"].fused.sum() > results["ins-dvl"].updates["dvl"].fused.sum()


def test_vkf_is_ins_dvl_while_the_dvl_is_in_range() -> None:
    """Eq. 29 picks the DVL whenever the altitude is within the threshold: over the first
    paper's seabed (altitude about 40 m) the two methods are one filter, number for number."""
    config = Config().replace("trajectory", name="figure8", duration_s=60.0).replace("run", methods=("ins-dvl", "vkf"))
    rng = np.random.default_rng(4)
    results = run(config, simulate(config, rng), rng)
    for name in ("vel_err_mps", "att_err_deg", "pos_err_m", "nees"):
        np.testing.assert_array_equal(getattr(results["vkf"], name), getattr(results["ins-dvl"], name), err_msg=name)


def test_over_the_trench_the_vkf_keeps_aiding_and_ins_dvl_coasts() -> None:
    """Beyond range (300-480 s) no beam returns: INS-DVL has nothing to fuse and its velocity
    error grows; the VKF's RPM velocity, learnt before, keeps the error at the centimetre level."""
    config = _longrange(480.0)
    results = run_streaming(config, np.random.default_rng(1))
    t = results["vkf"].t_s
    trench = (t > 320.0) & (t < 480.0)
    dvl_only, with_rpm = results["ins-dvl"], results["vkf"]
    assert np.mean(with_rpm.vel_err_mps[trench]) < 0.5 * np.mean(dvl_only.vel_err_mps[trench])
    assert np.mean(with_rpm.vel_err_mps[trench]) < 0.1
    up_dvl, up_vkf = dvl_only.updates["dvl"], with_rpm.updates["dvl"]
    in_trench = (up_dvl.t_s > 320.0) & (up_dvl.t_s < 470.0)
    assert not up_dvl.fused[in_trench].any() and up_vkf.fused[in_trench].all()


def test_yoo_methods_report_their_own_dimensions_and_are_consistent_in_range() -> None:
    """NEES of the 12-state filter over 12 (sensor: 6), position NaN; on the figure eight with
    Table 2's IMU its velocity and tilt NEES/dim lie near 1."""
    config = Config().replace("trajectory", name="figure8").replace("run", methods=("ins-dvl",))
    results = run_streaming(config, np.random.default_rng(2))
    c = method_consistency(results["ins-dvl"])
    assert c.nees["full"].dim == 12 and c.nees["sensor"].dim == 6
    assert np.isnan(c.nees["pos"].per_dim)
    assert 0.5 < c.nees["vel"].per_dim < 1.5 and 0.5 < c.nees["tilt"].per_dim < 1.5


@pytest.mark.parametrize("chunk_s", [7.3, 1000.0])
def test_yoo_methods_do_not_depend_on_the_chunk_size(chunk_s: float) -> None:
    config = _longrange(60.0)
    a = run_streaming(config, np.random.default_rng(3), chunk_s=10.0)
    b = run_streaming(config, np.random.default_rng(3), chunk_s=chunk_s)
    for method in ("ins-dvl", "vkf"):
        np.testing.assert_array_equal(a[method].vel_err_mps, b[method].vel_err_mps)
        np.testing.assert_array_equal(a[method].nees, b[method].nees)


def test_the_vkf_learns_the_rpm_models_scale_factor_and_bias_in_the_engine() -> None:
    """10 seeded runs of the long-range mission: while the DVL is in range the VKF's sf and b
    errors against the RPM model's truth (tauvcore.sensors.rpm) stay within 3 of the filter's own
    sigmas (a consistent filter: outside at 0.3 % of run-epochs in expectation, and the errors move
    slowly, so fewer than 3 % is the bound), and the speed changes of the first minute bring sf's
    sigma below a tenth of its prior (1.7e-5 against 4e-4 m/s per rpm). The DVL's own scale factor
    and bias are set to zero here: the VKF learns the speed the DVL measures, so a DVL 0.7 % off
    makes sf 0.7 % off (1.6e-5, one of its sigmas), which its covariance does not know of."""
    config = (_longrange(900.0).replace("run", methods=("vkf",))
              .replace("dvl", scale_factor_pct=0.0, scale_factor_rw_pct_per_sqrt_s=0.0, bias_mps=0.0,
                       bias_rw_mps_per_sqrt_s=0.0))
    trace = run_streaming(config, np.random.default_rng(8), num_runs=10)["vkf"].vkf_trace
    t, x, sigma = trace["t_s"], trace["x"], trace["sigma"]
    learning = (t > 120.0)[:, None] & ~trace["rpm_in_use"]
    sf_err = np.abs(x[..., 1] - trace["sf_true"])
    b_err = np.abs(x[..., 2] - trace["b_true"])
    assert np.mean(sf_err[learning] > 3.0 * sigma[..., 1][learning]) < 0.03
    assert np.mean(b_err[learning] > 3.0 * sigma[..., 2][learning]) < 0.03
    before_trench = np.searchsorted(t, 290.0)
    assert np.all(sigma[before_trench, :, 1] < 0.1 * config.vkf.initial_sf_sigma_mps_per_rpm)
    assert trace["rpm_in_use"][(t > 320.0) & (t < 470.0)].all()


def test_rpm_fallback_aids_the_first_papers_methods_where_they_had_no_dvl_velocity() -> None:
    """``run.rpm_fallback``: until the first ping at which any method has no DVL velocity nothing
    changes, number for number; over the trench LC and TC fuse the RPM velocity (source "rpm") instead of coasting, and
    their velocity error stays at centimetres."""
    base = _longrange(480.0).replace("run", methods=("lc", "tc"))
    plain = run_streaming(base, np.random.default_rng(6))
    aided = run_streaming(base.replace("run", rpm_fallback=True), np.random.default_rng(6))
    first_coast = min(plain[m].updates["dvl"].t_s[~plain[m].updates["dvl"].valid[:, 0]][0] for m in ("lc", "tc"))
    for method in ("lc", "tc"):
        t = plain[method].t_s
        before = t < first_coast
        np.testing.assert_array_equal(aided[method].vel_err_mps[before], plain[method].vel_err_mps[before])
        rpm = aided[method].updates["rpm"]
        in_trench = (rpm.t_s > 320.0) & (rpm.t_s < 470.0)
        assert rpm.fused[in_trench].all() and not rpm.valid[rpm.t_s < first_coast - 1.0].any()
        trench = (t > 320.0) & (t < 480.0)
        # within a DVL's error of the truth: the RPM speed carries the DVL's scale factor (0.7 % of
        # 5.1 m/s) and its sway and heave are a guessed zero (0.1 m/s); coasting, 0.3 m/s and more
        assert np.mean(aided[method].vel_err_mps[trench]) < 0.15
        assert np.mean(aided[method].vel_err_mps[trench]) < 0.5 * np.mean(plain[method].vel_err_mps[trench])
    assert "rpm" not in plain["lc"].updates


def _numpy_bank(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make the engine run the Yoo methods with the numpy reference (yoo_reference.py, beside this file)."""
    use_numpy_bank(monkeypatch)


def _assert_results_equal(fast: dict, slow: dict, rtol: float = 1e-9) -> None:
    """Every float of every MethodResult (series, updates, the VKF's trace) equal to ``rtol``
    relative to max(1, |value|), NaN where the other is NaN; every flag identical."""
    import dataclasses

    def same(a: object, b: object, where: str) -> None:
        if isinstance(a, dict):
            assert a.keys() == b.keys(), where
            for key in a:
                same(a[key], b[key], f"{where}.{key}")
        elif dataclasses.is_dataclass(a):
            for f in dataclasses.fields(a):
                same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
        elif isinstance(a, np.ndarray) and a.dtype.kind == "f":
            assert a.shape == b.shape, where
            np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=where)
            ok = ~np.isnan(a)
            assert np.all(np.abs(a[ok] - b[ok]) <= rtol * np.maximum(1.0, np.abs(b[ok]))), where
        elif isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=where)
        else:
            assert a == b, where

    assert fast.keys() == slow.keys()
    for method in fast:
        same(fast[method], slow[method], method)


def _case_config(case: str) -> Config:
    """The configuration of a case of the compiled loop's equality tests (their docstrings)."""
    if case == "flat-figure8":
        config = Config().replace("trajectory", name="figure8", duration_s=120.0).replace("earth", model="flat")
        config = config.replace("run", methods=("ins-dvl", "vkf"))
    else:
        config = _longrange(400.0).replace("run", methods=("vkf", "ins-dvl"))
        if case.startswith("noisy"):
            config = config.replace("dvl", beyond_range="noisy")
        if case.startswith("mag"):  # the magnetometer's corrections between the compiled spans
            config = config.replace("run", aiding=("dvl", "mag"))
        if case.startswith("current"):
            config = config.replace("trajectory", current_n_mps=(0.0, 0.3, 0.0)).replace(
                "run", aiding=("dvl", "mag"))
            config = config.replace("dvl", water_track="beyond_range", current_states="gauss-markov",
                                    current_tau_s=600.0) if "water" in case else config.replace(
                "dvl", current_states="random-walk")
    return config


@pytest.mark.parametrize("case", ["lost-geodetic", "noisy-geodetic", "flat-figure8", "mag-geodetic",
                                  "current-water-geodetic", "current-rpm-geodetic"])
def test_the_compiled_bank_equals_the_numpy_reference(case: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """tauvcore.filter.families.yoo.model_kernels against the numpy reference (yoo_reference.py), to 1e-9, every field: over the
    first trench wall and into it (300-400 s: beams lost one by one, then the VKF takes over), with
    Yoo's noisy beams (the gate refusing some), on the flat earth in turns, and in a cross current
    with the current as states, water-track beyond range (Gauss-Markov) or the VKF's RPM through
    the water (random walk); 3 runs each."""
    config = _case_config(case)
    fast = run_streaming(config, np.random.default_rng(3), num_runs=3)
    _numpy_bank(monkeypatch)
    slow = run_streaming(config, np.random.default_rng(3), num_runs=3)
    from tauvcore.engine import mission
    assert mission.BANKS["yoo"].made  # type: ignore[attr-defined]  # the numpy reference ran
    _assert_results_equal(fast, slow)
    ups = fast["vkf"].updates["dvl"]
    assert ups.fused.any() and (case == "flat-figure8" or fast["vkf"].vkf_trace["rpm_in_use"].any())
    if case.startswith("noisy"):
        assert fast["ins-dvl"].updates["dvl"].rejected.any()
    if case.startswith("mag"):
        assert fast["vkf"].updates["mag"].fused.mean() > 0.95
    if case.startswith("current"):
        assert fast["vkf"].state_est is not None and np.ptp(fast["vkf"].state_est[:, :, 1]) > 0.05
        assert ("water" in fast["ins-dvl"].updates) == ("water" in case)
        if "water" in case:
            assert fast["ins-dvl"].updates["water"].fused.any()


def test_progress_and_stop_reach_the_yoo_methods() -> None:
    """With only Yoo methods (no 20-state bank) the live progress comes when the 20-state bank's
    would (every 5 s of simulated time), with results up to then, and a stop request ends the
    results at that epoch; alongside the 20-state methods, their progress carries the Yoo methods
    too, up to the same time, and a stop cuts both at the same epoch."""
    times = {}
    for methods in (("lc",), ("ins-dvl", "vkf"), ("lc", "vkf")):
        config = _longrange(30.0).replace("run", methods=methods, aiding=("dvl", "mag"))
        seen: list[tuple[float, dict]] = []
        run_streaming(config, np.random.default_rng(0), watch=Watch(progress=lambda t, r: seen.append((t, r))))
        times[methods] = [t for t, _ in seen]
        for t, partial in seen:
            assert set(partial) == set(methods)
            for r in partial.values():
                assert r.t_s[-1] == pytest.approx(t), methods
                assert r.updates["mag"].t_s[-1] <= t + 1e-9, methods
        calls = iter(range(1000))
        stopped = run_streaming(config, np.random.default_rng(0), watch=Watch(should_stop=lambda: next(calls) >= 120))
        ends = {m: r.t_s[-1] for m, r in stopped.items()}
        assert len(set(ends.values())) == 1 and 10.0 < ends[methods[-1]] < 29.0, ends
        if "vkf" in methods:
            assert stopped["vkf"].updates["dvl"].t_s[-1] <= ends["vkf"]
            assert stopped["vkf"].updates["mag"].t_s[-1] <= ends["vkf"]
            assert stopped["vkf"].vkf_trace["t_s"][-1] <= ends["vkf"]
    assert len(times[("lc",)]) >= 5
    assert times[("ins-dvl", "vkf")] == times[("lc",)] == times[("lc", "vkf")]


@pytest.mark.parametrize("case", ["flat-figure8", "mag-geodetic", "current-water-geodetic"])
def test_the_compiled_smoother_equals_the_numpy_reference(case: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """With the smoother, Yoo 2014's compiled loop writes the tape itself (its pings' marks, its
    output epochs' and, between its spans, the magnetometer's): every field of the filtered and
    the smoothed results equals the numpy reference's to 1e-9, in turns on the flat earth, with
    the magnetometer's corrections and with the current as states and water-track; 3 runs each."""
    from tauvcore.engine.smoothing import SmoothOptions

    config = _case_config(case)
    fast = run_streaming(config, np.random.default_rng(3), num_runs=3, smooth=SmoothOptions())
    _numpy_bank(monkeypatch)
    slow = run_streaming(config, np.random.default_rng(3), num_runs=3, smooth=SmoothOptions())
    from tauvcore.engine import mission
    assert mission.BANKS["yoo"].made  # type: ignore[attr-defined]  # the numpy reference ran
    _assert_results_equal(fast, slow)
    for method in fast:  # the smoother moved the estimate (how much: test_smoothing_engine.py)
        smoothed = fast[method].smoothed
        assert smoothed is not None and np.any(smoothed.vel_err_mps != fast[method].vel_err_mps)
