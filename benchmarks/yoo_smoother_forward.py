"""What keeping the smoother's tape costs Yoo 2014's forward pass: ``ins-dvl`` and ``vkf`` on the
``longrange`` mission, the forward pass with the tape against the same pass without it.

    python benchmarks/yoo_smoother_forward.py                 # 1200 s of longrange, 1 and 10 runs
    python benchmarks/yoo_smoother_forward.py --duration 600 --runs 1

One simulation per row, then three forward passes (tauvcore.engine.mission.Banks fed the
simulation's 10 s chunks): without the smoother; with its tape held in memory (a budget of
IN_MEMORY_MB: what the compiled loop's marks cost, each covariance step's transition composed and
each ping's and output epoch's mark written); with the default budget (the tape beyond it written
to a temporary directory as the forward pass goes, as ``tauv run --smooth`` does). They alternate
``--repeats`` times after one warm pass each, in this process; the table gives each pass's median
wall time, the ratios of the medians to the plain pass and the backward pass's own time over the
default tape (the smoother's cost beyond the forward pass, tauvcore.engine.yoo_smoothing).
Writes docs/results/yoo_smoother_forward.md.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tauvcore.config import Config  # noqa: E402
from tauvcore.engine.mission import STREAM_CHUNK_S, Banks  # noqa: E402
from tauvcore.engine.simulation import chunks_of, simulate  # noqa: E402
from tauvcore.engine.smoothing import SmoothOptions  # noqa: E402

METHODS = ("ins-dvl", "vkf")
IN_MEMORY_MB = 8192.0  # the smoother's budget that holds the whole tape of a row in memory


def forward_s(config: Config, sim, smooth: SmoothOptions | None) -> tuple[float, Banks]:
    """Wall time [s] of the forward pass over ``sim`` (its chunks of STREAM_CHUNK_S), and the banks."""
    banks = Banks(config, sim.num_runs, sim.truth.num_samples, sim.truth.dt_s, np.random.default_rng(2),
                  smooth=smooth)
    chunk_samples = max(1, round(STREAM_CHUNK_S / sim.truth.dt_s))
    t0 = time.perf_counter()
    for chunk in chunks_of(sim, chunk_samples):
        banks.feed(chunk)
    return time.perf_counter() - t0, banks


def backward_s(banks: Banks) -> float:
    """Wall time [s] of the backward pass over the banks' tape, its smoothed results gathered."""
    t0 = time.perf_counter()
    chunks, close = banks.smoothed()
    try:
        for _ in chunks:
            pass
    finally:
        close()
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=1200.0, help="seconds of the longrange mission")
    parser.add_argument("--runs", type=int, nargs="+", default=[1, 10], help="Monte Carlo runs of a row")
    parser.add_argument("--repeats", type=int, default=5, help="alternated passes of each kind")
    args = parser.parse_args()
    config = Config().replace("trajectory", name="longrange", duration_s=args.duration).replace(
        "run", methods=METHODS)
    with fragment.capture() as shown:
        print(f"Yoo 2014's `{', '.join(METHODS)}` on `longrange`, {args.duration:g} s, the forward pass fed "
              f"10 s chunks in one process, median of {args.repeats} alternated passes each.\n")
        print("| runs | forward [s] | with the tape in memory [s] | ratio | with the default budget [s] | ratio "
              "| backward pass [s] |")
        print("|---|---|---|---|---|---|---|")
        for runs in args.runs:
            sim = simulate(config, np.random.default_rng(1), runs)
            forward_s(config, sim, None)  # warm: the kernels loaded, the caches filled
            forward_s(config, sim, SmoothOptions())
            plain, memory, disk, back = [], [], [], []
            for _ in range(args.repeats):
                plain.append(forward_s(config, sim, None)[0])
                memory.append(forward_s(config, sim, SmoothOptions(budget_mb=IN_MEMORY_MB))[0])
                seconds, banks = forward_s(config, sim, SmoothOptions())
                disk.append(seconds)
                back.append(backward_s(banks))
            p, m, d = statistics.median(plain), statistics.median(memory), statistics.median(disk)
            print(f"| {runs} | {p:.3f} | {m:.3f} | {m / p:.2f} | {d:.3f} | {d / p:.2f} "
                  f"| {statistics.median(back):.3f} |", flush=True)
    print(f"written to {fragment.write('yoo_smoother_forward', shown.getvalue())}")


if __name__ == "__main__":
    main()
