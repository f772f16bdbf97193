"""The accuracy table of docs/accuracy.md: Monte Carlo RMS errors at 250 s beside Tal et al. 2017.

    python benchmarks/paper_table.py [--runs 20] [--seed 7]

Prints a Markdown table (INS and LC, four beams, DVL aiding only as in the paper's section 4) and
writes it to docs/results/paper_table.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

PAPER_INS = {"straight": (34.0, 1.4), "figure8": (31.8, 1.26), "lawnmower": (36.5, 1.29)}  # m/s, deg at 250 s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    with fragment.capture() as shown:
        print(f"{args.runs} Monte Carlo runs, seed {args.seed}, 250 s, four beams, DVL aiding only, initial "
              "errors drawn as 1-sigma (Table 2)\n")
        print("| trajectory | INS vel [m/s] paper / ours | INS att [deg] paper / ours | LC vel [m/s] ours "
              "| LC att [deg] ours | LC pos [m] ours |")
        print("|---|---|---|---|---|---|")
        for i, name in enumerate(TRAJECTORIES):
            config = Config().replace("trajectory", name=name).replace("run", methods=("ins", "lc"))
            res = monte_carlo(config, args.runs, np.random.default_rng(args.seed + i))
            ins, lc = res["ins"], res["lc"]
            pv, pa = PAPER_INS[name]
            print(f"| {name} | {pv} / {rms_over_runs(ins.vel_err_mps)[-1]:.1f} "
                  f"| {pa} / {rms_over_runs(ins.att_err_deg)[-1]:.2f} "
                  f"| {rms_over_runs(lc.vel_err_mps)[-1]:.3f} | {rms_over_runs(lc.att_err_deg)[-1]:.2f} "
                  f"| {rms_over_runs(lc.pos_err_m)[-1]:.1f} |", flush=True)
    print(f"written to {fragment.write('paper_table', shown.getvalue())}")

if __name__ == "__main__":
    main()
