"""The dashboard's run pool: streaming, completion, Stop within a second, a bounded number of
workers with runs waiting in line, and a dead worker replaced (no browser)."""

import os
import queue
import signal
import time

import pytest

from app.dashboard.worker import WORKER_NICENESS, RunPool, death_message
from tauvcore.config import METHODS, Config, to_dict


@pytest.fixture(scope="module")
def pool():
    p = RunPool(workers=1)
    yield p
    p.shutdown()


def _next(handle, timeout: float = 60.0):
    return handle.queue.get(timeout=timeout)


def test_a_run_streams_truth_progress_and_final_results(pool: RunPool) -> None:
    config = Config().replace("trajectory", duration_s=12.0).replace("run", methods=("ins", "tc"))
    handle = pool.start(to_dict(config), 1)
    kind, truth = _next(handle)
    assert kind == "truth" and truth["pos_n"].shape[1] == 3 and truth["t_s"][-1] == pytest.approx(12.0)
    kinds = []
    while True:
        msg = _next(handle)
        kinds.append(msg[0])
        if msg[0] == "done":
            break
    results, stopped = msg[1], msg[2]
    assert not stopped and set(results) == {"ins", "tc"} and results["tc"].t_s[-1] == pytest.approx(12.0)
    assert "progress" in kinds                          # every 2 s of simulated time


def test_stop_ends_a_long_run_within_a_second(pool: RunPool) -> None:
    config = Config().replace("trajectory", duration_s=3000.0).replace("run", methods=METHODS)
    handle = pool.start(to_dict(config), 1)
    assert _next(handle)[0] == "truth"
    assert _next(handle)[0] == "sensors"                # each progress comes after the raw data so far
    assert _next(handle)[0] == "progress"
    t0 = time.monotonic()
    handle.stop()
    while True:
        msg = _next(handle, timeout=5.0)
        if msg[0] == "done":
            break
    assert time.monotonic() - t0 < 1.0
    results, stopped = msg[1], msg[2]
    assert stopped and results["ins"].t_s[-1] < 3000.0


def test_stop_while_truth_is_generated_ends_the_run_and_the_pool_recovers(pool: RunPool) -> None:
    """Truth and sensors are generated before the filter loop polls Stop (a 20,000 s mission
    takes several seconds there): the worker is killed after STOP_GRACE_S, the run ends as
    stopped (no error), a new worker replaces it, and the next run works."""
    from app.dashboard.worker import STOP_GRACE_S
    config = Config().replace("trajectory", duration_s=20000.0).replace("run", methods=("ins",))
    handle = pool.start(to_dict(config), 1)
    pids_before = set(pool.pids())
    time.sleep(0.3)              # computing now, inside simulate()
    assert pool.busy_pids(), "the run should be computing"
    t0 = time.monotonic()
    handle.stop()
    deadline = t0 + STOP_GRACE_S + 10.0
    while not handle.finished() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert handle.finished()
    assert time.monotonic() - t0 < STOP_GRACE_S + 3.0
    leftovers = []
    while not handle.queue.empty():
        leftovers.append(handle.queue.get_nowait()[0])
    assert "error" not in leftovers, leftovers
    later = pool.start(to_dict(Config().replace("trajectory", duration_s=10.0)), 1)
    kinds = []
    while "done" not in kinds:
        kinds.append(_next(later)[0])
    assert set(pool.pids()) != pids_before      # the killed worker was replaced


def test_bad_configuration_reports_one_line(pool: RunPool) -> None:
    data = to_dict(Config())
    data["dvl"]["noise_mps"] = -1.0
    handle = pool.start(data, 1)
    kind, message = _next(handle)
    assert kind == "error" and "dvl.noise_mps" in message and "-1.0" in message
    with pytest.raises(queue.Empty):
        handle.queue.get(timeout=0.5)


def test_yoo_s_methods_and_the_rpm_fallback_reach_the_dashboard_with_the_final_results(pool: RunPool) -> None:
    """Given LC with the RPM fallback beside Yoo 2014's INS-DVL and VKF over the long-range
    mission's first trench, the final results carry every method in the configuration's order,
    the 12-state filter's own NEES dimensions, the VKF's trace (the Seabed tab's figure) and LC's
    RPM updates. Live progress carries what the engine reports live (the first paper's methods)."""
    from tauvcore.config import from_dict, merge, trajectory_preset
    config = from_dict(merge(trajectory_preset("longrange"), {
        "trajectory": {"name": "longrange", "duration_s": 320.0},
        "run": {"methods": ["lc", "ins-dvl", "vkf"], "rpm_fallback": True}}))
    handle = pool.start(to_dict(config), 1)
    progress = []
    while (msg := _next(handle, timeout=120.0))[0] != "done":
        if msg[0] == "progress":
            progress.append(set(msg[2]))
    results, stopped = msg[1], msg[2]
    assert not stopped and list(results) == ["lc", "ins-dvl", "vkf"]
    assert results["vkf"].block_dims["full"] == 12 and results["lc"].block_dims is None
    trace = results["vkf"].vkf_trace
    assert trace["t_s"][-1] == pytest.approx(320.0) and trace["rpm_in_use"][-1].all()
    assert results["lc"].updates["rpm"].fused.any()                 # over the trench: the RPM's velocity
    assert progress and all(seen <= set(results) and "lc" in seen for seen in progress)


def test_monte_carlo_runs_draw_initial_errors_per_run(pool: RunPool) -> None:
    config = Config().replace("trajectory", duration_s=5.0).replace("run", methods=("ins",))
    handle = pool.start(to_dict(config), 3)
    while (msg := _next(handle))[0] != "done":
        pass
    ins = msg[1]["ins"]
    assert ins.vel_err_mps.shape[1] == 3
    # initial errors are drawn per run (random mode), so the runs start apart
    assert len({round(float(v), 6) for v in ins.pos_err_m[0]}) == 3


def test_a_run_computes_in_a_lower_priority_process_than_the_server(pool: RunPool) -> None:
    """The run computes in a worker process of lower priority (higher niceness), so the server's
    own interpreter (which answers every tab's controls) keeps the CPU while a long run goes on.
    (This used to time a busy loop in the server during a run: a timed assertion, which failed on
    a loaded machine; the server's speed during a run is measured by benchmarks/server_speed.py.)"""
    config = Config().replace("trajectory", duration_s=3000.0).replace("run", methods=METHODS)
    handle = pool.start(to_dict(config), 1)
    assert _next(handle)[0] == "truth"
    busy = pool.busy_pids()
    try:
        assert len(busy) == 1 and busy[0] != os.getpid()
        server_nice = os.getpriority(os.PRIO_PROCESS, 0)
        assert os.getpriority(os.PRIO_PROCESS, busy[0]) == min(19, server_nice + WORKER_NICENESS)
    finally:
        handle.stop()
        while _next(handle, timeout=10.0)[0] != "done":
            pass


LONG = Config().replace("trajectory", duration_s=3000.0).replace("run", methods=("ins", "lc", "tc"))
MEDIUM = Config().replace("trajectory", duration_s=1000.0).replace("run", methods=("ins", "lc"))   # ~3 s
STOP_QUEUED_WITHIN_S = 0.5
SHORT = Config().replace("trajectory", duration_s=5.0).replace("run", methods=("ins", "lc"))


def _until_done(handle, timeout: float = 60.0):
    while (msg := _next(handle, timeout))[0] not in ("done", "error"):
        pass
    return msg


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] == "Z"   # a zombie is dead, not yet reaped
    except FileNotFoundError:
        return True


def test_a_run_waits_in_line_while_every_worker_is_busy(pool: RunPool) -> None:
    first = pool.start(to_dict(LONG), 1)
    assert _next(first)[0] == "truth"
    second = pool.start(to_dict(SHORT), 1)
    third = pool.start(to_dict(SHORT), 1)
    assert (first.position(), second.position(), third.position()) == (0, 1, 2)
    time.sleep(0.5)
    assert second.queue.empty() and not second.finished()        # one worker: it waits
    third.stop()                                                  # a waiting run never starts
    assert third.finished() and third.queue.empty() and second.position() == 1
    first.stop()
    assert _until_done(first)[0] == "done"
    assert _until_done(second)[0] == "done" and second.position() == 0


def test_stop_on_a_waiting_run_ends_it_at_once_and_no_worker_ever_receives_it(pool: RunPool) -> None:
    """Given the one worker busy on a run, when a second run is queued its place is 1 at once
    (the dashboard's "Waiting for a free worker"); when Stop is pressed on it, it is finished
    within 0.5 s without a message, no worker receives it, and the computing run goes on to its
    end, not stopped."""
    first = pool.start(to_dict(MEDIUM), 1)
    assert _next(first)[0] == "truth"
    busy = pool.busy_pids()
    waiting = pool.start(to_dict(LONG), 1)
    assert (first.position(), waiting.position()) == (0, 1)
    t0 = time.monotonic()
    waiting.stop()
    while not waiting.finished() and time.monotonic() - t0 < STOP_QUEUED_WITHIN_S:
        time.sleep(0.01)
    assert waiting.finished(), f"a waiting run still not finished {STOP_QUEUED_WITHIN_S} s after Stop"
    assert waiting.position() == 0 and waiting.queue.empty()
    assert pool.busy_pids() == busy                               # the same worker, on the first run only
    kind, results, stopped = _until_done(first)
    assert kind == "done" and not stopped and results["lc"].t_s[-1] == pytest.approx(MEDIUM.trajectory.duration_s)
    # a worker handed the stopped run would now compute it: busy, and its truth (or an error)
    # on its queue
    time.sleep(1.0)
    assert pool.busy_pids() == [] and waiting.queue.empty()


def test_a_killed_worker_ends_its_run_with_a_message_and_is_replaced(pool: RunPool) -> None:
    handle = pool.start(to_dict(LONG), 1)
    assert _next(handle)[0] == "truth"
    [pid] = pool.busy_pids()
    waiting = pool.start(to_dict(SHORT), 1)                       # queued behind the doomed run
    os.kill(pid, signal.SIGKILL)                                  # as the out-of-memory killer does
    kind, message = _until_done(handle, timeout=10.0)
    assert kind == "error" and "worker computing this run died" in message and "signal 9" in message
    assert handle.finished()
    # the replacement computes the run that was waiting, and later runs
    assert _until_done(waiting, timeout=120.0)[0] == "done"
    assert pid not in pool.pids() and len(pool.pids()) == 1
    assert _until_done(pool.start(to_dict(SHORT), 1))[0] == "done"


def test_death_message_names_the_signal() -> None:
    assert "signal 9 (SIGKILL, as the out-of-memory killer does)" in death_message(-9)
    assert "signal 11 (SIGSEGV)" in death_message(-11)
    assert "exit status 1" in death_message(1)


def test_shutdown_kills_a_busy_worker_at_once(pool: RunPool) -> None:
    own = pool                  # the module's pool, shut down here (its teardown then does nothing)
    handle = own.start(to_dict(LONG), 1)
    assert _next(handle)[0] == "truth"
    pids = own.pids()
    assert len(pids) == 1 and own.busy_pids() == pids
    t0 = time.monotonic()
    own.shutdown()
    elapsed = time.monotonic() - t0
    assert all(_gone(p) for p in pids), pids
    assert elapsed < 1.5, elapsed                                 # killed, not awaited
    assert handle.finished()
    assert own.start(to_dict(SHORT), 1).queue.get(timeout=1.0)[0] == "error"


def test_worker_count_must_be_positive() -> None:
    with pytest.raises(ValueError, match="workers must be >= 1, got 0"):
        RunPool(workers=0)


def test_a_failed_run_is_reported_in_one_clean_line() -> None:
    from app.dashboard.worker import failure_message
    from tauvcore.validation import ConfigError
    assert failure_message(ConfigError("imu.gyro_noise_deg_per_sqrt_h must be within [0, 30], got 1e6")) == (
        "imu.gyro_noise_deg_per_sqrt_h must be within [0, 30], got 1e6")
    assert "LinAlgError" not in failure_message(MemoryError())
    assert failure_message(RuntimeError("boom")).startswith("the run failed unexpectedly (RuntimeError: boom)")


def test_a_log_is_replayed_by_a_worker(tmp_path) -> None:
    """``tauv serve --logs``: the worker replays a log, sending its configuration (the log's
    length and rate), its reference as the truth view, then the results; a bad log is one line
    naming its file and row, and the pool goes on."""
    from tauvcore.engine.simulation import SimChunk, simulate
    from tauvcore.logs import find_logs
    from tauvcore.logs.writer import simulation_tables, write_log
    config = Config().replace("trajectory", name="figure8", duration_s=15.0).replace("run", methods=("ins", "lc"))
    sim = simulate(config, __import__("numpy").random.default_rng(1))
    write_log(tmp_path / "dive", simulation_tables([SimChunk.whole(sim)]))
    logs = find_logs(tmp_path)
    assert logs == {"dive": str(tmp_path / "dive")}
    other = Config().replace("trajectory", duration_s=300.0).replace("run", methods=("ins", "lc"))
    pool = RunPool(workers=1)          # its own: the module's pool was shut down by a test above
    try:
        _replay_checks(pool, other, logs, tmp_path)
    finally:
        pool.shutdown()


def _replay_checks(pool: RunPool, other: Config, logs: dict, tmp_path) -> None:
    handle = pool.start(to_dict(other), 1, log_dir=logs["dive"])
    kind, replayed, source = _next(handle)
    assert kind == "config", replayed
    assert replayed["trajectory"]["duration_s"] == pytest.approx(15.0)
    assert replayed["run"]["ideal"] and not replayed["replay"]["initial_errors"]   # on the reference
    assert source["directory"] == logs["dive"] and source["start"].startswith("start: on the reference")
    kind, truth = _next(handle)
    assert kind == "truth" and truth["t_s"][-1] == pytest.approx(15.0)
    assert truth["propeller_rpm"] is None and truth["fin_angles_rad"] is None     # a log records no actuators
    while (msg := _next(handle))[0] != "done":
        pass
    assert msg[1]["lc"].t_s[-1] == pytest.approx(15.0) and not msg[2]
    (tmp_path / "dive" / "depth.csv").write_text("t_s,depth_m\n1.0,deep\n")
    handle = pool.start(to_dict(other), 1, log_dir=logs["dive"])
    kind, message = _next(handle)
    assert kind == "error" and "depth.csv" in message and "row 1" in message and "'deep'" in message


# ---------------------------------------------------------------------------- the truth view
def _output_step(config: Config) -> int:
    return int(round(config.imu.rate_hz / config.filter.output_rate_hz))


@pytest.mark.parametrize("duration_s", [5.0, 105.0], ids=["one chunk", "two chunks"])
def test_the_truth_view_of_a_dynamic_truth_carries_fins_and_propeller(duration_s: float) -> None:
    """Given the dynamic truth on the figure eight, when the worker builds the 3-D view's truth
    (chunks of 100 s, thinned to the output rate), then it carries the propeller and fins at the
    rows of pos_n and C_nb: the whole mission's vehicle record at every output epoch."""
    import numpy as np

    from app.dashboard.truth_view import truth_view
    from tauvcore.truth import generate
    config = Config().replace("trajectory", name="figure8", duration_s=duration_s, truth="dynamic")
    step = _output_step(config)
    view = truth_view(config, step)
    whole = generate(config.trajectory, config.earth, config.imu.rate_hz)
    rows = np.arange(0, whole.t_s.size, step)
    assert view["propeller_rpm"].shape == (rows.size,) and view["fin_angles_rad"].shape == (rows.size, 4)
    assert view["pos_n"].shape == (rows.size, 3) and view["C_nb"].shape == (rows.size, 3, 3)
    np.testing.assert_array_equal(view["t_s"], whole.t_s[rows])
    np.testing.assert_allclose(view["propeller_rpm"], whole.vehicle.propeller_rpm[rows], rtol=1e-12, atol=0)
    np.testing.assert_allclose(view["fin_angles_rad"], whole.vehicle.fin_angles_rad[rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(view["pos_n"], whole.pos_n[rows], rtol=0, atol=1e-9)
    # the vehicle flies: the propeller turns and the autopilot moves the fins in the turns
    assert np.all(view["propeller_rpm"] > 100.0)
    assert np.max(np.abs(view["fin_angles_rad"])) > np.radians(0.5)


def test_the_truth_view_of_the_kinematic_truth_has_no_actuators() -> None:
    from app.dashboard.truth_view import truth_view
    config = Config().replace("trajectory", name="figure8", duration_s=5.0)
    view = truth_view(config, _output_step(config))
    assert view["propeller_rpm"] is None and view["fin_angles_rad"] is None
    assert view["pos_n"].shape == (51, 3)


def test_the_truth_view_carries_the_seabed_under_the_longrange_mission() -> None:
    """Given the first 400 s of the long-range mission (its first trench from 300 s), when the
    worker builds the 3-D view's truth, then it carries the altitude above the seabed and each
    beam's slant range at the output epochs: the DVL simulation's own ranges (tauvcore.sensors.dvl),
    all four within range at the start's 60 m, all four beyond it (inf) over the trench's floor."""
    import numpy as np

    from app.dashboard.truth_view import truth_view
    from tauvcore.config import from_dict, merge, trajectory_preset
    from tauvcore.sensors.dvl import slant_ranges_m
    from tauvcore.truth import generate
    from tauvcore.truth.kinematic import bathymetry
    config = from_dict(merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange", "duration_s": 400.0}}))
    step = _output_step(config)
    view = truth_view(config, step)
    whole = generate(config.trajectory, config.earth, config.imu.rate_hz)
    rows = np.arange(0, whole.t_s.size, step)
    assert view["altitude_m"].shape == (rows.size,) and view["slant_range_m"].shape == (rows.size, 4)
    seabed = bathymetry(config.trajectory)
    # the echo sounder's altitude: the seabed under the tangent-plane position, less the true depth
    expected = seabed.depth_m(whole.pos_n[rows, 0], whole.pos_n[rows, 1]) - whole.depth_m[rows]
    np.testing.assert_allclose(view["altitude_m"], expected, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(view["slant_range_m"], slant_ranges_m(whole, rows, config.dvl, seabed))
    t = view["t_s"]
    start, floor = t < 250.0, (t > 330.0)
    np.testing.assert_allclose(view["altitude_m"][start], 60.0, rtol=0, atol=1e-6)
    assert np.isfinite(view["slant_range_m"][start]).all()
    assert np.all(view["slant_range_m"][start] < config.dvl.max_range_m)
    assert np.isinf(view["slant_range_m"][floor]).all()
    assert np.all(view["altitude_m"][floor] > config.vkf.switch_altitude_m)
    # the altitude crosses the DVL's limit at 300 s, to the output epoch
    first_high = t[np.argmax(view["altitude_m"] > config.dvl.max_altitude_m)]
    assert first_high == pytest.approx(300.0, abs=0.1 + 1e-9)


def test_a_replayed_log_s_truth_view_has_no_seabed() -> None:
    import types

    import numpy as np

    from app.dashboard.truth_view import log_truth_view
    truth = types.SimpleNamespace(num_samples=5, t_s=np.arange(5.0), pos_n=np.zeros((5, 3)),
                                  C_nb=np.broadcast_to(np.eye(3), (5, 3, 3)))
    dvl = types.SimpleNamespace(t_s=np.arange(5.0))
    view = log_truth_view(truth, Config(), dvl, 1)
    assert view["altitude_m"] is None and view["slant_range_m"] is None
    assert view["current_n_mps"] is None and view["vel_water_b"] is None      # nor a current


def test_stop_with_the_smoother_smooths_what_ran_however_long_it_takes(monkeypatch) -> None:
    """Stop during a smoothed run: the forward pass ends, the worker says it is smoothing and is let
    finish (not killed after the Stop grace, though the smoothing lasts longer), and the stopped
    results carry the smoothed results of what ran. The grace is the server's 2 s: the forward pass
    must heed Stop within it, which a loaded machine did not always do within 0.5 s (the worker
    was then killed, and the test waited for a message that never came)."""
    import app.dashboard.worker as worker_module

    monkeypatch.setattr(worker_module, "STOP_GRACE_S", 2.0)
    p = RunPool(workers=1)
    try:
        config = (Config().replace("trajectory", duration_s=3000.0)
                  .replace("run", methods=("ins", "lc", "tc", "nsv"), aiding=("dvl", "depth", "mag")))
        handle = p.start(to_dict(config), 12, smooth_mb=4.0)
        while _next(handle, timeout=120.0)[0] != "progress":
            pass
        time.sleep(6.0)  # a forward pass whose smoothing outlasts the grace (about 7 s on a quiet machine)
        stopped_at = time.monotonic()
        handle.stop()
        kinds = []
        while True:
            msg = _next(handle, timeout=120.0)
            kinds.append(msg[0])
            if msg[0] in ("done", "error"):
                break
        assert msg[0] == "done" and "smoothing" in kinds, kinds
        assert time.monotonic() - stopped_at > worker_module.STOP_GRACE_S   # it outlasted the grace
        results, stopped = msg[1], msg[2]
        lc = results["lc"]
        assert stopped and lc.t_s[-1] < 3000.0 and lc.smoothed is not None
        assert lc.smoothed.t_s.shape == lc.t_s.shape
        assert not (lc.smoothed.vel_err_mps == lc.vel_err_mps).all()
    finally:
        p.shutdown()
