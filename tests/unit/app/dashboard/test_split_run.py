"""A dashboard Monte Carlo on both workers (app.dashboard.split_run): the same numbers as one
worker, to 1e-9, and as ``tauv mc``'s study with the same seed; the first batch's truth and live
results pass as they come, the final message carries every run; Stop stops both batches; an
error of either is the run's; what is not split stays on one worker (no browser)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from app.dashboard import split_run
from app.dashboard.split_run import SplitRun, splits
from app.dashboard.worker import RunPool, run_worker
from tauvcore.config import Config, to_dict
from tauvcore.eval.study import run_chunk
from tests.unit.helpers.same_results import assert_same_results

RUNS = 5
CONFIG = (Config().replace("trajectory", name="figure8", duration_s=20.0).replace("dvl", beams=(1, 2))
          .replace("run", methods=("ins", "lc", "tc", "nsv", "elc"), seed=17))


@pytest.fixture(scope="module")
def pool():
    p = RunPool(workers=2)
    yield p
    p.shutdown()


class _Messages(list):
    def put(self, message) -> None:
        self.append(message)


def _read(handle, timeout_s: float = 120.0) -> list:
    """Every message of ``handle`` until its last."""
    out, deadline = [], time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            out.append(handle.queue.get(timeout=0.1))
        except Exception:  # noqa: BLE001 - queue.Empty
            if handle.finished() and handle.queue.empty():
                return out
    raise AssertionError(f"the run did not end in {timeout_s} s: {[m[0] for m in out]}")


def test_both_workers_give_one_worker_s_numbers_and_the_study_s(pool: RunPool) -> None:
    assert pool.idle_workers() == 2 and splits(CONFIG, RUNS, None, pool)
    handle = SplitRun(pool, to_dict(CONFIG), RUNS, progress_interval_s=5.0)
    messages = _read(handle)
    kinds = [m[0] for m in messages]
    assert kinds[0] == "truth" and kinds[-1] == "done" and kinds.count("done") == 1 and "error" not in kinds
    assert kinds.count("truth") == 1  # the second batch sends its final results only
    live = [m[2] for m in messages if m[0] == "progress"]
    assert live and all(r["tc"].vel_err_mps.shape[1] == 3 for r in live)  # the first batch's runs so far
    results, stopped = messages[-1][1], messages[-1][2]
    assert not stopped and results["tc"].vel_err_mps.shape[1] == RUNS
    one = _Messages()
    run_worker(to_dict(CONFIG), RUNS, one, threading.Event(), progress_interval_s=5.0)
    assert one[-1][0] == "done"
    assert_same_results(results, one[-1][1])
    study = run_chunk(CONFIG, CONFIG.run.seed, 0, RUNS)  # tauv mc --seed 17 --runs 5
    for method, r in study.items():
        for name in ("vel_err_mps", "pos_err_m", "att_err_deg", "nees", "nees_block"):
            np.testing.assert_allclose(getattr(results[method], name), getattr(r, name), rtol=1e-9, atol=1e-12,
                                       err_msg=f"{method} {name}")


def test_stop_stops_both_batches_and_joins_what_both_reached(pool: RunPool) -> None:
    config = CONFIG.replace("trajectory", duration_s=390.0)  # held whole: 3901 epochs at 10 Hz
    assert splits(config, 4, None, pool)
    handle = SplitRun(pool, to_dict(config), 4, progress_interval_s=2.0)
    while handle.queue.get(timeout=60.0)[0] != "progress":
        pass
    assert len(pool.busy_pids()) == 2
    handle.stop()
    t0 = time.monotonic()
    messages = _read(handle, 10.0)
    assert time.monotonic() - t0 < 3.0
    assert messages[-1][0] == "done", messages[-1]
    results, stopped = messages[-1][1], messages[-1][2]
    assert stopped
    t_end = results["tc"].t_s[-1]
    assert 0.0 < t_end < 390.0 and results["tc"].vel_err_mps.shape == (len(results["tc"].t_s), 4)
    assert all(np.isfinite(r.vel_err_mps).all() for r in results.values())
    deadline = time.monotonic() + 10.0
    while pool.idle_workers() < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert pool.idle_workers() == 2


def test_an_error_of_the_batches_is_the_run_s_once_and_frees_both_workers(pool: RunPool) -> None:
    bad = to_dict(CONFIG) | {"trajectory": {"name": "nowhere"}}
    messages = _read(SplitRun(pool, bad, 4), 60.0)
    assert [m[0] for m in messages] == ["error"] and "nowhere" in messages[0][1]
    deadline = time.monotonic() + 10.0
    while pool.idle_workers() < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert pool.idle_workers() == 2


def test_what_is_not_split_stays_on_one_worker(pool: RunPool) -> None:
    assert not splits(CONFIG, 1, None, pool)                      # one run
    assert not splits(CONFIG, RUNS, "/some/log", pool)            # a replay
    assert not splits(CONFIG.replace("trajectory", duration_s=20000.0), RUNS, None, pool)  # reduced to bins
    with pytest.raises(ValueError, match="at least 2 runs"):
        SplitRun(pool, to_dict(CONFIG), 1)
    busy = pool.start(to_dict(CONFIG.replace("trajectory", duration_s=3000.0)), 1)
    deadline = time.monotonic() + 10.0
    while pool.idle_workers() == 2 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert not splits(CONFIG, RUNS, None, pool)                   # another tab's run on a worker
    busy.stop()
    _read(busy, 10.0)


def test_the_joining_thread_names_a_failure_and_stops_the_batches(pool: RunPool, monkeypatch) -> None:
    def broken(a, b):
        raise ValueError("the batches' t_s differ")
    monkeypatch.setattr(split_run, "_joined", broken)
    messages = _read(SplitRun(pool, to_dict(CONFIG.replace("trajectory", duration_s=5.0)), 2), 60.0)
    assert [m[0] for m in messages][-1] == "error" and "could not be joined" in messages[-1][1]
