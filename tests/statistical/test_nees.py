"""Filter consistency over seeded Monte Carlo runs: NEES within chi-square bounds (navlie) and
mean(error^2 / sigma^2) near one (pyins)."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.eval.metrics import average_nees_bounds
from tauvcore.filter.layout import STATE

NUM_RUNS = 30
SEED = 2024


@pytest.fixture(scope="module")
def lc_figure8():
    cfg = (Config().replace("trajectory", name="figure8").replace("initial_error", mode="random")
           .replace("run", methods=("lc",)))
    rng = np.random.default_rng(SEED)
    sim = simulate(cfg, rng, NUM_RUNS)
    res = run(cfg, sim, rng)["lc"]
    t = res.t_s
    dvl_epochs = (np.abs(t - np.round(t)) < 1e-9) & (t > 0)
    return cfg, res, dvl_epochs


@pytest.mark.slow
def test_run_averaged_nees_within_chi_square_bounds(lc_figure8):
    cfg, res, at_dvl = lc_figure8
    assert res.nees.shape[1] == NUM_RUNS
    assert at_dvl.sum() == int(cfg.trajectory.duration_s)           # one DVL epoch per second
    avg = res.nees[at_dvl].mean(axis=1)
    lo, hi = average_nees_bounds(STATE.dim, NUM_RUNS)
    inside = (avg >= lo) & (avg <= hi)
    assert inside.mean() >= 0.9, (lo, hi, avg[~inside])
    # not consistent "by accident" from a few epochs: the overall average is near the state dimension
    assert lo <= avg.mean() <= hi


@pytest.mark.slow
def test_velocity_error_over_sigma_is_near_one(lc_figure8):
    cfg, res, at_dvl = lc_figure8
    ratio = res.vel_err_mps[at_dvl] ** 2 / res.vel_sigma_mps[at_dvl] ** 2
    assert 0.7 <= ratio.mean() <= 1.5, ratio.mean()


@pytest.mark.slow
def test_dvl_updates_are_fused(lc_figure8):
    """The consistency above is that of a filter that actually uses the DVL (gate at 3 sigma)."""
    cfg, res, at_dvl = lc_figure8
    dvl = res.updates["dvl"]
    assert dvl.valid.all()
    assert dvl.fused.mean() > 0.97


@pytest.mark.slow
def test_lc_is_consistent_over_an_hour_on_the_ellipsoid_with_the_1_deg_per_h_imu():
    """Issue 10: LC over 30 runs of a one-hour mission (7.2 km of 1 km figure eights, descending
    from 20 m to 50 m in 857 s, then level 10 m over the seabed, within the DVL's range) on
    WGS-84 with Yoo 2014's Table 1 IMU (scale factors and misalignments included): the
    run-averaged NEES of the full state stays in the two-sided 99 % band on average and at 80 %
    of the DVL epochs or more (measured 22.1 against [17.2, 23.1], 82 %). The position
    block alone is the least consistent (NEES/3 about 1.4 here, as on the flat earth with the
    Table 2 IMU: not an effect of the ellipsoid)."""
    import dataclasses

    from tauvcore.engine.mission import run_streaming
    from tauvcore.sensors.imu import imu_profile
    trajectory = dict(name="figure8", duration_s=3600.0, turn_radius_m=1000.0, dive_rate_mps=0.035)
    cfg = (Config().replace("trajectory", **trajectory).replace("initial_error", mode="random")
           .replace("imu", **dataclasses.asdict(imu_profile("yoo-table1"))).replace("run", methods=("lc",)))
    assert cfg.earth.model == "wgs84" and cfg.imu.has_axis_errors
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(2025).spawn(NUM_RUNS)]
    res = run_streaming(cfg, rngs, NUM_RUNS)["lc"]
    t = res.t_s
    at_dvl = (np.abs(t - np.round(t)) < 1e-9) & (t > 0)
    avg = res.nees[at_dvl].mean(axis=1)
    lo, hi = average_nees_bounds(STATE.dim, NUM_RUNS)
    assert lo <= avg.mean() <= hi, (lo, hi, avg.mean())
    assert ((avg >= lo) & (avg <= hi)).mean() >= 0.8
