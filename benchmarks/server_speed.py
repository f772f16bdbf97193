"""The dashboard server's own speed while a run computes in its worker pool.

    python benchmarks/server_speed.py [--samples 10]

Times a fixed piece of interpreter-bound work in this process (standing in for the server's
thread that answers every tab's controls) before and during a 3000 s run of all eight methods
in app.dashboard.worker's pool (a niced worker process), and prints the ratio. The minimum of several
samples is kept: other processes on a shared machine add delay, never speed. On a 2-core
machine the ratio is about 1.0-1.2; it exceeds 1 when the machine has fewer free cores than
workers + 1.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.dashboard.worker import RunPool
from tauvcore.config import METHODS, Config, to_dict


def busy_work_s() -> float:
    """Wall time of a fixed piece of interpreter-bound work in this process."""
    t0 = time.perf_counter()
    total = 0
    for i in range(300_000):
        total += i * i % 7
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=10)
    args = parser.parse_args()
    pool = RunPool(1)
    try:
        baseline = min(busy_work_s() for _ in range(args.samples))
        config = Config().replace("trajectory", duration_s=3000.0).replace("run", methods=METHODS)
        handle = pool.start(to_dict(config), 1)
        assert handle.queue.get(timeout=120)[0] == "truth"
        during = min(busy_work_s() for _ in range(args.samples))
        handle.stop()
        while handle.queue.get(timeout=60)[0] not in ("done", "error"):
            pass
    finally:
        pool.shutdown()
    print(f"{os.cpu_count()} cores; server busy work alone {1e3 * baseline:.1f} ms, during a run "
          f"{1e3 * during:.1f} ms: ratio {during / baseline:.2f}")


if __name__ == "__main__":
    main()
