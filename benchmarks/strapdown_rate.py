"""Accuracy of the strapdown mechanization against the IMU rate (a measurement, not a test).

    python benchmarks/strapdown_rate.py [--duration 300]

Ideal sensors and no initial error: the standalone INS should follow the truth exactly, so what
it does not is the algorithm's own error (the truth's increments are integrated to ~1e-13).
For each trajectory and IMU rate: the largest position error [m] and velocity error [m/s] over
the run, with the second-order rotation term ``dtheta x (dtheta x dv) / 6`` of the velocity
increment and without it (``tauvcore.ins.strapdown.SECOND_ORDER_ROTATION``). ``figure8-agile``
is the figure eight with 30 deg of roll and 5 m turns, where the term matters most.

Writes its tables to docs/results/strapdown_rate.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.ins import strapdown

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

CASES = {
    "straight": {"name": "straight"},
    "figure8": {"name": "figure8"},
    "lawnmower": {"name": "lawnmower"},
    "figure8-agile": {"name": "figure8", "turn_roll_deg": 30.0, "turn_radius_m": 5.0},
}
RATES_HZ = (50.0, 100.0, 150.0, 200.0, 400.0)


def errors(case: dict, rate_hz: float, duration_s: float, second_order: bool) -> tuple[float, float]:
    strapdown.SECOND_ORDER_ROTATION = second_order
    try:
        config = (Config().replace("trajectory", duration_s=duration_s, **case).replace("imu", rate_hz=rate_hz)
                  .replace("run", ideal=True, methods=("ins",)))
        rng = np.random.default_rng(0)
        result = run(config, simulate(config, rng), rng)["ins"]
    finally:
        strapdown.SECOND_ORDER_ROTATION = True
    return float(np.max(result.pos_err_m)), float(np.max(result.vel_err_mps))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--duration", type=float, default=300.0, help="mission length [s]")
    args = parser.parse_args()
    with fragment.capture() as shown:
        print(f"Largest error over {args.duration:g} s, ideal sensors: position [m] / velocity [m/s]\n")
        print("| trajectory | IMU rate [Hz] | with the second-order term | without |")
        print("|---|---|---|---|")
        for label, case in CASES.items():
            for rate in RATES_HZ:
                with_term = errors(case, rate, args.duration, True)
                without = errors(case, rate, args.duration, False)
                print(f"| {label} | {rate:g} | {with_term[0]:.2e} / {with_term[1]:.1e} | "
                      f"{without[0]:.2e} / {without[1]:.1e} |", flush=True)
    print(f"written to {fragment.write('strapdown_rate', shown.getvalue())}")


if __name__ == "__main__":
    main()
