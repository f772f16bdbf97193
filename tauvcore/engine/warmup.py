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

On a machine of two cores or more the mission is compiled in two processes side by side: this
one takes the 20-state bank's methods and the smoother (``--part eskf``), a helper process the
other families' methods and the dynamic truth (``--part others``); numba writes each kernel's
cache whole (a temporary file renamed into place), so the two do not spoil each other's. Then
the whole mission runs once more here: it loads what both compiled, and compiles anything the
helper left (had it failed, this pass does all its work).

On a terminal a progress bar (tqdm, on stderr) counts the kernels compiled, in either process,
each weighted by its source lines (a kernel's compile time grows with its code), against every
kernel of the modules the warm-up loads, and says the time left at that pace; a cached kernel is
loaded, not counted, so a warm cache shows the bar full at once.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from tauvcore.config import ALL_METHODS, Config
from tauvcore.filter.families import FAMILIES
from tauvcore.sensors.dvl import Outage

PARTS = ("eskf", "others")
"""The halves of the warm-up (:func:`warm_up`): the 20-state bank's methods and the smoother; the
other families' methods and the dynamic truth."""
COMPILED = "compiled "  # a helper's line on stdout: COMPILED + the kernel's key (kernel_key)


def warm_up(part: str | None = None) -> float:
    """Run the warm-up mission, or its ``part`` (:data:`PARTS`; None: all of it); returns its wall
    time [s]."""
    from tauvcore.engine.mission import run_streaming

    methods = part_methods(part)
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
        .replace("run", methods=methods, aiding=("dvl", "depth", "mag"))
    )
    t0 = time.perf_counter()
    run_streaming(config, np.random.default_rng(0), num_runs=2, chunk_s=6.0)
    if part != "others":
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
    if part != "eskf":
        from tauvcore.truth import generate

        generate(
            config.trajectory.__class__(name="figure8", duration_s=2.0, truth="dynamic"),
            config.earth,
            config.imu.rate_hz,
        )
    return time.perf_counter() - t0


def part_methods(part: str | None) -> tuple[str, ...]:
    """The methods the warm-up's ``part`` (:data:`PARTS`; None: the whole) runs."""
    if part is not None and part not in PARTS:
        raise ValueError(f"part must be one of {PARTS}, got {part!r}")
    eskf = FAMILIES["eskf"].methods
    if part is None:
        return ALL_METHODS
    return eskf if part == "eskf" else tuple(m for m in ALL_METHODS if m not in eskf)


def kernel_key(dispatcher: Any) -> str:
    """A compiled kernel's name in every process: its module and qualified name."""
    func = dispatcher.py_func
    return f"{func.__module__}.{func.__qualname__}"


def kernel_weights() -> dict[str, int]:
    """:func:`kernel_key` -> source lines of every compiled kernel (numba dispatcher) of the
    tauvcore modules loaded, after loading those the warm-up runs."""
    import importlib

    from numba.core.dispatcher import Dispatcher

    for name in ("tauvcore.engine.mission", "tauvcore.engine.smoothing", "tauvcore.truth.dynamic",
                 "tauvcore.truth.seabed_kernels"):  # fmt: skip
        importlib.import_module(name)
    weights: dict[str, int] = {}
    for name, module in list(sys.modules.items()):
        if not name.startswith("tauvcore.") or module is None:
            continue
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and kernel_key(value) not in weights:
                weights[kernel_key(value)] = _lines(value)
    return weights


def _lines(dispatcher: Any) -> int:
    try:
        return len(inspect.getsourcelines(dispatcher.py_func)[0])
    except (OSError, TypeError):
        return 1


class Progress:
    """The bar of :func:`compile_progress` (``bar``, tqdm) and :meth:`mark`, which counts a kernel."""

    def __init__(self, bar: Any, weights: dict[str, int]) -> None:
        self.bar, self.weights = bar, weights
        self.done: set[str] = set()
        self.lock = threading.Lock()

    def mark(self, key: str) -> None:
        """Kernel ``key`` was compiled (here or in the helper): its lines once; a stranger's none."""
        with self.lock:
            if key in self.weights and key not in self.done:
                self.done.add(key)
                self.bar.update(self.weights[key])


@contextlib.contextmanager
def _compile_events(on_compiled: Callable[[str], None]) -> Iterator[None]:
    """``on_compiled(kernel_key)`` at the end of every compilation numba makes in this process."""
    from numba.core import event as numba_event

    class Listener(numba_event.Listener):
        def on_start(self, event: numba_event.Event) -> None:
            pass

        def on_end(self, event: numba_event.Event) -> None:
            dispatcher = (event.data or {}).get("dispatcher")
            if dispatcher is not None:
                on_compiled(kernel_key(dispatcher))

    with numba_event.install_listener("numba:compile", Listener()):
        yield


@contextlib.contextmanager
def compile_progress(show: bool) -> Iterator[Progress | None]:
    """A tqdm bar on stderr while numba compiles (module docstring), yielded as a
    :class:`Progress` whose :meth:`~Progress.mark` also counts a helper's kernels; None when not
    ``show``."""
    if not show:
        yield None
        return
    from tqdm import tqdm

    weights = kernel_weights()
    width = min(shutil.get_terminal_size().columns, 100)  # a terminal that says 0 columns: 80
    bar = tqdm(total=sum(weights.values()), desc="tauv: compiling kernels", file=sys.stderr, ncols=width,
               mininterval=0.5, smoothing=0.0, bar_format="{desc} {percentage:3.0f}%|{bar}| {elapsed} so far, about {remaining} left")  # fmt: skip
    progress = Progress(bar, weights)
    try:
        with _compile_events(progress.mark):
            yield progress
        bar.update(max(bar.total - bar.n, 0))
    finally:
        bar.close()


def cores() -> int:
    """The CPU cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _helper(progress: Progress | None) -> tuple[subprocess.Popen, threading.Thread]:
    """The helper process compiling ``--part others``; a thread passes its kernels to ``progress``."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tauvcore.engine.warmup", "--part", "others"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            if progress is not None and line.startswith(COMPILED):
                progress.mark(line[len(COMPILED) :].strip())

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    return proc, reader


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m tauvcore.engine.warmup",
        description="Compile the filter bank's kernels once per install.",
    )
    parser.add_argument(
        "--part", choices=PARTS, help="compile this half only, reporting each kernel on stdout"
    )
    args = parser.parse_args(argv)
    if args.part is not None:  # the helper: every kernel it compiles, one line each
        with _compile_events(lambda key: print(COMPILED + key, flush=True)):
            warm_up(args.part)
        return
    t0 = time.perf_counter()
    with compile_progress(sys.stderr.isatty()) as progress:
        helper = _helper(progress) if cores() >= 2 else None
        try:
            warm_up("eskf" if helper is not None else None)
        except BaseException:  # Ctrl-C or a failure: the helper goes too
            if helper is not None:
                helper[0].kill()
            raise
        finally:
            if helper is not None:
                helper[0].wait()
                helper[1].join()
        if helper is not None:
            warm_up()  # both halves' kernels loaded; what the helper left, compiled
    print(f"tauv: the filter bank's compiled kernels are ready ({time.perf_counter() - t0:.1f} s)")


if __name__ == "__main__":
    main()
