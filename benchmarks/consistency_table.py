"""Does every method know its own error? The consistency tables of docs/accuracy.md: average NEES divided by
its dimension, and the fraction of output epochs whose run-averaged NEES lies inside the two-sided
99 % chi-square band, for every method on the three trajectories.

    python benchmarks/consistency_table.py [--runs 20] [--seed 0]

Every method but LC sees beams 1 and 2 only (the paper's section 4.2 case); LC, which cannot use
two beams, sees all four. DVL aiding only, 250 s, Monte Carlo runs with the initial errors drawn
as 1-sigma (Table 2), defaults otherwise (n_f = 20, epsilon "auto"). The first table gives the
full 20-state NEES and the velocity block's; the second every block (position, velocity, tilt,
heading, sensor errors) and the DVL NIS per degree of freedom. Writes both to
docs/results/consistency_table.md (benchmarks/fragment.py; with ``--attitude-scale``,
consistency_table_attitude_x<scale>.md, e.g. consistency_table_attitude_x0.1.md).

``--attitude-scale 0.1`` shrinks the initial roll, pitch and yaw errors tenfold: the standalone
INS and PLCF on the straight line (whose unaided velocity errors reach tens of m/s with Table 2's
errors) then come back to a full-state NEES/dim near 1, which shows that their large full-state
NEES is the linearisation's second-order terms, not the model (docs/accuracy.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import METHODS, Config
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import MethodConsistency, method_consistency
from tauvcore.eval.montecarlo import monte_carlo
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

FOUR_BEAM_METHODS = ("lc",)
"""Methods that cannot use two beams: they run with all four (LC would only coast on two)."""


def consistency_by_method(name: str, runs: int, seed: int, attitude_scale: float = 1.0) -> dict[str, MethodConsistency]:
    """Every method on one trajectory: the two-beam methods in one bank, LC with four beams."""
    base = Config().replace("trajectory", name=name)
    ie = base.initial_error
    base = base.replace("initial_error", roll_pitch_deg=ie.roll_pitch_deg * attitude_scale,
                        yaw_deg=ie.yaw_deg * attitude_scale)
    two = tuple(m for m in METHODS if m not in FOUR_BEAM_METHODS)
    out: dict[str, MethodConsistency] = {}
    for beams, methods in (((1, 2, 3, 4), FOUR_BEAM_METHODS), ((1, 2), two)):
        config = base.replace("dvl", beams=beams).replace("run", methods=methods, seed=seed)
        for method, result in monte_carlo(config, runs, np.random.default_rng(seed)).items():
            out[method] = method_consistency(result)
    return {m: out[m] for m in METHODS}


def cell(per_dim: float, in_band: float) -> str:
    return "-" if not np.isfinite(per_dim) else f"{per_dim:.3g} ({in_band:.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--attitude-scale", type=float, default=1.0,
                        help="factor on Table 2's initial attitude errors (default 1)")
    args = parser.parse_args()
    started = time.perf_counter()
    table = {name: consistency_by_method(name, args.runs, args.seed, args.attitude_scale) for name in TRAJECTORIES}
    scaled = f", initial attitude errors x {args.attitude_scale:g}" if args.attitude_scale != 1.0 else ""
    with fragment.capture() as shown:
        print(f"NEES/dim (fraction of epochs in the 99 % band); {args.runs} Monte Carlo runs, seed {args.seed}, 250 s, "
              f"DVL aiding only; beams 1 and 2 (LC: four beams){scaled}\n")
        print("| method | " + " | ".join(f"{t}, full | {t}, velocity" for t in TRAJECTORIES) + " |")
        print("|---" * (1 + 2 * len(TRAJECTORIES)) + "|")
        for method in METHODS:
            cells = []
            for name in TRAJECTORIES:
                nees = table[name][method].nees
                cells += [cell(nees["full"].per_dim, nees["full"].in_band), cell(nees["vel"].per_dim, nees["vel"].in_band)]
            print(f"| {method.upper()} | " + " | ".join(cells) + " |")
        blocks = [b for b in BLOCK_DIMS if b != "full"]
        print("\nPer block, NEES/dim (in band), and the DVL's NIS/dof (in band)\n")
        print("| trajectory | method | " + " | ".join(f"{b} ({BLOCK_DIMS[b]})" for b in blocks) + " | DVL NIS |")
        print("|---|---|" + "---|" * (len(blocks) + 1))
        for name in TRAJECTORIES:
            for method in METHODS:
                c = table[name][method]
                nis = c.nis.get("dvl")
                nis_cell = cell(nis.per_dof, nis.in_band) if nis is not None else "-"
                print(f"| {name} | {method.upper()} | "
                      + " | ".join(cell(c.nees[b].per_dim, c.nees[b].in_band) for b in blocks) + f" | {nis_cell} |")
    print(f"\n({time.perf_counter() - started:.0f} s wall)")
    name = "consistency_table" + (f"_attitude_x{args.attitude_scale:g}" if args.attitude_scale != 1.0 else "")
    print(f"written to {fragment.write(name, shown.getvalue())}")


if __name__ == "__main__":
    main()
