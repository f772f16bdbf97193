"""The long-range mission of Yoo 2014: INS, INS-DVL and the velocity Kalman filter (VKF) over 24 minutes.

Shows the second paper's scenario as a library call: :func:`tauvcore.config.trajectory_preset`
("longrange": 24 min at 10 knots, 50 m deep over a seabed at 110 m with trenches, the paper's
IMU at 100 Hz and its 5 Hz DVL) laid under our own values with :func:`tauvcore.config.merge`, then
:func:`tauvcore.config.from_dict`. Three methods run side by side: the standalone INS, Yoo's
12-state filter aided by the DVL's velocity (``ins-dvl``, coasting where the seabed is out of
range), and the same filter aided by the VKF (``vkf``), which learns the propeller's RPM-to-speed
map ``V = rpm sf - b`` from the DVL while it has bottom lock and switches to the RPM beyond
range. Printed: each method's end errors, and the VKF's learned scale factor and bias (with
their 1-sigma) beside the RPM model's true values.

Run::

    .venv/bin/python examples/05_long_range.py [--duration 1440]
"""

from __future__ import annotations

import numpy as np
from _common import error_table, finite, parser

from tauvcore.config import from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run_streaming


def main() -> None:
    args = parser(__doc__, duration_s=1440.0, short_duration_s=30.0).parse_args()
    ours = {
        "trajectory": {"name": "longrange", "duration_s": args.duration},
        "run": {"methods": ["ins", "ins-dvl", "vkf"], "seed": 0},
    }
    config = from_dict(merge(trajectory_preset("longrange"), ours))  # the preset under our values
    results = run_streaming(config, np.random.default_rng(config.run.seed))

    tr = config.trajectory
    print(
        f"longrange, {tr.duration_s:g} s at {tr.speed_mps:.2f} m/s, IMU {config.imu.rate_hz:g} Hz, "
        f"DVL {config.dvl.rate_hz:g} Hz\n"
    )
    print(error_table(results))

    trace = results["vkf"].vkf_trace
    if trace is None or trace["t_s"].size == 0:
        raise SystemExit("the VKF left no trace")
    x, sigma = trace["x"][-1, 0], trace["sigma"][-1, 0]  # [V_rpm, sf, b] of run 0 at the last ping
    in_use = trace["rpm_in_use"][:, 0].astype(bool)
    print(f"\nVKF at {trace['t_s'][-1]:g} s (state [V_rpm, sf, b], tauvcore.filter.vkf):")
    print(
        f"  scale factor sf = {x[1]:.6f} +- {sigma[1]:.6f} m/s per rpm   (true {trace['sf_true'][-1, 0]:.6f})"
    )
    print(
        f"  bias         b  = {x[2]:.4f} +- {sigma[2]:.4f} m/s           (true {trace['b_true'][-1, 0]:.4f})"
    )
    print(f"  RPM speed in use at {100 * in_use.mean():.0f} % of the pings (the DVL out of range)")
    if not (finite(results) and np.isfinite(x).all()):
        raise SystemExit("a method's errors or the VKF's state are not finite")


if __name__ == "__main__":
    main()
