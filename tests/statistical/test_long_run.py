"""Long straight run: heading is unobservable with the DVL alone, the magnetometer bounds it.

On a straight, level, constant-speed track nothing the DVL measures (body-frame velocity)
depends on heading, so the heading error is a random walk driven by the gyro (0.34 deg/sqrt(h),
3 deg/h turn-on bias the filter cannot separate from it): the filter's heading sigma grows and the
error with it, until, over many hours, the linearisation fails (the issue measured NEES 1065 after
10 hours at 29 deg; benchmarks/long_run.py measures the 10-hour figures). The magnetometer's
5.7 deg yaw at 0.5 Hz averages down to a bounded heading sigma, and the filter stays consistent.

One hour at the lowest legal IMU rate (50 Hz) and 1 Hz records keeps the cost to about 30 s of
one core; four seeded Monte Carlo runs (random initial errors) give the NEES band.
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.eval.metrics import average_nees_bounds, rms
from tauvcore.filter.layout import STATE

DURATION_S = 3600.0
NUM_RUNS = 4
SEED = 2024


def _lc_straight(aiding: tuple[str, ...]):
    config = (Config().replace("trajectory", name="straight", duration_s=DURATION_S)
              .replace("imu", rate_hz=50.0).replace("filter", output_rate_hz=1.0)
              .replace("run", methods=("lc",), aiding=aiding).replace("initial_error", mode="random"))
    rng = np.random.default_rng(SEED)
    return run(config, simulate(config, rng, NUM_RUNS), rng)["lc"]


@pytest.fixture(scope="module")
def dvl_only():
    return _lc_straight(("dvl",))


@pytest.fixture(scope="module")
def dvl_mag():
    return _lc_straight(("dvl", "mag"))


def _window(res, start_s: float, end_s: float) -> np.ndarray:
    return (res.t_s >= start_s) & (res.t_s <= end_s)


@pytest.mark.slow
def test_dvl_alone_heading_error_and_sigma_grow(dvl_only):
    res = dvl_only
    sigma = rms(res.att_sigma_deg, axis=1)                       # RMS over runs, per epoch
    error = rms(res.att_err_deg, axis=1)
    early, late = _window(res, 300.0, 900.0), _window(res, 3300.0, DURATION_S)
    assert np.all(np.diff(sigma[res.t_s >= 60.0]) >= -1e-9)        # the filter knows: its sigma only grows
    assert sigma[-1] > 3.0 * sigma[res.t_s == 600.0][0]
    assert sigma[-1] > 4.0                                          # deg, after one hour
    assert rms(error[late]) > 2.0 * rms(error[early])               # and the error follows it
    assert not res.diverged.any()                                   # nothing in the innovations shows it


@pytest.mark.slow
def test_magnetometer_bounds_the_heading_and_keeps_the_filter_consistent(dvl_only, dvl_mag):
    res = dvl_mag
    sigma = rms(res.att_sigma_deg, axis=1)
    error = rms(res.att_err_deg, axis=1)
    second_half = res.t_s >= DURATION_S / 2
    assert sigma[second_half].max() < 0.6                            # deg: bounded ...
    assert abs(sigma[-1] - sigma[res.t_s == 1800.0][0]) < 0.05       # ... and flat
    assert rms(error[second_half]) < 1.0
    assert error[-1] < 0.2 * rms(dvl_only.att_err_deg, axis=1)[-1]
    # consistent: the run-averaged NEES within its chi-square band at >= 90 % of the epochs
    lo, hi = average_nees_bounds(STATE.dim, NUM_RUNS)
    avg = res.nees[res.t_s > 0].mean(axis=1)
    assert ((avg >= lo) & (avg <= hi)).mean() >= 0.9, (lo, hi)
    assert lo <= avg.mean() <= hi
    assert not res.diverged.any() and not res.p_floor_count.any()
