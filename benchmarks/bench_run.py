"""Wall time of the navigation core (a speed record, not a test).

    python benchmarks/bench_run.py

writes docs/results/bench_run.md (benchmarks/fragment.py), which docs/performance.md includes.

Times one 250 s run of each method alone and together, and a 30-run Monte Carlo of ``lc`` on
the figure eight (the NEES test's workload). Best of three, on this machine.
"""

from __future__ import annotations

import time

import fragment
import numpy as np

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.eval.montecarlo import monte_carlo


def best_of(fn, repeats: int = 3) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    rows = ["| workload | wall [s] |", "|---|---|"]
    from tauvcore.config import METHODS
    for methods in (("lc",), ("ins", "lc"), METHODS):
        config = Config().replace("trajectory", name="figure8").replace("run", methods=methods)

        def one() -> None:
            rng = np.random.default_rng(0)
            run(config, simulate(config, rng), rng)
        label = "all eight" if methods == METHODS else ",".join(methods)
        rows.append(f"| one 250 s run, figure8, methods {label} (simulation included) | {best_of(one):.2f} |")
    config = Config().replace("trajectory", name="figure8").replace("run", methods=("lc",))
    mc = best_of(lambda: monte_carlo(config, 30, np.random.default_rng(0)))
    rows.append(f"| 30-run Monte Carlo, figure8, lc, 250 s | {mc:.2f} |")
    table = "\n".join(rows) + "\n\nBest of three, in one process, the compiled code warm."
    print(table)
    print(f"written to {fragment.write('bench_run', table)}")


if __name__ == "__main__":
    main()
