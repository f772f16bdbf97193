"""Why the plain EKF fails on ten hours of straight line: each suspected cause switched off alone.

    python benchmarks/long_mission_causes.py               # 10 h, 20 runs, 50 Hz IMU (about 25 min on 2 cores)
    python benchmarks/long_mission_causes.py --hours 3 --runs 8

``lc`` on the straight line with DVL, depth and magnetometer aiding, random initial errors, the
same seeds for every row. Each row changes one thing against the first (the EKF with the DVL scale
factor's column of H at the current velocity estimate, ``filter.scale_factor_velocity_tau_s = 0``):

- the scale factor's random walk off in the truth and in the filter (its process noise against the
  truth's walk);
- the IMU's white noise off (accelerometer and gyro): what makes the velocity estimate jitter;
- the lock-out reset off (tauvcore.engine.lockout);
- the covariance propagated at 50 Hz instead of 10 (numerical growth between pings);
- the column at the true body velocity (an oracle: the truth is read at each ping; no filter can);
- the column at the body velocity averaged over 300 s (the filter's default,
  tauvcore.engine.scale_factor).

First-estimates Jacobians (Huang, Mourikis and Roumeliotis) evaluate every Jacobian at the first
estimate of each state; for the time-varying velocity that is the prior at the ping, which the
plain EKF already uses, so that row is the first. The small-angle error model is not in question
here: the magnetometer holds the heading error to a fraction of a degree.

Per row: the scale factor's error and the filter's sigma at the end (RMS over runs, %), the velocity
and position error at the end (RMS over runs), NEES/dim per block averaged over runs and the whole
mission, and the count of P floors (eigenvalues repaired). Each row runs in its own process, two at
a time. Writes docs/results/long_mission_causes.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import fragment
import numpy as np

SEED = 2026
ROWS = {
    "plain EKF (column at the current estimate)": {},
    "scale factor walk off (truth and filter)": {"dvl": {"scale_factor_rw_pct_per_sqrt_s": 0.0}},
    "IMU white noise off": {"imu": {"accel_noise_mps_per_sqrt_h": 0.0, "gyro_noise_deg_per_sqrt_h": 0.0}},
    "lock-out reset off": {"filter": {"lockout_reset_updates": 0}},
    "covariance at 50 Hz": {"filter": {"covariance_rate_hz": 50.0}},
    "column at the true velocity (oracle)": {"oracle": True},
    "column at the 300 s average (default)": {"filter": {"scale_factor_velocity_tau_s": 300.0}},
}
BLOCKS = ("pos", "vel", "tilt", "heading", "sensor")


def _install_oracle() -> None:
    """Evaluate the scale factor's column at the truth's body velocity at each ping."""
    from tauvcore.engine import filter_bank
    from tauvcore.engine.scale_factor import body_velocity

    plain_rows = filter_bank.scale_factor_rows
    update = filter_bank.FilterBank._update_dvl
    truth_v_b = {}

    def truthful_update(self, y, available, omega_meas, t):
        t_s, vel_n, C_nb = self._chunk_in[3], self._chunk_in[5], self._chunk_in[6]   # loop.ChunkTruth, plain
        i = int(np.argmin(np.abs(t_s - t)))
        truth_v_b["now"] = np.broadcast_to(body_velocity(C_nb[i], vel_n[i]), self.vel.shape)
        return update(self, y, available, omega_meas, t)

    filter_bank.FilterBank._update_dvl = truthful_update
    filter_bank.scale_factor_rows = lambda H, mode, A_b, v_ref_b: plain_rows(H, mode, A_b, truth_v_b["now"])


def child(hours: float, runs: int, imu_rate_hz: float, row: str) -> None:
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.engine.results import BLOCK_DIMS, SENSOR_STATES

    change = dict(ROWS[row])
    oracle = change.pop("oracle", False)
    config = (Config().replace("trajectory", name="straight", duration_s=hours * 3600.0)
              .replace("imu", rate_hz=imu_rate_hz).replace("filter", output_rate_hz=1.0,
                                                           scale_factor_velocity_tau_s=300.0 if oracle else 0.0)
              .replace("initial_error", mode="random").replace("run", methods=("lc",), aiding=("dvl", "depth", "mag")))
    for section, fields in change.items():
        config = config.replace(section, **fields)
    if oracle:
        _install_oracle()
    sf = [s.name for s in SENSOR_STATES].index("sf_dvl")
    dims = np.array([BLOCK_DIMS[b] for b in BLOCKS], dtype=float)
    keep = {"sum": np.zeros(len(BLOCKS)), "n": 0, "last": None}

    def reduce(chunk):
        res = chunk["lc"]
        keep["sum"] += res.nees_block.sum(axis=(0, 1))
        keep["n"] += res.nees_block.shape[0] * res.nees_block.shape[1]
        keep["last"] = res

    t0 = time.perf_counter()
    rngs = [np.random.default_rng([SEED, r]) for r in range(runs)]
    run_streaming(config, rngs, num_runs=runs, keep=False, sensor_errors=True, sinks=Sinks(on_chunk=reduce))
    res = keep["last"]
    sf_err = res.sensor_true[-1, :, sf] - res.sensor_est[-1, :, sf]
    print(json.dumps({
        "row": row,
        "sf_err_pct": 100 * float(np.sqrt(np.mean(sf_err**2))),
        "sf_est_mean_pct": 100 * float(np.mean(res.sensor_est[-1, :, sf])),
        "sf_sigma_pct": 100 * float(np.sqrt(np.mean(res.sensor_sigma[-1, :, sf] ** 2))),
        "vel_err_mps": float(np.sqrt(np.mean(res.vel_err_mps[-1] ** 2))),
        "pos_err_m": float(np.sqrt(np.mean(res.pos_err_m[-1] ** 2))),
        "nees": (keep["sum"] / keep["n"] / dims).tolist(),
        "p_floors": int(res.p_floor_count.sum()),
        "wall_s": time.perf_counter() - t0,
    }))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=10.0)
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--imu-rate-hz", type=float, default=50.0)
    parser.add_argument("--child", choices=list(ROWS), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.hours, args.runs, args.imu_rate_hz, args.child)
        return
    started = time.perf_counter()

    def one(row: str) -> dict:
        out = subprocess.run([sys.executable, __file__, "--hours", str(args.hours), "--runs", str(args.runs),
                              "--imu-rate-hz", str(args.imu_rate_hz), "--child", row],
                             check=True, capture_output=True, text=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(one, ROWS))
    lines = [
        f"`lc`, straight line, {args.hours:g} h, DVL + depth + magnetometer, {args.runs} seeded runs (random "
        f"initial errors), IMU {args.imu_rate_hz:g} Hz. Errors at the end, RMS over runs; NEES/dim averaged "
        "over runs and the whole mission.",
        "",
        "| change | scale factor: mean estimate / RMS error / sigma [%] | velocity error [m/s] | "
        "position error [m] | NEES/dim pos | vel | tilt | heading | sensor | P floors |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        n = r["nees"]
        lines.append(
            f"| {r['row']} | {r['sf_est_mean_pct']:+.2f} / {r['sf_err_pct']:.2f} / {r['sf_sigma_pct']:.2f} | "
            f"{r['vel_err_mps']:.3f} | {r['pos_err_m']:,.0f} | {n[0]:.2f} | {n[1]:.2f} | {n[2]:.2f} | {n[3]:.2f} | "
            f"{n[4]:.2f} | {r['p_floors']} |"
        )
    table = "\n".join(lines)
    print(table)
    print(f"{time.perf_counter() - started:.0f} s; written to {fragment.write('long_mission_causes', table)}")


if __name__ == "__main__":
    main()
