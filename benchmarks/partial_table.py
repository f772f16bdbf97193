"""Reproduce the README's partial-DVL table: every method with beams 3 and 4 lost for the whole
run (only beams 1 and 2 return, the paper's section 4.2 case), on the three trajectories.

    python benchmarks/partial_table.py [--runs 1] [--seed 0]

With --runs 1 (default) the initial errors are applied as given (a single deterministic run, the
``tauv run --method all --beams 1,2 --seed 0`` numbers); with more runs they are drawn and the
table shows Monte Carlo RMS values, like the paper's figures.
"""

from __future__ import annotations

import argparse

import numpy as np

from tauvcore.config import METHODS, Config
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.eval.runner import run, simulate
from tauvcore.truth import TRAJECTORIES


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    header = "| method | " + " | ".join(f"{t} vel [m/s] | {t} att [deg]" for t in TRAJECTORIES) + " |"
    rows: dict[str, list[str]] = {m: [] for m in METHODS}
    for name in TRAJECTORIES:
        config = (Config().replace("trajectory", name=name).replace("dvl", beams=(1, 2))
                  .replace("run", methods=METHODS, seed=args.seed))
        rng = np.random.default_rng(args.seed)
        if args.runs == 1:
            res = run(config, simulate(config, rng), rng)
        else:
            res = monte_carlo(config, args.runs, rng)
        for m, r in res.items():
            rows[m] += [f"{rms_over_runs(r.vel_err_mps)[-1]:.3f}", f"{rms_over_runs(r.att_err_deg)[-1]:.2f}"]
    what = "single run, initial errors as given" if args.runs == 1 else f"RMS of {args.runs} Monte Carlo runs"
    print(f"Errors at 250 s, beams 1 and 2 only, DVL aiding only ({what}, seed {args.seed})\n")
    print(header)
    print("|---" * (1 + 2 * len(TRAJECTORIES)) + "|")
    for m, cells in rows.items():
        print(f"| {m.upper()} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
