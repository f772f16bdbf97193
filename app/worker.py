"""Runs in a pool of worker processes, streaming progress to the dashboard through queues.

Separate processes keep a long run from holding the server's interpreter: two tabs running at
once use both cores, and neither tab's controls wait on the other's run. The processes start
with the server (numpy, scipy and tauvcore already imported when Run is pressed) and lower
their own priority, so on a small machine the interactive server and the browser win the CPU
over a background computation. Messages on a run's queue:

- ``("truth", dict)``: the truth at the output epochs and the DVL pings, for the 3-D view;
- ``("progress", t_s, results)``: results so far, every ``progress_interval_s`` simulated seconds;
- ``("done", results, stopped)``: the final (or, after Stop, partial) results;
- ``("error", message)``: one line, for a notification.
"""

from __future__ import annotations

import dataclasses
import multiprocessing as mp
import os
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.config import from_dict
from tauvcore.eval.runner import MethodResult, run, simulate

WORKER_NICENESS = 10
PROGRESS_MIN_WALL_S = 0.8     # live updates at most this often (wall time)
PROGRESS_MAX_EPOCHS = 1200    # output epochs per live update (evenly thinned, last one kept)
STOP_POLL_S = 0.05            # how often the run asks the (cross-process) stop flag


def _throttled(check: Callable[[], bool], period_s: float) -> Callable[[], bool]:
    """``check`` asked at most every ``period_s`` (it is a round trip to the manager process)."""
    state = {"t": 0.0, "value": False}

    def wrapped() -> bool:
        now = time.monotonic()
        if not state["value"] and now - state["t"] >= period_s:
            state["t"], state["value"] = now, bool(check())
        return state["value"]
    return wrapped


def thin(results: dict[str, MethodResult], max_epochs: int) -> dict[str, MethodResult]:
    """Every n-th output epoch (and the last) of each series, so at most ~max_epochs remain."""
    out = {}
    for method, r in results.items():
        n = len(r.t_s)
        if n <= max_epochs:
            out[method] = r
            continue
        step = int(np.ceil(n / max_epochs))
        keep = np.r_[np.arange(0, n - 1, step), n - 1]
        out[method] = dataclasses.replace(
            r, t_s=r.t_s[keep], vel_err_mps=r.vel_err_mps[keep], att_err_deg=r.att_err_deg[keep],
            pos_err_m=r.pos_err_m[keep], vel_sigma_mps=r.vel_sigma_mps[keep], att_sigma_deg=r.att_sigma_deg[keep],
            pos_sigma_m=r.pos_sigma_m[keep], nees=r.nees[keep], est_pos_n=r.est_pos_n[keep])
    return out


def _init_worker() -> None:
    try:
        os.nice(WORKER_NICENESS)
    except OSError:  # not permitted: run at normal priority
        pass


def _warm() -> int:
    return os.getpid()


def run_worker(config_dict: dict[str, Any], num_runs: int, queue: Any, stop_event: Any,
               progress_interval_s: float = 2.0) -> None:
    """Simulate, run all methods, stream results (runs in a pool process)."""
    try:
        config = from_dict(config_dict)
        if num_runs > 1:
            config = config.replace("initial_error", mode="random")
        rng = np.random.default_rng(config.run.seed)
        sim = simulate(config, rng, num_runs)
        step = max(1, int(round(config.imu.rate_hz / config.filter.output_rate_hz)))
        truth = sim.truth
        queue.put(("truth", {
            "t_s": truth.t_s[::step], "pos_n": truth.pos_n[::step], "C_nb": truth.C_nb[::step],
            "ping_t_s": sim.dvl.t_s, "ping_available": sim.dvl.available[:, 0, :],
        }))
        last_sent = [0.0]

        def progress(t: float, res: dict[str, MethodResult]) -> None:
            # at most one message per PROGRESS_MIN_WALL_S, thinned: a live view needs the shape
            # of the curves, not every epoch of a long run (the final message has them all)
            now = time.monotonic()
            if now - last_sent[0] >= PROGRESS_MIN_WALL_S:
                queue.put(("progress", t, thin(res, PROGRESS_MAX_EPOCHS)))
                last_sent[0] = now

        results = run(config, sim, rng, progress=progress, progress_interval_s=progress_interval_s,
                      should_stop=_throttled(stop_event.is_set, STOP_POLL_S))
        queue.put(("done", results, stop_event.is_set()))
    except Exception as exc:  # the dashboard shows it; the server keeps serving
        queue.put(("error", f"{type(exc).__name__}: {exc}"))


@dataclass
class RunHandle:
    """One submitted run: its future, message queue and stop flag."""

    future: Future
    queue: Any
    stop_event: Any

    def stop(self) -> None:
        self.stop_event.set()
        self.future.cancel()   # a run still waiting for a free process never starts

    def finished(self) -> bool:
        return self.future.done()


class RunPool:
    """The server's worker processes (one per core by default)."""

    def __init__(self, workers: int = 2) -> None:
        ctx = mp.get_context("spawn")   # no fork of a threaded server
        self._manager = ctx.Manager()
        self._executor = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker)
        for f in [self._executor.submit(_warm) for _ in range(workers)]:
            f.result()

    def start(self, config_dict: dict[str, Any], num_runs: int) -> RunHandle:
        queue, stop_event = self._manager.Queue(), self._manager.Event()
        future = self._executor.submit(run_worker, config_dict, num_runs, queue, stop_event)
        return RunHandle(future=future, queue=queue, stop_event=stop_event)

    def shutdown(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)
        self._manager.shutdown()
