"""The USBL table of docs/adding_a_sensor.md: position error after one hour on the lawnmower, with
only beams 1 and 2 of the DVL returning, without a USBL and with a fix every 5, 10 and 30 s, for
INS, LC and NSV; and what the fix's 1 s latency costs when the model ignores it.

    python benchmarks/usbl_table.py [--runs 10] [--seed 0] [--duration 3600]

Each cell is the RMS over the runs (random initial errors, seeded) of the position error at the
end [m]; in brackets the RMS over the last 10 minutes. The USBL is the default one
(tauvcore.aiding.usbl: 0.1 m + 0.2 % of slant range per axis, 1 s latency, 5 % lost, 1 % outliers),
its transceiver 2 m under the surface above the start, so the slant range grows to about 1 km.

Writes its tables to docs/results/usbl_table.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.metrics import rms

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

METHODS = ("ins", "lc", "nsv")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--duration", type=float, default=3600.0)
    args = parser.parse_args()
    started = time.perf_counter()
    base = (
        Config()
        .replace("trajectory", name="lawnmower", duration_s=args.duration)
        .replace("initial_error", mode="random")
        .replace("dvl", beams=(1, 2))
        .replace("run", methods=METHODS)
    )
    rows = [("no USBL", base.replace("run", aiding=("dvl",)))]
    for interval in (5.0, 10.0, 30.0):
        with_usbl = base.replace("run", aiding=("dvl", "usbl")).replace("usbl", interval_s=interval)
        rows.append((f"USBL every {interval:g} s", with_usbl))
    rows.append(
        (
            "USBL every 10 s, latency ignored",
            base.replace("run", aiding=("dvl", "usbl")).replace("usbl", interval_s=10.0, compensate_latency=False),
        )
    )
    with fragment.capture() as shown:
        print(
            f"Position error at {args.duration:g} s [m], lawnmower, beams 1 and 2 only, RMS over {args.runs} runs "
            f"(seed {args.seed}); in brackets the RMS over the last 600 s\n"
        )
        print("| aiding | " + " | ".join(m.upper() for m in METHODS) + " |")
        print("|---" * (1 + len(METHODS)) + "|")
        for label, config in rows:
            rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(args.seed).spawn(args.runs)]
            results = run_streaming(config, rngs, args.runs)
            cells = []
            for m in METHODS:
                r = results[m]
                last = r.t_s >= r.t_s[-1] - 600.0
                cells.append(f"{float(rms(r.pos_err_m[-1])):.3g} ({float(rms(r.pos_err_m[last].ravel())):.3g})")
            print(f"| {label} | " + " | ".join(cells) + " |", flush=True)
    print(f"\n({time.perf_counter() - started:.0f} s wall)")
    print(f"written to {fragment.write('usbl_table', shown.getvalue())}")


if __name__ == "__main__":
    main()
