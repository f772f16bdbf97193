"""Yoo 2014's long-range mission in an ocean current: what a current the filters ignore costs.

    python benchmarks/current_table.py [--runs 20] [--seed 0]

The mission (``--trajectory longrange``: 24 minutes north at 10 knots, bottom lock lost over the
two trenches from 5 to 8 and from 15 to 16 minutes) with DVL, depth and magnetometer aiding and
random initial errors, in still water and in a 0.3 m/s current across the track (east) and along
it (against the vehicle, south). The kinematic truth keeps its track over ground and crabs into
the current; the DVL's bottom-track measures velocity over ground, the propeller speed through
the water. Per method, over the runs: the RMS of the position error at the end, of the
velocity error inside the trenches, and the velocity NEES per dimension inside the trenches; for
``vkf`` also the learned bias of eq. 20 less the speed model's true bias at the end, which takes
up the current's along-hull part.

Methods: INS, INS-DVL and VKF (Yoo 2014's 12-state filter), LC with ``run.rpm_fallback`` (the VKF's
RPM velocity where the DVL gives none).

Writes docs/results/current_table.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import Config, from_dict, trajectory_preset
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

TRENCHES_S = ((300.0, 480.0), (900.0, 960.0))
METHODS = ("ins", "ins-dvl", "vkf", "lc")
CASES = (
    ("still water", (0.0, 0.0, 0.0)),
    ("0.3 m/s across the track (toward east)", (0.0, 0.3, 0.0)),
    ("0.3 m/s along the track (toward south, against the vehicle)", (-0.3, 0.0, 0.0)),
)


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.asarray(a) ** 2)))


def case_rows(current_n_mps: tuple[float, float, float], runs: int, seed: int) -> list[str]:
    config = (
        from_dict(trajectory_preset("longrange"), Config().replace("trajectory", name="longrange"))
        .replace("trajectory", current_n_mps=current_n_mps)
        .replace("initial_error", mode="random")
        .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"), seed=seed, rpm_fallback=True)
    )
    rng = np.random.default_rng(seed)
    results = run(config, simulate(config, rng, runs), rng)
    rows = []
    for method, r in results.items():
        t = np.asarray(r.t_s)
        trench = np.zeros(t.shape, bool)
        for start, end in TRENCHES_S:
            trench |= (t > start) & (t < end)
        nees_vel = np.asarray(r.nees_block)[..., 1] / 3.0
        bias = "-"
        if method == "vkf" and r.vkf_trace is not None:
            tr = r.vkf_trace
            bias = f"{rms(np.asarray(tr['x'])[-1, ..., 2] - np.asarray(tr['b_true'])[-1]):.3f}"
        label = f"{method.upper()}{' (--rpm-fallback)' if method == 'lc' else ''}"
        rows.append(
            f"| {label} | {rms(np.asarray(r.pos_err_m)[-1]):.1f} | {rms(np.asarray(r.vel_err_mps)[trench]):.3f} "
            f"| {np.nanmean(nees_vel[trench]):.2f} | {bias} |"
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    with fragment.capture() as shown:
        print(f"Long-range mission, {args.runs} Monte Carlo runs (seed {args.seed}), DVL, depth and magnetometer "
              "aiding, random initial errors; RMS over the runs. Trench: 5-8 and 15-16 minutes, no bottom lock.\n")
        for title, current in CASES:
            print(f"**{title}**\n")
            print("| method | end position [m] | trench velocity RMS [m/s] | trench velocity NEES/3 "
                  "| VKF bias less true, end [m/s] |")
            print("|---|---|---|---|---|")
            for line in case_rows(current, args.runs, args.seed):
                print(line, flush=True)
            print()
        print(f"*{time.perf_counter() - started:.0f} s in all.*")
    print(f"written to {fragment.write('current_table', shown.getvalue())}")


if __name__ == "__main__":
    main()
