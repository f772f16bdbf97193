"""The depth innovations of a long mission: how white and how Gaussian they are, and the windows
the divergence monitor flags.

    python benchmarks/depth_innovations.py               # lc, 10 h straight, 8 runs: about 2 minutes
    python benchmarks/depth_innovations.py --hours 1

LC on the straight line with DVL, depth and magnetometer, random initial errors, IMU 50 Hz,
records at 1 Hz, seeds [2027, r]. Prints, per run, the normalised depth innovations' lag-1
autocorrelation and excess kurtosis over the first hour, the NIS mean over the mission, the
fraction of NIS values beyond the chi-square 0.1 % quantile (10.83) and the monitor's first flag
of the depth source with its window (tauvcore.engine.monitor). Prints only; the long-missions page
quotes it.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import stats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=10.0)
    parser.add_argument("--runs", type=int, default=8)
    args = parser.parse_args()
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming
    from tauvcore.engine.monitor import NIS_WINDOW_UPDATES

    config = (
        Config()
        .replace("trajectory", name="straight", duration_s=args.hours * 3600.0)
        .replace("imu", rate_hz=50.0)
        .replace("filter", output_rate_hz=1.0)
        .replace("initial_error", mode="random")
        .replace("run", methods=("lc",), aiding=("dvl", "depth", "mag"))
    )
    parts: dict[str, list] = {"t": [], "nis": [], "nu": [], "s": []}
    flags: dict[str, np.ndarray] = {}

    def reduce(chunk: dict) -> None:
        res = chunk["lc"]
        u = res.updates["depth"]
        parts["t"].append(u.t_s)
        parts["nis"].append(u.nis)
        parts["nu"].append(u.innovation[..., 0])
        parts["s"].append(u.innovation_var[..., 0])
        flags["at"] = res.diverged_at_s

    rngs = [np.random.default_rng([2027, r]) for r in range(args.runs)]
    run_streaming(config, rngs, num_runs=args.runs, keep=False, sinks=Sinks(on_chunk=reduce))
    t = np.concatenate(parts["t"])
    nis = np.concatenate(parts["nis"])
    e = np.concatenate(parts["nu"]) / np.sqrt(np.concatenate(parts["s"]))
    first = t <= 3600.0
    print(f"lc, {args.hours:g} h straight, DVL + depth + magnetometer, {args.runs} runs; depth at "
          f"{config.pressure.rate_hz:g} Hz, monitor window {NIS_WINDOW_UPDATES} updates")
    print("run | lag-1 autocorrelation (1st hour) | excess kurtosis (1st hour) | NIS mean | NIS > 10.83 "
          "(0.1 % expected) | flagged at [s] | largest window NIS sum")
    for r in range(args.runs):
        a = e[first, r]
        windows = np.convolve(np.minimum(nis[:, r], 10.83), np.ones(NIS_WINDOW_UPDATES), "valid")
        print(f"{r} | {np.corrcoef(a[:-1], a[1:])[0, 1]:+.3f} | {stats.kurtosis(a):+.2f} | {nis[:, r].mean():.3f} | "
              f"{100 * np.mean(nis[:, r] > 10.83):.2f} % | {flags['at'][r]:.0f} | {windows.max():.1f}")
    print(f"all | | | {nis.mean():.3f} | {100 * np.mean(nis > 10.83):.2f} % | "
          f"{int(np.isfinite(flags['at']).sum())} of {args.runs} flagged |")
    # the largest window of all: its innovations against their sigma
    capped = np.minimum(nis, 10.83)
    sums = np.stack([np.convolve(capped[:, r], np.ones(NIS_WINDOW_UPDATES), "valid") for r in range(args.runs)], 1)
    k, r = np.unravel_index(np.argmax(sums), sums.shape)
    s = np.sqrt(np.concatenate(parts["s"])[:, r])
    nu = np.concatenate(parts["nu"])[:, r]
    print(f"\nrun {r}, the largest window ({t[k]:.0f}-{t[k + NIS_WINDOW_UPDATES - 1]:.0f} s): depth innovation / "
          "sigma [cm], NIS")
    for i in range(max(k - 4, 0), min(k + NIS_WINDOW_UPDATES + 4, t.size)):
        print(f"  {t[i]:.0f} s: {100 * nu[i]:+.1f} / {100 * s[i]:.1f}, {nis[i, r]:.1f}")


if __name__ == "__main__":
    main()
