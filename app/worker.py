"""A run in its own process, streaming progress to the dashboard through a queue.

A separate process keeps a long run from holding the server's interpreter (two tabs running at
once use both cores, and neither tab's controls wait on the other's run). Messages:

- ``("truth", dict)``: the truth at the output epochs and the DVL pings, for the 3-D view;
- ``("progress", t_s, results)``: results so far, every ``progress_interval_s`` simulated seconds;
- ``("done", results, stopped)``: the final (or, after Stop, partial) results;
- ``("error", message)``: one line, for a notification.
"""

from __future__ import annotations

import multiprocessing as mp
from typing import Any

import numpy as np

from tauvcore.config import from_dict
from tauvcore.eval.runner import run, simulate


def run_worker(config_dict: dict[str, Any], num_runs: int, queue: Any, stop_event: Any,
               progress_interval_s: float = 2.0) -> None:
    """Process entry point (picklable): simulate, run all methods, stream results."""
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
        results = run(config, sim, rng, progress=lambda t, res: queue.put(("progress", t, res)),
                      progress_interval_s=progress_interval_s, should_stop=stop_event.is_set)
        queue.put(("done", results, stop_event.is_set()))
    except Exception as exc:  # the dashboard shows it; the server keeps serving
        queue.put(("error", f"{type(exc).__name__}: {exc}"))


def start(config_dict: dict[str, Any], num_runs: int) -> tuple[mp.Process, Any, Any]:
    """Start a run process; returns (process, queue, stop_event)."""
    ctx = mp.get_context("spawn")   # no fork of a threaded server
    queue, stop_event = ctx.Queue(), ctx.Event()
    proc = ctx.Process(target=run_worker, args=(config_dict, num_runs, queue, stop_event), daemon=True)
    proc.start()
    return proc, queue, stop_event
