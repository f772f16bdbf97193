"""The 6-DOF TAUV on the three missions: how well it flies them, and how fast it is simulated
(a measurement, not a test; docs/models.md, "Dynamic truth").

    python benchmarks/dynamic_truth.py [--duration 250] [--repeats 5]

Per mission, from the autopilot's own record (tauvcore.truth.truth_record.VehicleRecord): cross-track
error from the mission's path and depth error from its schedule (RMS and largest, after the
first 20 s, in which the vehicle settles from the kinematic start), sway and sideslip (what NSV
assumes away), the largest fin deflection, the propeller's RPM range. Then the time to simulate
the mission at the IMU rate (150 Hz; the equations of motion, autopilot and RK4:
tauvcore.truth.dynamic.DynamicSimulation) and to make the whole truth record from it (the
interpolant, IMU increments, WGS-84 position), best of ``--repeats``, compiled code warm. The
target: 250 s of mission in under 0.25 s (1,000 times faster than real time).

Writes its tables to docs/results/dynamic_truth.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from bench_run import best_of  # a sibling script (run from the repository root)

from tauvcore.geo.earth import Earth
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES
from tauvcore.truth import TrajectoryConfig, dynamic, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

SETTLE_S = 20.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=250.0)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    if not args.duration > SETTLE_S:
        parser.error(f"--duration must exceed the {SETTLE_S:g} s the statistics leave out, got {args.duration:g}")
    rate_hz = 150.0
    generate(TrajectoryConfig(name="figure8", duration_s=2.0, truth="dynamic"), Earth(), rate_hz)   # compile
    with fragment.capture() as shown:
        print(f"{args.duration:g} s missions at {rate_hz:g} Hz, statistics after the first {SETTLE_S:g} s\n")
        print("| mission | cross-track RMS / max [m] | depth RMS / max [m] | sway RMS / max [m/s] | sideslip max "
              "[deg] | fin max [deg] | RPM | simulation [s] | truth record [s] | faster than real time |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for name in TRAJECTORIES:
            cfg = TrajectoryConfig(name=name, duration_s=args.duration, truth="dynamic")
            n = dynamic.num_samples(cfg.duration_s, rate_hz) + 1
            sim_s = best_of(lambda: dynamic.DynamicSimulation(cfg, rate_hz).knots(n), args.repeats)
            record_s = best_of(lambda: dynamic.DynamicTruthStream(cfg, Earth(), rate_hz, n - 1, cache=False)
                                 .__iter__().__next__(), args.repeats)
            truth = generate(cfg, Earth(), rate_hz)
            v = truth.vehicle
            late = truth.t_s > SETTLE_S
            sway = truth.vel_b[late, 1]
            slip = np.degrees(np.arctan2(truth.vel_b[late, 1], truth.vel_b[late, 0]))

            def rms_max(x: np.ndarray) -> str:
                return f"{np.sqrt(np.mean(x ** 2)):.3f} / {np.max(np.abs(x)):.3f}"

            print(f"| {name} | {rms_max(v.cross_track_m[late])} | {rms_max(v.depth_error_m[late])} | {rms_max(sway)} | "
                  f"{np.max(np.abs(slip)):.1f} | {np.degrees(np.max(np.abs(v.fin_angles_rad[late]))):.1f} | "
                  f"{v.propeller_rpm[late].min():.0f}-{v.propeller_rpm[late].max():.0f} | {sim_s:.3f} | {record_s:.3f} | "
                  f"{args.duration / sim_s:,.0f}x |")
    print(f"written to {fragment.write('dynamic_truth', shown.getvalue())}")


if __name__ == "__main__":
    main()
