"""The dashboard's run pool: streaming, completion, and Stop within a second (no browser)."""

import queue
import time

import pytest

from app.worker import RunPool
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


def test_bad_configuration_reports_one_line(pool: RunPool) -> None:
    data = to_dict(Config())
    data["dvl"]["noise_mps"] = -1.0
    handle = pool.start(data, 1)
    kind, message = _next(handle)
    assert kind == "error" and "dvl.noise_mps" in message and "-1.0" in message
    with pytest.raises(queue.Empty):
        handle.queue.get(timeout=0.5)


def test_monte_carlo_runs_draw_initial_errors_per_run(pool: RunPool) -> None:
    config = Config().replace("trajectory", duration_s=5.0).replace("run", methods=("ins",))
    handle = pool.start(to_dict(config), 3)
    while (msg := _next(handle))[0] != "done":
        pass
    ins = msg[1]["ins"]
    assert ins.vel_err_mps.shape[1] == 3
    # initial errors are drawn per run (random mode), so the runs start apart
    assert len({round(float(v), 6) for v in ins.pos_err_m[0]}) == 3


def _busy_work_s() -> float:
    """Wall time of a fixed piece of interpreter-bound work in this (the server's) process."""
    t0 = time.perf_counter()
    total = 0
    for i in range(300_000):
        total += i * i % 7
    return time.perf_counter() - t0


def test_a_run_leaves_the_server_process_its_speed(pool: RunPool) -> None:
    """The run computes in a low-priority worker process, so the server's own interpreter (which
    answers every tab's controls) keeps its speed while a long run goes on."""
    baseline = min(_busy_work_s() for _ in range(5))
    config = Config().replace("trajectory", duration_s=3000.0).replace("run", methods=METHODS)
    handle = pool.start(to_dict(config), 1)
    assert _next(handle)[0] == "truth"
    during = min(_busy_work_s() for _ in range(5))
    handle.stop()
    while _next(handle, timeout=10.0)[0] != "done":
        pass
    assert during < 1.5 * baseline, (baseline, during)
