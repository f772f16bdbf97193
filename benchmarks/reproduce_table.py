"""The paper's study as a user runs it: ``tauv reproduce --out DIR`` timed, its files measured, and
the comparison with the paper it writes (``paper_comparison.md``) put on the documentation site.

    python benchmarks/reproduce_table.py [--workers 2] [--runs 100]

Runs the command in a child process into a temporary directory: wall time by a monotonic clock,
CPU time and the largest process's peak resident set from ``getrusage`` of the children, the size
of each file it wrote, how many filter runs the divergence monitor flagged, and LC's final velocity
error with and without them (``summary.json``).
Writes docs/results/reproduce_claims.md (the comparison table, as ``tauv reproduce`` wrote it) and
docs/results/reproduce_cost.md (the cost) through benchmarks/fragment.py.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)


def flagged(summary: dict) -> tuple[int, int]:
    """(filter runs the divergence monitor flagged, filter runs) over every trajectory and method."""
    hit = total = 0
    for trajectory in summary["trajectories"].values():
        for method in trajectory["methods"].values():
            hit += int(method["runs_flagged_by_monitor"])
            total += int(trajectory["num_runs"])
    return hit, total


def where(summary: dict, key: str) -> str:
    """Which trajectory, method and runs carry ``key`` (``flagged_runs`` or ``reset_runs``)."""
    found = [f"{method.upper()} on {name} (runs {', '.join(map(str, m[key]))})"
             for name, trajectory in summary["trajectories"].items()
             for method, m in trajectory["methods"].items() if m.get(key)]
    return "; ".join(found) or "none"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--runs", type=int, default=100)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "paper"
        cmd = [sys.executable, "-m", "app.cli", "reproduce", "--out", str(out), "--workers", str(args.workers),
               "--runs", str(args.runs)]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        wall_s = time.monotonic() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu_s = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        peak_mib = after.ru_maxrss / 1024.0
        sizes = {p.name: p.stat().st_size for p in sorted(out.iterdir()) if p.is_file()}
        table = (out / "paper_comparison.md").read_text(encoding="utf-8").strip()
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    hit, total = flagged(summary)
    command = f"tauv reproduce --out DIR --workers {args.workers} --runs {args.runs}"
    files = ", ".join(f"`{name}` {size / 1e6:.1f} MB" if size >= 1e5 else f"`{name}` {size / 1e3:.0f} kB"
                      for name, size in sizes.items())
    cost = (f"| `{command}` | measured |\n|---|---|\n| wall time | {wall_s:.1f} s |\n| CPU time | {cpu_s:.0f} s |\n"
            f"| largest process, peak resident | {peak_mib:.0f} MiB |\n| files written | {files} |\n"
            f"| filter runs the divergence monitor flagged | {hit} of {total}: {where(summary, 'flagged_runs')} |\n"
            f"| velocity resets after a DVL lock-out | "
            f"{sum(m.get('lockout_resets', 0) for t in summary['trajectories'].values() for m in t['methods'].values())}"
            f": {where(summary, 'reset_runs')} |")
    for name, trajectory in summary["trajectories"].items():
        lc = trajectory["methods"]["lc"]
        st = lc["final_stats"]["vel_err_mps"]
        runs = ", ".join(map(str, lc["flagged_runs"])) or "none"
        cost += (f"\n| LC (four beams) on {name}: velocity error at the end, RMS / median / 95th percentile; "
                 f"RMS without the flagged runs (runs {runs}) | {st['rms']:.3g} / {st['median']:.3g} / "
                 f"{st['p95']:.3g} m/s; {st['rms_unflagged']:.3g} m/s |")
    claims = (f"As `{command}` wrote it ({args.runs} seeded runs per trajectory, seed 0):\n\n{table}")
    print(cost, "\n", claims, sep="\n")
    print(f"written to {fragment.write('reproduce_cost', cost)} and {fragment.write('reproduce_claims', claims)}")


if __name__ == "__main__":
    main()
