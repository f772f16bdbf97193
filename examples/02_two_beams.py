"""Methods compared on two beams: beams 3 and 4 lost, loosely coupled DVL against the extended methods.

Shows Tal et al. 2017 section 4.2 in a few lines: the same mission twice, once with all four
beams and LC (the reference), once with only beams 1 and 2 returning, where LC has no velocity
and coasts on the INS, while TC fuses the two beams one by one and the extended loosely coupled
methods (VB, NSV, PLCF, VHV and the per-axis selector ELC) build a velocity from two beams and an
assumption. Per method: end and RMS errors, NEES/dim, and what its DVL updates did (the records'
``mode``: loosely coupled, two-beam construction, tightly coupled, or coast). ``tauv run --beams
1,2 --method ins,lc,tc,vb,nsv,plcf,vhv,elc`` prints the same comparison.

Run::

    .venv/bin/python examples/02_two_beams.py [--duration 250] [--trajectory straight]
"""

from __future__ import annotations

import numpy as np
from _common import error_table, finite, parser

from tauvcore.aiding.dvl_extended import MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC
from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.truth import PAPER_TRAJECTORIES

TWO_BEAM_METHODS = ("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc")
MODE_NAMES = {MODE_COAST: "coast", MODE_LC: "lc", MODE_PARTIAL: "two-beam", MODE_TC: "tc"}


def main() -> None:
    p = parser(__doc__, duration_s=250.0, short_duration_s=20.0)
    p.add_argument("--trajectory", default="straight", choices=PAPER_TRAJECTORIES)
    args = p.parse_args()
    base = (
        Config().replace("trajectory", name=args.trajectory, duration_s=args.duration).replace("run", seed=1)
    )
    rng_seed = base.run.seed

    reference = run_streaming(base.replace("run", methods=("lc",)), np.random.default_rng(rng_seed))
    two = base.replace("dvl", beams=(1, 2)).replace("run", methods=TWO_BEAM_METHODS)
    results = run_streaming(two, np.random.default_rng(rng_seed))

    print(f"{args.trajectory}, {args.duration:g} s\n\nall four beams (the reference):")
    print(error_table(reference))
    print("\nbeams 3 and 4 lost (only beams 1 and 2 return):")
    print(error_table(results))
    print("\nwhat each method did with the DVL's pings:")
    for name, r in results.items():
        dvl = r.updates.get("dvl")
        if dvl is None:
            print(f"{name:<8} no DVL")
            continue
        modes = dvl.mode[:, 0]
        counts = ", ".join(
            f"{MODE_NAMES[int(code)]} {int(np.sum(modes == code))}" for code in np.unique(modes)
        )
        print(
            f"{name:<8} {counts}; fused {int(dvl.fused[:, 0].sum())}, rejected {int(dvl.rejected[:, 0].sum())}"
        )
    if not (finite(reference) and finite(results)):
        raise SystemExit("a method's errors are not finite")


if __name__ == "__main__":
    main()
