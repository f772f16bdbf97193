"""The partial-DVL tables of docs/accuracy.md: every method with beams 3 and 4 lost for the whole
run (only beams 1 and 2 return, the paper's section 4.2 case), on the three trajectories.

    python benchmarks/partial_table.py [--runs 20] [--seed 0] [--truth kinematic|dynamic]

Per trajectory, the errors at 250 s: velocity, the attitude norm and its two parts, tilt (roll
and pitch: |(rho_N, rho_E)|) and heading (|rho_D|), and position; in brackets the change of the
attitude norm and of the tilt against the standalone INS (the paper states its attitude results
as such percentages). With --runs 1 the initial errors are applied as given (a single
deterministic run, the ``tauv run --method all --beams 1,2 --seed 0`` numbers); with more runs
they are drawn and the tables show Monte Carlo RMS values, like the paper's figures. ``--truth
dynamic`` flies the missions with the 6-DOF TAUV (tauvcore.truth.dynamic) instead of the
closed-form profiles.

Writes docs/results/partial_kinematic.md (``--truth dynamic``: partial_dynamic.md) through
benchmarks/fragment.py.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES
from tauvcore.truth import TRUTH_SOURCES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

QUANTITIES = (("vel_err_mps", "vel [m/s]", ".3g"), ("att_err_deg", "att [deg]", ".2f"),
              ("tilt_err_deg", "tilt [deg]", ".3f"), ("heading_err_deg", "heading [deg]", ".2f"),
              ("pos_err_m", "pos [m]", ".3g"))


def errors_at_end(name: str, runs: int, seed: int, truth: str = "kinematic") -> dict[str, dict[str, float]]:
    config = (Config().replace("trajectory", name=name, truth=truth).replace("dvl", beams=(1, 2))
              .replace("run", methods=METHODS, seed=seed))
    rng = np.random.default_rng(seed)
    res = run(config, simulate(config, rng), rng) if runs == 1 else monte_carlo(config, runs, rng)
    return {m: {q: float(rms_over_runs(getattr(r, q))[-1]) for q, _, _ in QUANTITIES} for m, r in res.items()}


def change(value: float, reference: float) -> str:
    return f"{100.0 * (value - reference) / reference:+.0f} %"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--truth", choices=TRUTH_SOURCES, default="kinematic")
    args = parser.parse_args()
    started = time.perf_counter()
    what = "a single run, initial errors as given" if args.runs == 1 else f"RMS of {args.runs} Monte Carlo runs"
    out = [f"Errors at 250 s, beams 1 and 2 only, DVL aiding only ({what}, seed {args.seed}, {args.truth} "
           "truth); in brackets the change against the INS. LC cannot form a velocity from two beams and "
           "coasts.", ""]
    for name in TRAJECTORIES:
        table = errors_at_end(name, args.runs, args.seed, args.truth)
        ins = table["ins"]
        out += [f"**{name}**", "", "| method | " + " | ".join(label for _, label, _ in QUANTITIES) + " |",
                "|---" * (1 + len(QUANTITIES)) + "|"]
        for m, row in table.items():
            cells = []
            for q, _, fmt in QUANTITIES:
                text = format(row[q], fmt)
                if q in ("att_err_deg", "tilt_err_deg") and m != "ins":
                    text += f" ({change(row[q], ins[q])})"
                cells.append(text)
            out.append(f"| {m.upper()} | " + " | ".join(cells) + " |")
        out.append("")
    print("\n".join(out))
    print(f"({time.perf_counter() - started:.0f} s wall)")
    print(f"written to {fragment.write(f'partial_{args.truth}', chr(10).join(out))}")


if __name__ == "__main__":
    main()
