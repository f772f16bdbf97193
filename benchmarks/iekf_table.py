"""The invariant EKF against the ESKF: accuracy, consistency and cost, 250 s to 10 h, full and
partial beams.

    python benchmarks/iekf_table.py                 # about 20 minutes on 2 cores
    python benchmarks/iekf_table.py --quick         # 250 s and 1 h only

``iekf`` (tauvcore.filter.invariant) fuses the returned beams one row each, as ``tc`` does, so
``tc`` is the ESKF it is compared with measurement for measurement; ``lc`` (all beams) and ``nsv``
(beams 1-2) are the other ESKFs of the lab. Straight line, DVL + depth + magnetometer, random
initial errors, the same seeds for every method of a row (one bank runs them side by side):
20 runs at 250 s and 1 h (IMU 150 Hz), 8 runs at 10 h (IMU 50 Hz, 1 Hz records, streamed). Per
method: position, velocity and heading error at the end (RMS over runs) and NEES/dim of each
block averaged over runs and the mission. Cost per step: one run of the method alone, 1 h at
150 Hz, wall time over the IMU steps, against ``tc``'s (each in its own process, best of three).

Writes docs/results/iekf_table.md (benchmarks/fragment.py).
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

SEED = 2027
BLOCKS = ("pos", "vel", "tilt", "heading", "sensor")
CASES = {  # label -> (duration [s], runs, IMU rate [Hz])
    "250 s": (250.0, 20, 150.0),
    "1 h": (3600.0, 20, 150.0),
    "10 h": (36000.0, 8, 50.0),
}
BEAMS = {"all beams": ((1, 2, 3, 4), ("lc", "tc", "iekf")), "beams 1-2": ((1, 2), ("nsv", "tc", "iekf"))}


def accuracy(case: str, beams: str) -> dict:
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.engine.results import BLOCK_DIMS

    duration, runs, rate = CASES[case]
    beam_list, methods = BEAMS[beams]
    config = (Config().replace("trajectory", name="straight", duration_s=duration)
              .replace("imu", rate_hz=rate).replace("filter", output_rate_hz=1.0)
              .replace("dvl", beams=beam_list).replace("initial_error", mode="random")
              .replace("run", methods=methods, aiding=("dvl", "depth", "mag")))
    dims = np.array([BLOCK_DIMS[b] for b in BLOCKS], dtype=float)
    keep = {m: {"sum": np.zeros(len(BLOCKS)), "n": 0, "last": None} for m in methods}

    def reduce(chunk):
        for m, res in chunk.items():
            keep[m]["sum"] += res.nees_block.sum(axis=(0, 1))
            keep[m]["n"] += res.nees_block.shape[0] * res.nees_block.shape[1]
            keep[m]["last"] = res

    rngs = [np.random.default_rng([SEED, r]) for r in range(runs)]
    run_streaming(config, rngs, num_runs=runs, keep=False, sinks=Sinks(on_chunk=reduce))
    out = {}
    for m in methods:
        res = keep[m]["last"]
        out[m] = {
            "pos_m": float(np.sqrt(np.mean(res.pos_err_m[-1] ** 2))),
            "vel_mps": float(np.sqrt(np.mean(res.vel_err_mps[-1] ** 2))),
            "heading_deg": float(np.sqrt(np.mean(res.heading_err_deg[-1] ** 2))),
            "nees": (keep[m]["sum"] / keep[m]["n"] / dims).tolist(),
            "flagged": int(res.diverged.sum()),
        }
    return out


def cost(method: str) -> float:
    """Wall seconds per IMU step of ``method`` alone, 1 h at 150 Hz, one run."""
    from tauvcore.config import Config
    from tauvcore.engine.mission import run_streaming

    config = (Config().replace("trajectory", name="straight", duration_s=3600.0)
              .replace("run", methods=(method,), aiding=("dvl", "depth", "mag")))
    run_streaming(config.replace("trajectory", duration_s=20.0), np.random.default_rng(0), keep=False)  # compile
    t0 = time.perf_counter()
    run_streaming(config, np.random.default_rng(0), keep=False)
    return (time.perf_counter() - t0) / (3600.0 * config.imu.rate_hz)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="250 s and 1 h only")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, *rest = args.child.split("|")
        print(json.dumps(accuracy(*rest) if kind == "accuracy" else cost(rest[0])))
        return
    started = time.perf_counter()

    def child(spec: str):
        out = subprocess.run([sys.executable, __file__, "--child", spec], check=True, capture_output=True, text=True)
        return json.loads(out.stdout.strip().splitlines()[-1])

    cases = [c for c in CASES if not (args.quick and c == "10 h")]
    jobs = [f"accuracy|{c}|{b}" for c in cases for b in BEAMS]
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = dict(zip(jobs, pool.map(child, jobs), strict=True))
    costs = {}
    for method in ("tc", "iekf", "lc"):             # one at a time: timings on a quiet machine
        costs[method] = min(child(f"cost|{method}") for _ in range(3))
    lines = [
        "Straight line, DVL + depth + magnetometer, random initial errors; errors at the end, RMS over runs; "
        "NEES/dim averaged over runs and the mission (250 s and 1 h: 20 runs, IMU 150 Hz; 10 h: 8 runs, 50 Hz).",
        "",
        "| mission | beams | method | position [m] | velocity [m/s] | heading [deg] | NEES/dim pos | vel | tilt | "
        "heading | sensor | flagged |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cases:
        for b, (_, methods) in BEAMS.items():
            for m in methods:
                r = results[f"accuracy|{c}|{b}"][m]
                n = r["nees"]
                lines.append(f"| {c} | {b} | {m} | {r['pos_m']:,.1f} | {r['vel_mps']:.3f} | {r['heading_deg']:.2f} | "
                             f"{n[0]:.2f} | {n[1]:.2f} | {n[2]:.2f} | {n[3]:.2f} | {n[4]:.2f} | {r['flagged']} |")
    lines += ["", "Cost per IMU step, the method alone (1 h at 150 Hz, one run, best of three):", "",
              "| method | per step [us] | against tc |", "|---|---|---|"]
    for m, c in costs.items():
        lines.append(f"| {m} | {1e6 * c:.2f} | {c / costs['tc']:.2f} |")
    table = "\n".join(lines)
    print(table)
    print(f"{time.perf_counter() - started:.0f} s; written to {fragment.write('iekf_table', table)}")


if __name__ == "__main__":
    main()
