"""Yoo 2014's methods with and without the magnetometer: heading, tilt and velocity errors and
their consistency on the paper's long-range mission (24 minutes, the trenches included).

    python benchmarks/yoo_mag_table.py [--runs 10] [--seed 0] [--duration 1440]

writes docs/results/yoo_mag.md (benchmarks/fragment.py), which docs/models.md includes.

The 12-state filter fuses the magnetometer's attitude (tauvcore.engine.yoo_sources: its H weighs
the misalignment alone). Errors are RMS over the runs (run r seeded ``seed + r``) after the first
600 s (heading, tilt) or over the whole mission (velocity); the final position error is the median
over the runs; NEES per dimension over every output epoch and run, NIS per degree of freedom of
the magnetometer's updates.
"""

from __future__ import annotations

import argparse
import time

import fragment
import numpy as np

from tauvcore.config import from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.consistency import method_consistency


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=1440.0)
    args = parser.parse_args()
    started = time.perf_counter()
    rows = [
        "| aiding | method | heading RMS [deg] | tilt RMS [deg] | vel RMS [m/s] | final pos, median [m] "
        "| NEES/1 heading | NEES/2 tilt | NEES/3 vel | mag NIS/dof |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for aiding in (("dvl",), ("dvl", "mag")):
        raw = merge(
            trajectory_preset("longrange"),
            {
                "trajectory": {"name": "longrange", "duration_s": args.duration},
                "run": {"methods": ["ins-dvl", "vkf"], "aiding": list(aiding)},
            },
        )
        rngs = [np.random.default_rng(args.seed + r) for r in range(args.runs)]
        results = run_streaming(from_dict(raw), rngs, num_runs=args.runs)
        for method, r in results.items():
            c = method_consistency(r)
            late = r.t_s > min(600.0, 0.5 * args.duration)
            nis = f"{c.nis['mag'].per_dof:.2f}" if "mag" in c.nis else "-"
            rows.append(
                f"| {'+'.join(aiding)} | {method} | {np.sqrt(np.mean(r.heading_err_deg[late] ** 2)):.3f} "
                f"| {np.sqrt(np.mean(r.tilt_err_deg[late] ** 2)):.3f} | {np.sqrt(np.mean(r.vel_err_mps**2)):.4f} "
                f"| {np.median(r.pos_err_m[-1]):.1f} | {c.nees['heading'].per_dim:.2f} | {c.nees['tilt'].per_dim:.2f} "
                f"| {c.nees['vel'].per_dim:.2f} | {nis} |"
            )
    table = "\n".join(rows) + f"\n\n{args.runs} runs of {args.duration:g} s, seed {args.seed}."
    print(table)
    print(f"{time.perf_counter() - started:.0f} s; written to {fragment.write('yoo_mag', table)}")


if __name__ == "__main__":
    main()
