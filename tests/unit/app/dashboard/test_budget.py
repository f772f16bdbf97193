"""The per-run memory estimate and budget of the dashboard.

The slow test runs real missions through app.dashboard.worker.run_worker in a fresh process each and
compares the estimate with the measured peak resident memory above the process's baseline.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

from app.dashboard import budget
from app.dashboard.budget import estimate_run, over_budget_message
from tauvcore.config import Config


def mission(duration_s: float, methods: tuple[str, ...] = ("ins", "lc", "tc", "nsv", "elc"),
            aiding: tuple[str, ...] = ("dvl",), name: str = "figure8") -> Config:
    return (Config().replace("trajectory", name=name, duration_s=duration_s)
            .replace("run", methods=methods, aiding=aiding))


def test_the_default_run_fits_the_default_budget_with_room() -> None:
    e = estimate_run(Config(), 1)
    assert e.total_bytes < 0.1 * budget.DEFAULT_BUDGET_BYTES
    assert over_budget_message(e, budget.DEFAULT_BUDGET_BYTES) is None


@pytest.mark.parametrize("duration_s, runs", [(250.0, 1000), (3600.0, 20), (36000.0, 20)])
def test_runs_past_the_budget_are_refused_with_the_size(duration_s: float, runs: int) -> None:
    """The most runs, and many runs of a long mission, were MemoryErrors in the server."""
    e = estimate_run(mission(duration_s), runs)
    message = over_budget_message(e, budget.DEFAULT_BUDGET_BYTES)
    assert message is not None
    assert f"{e.total_bytes / 2**30:.2f} GB" in message and "Duration" in message and "Runs" in message


def test_a_10_hour_mission_of_the_default_methods_fits_the_default_budget() -> None:
    """Results reduced to bins (tauvcore.eval.envelope) do not grow with the mission: the longest
    legal mission (10 h) of the dashboard's five default methods fits, at every IMU rate."""
    from app.dashboard.control_table import DEFAULT_METHODS
    from tauvcore.eval.envelope import SCREEN_BINS

    for rate_hz in (50.0, 150.0, 400.0):
        config = mission(36000.0, methods=DEFAULT_METHODS).replace("imu", rate_hz=rate_hz)
        e = estimate_run(config, 1)
        assert over_budget_message(e, budget.DEFAULT_BUDGET_BYTES) is None, (rate_hz, e)
        assert budget.kept_epochs(config) <= SCREEN_BINS < budget.output_epochs(config)
    one_hour = estimate_run(mission(3600.0), 1).results_bytes
    assert estimate_run(mission(36000.0), 1).results_bytes < 1.2 * one_hour


def test_the_estimate_grows_with_duration_runs_methods_and_aiding() -> None:
    base = estimate_run(mission(250.0), 4).total_bytes
    assert estimate_run(mission(500.0), 4).total_bytes > base
    assert estimate_run(mission(250.0), 8).total_bytes > base
    all_methods = ("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc")
    assert estimate_run(mission(250.0, methods=all_methods), 4).total_bytes > base
    assert estimate_run(mission(250.0, aiding=("dvl", "depth", "mag")), 4).total_bytes > base


def test_the_live_copy_bound_is_the_workers() -> None:
    from app.dashboard import worker
    assert budget.LIVE_EPOCHS == worker.PROGRESS_MAX_EPOCHS


def test_the_dynamic_truths_constants_are_its_own() -> None:
    from tauvcore.truth import dynamic
    assert budget.KNOT_DOUBLES == dynamic.KNOT_COLUMNS
    assert budget.CACHE_MAX_KNOTS == dynamic.CACHE_MAX_KNOTS


def test_the_budget_comes_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(budget.BUDGET_ENV, raising=False)
    assert budget.budget_bytes() == budget.DEFAULT_BUDGET_BYTES
    monkeypatch.setenv(budget.BUDGET_ENV, "512")
    assert budget.budget_bytes() == 512 * 2**20
    for bad in ("abc", "-5", "0", "nan", "inf"):
        monkeypatch.setenv(budget.BUDGET_ENV, bad)
        with pytest.raises(ValueError, match=f"{budget.BUDGET_ENV} must be a positive number of MB, got '{bad}'"):
            budget.budget_bytes()


MEASURE = textwrap.dedent("""
    import json, pickle, sys, threading
    from app.dashboard import budget, worker
    from tauvcore.config import Config, to_dict

    def status_bytes(key):
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key + ":"))

    def rss_bytes():
        return status_bytes("VmRSS")

    class PicklingQueue:
        # stands in for the manager queue: put() pickles the message, as its proxy does
        def put(self, message):
            if message[0] == "error":
                raise SystemExit(message[1])
            pickle.dumps(message)

    duration_s, runs, methods, aiding, name, truth, rate_hz, *smooth = json.loads(sys.argv[1])
    smooth_mb = smooth[0] if smooth else None
    config = (Config().replace("trajectory", name=name, duration_s=duration_s, truth=truth)
              .replace("run", methods=tuple(methods), aiding=tuple(aiding)).replace("imu", rate_hz=rate_hz))
    base = rss_bytes()
    worker.run_worker(to_dict(config), runs, PicklingQueue(), threading.Event(), smooth_mb=smooth_mb)
    # VmHWM, not ru_maxrss: ru_maxrss survives exec, so a child of a large pytest process would
    # report its parent's peak (658 MiB for every case in the full suite)
    peak = status_bytes("VmHWM")
    print(json.dumps({"measured": peak - base, "estimate": budget.estimate_run(config, runs, smooth_mb=smooth_mb).worker_peak_bytes}))
""")


@pytest.mark.slow
@pytest.mark.parametrize("duration_s, runs, methods, aiding, name, truth, rate_hz, smooth_mb", [
    (250.0, 1, ("ins", "lc", "tc", "nsv", "elc"), ("dvl",), "figure8", "kinematic", 150.0, None),  # the default
    (600.0, 1, ("ins",), ("dvl",), "straight", "kinematic", 150.0, None),           # truth generation dominates
    (250.0, 12, ("ins", "lc", "tc", "nsv", "elc"), ("dvl",), "figure8", "kinematic", 150.0, None),  # IMU, compensation
    (300.0, 6, ("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc"), ("dvl", "depth", "mag"), "lawnmower",
     "kinematic", 150.0, None),
    (600.0, 1, ("ins",), ("dvl",), "figure8", "dynamic", 150.0, None),              # the vehicle's kept knots
    (1200.0, 1, ("ins",), ("dvl",), "lawnmower", "dynamic", 150.0, None),           # too long to keep: streamed
    (10800.0, 1, ("ins", "lc", "tc", "nsv", "elc"), ("dvl",), "figure8", "kinematic", 50.0, None),  # 3 h in bins
    # with the smoother: its tape beyond 256 MB on disk; 3 h in bins holds the tape and its stores
    (250.0, 12, ("ins", "lc", "tc", "nsv", "elc"), ("dvl",), "figure8", "kinematic", 150.0, 256.0),
    (10800.0, 1, ("ins", "lc", "tc", "nsv", "elc"), ("dvl",), "figure8", "kinematic", 50.0, 256.0),
])
def test_the_estimate_bounds_the_measured_peak_within_1_5x(duration_s, runs, methods, aiding, name, truth,
                                                           rate_hz, smooth_mb) -> None:
    arg = json.dumps([duration_s, runs, methods, aiding, name, truth, rate_hz, smooth_mb])
    out = subprocess.run([sys.executable, "-c", MEASURE, arg], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    figures = json.loads(out.stdout.strip().splitlines()[-1])
    measured, estimate = figures["measured"], figures["estimate"]
    print(f"{duration_s:g} s x {runs} runs, {len(methods)} methods, {'+'.join(aiding)}, {truth}: "
          f"measured {measured / 2**20:.0f} MiB, estimate {estimate / 2**20:.0f} MiB ({estimate / measured:.2f}x)")
    assert measured <= estimate <= 1.5 * measured


def test_a_run_records_its_sensor_errors_only_where_they_fit(monkeypatch: pytest.MonkeyPatch) -> None:
    """The sensor errors' records (3 x 11 doubles per epoch, method and run) are asked for only
    when the run fits the budget with them; a run that fits only without them runs without them
    (the worker's results carry none), and only a run that does not fit even so is refused."""
    import threading

    from app.dashboard import worker
    from tauvcore.config import to_dict
    config = mission(30.0)
    with_sensors, without = estimate_run(config, 4), estimate_run(config, 4, sensor_errors=False)
    assert with_sensors.total_bytes > without.total_bytes
    assert budget.records_sensor_errors(config, 4, with_sensors.total_bytes)
    assert not budget.records_sensor_errors(config, 4, with_sensors.total_bytes - 1)

    def results_under(limit_mb: float):
        monkeypatch.setenv(budget.BUDGET_ENV, f"{limit_mb:.6f}")
        seen = []
        worker.run_worker(to_dict(config), 4, type("Q", (), {"put": lambda self, m: seen.append(m)})(),
                          threading.Event())
        assert seen[-1][0] == "done", seen[-1]
        return seen[-1][1]

    between = (with_sensors.total_bytes + without.total_bytes) / 2 / 2**20
    assert all(r.sensor_est is None for r in results_under(between).values())
    recorded = results_under(with_sensors.total_bytes / 2**20 + 1)
    assert all(r.sensor_est is not None and r.sensor_est.shape[1] == 4 for r in recorded.values())


def test_large_runs_go_without_the_sensor_errors_whatever_the_budget() -> None:
    """Records over SENSOR_RECORDS_MAX_BYTES travel with every result: 20 runs of five methods
    over 250 s are recorded, 21 are not, with any budget."""
    config = mission(250.0)
    assert budget.records_sensor_errors(config, 20, 2**40)
    assert not budget.records_sensor_errors(config, 21, 2**40)
