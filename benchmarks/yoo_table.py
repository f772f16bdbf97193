"""Yoo 2014's comparison on its long-range mission: the end-point position error of the pure INS,
INS-DVL and INS-DVL + VKF beside the paper's figures, with the DVL's beams lost beyond range (our
default) and with Yoo's own model (they return with 5 m/s more noise).

    python benchmarks/yoo_table.py [--runs 20] [--seed 0] [--workers 2]

Each cell is the RMS over the runs of the position error at the end (1,440 s) and, in brackets,
the smallest and largest run's; the same study as ``tauv mc --trajectory longrange --runs 20
--method ins,ins-dvl,vkf`` (with ``[dvl] beyond_range = "noisy"`` in a ``--config`` file for
the second column). Writes docs/results/yoo_table.md (benchmarks/fragment.py), which
docs/models.md includes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from tauvcore.config import from_dict, merge, trajectory_preset
from tauvcore.eval.study import run_study

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

METHODS = (("ins", "pure INS", 21_181.0), ("ins-dvl", "INS-DVL", 1_117.0), ("vkf", "INS-DVL + VKF", 209.0))
"""(method, the paper's name, the paper's end-point error [m]: Yoo 2014, section 4)."""


def end_errors(beyond_range: str, runs: int, seed: int, workers: int) -> dict[str, tuple[float, float, float]]:
    """method -> (RMS over runs, smallest, largest) of the position error at the end [m]."""
    config = from_dict(merge(trajectory_preset("longrange"), {
        "trajectory": {"name": "longrange"},
        "dvl": {"beyond_range": beyond_range},
        "run": {"methods": [m for m, _, _ in METHODS], "seed": seed},
    }))
    summary = run_study(config, runs, workers=workers).summary()
    out = {}
    for method, _, _ in METHODS:
        per_run = np.asarray(summary["methods"][method]["final_per_run"]["pos_err_m"], dtype=float)
        out[method] = (float(np.sqrt(np.mean(per_run**2))), float(per_run.min()), float(per_run.max()))
    return out


def cell(value: tuple[float, float, float]) -> str:
    rms, lo, hi = value
    return f"{rms:,.0f} m ({lo:,.0f}-{hi:,.0f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    lost = end_errors("lost", args.runs, args.seed, args.workers)
    noisy = end_errors("noisy", args.runs, args.seed, args.workers)
    with fragment.capture() as shown:
        print(f"End-point position error, {args.runs} runs (seed {args.seed}) at 1,440 s: RMS over the runs "
              "(smallest-largest run)\n")
        print("| method | paper | ours, DVL beams lost beyond range | ours, Yoo's model (5 m/s noise beyond range) |")
        print("|---|---|---|---|")
        for method, name, paper_m in METHODS:
            print(f"| {name} | {paper_m:,.0f} m | {cell(lost[method])} | {cell(noisy[method])} |")
    print(f"written to {fragment.write('yoo_table', shown.getvalue())}")


if __name__ == "__main__":
    main()
