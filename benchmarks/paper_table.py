"""Reproduce the README's accuracy table: Monte Carlo RMS errors at 250 s beside Tal et al. 2017.

    python benchmarks/paper_table.py [--runs 20] [--seed 7]

Prints a Markdown table (INS and LC, four beams, DVL aiding only as in the paper's section 4).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from tauvcore.config import Config
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

PAPER_INS = {"straight": (34.0, 1.4), "figure8": (31.8, 1.26), "lawnmower": (36.5, 1.29)}  # m/s, deg at 250 s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    print(f"{args.runs} Monte Carlo runs, seed {args.seed}, 250 s, initial errors drawn as 1-sigma (Table 2)\n")
    print("| trajectory | INS vel [m/s] paper / ours | INS att [deg] paper / ours | LC vel [m/s] ours | LC att [deg] ours | LC pos [m] ours | wall [s] |")
    print("|---|---|---|---|---|---|---|")
    for i, name in enumerate(TRAJECTORIES):
        config = Config().replace("trajectory", name=name).replace("run", methods=("ins", "lc"))
        t0 = time.perf_counter()
        res = monte_carlo(config, args.runs, np.random.default_rng(args.seed + i))
        wall = time.perf_counter() - t0
        ins, lc = res["ins"], res["lc"]
        pv, pa = PAPER_INS[name]
        print(f"| {name} | {pv} / {rms_over_runs(ins.vel_err_mps)[-1]:.1f} | {pa} / {rms_over_runs(ins.att_err_deg)[-1]:.2f} "
              f"| {rms_over_runs(lc.vel_err_mps)[-1]:.3f} | {rms_over_runs(lc.att_err_deg)[-1]:.2f} "
              f"| {rms_over_runs(lc.pos_err_m)[-1]:.1f} | {wall:.1f} |")


if __name__ == "__main__":
    main()
