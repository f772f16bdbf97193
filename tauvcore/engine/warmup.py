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

On a terminal a progress bar (tqdm, on stderr) counts the kernels compiled, each weighted by its
source lines (a kernel's compile time grows with its code), against every kernel of the modules
the warm-up loads, and says the time left at that pace; a cached kernel is loaded, not counted,
so a warm cache shows the bar full at once.
"""

from __future__ import annotations

import contextlib
import inspect
import shutil
import sys
import time
from collections.abc import Iterator
from typing import Any

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


def kernel_weights() -> dict[int, int]:
    """id -> source lines of every compiled kernel (numba dispatcher) of the tauvcore modules
    loaded, after loading those the warm-up runs."""
    import importlib

    from numba.core.dispatcher import Dispatcher

    for name in ("tauvcore.engine.mission", "tauvcore.engine.smoothing", "tauvcore.truth.dynamic",
                 "tauvcore.truth.seabed_kernels"):  # fmt: skip
        importlib.import_module(name)
    weights: dict[int, int] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("tauvcore.") or module is None:
            continue
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and id(value) not in weights:
                weights[id(value)] = _lines(value)
    return weights


def _lines(dispatcher: Any) -> int:
    try:
        return len(inspect.getsourcelines(dispatcher.py_func)[0])
    except (OSError, TypeError):
        return 1


@contextlib.contextmanager
def compile_progress(show: bool) -> Iterator[Any]:
    """A tqdm bar on stderr while numba compiles (module docstring), yielded; None when not ``show``."""
    if not show:
        yield None
        return
    from numba.core import event as numba_event
    from tqdm import tqdm

    weights = kernel_weights()
    done: set[int] = set()
    width = min(shutil.get_terminal_size().columns, 100)  # a terminal that says 0 columns: 80
    bar = tqdm(total=sum(weights.values()), desc="tauv: compiling kernels", file=sys.stderr, ncols=width,
               mininterval=0.5, smoothing=0.0, bar_format="{desc} {percentage:3.0f}%|{bar}| {elapsed} so far, about {remaining} left")  # fmt: skip

    class Counter(numba_event.Listener):
        def on_start(self, event: numba_event.Event) -> None:
            pass

        def on_end(self, event: numba_event.Event) -> None:
            key = id((event.data or {}).get("dispatcher"))
            if key in weights and key not in done:  # a kernel made inside a function: not counted
                done.add(key)
                bar.update(weights[key])

    try:
        with numba_event.install_listener("numba:compile", Counter()):
            yield bar
        bar.update(max(bar.total - bar.n, 0))
    finally:
        bar.close()


def main() -> None:
    with compile_progress(sys.stderr.isatty()):
        seconds = warm_up()
    print(f"tauv: the filter bank's compiled kernels are ready ({seconds:.1f} s)")


if __name__ == "__main__":
    main()
