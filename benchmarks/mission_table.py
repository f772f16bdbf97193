"""Long missions: every mission, both truths, DVL alone and DVL + depth + magnetometer, the
standalone INS and the ESKF and invariant methods, at 1 h and at 10 h.

    python benchmarks/mission_table.py                     # 1 h and 10 h: about 90 minutes on 2 cores
    python benchmarks/mission_table.py --hours 1           # the 1 h table only (about 20 minutes)
    python benchmarks/mission_table.py --runs-10h 4        # fewer runs at 10 h

Per mission (straight line, figure eight, lawnmower), truth (kinematic, dynamic) and aiding, one
bank runs ``ins, lc, tc, nsv, elc, iekf`` side by side on the same seeded runs, all four beams,
random initial errors, WGS-84. Per method: position, velocity and heading error at the end and
their RMS over the mission (each the RMS over runs), NEES/dim of each block (position, velocity,
tilt, heading, sensor errors) averaged over runs and over the mission and over its last hour, the
runs the divergence monitor flagged and the DVL lock-out resets. 1 h: 20 runs, IMU 150 Hz; 10 h:
``--runs-10h`` runs (default 8), IMU 50 Hz; records at 1 Hz, streamed (memory does not grow with
the mission). The standalone INS has no DVL: its errors grow without bound (on WGS-84 the vertical
channel diverges) and its NEES is shown for completeness.

Writes docs/results/mission_table_1h.md and docs/results/mission_table_10h.md (benchmarks/fragment.py).
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

SEED = 2028
BLOCKS = ("pos", "vel", "tilt", "heading", "sensor")
METHODS = ("ins", "lc", "tc", "nsv", "elc", "iekf")
MISSIONS = ("straight", "figure8", "lawnmower")
TRUTHS = ("kinematic", "dynamic")
AIDINGS = {"dvl": ("dvl",), "dvl,depth,mag": ("dvl", "depth", "mag")}
HOURS = {1: (20, 150.0), 10: (8, 50.0)}  # hours -> (runs, IMU rate [Hz])


def accuracy(hours: float, runs: int, rate_hz: float, mission: str, truth: str, aiding: str) -> dict:
    """One bank of :data:`METHODS` on one mission: the table's numbers per method."""
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.engine.results import BLOCK_DIMS

    duration_s = hours * 3600.0
    config = (
        Config()
        .replace("trajectory", name=mission, truth=truth, duration_s=duration_s)
        .replace("imu", rate_hz=rate_hz)
        .replace("filter", output_rate_hz=1.0)
        .replace("initial_error", mode="random")
        .replace("run", methods=METHODS, aiding=AIDINGS[aiding])
    )
    dims = np.array([BLOCK_DIMS[b] for b in BLOCKS], dtype=float)
    last_hour_s = duration_s - 3600.0
    zeros = {"nees": np.zeros(len(BLOCKS)), "nees_last": np.zeros(len(BLOCKS)), "n": 0, "n_last": 0,
             "sq_pos": 0.0, "sq_vel": 0.0, "sq_hdg": 0.0, "resets": 0, "last": None}
    keep = {m: {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in zeros.items()} for m in METHODS}

    def reduce(chunk: dict) -> None:
        for m, res in chunk.items():
            k = keep[m]
            late = res.t_s >= last_hour_s
            k["nees"] += res.nees_block.sum(axis=(0, 1))
            k["nees_last"] += res.nees_block[late].sum(axis=(0, 1))
            k["n"] += res.nees_block.shape[0] * res.nees_block.shape[1]
            k["n_last"] += int(late.sum()) * res.nees_block.shape[1]
            k["sq_pos"] += float(np.sum(res.pos_err_m**2))
            k["sq_vel"] += float(np.sum(res.vel_err_mps**2))
            k["sq_hdg"] += float(np.sum(res.heading_err_deg**2))
            dvl = res.updates.get("dvl")
            if dvl is not None and dvl.reset is not None:
                k["resets"] += int(dvl.reset.sum())
            k["last"] = res

    rngs = [np.random.default_rng([SEED, r]) for r in range(runs)]
    run_streaming(config, rngs, num_runs=runs, keep=False, sinks=Sinks(on_chunk=reduce))
    out = {}
    for m in METHODS:
        k, res = keep[m], keep[m]["last"]
        samples = k["n"]
        out[m] = {
            "pos_end_m": float(np.sqrt(np.mean(res.pos_err_m[-1] ** 2))),
            "vel_end_mps": float(np.sqrt(np.mean(res.vel_err_mps[-1] ** 2))),
            "hdg_end_deg": float(np.sqrt(np.mean(res.heading_err_deg[-1] ** 2))),
            "pos_rms_m": float(np.sqrt(k["sq_pos"] / samples)),
            "vel_rms_mps": float(np.sqrt(k["sq_vel"] / samples)),
            "hdg_rms_deg": float(np.sqrt(k["sq_hdg"] / samples)),
            "nees": (k["nees"] / samples / dims).tolist(),
            "nees_last": (k["nees_last"] / max(k["n_last"], 1) / dims).tolist(),
            "flagged": int(res.diverged.sum()),
            "resets": k["resets"],
        }
    return out


def _number(value: float, digits: int) -> str:
    return "-" if not np.isfinite(value) else (f"{value:,.0f}" if value >= 1e4 else f"{value:,.{digits}f}")


def table(hours: int, runs: int, rate_hz: float, results: dict) -> str:
    lines = [
        f"{hours} h, all four beams, random initial errors, WGS-84; {runs} seeded runs per row (the same seeds "
        f"for every method of a mission), IMU {rate_hz:.0f} Hz, records at 1 Hz. Errors: RMS over runs at the "
        "end, and over runs and the mission (RMS). NEES/dim per block: averaged over runs and the mission, "
        "then over the last hour (mission / last hour). Flagged: runs the divergence monitor flagged; resets: "
        "DVL lock-out resets over all runs.",
        "",
        "| mission | truth | aiding | method | position end / RMS [m] | velocity end / RMS [m/s] | "
        "heading end / RMS [deg] | NEES/dim pos | vel | tilt | heading | sensor | flagged | resets |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for (mission, truth, aiding), rows in results.items():
        for m in METHODS:
            r = rows[m]
            nees = " | ".join(
                f"{_number(a, 2)} / {_number(b, 2)}" for a, b in zip(r["nees"], r["nees_last"], strict=True)
            )
            lines.append(
                f"| {mission} | {truth} | {aiding} | {m} | {_number(r['pos_end_m'], 1)} / {_number(r['pos_rms_m'], 1)} | "
                f"{_number(r['vel_end_mps'], 3)} / {_number(r['vel_rms_mps'], 3)} | "
                f"{_number(r['hdg_end_deg'], 2)} / {_number(r['hdg_rms_deg'], 2)} | {nees} | "
                f"{r['flagged']} | {r['resets']} |"
            )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=int, nargs="+", choices=sorted(HOURS), default=sorted(HOURS))
    parser.add_argument("--runs-10h", type=int, default=HOURS[10][0], help="runs per row at 10 h (default 8)")
    parser.add_argument("--workers", type=int, default=2, help="missions computed at once (default 2)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        spec = json.loads(args.child)
        print(json.dumps(accuracy(**spec)))
        return
    for hours in args.hours:
        started = time.perf_counter()
        runs, rate_hz = HOURS[hours]
        if hours == 10:
            runs = args.runs_10h
        keys = [(m, t, a) for m in MISSIONS for t in TRUTHS for a in AIDINGS]

        def child(key: tuple, hours: int = hours, runs: int = runs, rate_hz: float = rate_hz) -> dict:
            spec = dict(hours=hours, runs=runs, rate_hz=rate_hz, mission=key[0], truth=key[1], aiding=key[2])
            out = subprocess.run(
                [sys.executable, __file__, "--child", json.dumps(spec)], check=True, capture_output=True, text=True
            )
            print(f"  {hours} h {key}: done", flush=True)
            return json.loads(out.stdout.strip().splitlines()[-1])

        with ThreadPoolExecutor(max_workers=args.workers) as pool:
            results = dict(zip(keys, pool.map(child, keys), strict=True))
        text = table(hours, runs, rate_hz, results)
        print(text)
        elapsed = time.perf_counter() - started
        print(f"{elapsed:.0f} s; written to {fragment.write(f'mission_table_{hours}h', text)}")


if __name__ == "__main__":
    main()
