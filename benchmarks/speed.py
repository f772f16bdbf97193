"""What a user waits for around the engine: start-up, single runs, the paper's study and the first
start after an install, each as whole commands against a baseline command in the same run.

    python benchmarks/speed.py [--repeats 5] [--study-repeats 1] [--no-study] [--no-first-start]

writes docs/results/speed.md (benchmarks/fragment.py), which docs/performance.md includes.

Each command runs as a child process, alternating with the baseline ``python -c "import numpy"``
(the floor of any command: the interpreter and numpy), so that both meet the same load; its CPU
time (user + system of the child and the processes it waited for, ``os.wait4``), wall time and
peak resident set size (of its largest process) are read from the kernel. The table gives the
median of ``--repeats`` and the median paired ratio CPU / baseline CPU, which holds on a loaded
machine better than either alone. Commands:

- ``tauv --help``; ``tauv run --trajectory figure8 --method lc`` and ``--method all`` (250 s);
- ``tauv reproduce --workers 2`` (the paper's study, 100 runs x 8 methods x 3 trajectories) into
  a temporary directory (``--no-study``: skipped);
- the first start: ``python -m tauvcore.engine.warmup`` with an empty numba cache
  (``NUMBA_CACHE_DIR`` a new temporary directory), what ``scripts/start.sh`` pays once after an
  install (``--no-first-start``: skipped), and the same again with that cache filled.

Python writes its bytecode caches as a user's install does (``PYTHONDONTWRITEBYTECODE`` unset).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import fragment

REPO = Path(__file__).resolve().parents[1]
TAUV = [sys.executable, "-m", "app.entry"]  # the tauv console script's module
BASELINE = [sys.executable, "-c", "import numpy"]


@dataclass
class Target:
    """An issue's bound for a command: at most these CPU seconds, wall seconds, megabytes."""

    cpu_s: float | None = None
    wall_s: float | None = None
    rss_mb: float | None = None


@dataclass
class Sample:
    cpu_s: float
    wall_s: float
    rss_mb: float


def measure(argv: list[str], env: dict[str, str] | None = None) -> Sample:
    """One run of ``argv`` (stdout and stderr discarded): its CPU, wall time and peak RSS."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited with {proc.returncode}")
    return Sample(usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss / 1024.0)


def paired(argv: list[str], repeats: int, env: dict[str, str] | None = None) -> tuple[list[Sample], list[float]]:
    """``repeats`` runs of ``argv``, each after a run of the baseline; the samples and the ratios."""
    samples, ratios = [], []
    for _ in range(repeats):
        base = measure(BASELINE, env)
        sample = measure(argv, env)
        samples.append(sample)
        ratios.append(sample.cpu_s / base.cpu_s)
    return samples, ratios


def row(label: str, samples: list[Sample], ratios: list[float], target: Target) -> str:
    cpu = statistics.median(s.cpu_s for s in samples)
    wall = statistics.median(s.wall_s for s in samples)
    rss = max(s.rss_mb for s in samples)
    bounds = []
    met = True
    for value, bound, unit in ((cpu, target.cpu_s, "CPU-s"), (wall, target.wall_s, "s"), (rss, target.rss_mb, "MB")):
        if bound is not None:
            bounds.append(f"{bound:g} {unit}")
            met = met and value <= bound
    verdict = ("met" if met else "**not met**") if bounds else ""
    return (f"| {label} | {cpu:.2f} | {wall:.2f} | {rss:.0f} | {statistics.median(ratios):.1f} "
            f"| {', '.join(bounds)} {verdict} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs of each short command")
    parser.add_argument("--study-repeats", type=int, default=1, help="runs of tauv reproduce")
    parser.add_argument("--no-study", action="store_true", help="skip tauv reproduce (about 40 s a run)")
    parser.add_argument("--no-first-start", action="store_true", help="skip the cold warm-up (about 100 s)")
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    measure([*TAUV, "--help"], env)  # bytecode caches written, the numba cache loaded once
    measure([*TAUV, "run", "--trajectory", "figure8", "--method", "all"], env)
    base, _ = paired(BASELINE, args.repeats, env)
    rows = [
        f"| command (median of {args.repeats}; the study: of {args.study_repeats}) | CPU [s] | wall [s] "
        "| peak RSS [MB] | CPU / baseline | target |",
        "|---|---|---|---|---|---|",
        row('baseline: `python -c "import numpy"`', base, [1.0], Target()),
    ]
    commands = [
        ("`tauv --help`", [*TAUV, "--help"], Target(cpu_s=0.2)),
        ("`tauv run --trajectory figure8 --method lc`", [*TAUV, "run", "--trajectory", "figure8", "--method", "lc"],
         Target(cpu_s=0.5)),
        ("`tauv run --trajectory figure8 --method all`",
         [*TAUV, "run", "--trajectory", "figure8", "--method", "all"], Target(cpu_s=0.8)),
    ]
    for label, argv, target in commands:
        rows.append(row(label, *paired(argv, args.repeats, env), target))
        print(rows[-1], flush=True)
    if not args.no_study:
        with tempfile.TemporaryDirectory(prefix="tauv-speed-") as out:
            argv = [*TAUV, "reproduce", "--workers", "2", "--out", out, "--replace"]
            rows.append(row("`tauv reproduce --workers 2`", *paired(argv, args.study_repeats, env),
                            Target(cpu_s=35.0, wall_s=20.0, rss_mb=500.0)))
            print(rows[-1], flush=True)
    if not args.no_first_start:
        with tempfile.TemporaryDirectory(prefix="tauv-numba-") as cache:
            cold = {**env, "NUMBA_CACHE_DIR": cache}
            warmup = [sys.executable, "-m", "tauvcore.engine.warmup"]
            rows.append(row("first start: `python -m tauvcore.engine.warmup`, numba cache empty",
                            *paired(warmup, 1, cold), Target(wall_s=60.0)))
            print(rows[-1], flush=True)
            rows.append(row("the same, the cache filled", *paired(warmup, 1, cold), Target()))
            print(rows[-1], flush=True)
    table = "\n".join(rows) + (
        "\n\nCPU: user + system of the command's processes (os.wait4); peak RSS: its largest process. "
        "Each run follows a run of the baseline, and the ratio is of that pair. Targets as the "
        "performance page states them."
    )
    print(table)
    print(f"written to {fragment.write('speed', table)}")


if __name__ == "__main__":
    main()
