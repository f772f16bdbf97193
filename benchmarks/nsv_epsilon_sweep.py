"""Where NSV's epsilon comes from (eq. 36, the variance of the "sway = 0" assumption; the paper gives
no value): the sway the vehicle really has on each trajectory, the value derived from the vehicle
("auto"), and a sweep of epsilon against NSV's velocity error and consistency, beams 1 and 2 only,
over seeded Monte Carlo runs.

    python benchmarks/nsv_epsilon_sweep.py [--runs 20] [--seed 0] [--eps 1e-4,1e-3,0.011,0.05,auto,1]

First table: per trajectory, the truth's sway (RMS over the run and its largest magnitude), the
bound ``U tan(beta_max)`` and the derived epsilon (tauvcore.aiding.elc_nsv.epsilon_from_vehicle).
Second: per trajectory and epsilon, NSV's velocity RMS over runs averaged after the first 30 s
(the lawnmower's dive), its full-state and velocity NEES/dim (fraction of output epochs whose
run-averaged NEES lies inside the two-sided 99 % band) and how many runs the monitor flagged.
Writes both to docs/results/nsv_epsilon_sweep.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import AUTO, Config
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.metrics import rms
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tauvcore.truth import generate

SETTLE_S = 30.0


def sway_row(name: str) -> dict[str, float]:
    config = Config().replace("trajectory", name=name)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    sway = truth.vel_b[:, 1]
    tr = config.trajectory
    return {"rms": float(rms(sway, axis=0)), "max": float(np.max(np.abs(sway))),
            "bound": tr.speed_mps * np.tan(np.radians(tr.turn_sideslip_deg)),
            "auto": config.nsv_epsilon_value_m2_per_s2()}


def sweep_row(name: str, epsilon: float | str, runs: int, seed: int) -> dict[str, float]:
    config = (Config().replace("trajectory", name=name).replace("dvl", beams=(1, 2))
              .replace("partial", nsv_epsilon_m2_per_s2=epsilon).replace("run", methods=("nsv",), seed=seed))
    res = monte_carlo(config, runs, np.random.default_rng(seed))["nsv"]
    c = method_consistency(res).nees
    vel = rms_over_runs(res.vel_err_mps)
    return {"vel_rms": float(rms(vel[res.t_s >= SETTLE_S])), "full": c["full"].per_dim, "full_in": c["full"].in_band,
            "vel": c["vel"].per_dim, "vel_in": c["vel"].in_band, "diverged": int(res.diverged.sum()),
            "value": config.nsv_epsilon_value_m2_per_s2()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--eps", default="1e-4,1e-3,0.011,0.05,auto,1", help="comma-separated values or 'auto'")
    args = parser.parse_args()
    values: list[float | str] = [AUTO if v.strip() == AUTO else float(v) for v in args.eps.split(",")]
    started = time.perf_counter()
    with fragment.capture() as shown:
        print("The vehicle's sway (truth, 250 s)\n")
        print("| trajectory | sway RMS [m/s] | sway max [m/s] | bound U tan(beta_max) [m/s] | epsilon auto [m^2/s^2] |")
        print("|---|---|---|---|---|")
        for name in TRAJECTORIES:
            s = sway_row(name)
            print(f"| {name} | {s['rms']:.3f} | {s['max']:.3f} | {s['bound']:.3f} | {s['auto']:.3g} |")
        print(f"\nNSV, beams 1 and 2 only, DVL aiding only, 250 s, {args.runs} Monte Carlo runs, seed {args.seed}\n")
        print("| trajectory | epsilon [m^2/s^2] | vel RMS after 30 s [m/s] | NEES/dim full (in band) "
              "| NEES/dim velocity (in band) | runs flagged |")
        print("|---|---|---|---|---|---|")
        for name in TRAJECTORIES:
            for eps in values:
                r = sweep_row(name, eps, args.runs, args.seed)
                label = f"auto ({r['value']:.3g})" if eps == AUTO else f"{eps:g}"
                print(f"| {name} | {label} | {r['vel_rms']:.3f} | {r['full']:.3g} ({r['full_in']:.2f}) | "
                      f"{r['vel']:.3g} ({r['vel_in']:.2f}) | {r['diverged']}/{args.runs} |", flush=True)
    print(f"\n({time.perf_counter() - started:.0f} s wall)")
    print(f"written to {fragment.write('nsv_epsilon_sweep', shown.getvalue())}")


if __name__ == "__main__":
    main()
