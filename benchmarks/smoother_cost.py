"""What the smoother costs: ``tauv run --smooth`` against ``tauv run``, wall time, peak memory and
the disk its tape takes, for missions of 250 s, 1 h and 10 h.

    python benchmarks/smoother_cost.py                    # 250 s, 1 h and 10 h
    python benchmarks/smoother_cost.py --hours 0.0694 1

Each row is a pair of whole commands, each in its own process: ``tauv run --trajectory straight
--duration S --method ins,lc,tc,nsv,iekf --aiding dvl,depth,mag`` and the same with ``--smooth
--smooth-dir DIR``. The smoother's cost is the difference of their wall times, against the
forward run's (the backward pass reads the tape the forward pass wrote, so the forward pass with
its tape is in the first part of the difference too). Peak resident memory is the kernel's
accounting of each child (``ru_maxrss`` of ``wait4``, what ``/usr/bin/time -v`` reports); the
tape's disk is the largest size of ``DIR`` while the command runs (sampled every 0.2 s; the
smoother removes it when done). Writes docs/results/smoother_cost.md.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

METHODS = "ins,lc,tc,nsv,iekf"


def argv(hours: float, smooth_dir: str | None) -> list[str]:
    out = ["run", "--trajectory", "straight", "--duration", f"{hours * 3600:g}", "--method", METHODS,
           "--aiding", "dvl,depth,mag"]
    return out + (["--smooth", "--smooth-dir", smooth_dir] if smooth_dir is not None else [])


def dir_bytes(path: str) -> int:
    total = 0
    for root, _, files in os.walk(path):
        for name in files:
            try:
                total += os.path.getsize(os.path.join(root, name))
            except OSError:
                pass
    return total


def child(args: list[str], watch: str | None) -> tuple[float, float, float]:
    """``tauv args`` in a child process: wall time [s], peak resident memory [MiB] and the largest
    size of ``watch`` while it ran [MB] (0 without one)."""
    largest = [0]
    done = threading.Event()

    def sample() -> None:
        while not done.wait(0.2):
            largest[0] = max(largest[0], dir_bytes(watch))

    watcher = threading.Thread(target=sample, daemon=True) if watch is not None else None
    with tempfile.TemporaryFile("w+") as err:
        t0 = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-m", "app.cli", *args], stdout=subprocess.DEVNULL, stderr=err)
        if watcher is not None:
            watcher.start()
        _, status, usage = os.wait4(proc.pid, 0)
        wall_s = time.monotonic() - t0
        done.set()
        if watcher is not None:
            watcher.join()
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            raise RuntimeError(f"tauv {' '.join(args)} failed: {err.read()[-2000:]}")
    return wall_s, usage.ru_maxrss / 1024.0, largest[0] / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[250.0 / 3600.0, 1.0, 10.0])
    args = parser.parse_args()
    with fragment.capture() as shown:
        print(f"`tauv run --trajectory straight --duration S --method {METHODS} --aiding dvl,depth,mag`, without "
              "and with `--smooth` (default budget: the tape beyond 64 MB in a temporary directory), each a "
              "process of its own.\n")
        print("| mission | forward [s] | with the smoother [s] | smoother / forward | peak resident forward "
              "[MiB] | with the smoother [MiB] | tape on disk, largest [MB] |")
        print("|---|---|---|---|---|---|---|")
        for hours in sorted(args.hours):
            with tempfile.TemporaryDirectory() as tmp:
                forward_s, forward_mib, _ = child(argv(hours, None), None)
                smooth_s, smooth_mib, disk_mb = child(argv(hours, tmp), tmp)
                left = os.listdir(tmp)
            assert not left, f"the smoother left {left} behind"
            label = f"{hours * 3600:.0f} s" if hours < 1 else f"{hours:g} h"
            print(f"| {label} | {forward_s:.1f} | {smooth_s:.1f} | {(smooth_s - forward_s) / forward_s:.2f} "
                  f"| {forward_mib:.0f} | {smooth_mib:.0f} | {disk_mb:,.0f} |", flush=True)
    print(f"written to {fragment.write('smoother_cost', shown.getvalue())}")


if __name__ == "__main__":
    main()
