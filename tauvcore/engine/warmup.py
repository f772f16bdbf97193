"""Compile the filter bank's kernels once per install, before anything needs them fast.

    python -m tauvcore.engine.warmup

numba compiles a kernel at its first call and caches the machine code (``cache=True``), so the
first run after an install pays about 20 s of compilation. The README's two commands run this
module right after installing, so that neither the first dashboard run (whose worker processes
would otherwise compile side by side while the server answers its clients) nor the first test
pays it. It runs a 12 s mission that takes every path of the engine: all eleven methods (the
20-state bank's nine, Yoo 2014's two in their own compiled loop), DVL, depth and magnetometer
aiding, four, two and three beams, two runs with random initial errors, streamed in two
chunks, and the smoother's backward pass over the same mission (one method); then 2 s of the dynamic truth (the 6-DOF vehicle's compiled equations of motion and
autopilot).
"""

from __future__ import annotations

import time

import numpy as np

from tauvcore.config import ALL_METHODS, Config
from tauvcore.sensors.dvl import Outage


def warm_up() -> float:
    """Run the warm-up mission; returns its wall time [s]."""
    from tauvcore.engine.mission import run_streaming

    config = (
        Config()
        .replace("trajectory", name="figure8", duration_s=12.0)
        .replace(
            "dvl",
            outages=(
                Outage(beams=(3, 4), start_s=3.0, end_s=7.0),
                Outage(beams=(1,), start_s=8.0, end_s=10.0),
            ),
        )
        .replace("initial_error", mode="random")
        .replace("run", methods=ALL_METHODS, aiding=("dvl", "depth", "mag"))
    )
    t0 = time.perf_counter()
    run_streaming(config, np.random.default_rng(0), num_runs=2, chunk_s=6.0)
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate
    from tauvcore.engine.smoothing import SmoothOptions

    smoothed = config.replace("run", methods=("lc",))
    run(
        smoothed,
        simulate(smoothed, np.random.default_rng(1)),
        np.random.default_rng(2),
        smooth=SmoothOptions(),
    )
    from tauvcore.truth import generate

    generate(
        config.trajectory.__class__(name="figure8", duration_s=2.0, truth="dynamic"),
        config.earth,
        config.imu.rate_hz,
    )
    return time.perf_counter() - t0


def main() -> None:
    print(f"tauv: the filter bank's compiled kernels are ready ({warm_up():.1f} s)")


if __name__ == "__main__":
    main()
