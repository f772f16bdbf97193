"""Sweep the virtual-beam method's n_f (eq. 28, the inflation of the predicted beam's sigma; the
paper gives no value): velocity error and consistency of VB with beams 1 and 2 only, on the
three trajectories, over seeded Monte Carlo runs.

    python benchmarks/vb_nf_sweep.py [--runs 20] [--seed 0] [--nf 1,2,3,5,10,20,50]

Per trajectory and n_f: the velocity RMS over runs at the end and its time average after the
first 30 s (the lawnmower's dive), the run-averaged 20-state NEES divided by 20 (1.0 is
consistent) averaged over the output epochs, the fraction of output epochs whose run-averaged
NEES lies inside the two-sided 99 % chi-square band, the fraction of VB's pings the 3-sigma gate
rejected, and how many runs the divergence monitor flagged. Writes docs/results/vb_nf_sweep.md
(benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.metrics import rms
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

SETTLE_S = 30.0     # the lawnmower's dive; the time-averaged RMS starts after it


def sweep_row(name: str, nf: float, runs: int, seed: int) -> dict[str, float]:
    config = (Config().replace("trajectory", name=name).replace("dvl", beams=(1, 2))
              .replace("partial", vb_nf=nf).replace("run", methods=("vb",), seed=seed))
    res = monte_carlo(config, runs, np.random.default_rng(seed))["vb"]
    vel = rms_over_runs(res.vel_err_mps)
    after = res.t_s >= SETTLE_S
    full = method_consistency(res).nees["full"]
    dvl = res.updates["dvl"]
    return {"vel_end": float(vel[-1]), "vel_rms": float(rms(vel[after])),
            "nees_dim": full.per_dim, "inside": full.in_band,
            "rejected": float(dvl.rejected.sum() / max(dvl.valid.sum(), 1)),
            "diverged": int(res.diverged.sum())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--nf", default="1,2,3,5,10,20,50", help="comma-separated n_f values")
    args = parser.parse_args()
    values = [float(v) for v in args.nf.split(",")]
    started = time.perf_counter()
    with fragment.capture() as shown:
        print(f"VB, beams 1 and 2 only, DVL aiding only, 250 s, {args.runs} Monte Carlo runs, seed {args.seed}\n")
        print("| trajectory | n_f | vel end [m/s] | vel RMS after 30 s [m/s] | NEES/dim | epochs in 99 % band "
              "| pings rejected | runs flagged |")
        print("|---|---|---|---|---|---|---|---|")
        for name in TRAJECTORIES:
            for nf in values:
                r = sweep_row(name, nf, args.runs, args.seed)
                print(f"| {name} | {nf:g} | {r['vel_end']:.3f} | {r['vel_rms']:.3f} | {r['nees_dim']:.3g} | "
                      f"{r['inside']:.2f} | {r['rejected']:.2f} | {r['diverged']}/{args.runs} |", flush=True)
    print(f"\n({time.perf_counter() - started:.0f} s wall)")
    print(f"written to {fragment.write('vb_nf_sweep', shown.getvalue())}")

if __name__ == "__main__":
    main()
