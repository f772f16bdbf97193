"""Long straight run of ``lc``: heading drift with the DVL alone, bounded by the magnetometer.

    python benchmarks/long_run.py                       # 10 hours, 150 Hz IMU
    python benchmarks/long_run.py --hours 1 --imu-rate-hz 50

Runs ``lc`` on the straight track with ``--aiding dvl``, with ``dvl,mag``, and with ``dvl`` at
latitude 89 deg, where the earth's rotation carries no heading (same seed, Table 2 sensors, fixed
initial errors), each in its own process so that its peak memory (maxrss) is its own, and prints a
Markdown table: heading error and the filter's heading 1-sigma at the end, the heading NEES
averaged over the mission, NEES (20 states) at the end and averaged over the last hour, the
divergence monitor's verdict, the P floor count, wall time and peak memory. A speed and behaviour record, not a test
(tests/statistical/test_long_run.py is the bounded-cost test). Writes docs/results/long_run.md
(benchmarks/fragment.py).

The run is streamed (tauvcore.engine.mission.run_streaming, ``keep=False``): truth, sensors and
results pass 10 s at a time and only the figures above are kept, so the memory does not grow
with the mission's length.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import fragment
import numpy as np

ROWS = {  # row -> (aiding, latitude [deg] or None for the default)
    "dvl": ("dvl", None),
    "dvl,mag": ("dvl,mag", None),
    "dvl, latitude 89 deg": ("dvl", 89.0),
}


def child(hours: float, imu_rate_hz: float, seed: int, row: str) -> None:
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.filter.layout import NEES_BLOCKS

    aiding, latitude = ROWS[row]
    config = (Config().replace("trajectory", name="straight", duration_s=hours * 3600.0)
              .replace("imu", rate_hz=imu_rate_hz).replace("run", methods=("lc",), aiding=tuple(aiding.split(","))))
    if latitude is not None:
        config = config.replace("earth", latitude_deg=latitude)
    heading = list(NEES_BLOCKS).index("heading")
    t0 = time.perf_counter()
    last_hour_start = config.trajectory.duration_s - 3600.0
    keep: dict[str, float] = {"att_err_max_deg": 0.0, "nees_sum": 0.0, "nees_count": 0, "hdg_sum": 0.0, "hdg_n": 0}
    end: list = []

    def reduce(chunk: dict) -> None:       # each 10 s of results, then dropped
        res = chunk["lc"]
        keep["att_err_max_deg"] = max(keep["att_err_max_deg"], float(np.max(res.att_err_deg[:, 0])))
        late = res.t_s >= last_hour_start
        keep["nees_sum"] += float(res.nees[late, 0].sum())
        keep["nees_count"] += int(late.sum())
        keep["hdg_sum"] += float(res.nees_block[:, 0, heading].sum())
        keep["hdg_n"] += res.t_s.size
        end[:] = [res]
    run_streaming(config, np.random.default_rng(seed), keep=False, sinks=Sinks(on_chunk=reduce))
    res = end[0]
    wall = time.perf_counter() - t0
    print(json.dumps({
        "row": row, "hdg_err_deg": float(res.heading_err_deg[-1, 0]),
        "hdg_sigma_deg": float(res.heading_sigma_deg[-1, 0]),
        "hdg_nees_mean": keep["hdg_sum"] / keep["hdg_n"],
        "att_err_max_deg": keep["att_err_max_deg"],
        "nees_end": float(res.nees[-1, 0]), "nees_last_hour": keep["nees_sum"] / keep["nees_count"],
        "pos_err_m": float(res.pos_err_m[-1, 0]),
        "diverged_at_s": None if np.isnan(res.diverged_at_s[0]) else float(res.diverged_at_s[0]),
        "p_floor_count": int(res.p_floor_count[0]), "wall_s": wall,
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2,
    }))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=10.0)
    parser.add_argument("--imu-rate-hz", type=float, default=150.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--child", choices=list(ROWS), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.hours, args.imu_rate_hz, args.seed, args.child)
        return
    lines = [
        f"`lc`, straight line, {args.hours:g} h, IMU {args.imu_rate_hz:g} Hz, seed {args.seed}.",
        "",
        "| aiding | heading error end [deg] | heading 1-sigma end [deg] | heading NEES mean | att error max [deg] | "
        "NEES end | NEES mean last hour | pos error end [m] | flagged at [s] | P floors | wall [s] | peak memory [GB] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in ROWS:
        out = subprocess.run([sys.executable, __file__, "--hours", str(args.hours), "--imu-rate-hz",
                              str(args.imu_rate_hz), "--seed", str(args.seed), "--child", row],
                             check=True, capture_output=True, text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        div = "never" if r["diverged_at_s"] is None else f"{r['diverged_at_s']:.0f}"
        lines.append(f"| {row} | {r['hdg_err_deg']:.2f} | {r['hdg_sigma_deg']:.2f} | {r['hdg_nees_mean']:.2f} | "
                     f"{r['att_err_max_deg']:.2f} | "
                     f"{r['nees_end']:.1f} | {r['nees_last_hour']:.1f} | {r['pos_err_m']:,.0f} | {div} | "
                     f"{r['p_floor_count']} | {r['wall_s']:.0f} | {r['peak_rss_gb']:.2f} |")
        print(lines[-1], flush=True)
    print(f"written to {fragment.write('long_run', chr(10).join(lines))}")


if __name__ == "__main__":
    main()
