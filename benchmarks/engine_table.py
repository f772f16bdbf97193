"""Issue 9's table: where the engine stands against its targets, measured in one process on this
machine (named in the first line). Every workload is a whole command in a child process; wall
time by a monotonic clock, peak memory as the child's maximum resident set (getrusage).

    python benchmarks/engine_table.py [--skip-study] [--skip-long] [--repeats 3]

Rows: the CLI's import and ``tauv --help``; ``tauv run --trajectory figure8 --method all`` whole;
one 250 s scenario of all eight methods after import; the paper's study (``tauv reproduce``,
100 runs x 8 methods x 3 trajectories) on 2 workers; peak memory of 100 runs of ``lc``; peak
memory of a 10-hour mission with all eight methods. ``--skip-study`` and ``--skip-long`` leave
out the two longest (minutes).
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile

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
    print(machine())
    print("\n| workload | now | target |\n|---|---|---|")
    wall, _ = measure([PYTHON, "-c", "import app.cli"], args.repeats)
    print(f"| import of the CLI | {wall:.2f} s | - |")
    wall, _ = measure(TAUV + ["--help"], args.repeats)
    print(f"| `tauv --help` | {wall:.2f} s | < 0.3 s |", flush=True)
    wall, _ = measure(TAUV + ["run", "--trajectory", "figure8", "--method", "all"], args.repeats)
    print(f"| `tauv run --trajectory figure8 --method all`, whole process | {wall:.2f} s | < 1 s |", flush=True)
    scenario = ("import time, numpy as np; from tauvcore.config import Config, METHODS; "
                "from tauvcore.eval.runner import run, simulate; "
                "c = Config().replace('trajectory', name='figure8').replace('run', methods=METHODS); "
                "rng = np.random.default_rng(0); t = time.perf_counter(); run(c, simulate(c, rng), rng); "
                "print(time.perf_counter() - t)")
    runs = sorted(float(subprocess.run([PYTHON, "-c", scenario], check=True, capture_output=True, text=True).stdout)
                  for _ in range(args.repeats))
    print(f"| one 250 s scenario, figure8, all 8 methods, after import | {runs[len(runs) // 2]:.2f} s | < 0.3 s |",
          flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        if not args.skip_study:
            wall, peak = measure(TAUV + ["reproduce", "--out", os.path.join(tmp, "paper"), "--workers", "2"])
            print(f"| 100 runs x 8 methods x 3 trajectories (`tauv reproduce --workers 2`) | {wall:.0f} s wall, "
                  f"largest process {peak:.0f} MiB | < 20 s wall on 2 cores |", flush=True)
        wall, peak = measure(TAUV + ["mc", "--method", "lc", "--runs", "100", "--out", os.path.join(tmp, "lc100")])
        print(f"| peak memory, 100 runs, lc, 250 s (`tauv mc`, 1 process) | {peak:.0f} MiB ({wall:.0f} s) "
              f"| < 300 MB |", flush=True)
        if not args.skip_long:
            wall, peak = measure(TAUV + ["run", "--method", "all", "--duration", "36000"])
            print(f"| peak memory, 36,000 s, 8 methods, 1 run | {peak:.0f} MiB ({wall:.0f} s) | < 200 MB, flat in "
                  "duration |", flush=True)


if __name__ == "__main__":
    main()
