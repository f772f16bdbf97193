"""Yoo 2014's long-range mission in a 0.3 m/s cross current: the current ignored, and estimated.

Shows the current as the truth flies it (tauvcore.truth.current: the kinematic truth crabs into it
over the same track) and as the filters estimate it. The same mission runs twice: LC with the
propeller's RPM standing in for the DVL over the trenches (``run.rpm_fallback``), first blind to
the current, then with the DVL water-tracking beyond bottom range (``dvl.water_track =
"beyond_range"``) and the current as two error states (``dvl.current_states = "random-walk"``,
tauvcore.aiding.dvl_water). Printed: each run's end errors and NEES, and the current the second
estimated (with its 1-sigma) beside the truth.

Run::

    .venv/bin/python examples/06_ocean_current.py [--duration 1440]
"""

from __future__ import annotations

import numpy as np
from _common import error_table, finite, parser

from tauvcore.config import from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.consistency import method_consistency


def main() -> None:
    args = parser(__doc__, duration_s=1440.0, short_duration_s=30.0).parse_args()
    ours = {
        "trajectory": {"name": "longrange", "duration_s": args.duration, "current_n_mps": [0.0, 0.3, 0.0]},
        "run": {"methods": ["lc", "tc"], "aiding": ["dvl", "depth", "mag"], "seed": 0, "rpm_fallback": True},
    }
    blind = from_dict(merge(trajectory_preset("longrange"), ours))
    aware = blind.replace(
        "dvl", water_track="beyond_range", current_states="random-walk", current_walk_mps_per_sqrt_s=1e-4
    )
    print(f"longrange, {args.duration:g} s, in a current of 0.3 m/s toward east\n")
    print("the current ignored (LC and TC with --rpm-fallback):")
    ignored = run_streaming(blind, np.random.default_rng(0))
    print(error_table(ignored))
    print("\nwater-track beyond bottom range, the current as states:")
    estimated = run_streaming(aware, np.random.default_rng(0))
    print(error_table(estimated))
    for name, res in estimated.items():
        print(f"{name}: the current's NEES/dim {method_consistency(res).nees['current'].per_dim:.2f}")
    r = estimated["lc"]
    if r.state_est is None or r.state_sigma is None or r.state_true is None:
        raise SystemExit("LC recorded no current states")
    est, sigma, true = r.state_est[-1, 0], r.state_sigma[-1, 0], r.state_true[-1, 0]
    print(
        f"\nLC's current at {r.t_s[-1]:g} s: north {est[0]:+.3f} +- {sigma[0]:.3f} m/s (true {true[0]:+.3f}), "
        f"east {est[1]:+.3f} +- {sigma[1]:.3f} m/s (true {true[1]:+.3f})"
    )
    if not (finite(ignored) and finite(estimated) and np.isfinite(est).all()):
        raise SystemExit("a method's errors or the current's estimate are not finite")


if __name__ == "__main__":
    main()
