"""Heading with the DVL alone over ten hours: the aided filter against the free INS, on the same
seeds, for Table 2's gyro and for Yoo's 1 deg/h IMU.

    python benchmarks/heading_dvl_alone.py            # about 15 minutes on one core
    python benchmarks/heading_dvl_alone.py --runs 8

Straight line, 10 h, aiding ``dvl`` only, ``ins``, ``lc``, ``iekf`` and ``ukf`` in one bank (the same runs), the
paper's flat earth (on the ellipsoid the free INS's vertical channel diverges and takes its
navigation frame, and so its heading, with it), IMU 50 Hz, records at 1 Hz, seeds [2026, r].
Per IMU and method: the heading error at the end (RMS over runs), the filter's heading sigma there
(RMS over runs) and the heading NEES at the end (mean over runs). The free heading's 1-sigma that
the gyro's bias walk alone gives, ``q t^1.5 / sqrt(3)``, is printed beside it: an angle whose
sigma is beyond some 60 deg is a random one, and a mean square error over the circle is at most
104 deg (a uniform angle's).

Writes docs/results/heading_dvl_alone.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import dataclasses

import fragment
import numpy as np

METHODS = ("ins", "lc", "iekf", "ukf")
HOURS = (1, 3)  # the heading error and NEES also at these hours


def run(profile: str, runs: int) -> dict:
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.sensors.imu import imu_profile

    imu = dataclasses.asdict(imu_profile(profile)) | {"rate_hz": 50.0}
    config = (
        Config()
        .replace("trajectory", name="straight", duration_s=36000.0)
        .replace("imu", **imu)
        .replace("earth", model="flat")
        .replace("filter", output_rate_hz=1.0)
        .replace("run", methods=METHODS, aiding=("dvl",))
    )
    end: dict = {}
    at: dict = {}  # (method, hour) -> (heading error, sigma) (R,) at that hour

    def reduce(chunk: dict) -> None:
        for m, res in chunk.items():
            end[m] = (res.heading_err_deg[-1], res.heading_sigma_deg[-1])
            for hour in HOURS:
                k = np.flatnonzero(np.isclose(res.t_s, hour * 3600.0))
                if k.size:
                    at[m, hour] = (res.heading_err_deg[k[0]], res.heading_sigma_deg[k[0]])

    rngs = [np.random.default_rng([2026, r]) for r in range(runs)]
    run_streaming(config, rngs, num_runs=runs, keep=False, sinks=Sinks(on_chunk=reduce))
    walk_deg = np.degrees(imu_profile(profile).gyro_bias_rw_rps_per_sqrt_s) * 36000.0**1.5 / np.sqrt(3.0)
    return {"walk_deg": float(walk_deg), **{
        m: {"rms": float(np.sqrt(np.mean(e**2))), "sigma": float(np.sqrt(np.mean(s**2))),
            "nees": float(np.mean((e / s) ** 2)),
            "nees_at": [float(np.mean((at[m, h][0] / at[m, h][1]) ** 2)) for h in HOURS],
            "rms_at": [float(np.sqrt(np.mean(at[m, h][0] ** 2))) for h in HOURS]}
        for m, (e, s) in end.items()
    }}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args()
    lines = [
        f"Straight line, 10 h, DVL alone, flat earth, {args.runs} seeded runs (the same for every method); "
        "at the end: heading error (RMS over runs), the filter's heading sigma (RMS over runs), heading "
        "NEES (mean over runs); the same error and NEES at 1 h and 3 h; the free heading's 1-sigma "
        "from the gyro bias walk alone at 10 h.",
        "",
        "| IMU | bias walk's free heading 1-sigma [deg] | method | heading error 1 h / 3 h [deg] | "
        "heading NEES 1 h / 3 h | heading error 10 h [deg] | heading sigma 10 h [deg] | heading NEES 10 h |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for profile in ("table2", "yoo-table1"):
        out = run(profile, args.runs)
        for m in METHODS:
            r = out[m]
            lines.append(f"| {profile} | {out['walk_deg']:.0f} | {m} | "
                         f"{' / '.join(f'{v:.1f}' for v in r['rms_at'])} | "
                         f"{' / '.join(f'{v:.2f}' for v in r['nees_at'])} | {r['rms']:.1f} | {r['sigma']:.1f} | "
                         f"{r['nees']:.2f} |")
    table = "\n".join(lines)
    print(table)
    print(f"written to {fragment.write('heading_dvl_alone', table)}")


if __name__ == "__main__":
    main()
