"""Where the engine stands against its targets, measured in one process on this
machine (named in the first line). Every workload is a whole command in a child process; wall
time by a monotonic clock, peak memory as the child's maximum resident set (getrusage).

    python benchmarks/engine_table.py [--skip-study] [--skip-long] [--repeats 3]

writes docs/results/engine_table.md (benchmarks/fragment.py), which docs/performance.md includes.

Rows: the CLI's import and ``tauv --help``; ``tauv run --trajectory figure8 --method all`` whole;
one 250 s scenario of all eight methods after import; the paper's study (``tauv reproduce``,
100 runs x 8 methods x 3 trajectories) on 2 workers; peak memory of 100 runs of ``lc``; the
floor (the engine and its compiled kernels loaded); peak memory of missions of 600 s, 3600 s (1
and 10 runs) and 10 hours with all eight methods, streamed to a consumer that keeps only the
last chunk's results; and ``tauv run`` of an hour, which keeps every series. ``--skip-study``
and ``--skip-long`` leave out the two longest (minutes).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile

import fragment

PYTHON = sys.executable
TAUV = [PYTHON, "-m", "app.cli"]


def machine() -> str:
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem_gib = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{platform.node()}: {model}, {os.cpu_count()} cores, {mem_gib:.0f} GiB, Python {platform.python_version()}"


_PEAK = ("import resource, subprocess, sys, time; t = time.perf_counter(); "
         "subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL); "
         "print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")


def measure(cmd: list[str], repeats: int = 1) -> tuple[float, float]:
    """Median wall time [s] and the largest peak resident memory [MiB] of ``cmd`` over ``repeats``.

    Each run goes through a fresh intermediate process, so the peak is this command's own (the
    largest of its processes), not the largest of everything measured before."""
    walls, peaks = [], []
    for _ in range(repeats):
        out = subprocess.run([PYTHON, "-c", _PEAK, *cmd], check=True, capture_output=True, text=True).stdout.split()
        walls.append(float(out[0]))
        peaks.append(float(out[1]) / 1024)
    walls.sort()
    return walls[len(walls) // 2], max(peaks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-study", action="store_true")
    parser.add_argument("--skip-long", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rows = ["| workload | now | target |", "|---|---|---|"]

    def row(text: str) -> None:
        rows.append(text)
        print(text, flush=True)

    print(machine())
    wall, _ = measure([PYTHON, "-c", "import app.cli"], args.repeats)
    row(f"| import of the CLI | {wall:.2f} s | - |")
    wall, _ = measure(TAUV + ["--help"], args.repeats)
    row(f"| `tauv --help` | {wall:.2f} s | < 0.3 s |")
    wall, _ = measure(TAUV + ["run", "--trajectory", "figure8", "--method", "all"], args.repeats)
    row(f"| `tauv run --trajectory figure8 --method all`, whole process | {wall:.2f} s | < 1 s |")
    scenario = ("import time, numpy as np; from tauvcore.config import Config, METHODS; "
                "from tauvcore.engine.mission import run_streaming; "
                "c = Config().replace('trajectory', name='figure8').replace('run', methods=METHODS); "
                "run_streaming(c.replace('trajectory', duration_s=1.0), np.random.default_rng(0)); "
                "t = time.perf_counter(); run_streaming(c, np.random.default_rng(0)); "
                "print(time.perf_counter() - t)")
    runs = sorted(float(subprocess.run([PYTHON, "-c", scenario], check=True, capture_output=True, text=True).stdout)
                  for _ in range(args.repeats))
    row(f"| one 250 s scenario, figure8, all 8 methods, after import and compiled-code load | "
          f"{runs[len(runs) // 2]:.2f} s | < 0.3 s |")
    with tempfile.TemporaryDirectory() as tmp:
        if not args.skip_study:
            wall, peak = measure(TAUV + ["reproduce", "--out", os.path.join(tmp, "paper"), "--workers", "2"])
            row(f"| 100 runs x 8 methods x 3 trajectories (`tauv reproduce --workers 2`) | {wall:.0f} s wall, "
                  f"largest process {peak:.0f} MiB | < 20 s wall on 2 cores |")
        wall, peak = measure(TAUV + ["mc", "--method", "lc", "--runs", "100", "--out", os.path.join(tmp, "lc100")])
        row(f"| peak memory, 100 runs, lc, 250 s (`tauv mc`, 1 process) | {peak:.0f} MiB ({wall:.0f} s) "
              f"| < 300 MB |")
    wall, peak = measure([PYTHON, "-c", _STREAM, "1", "1"])
    row(f"| (floor: the engine imported, its compiled kernels loaded, a 1 s mission) | {peak:.0f} MiB | - |")
    durations = [(600, 1), (3600, 1), (3600, 10)] + ([] if args.skip_long else [(36000, 1)])
    for duration, runs in durations:
        wall, peak = measure([PYTHON, "-c", _STREAM, str(duration), str(runs)])
        target = "< 200 MB, flat in duration" if duration <= 3600 else "must run"
        row(f"| peak memory, {duration:,} s, 8 methods, {runs} run{'s' if runs > 1 else ''}, results streamed "
              f"(`run_streaming(keep=False)`) | {peak:.0f} MiB ({wall:.0f} s) | {target} |")
    wall, peak = measure(TAUV + ["run", "--method", "all", "--duration", "3600"])
    row(f"| peak memory, `tauv run --method all --duration 3600` (every 10 Hz series kept) | {peak:.0f} MiB "
          f"({wall:.0f} s) | - |")
    scope = "the study left out (--skip-study)" if args.skip_study else "the paper's study included"
    scope += "; the 10-hour mission left out (--skip-long)" if args.skip_long else ""
    table = "\n".join(rows) + f"\n\nEvery row a whole command in a child process, {args.repeats} repeats where timed; {scope}."
    print(f"written to {fragment.write('engine_table', table)}")


_STREAM = ("import sys, numpy as np; from tauvcore.config import Config, METHODS; "
           "from tauvcore.engine.mission import run_streaming; "
           "c = Config().replace('trajectory', name='figure8', duration_s=float(sys.argv[1]))"
           ".replace('run', methods=METHODS).replace('initial_error', mode='random'); "
           "last = {}; run_streaming(c, np.random.default_rng(0), int(sys.argv[2]), on_chunk=last.update, keep=False); "
           "assert abs(last['lc'].t_s[-1] - float(sys.argv[1])) < 1e-6")
"""A mission streamed with only the last chunk's results kept (a reducing consumer's memory)."""


if __name__ == "__main__":
    main()
