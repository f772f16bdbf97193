"""Yoo 2014's 24-minute mission with every method of both papers: how long it takes (a
measurement, not a test; its target: under 3 s after import).

    python benchmarks/longrange.py [--repeats 5] [--runs 1]

writes docs/results/longrange.md (benchmarks/fragment.py), which docs/performance.md includes.

The mission is ``tauv run --trajectory longrange`` (1,440 s at 10 knots over the trenches; IMU
100 Hz, DVL 5 Hz: 144,000 IMU samples, 7,200 pings) streamed as the CLI streams it
(tauvcore.engine.mission.run_streaming), compiled code warm (a 20 s mission first). Wall time of the
whole run, median and spread of ``--repeats``, for: the simulation with the INS alone; the first
paper's eight methods; Yoo's two; all ten.
"""

from __future__ import annotations

import argparse
import time

import fragment
import numpy as np

from tauvcore.config import (
    ALL_METHODS,
    METHODS,
    YOO_METHODS,
    from_dict,
    merge,
    trajectory_preset,
)
from tauvcore.engine.mission import run_streaming

TARGET_S = 3.0


def _config(methods: tuple[str, ...], duration_s: float | None = None):
    trajectory = {"name": "longrange"} if duration_s is None else {"name": "longrange", "duration_s": duration_s}
    return from_dict(merge(trajectory_preset("longrange"), {"trajectory": trajectory,
                                                          "run": {"methods": list(methods)}}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=1, help="Monte Carlo runs per batch")
    args = parser.parse_args()
    if args.repeats < 1 or args.runs < 1:
        parser.error(f"--repeats and --runs must be at least 1, got {args.repeats} and {args.runs}")
    run_streaming(_config(ALL_METHODS, 20.0), np.random.default_rng(0))           # compile / load the cache
    rows = ["| methods | median [s] | min-max [s] |", "|---|---|---|"]
    for label, methods in (("INS only (the simulation)", ("ins",)), ("the first paper's 8", METHODS),
                           ("Yoo's 2 (ins-dvl, vkf)", YOO_METHODS), ("all 10", ALL_METHODS)):
        config = _config(methods)
        times = []
        for repeat in range(args.repeats):
            t0 = time.perf_counter()
            run_streaming(config, np.random.default_rng(repeat), num_runs=args.runs)
            times.append(time.perf_counter() - t0)
        verdict = f" (target < {TARGET_S:g} s: {'met' if np.median(times) < TARGET_S else 'NOT met'})" \
            if methods == ALL_METHODS and args.runs == 1 else ""
        rows.append(f"| {label} | {np.median(times):.2f}{verdict} | {min(times):.2f}-{max(times):.2f} |")
    table = "\n".join(rows) + (
        f"\n\nlongrange, 1,440 s, {args.runs} run(s) per batch, wall time over {args.repeats} repeats, the "
        "compiled code warm."
    )
    print(table)
    print(f"written to {fragment.write('longrange', table)}")


if __name__ == "__main__":
    main()
