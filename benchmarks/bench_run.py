"""Wall time of the navigation core (a speed record, not a test).

    python benchmarks/bench_run.py

Times one 250 s run of each method alone and together, and a 30-run Monte Carlo of ``lc`` on
the figure eight (the NEES test's workload). Best of three, on this machine.
"""

from __future__ import annotations

import time

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
    print("| workload | wall [s] |\n|---|---|")
    from tauvcore.config import METHODS
    for methods in (("lc",), ("ins", "lc"), METHODS):
        config = Config().replace("trajectory", name="figure8").replace("run", methods=methods)

        def one() -> None:
            rng = np.random.default_rng(0)
            run(config, simulate(config, rng), rng)
        label = "all eight" if methods == METHODS else ",".join(methods)
        print(f"| one 250 s run, figure8, methods {label} (simulation included) | {best_of(one):.2f} |")
    config = Config().replace("trajectory", name="figure8").replace("run", methods=("lc",))
    mc = best_of(lambda: monte_carlo(config, 30, np.random.default_rng(0)))
    print(f"| 30-run Monte Carlo, figure8, lc, 250 s | {mc:.2f} |")


if __name__ == "__main__":
    main()
