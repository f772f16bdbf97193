"""Filtered against smoothed: the fixed-interval smoother's gain for every method, on the three
missions and on the A-KIT segments.

    python benchmarks/smoother_table.py [--runs 20] [--seed 0] [--data ../shared/data/akit]

Simulated (tauvcore.engine.mission.run with ``smooth``): each paper mission (250 s, DVL, depth and
magnetometer aiding, random initial errors) in two cases, beams 3 and 4 lost for the whole run
(only beams 1 and 2 return) and a 60 s outage of all four beams (100 to 160 s); per method the
RMS over runs and epochs of the position, velocity, tilt and heading errors, filtered -> smoothed,
and the NEES/dim of each block (position / velocity / tilt / heading / sensors), filtered and
smoothed. LC, which
cannot form a velocity from two beams, coasts through the two-beam case as the filter does, and so
do Yoo 2014's two methods (which have no position state: their position, smoothed or not, is the
strapdown's; their NEES blocks are their own, 12 states).

A-KIT (each segment converted to a log by scripts/akit_to_log.py and replayed from the
reference's first row, as benchmarks/akit_table.py does): LC with four beams and NSV with beams 1
and 2, the RMS of each error against the reference over the segment, filtered -> smoothed. The
reference is itself a forward-backward smoother of the vehicle's INS and the same DVL, so it is
not independent of what our smoother uses: closer agreement after smoothing says the two
smoothers draw the same trajectory from the same measurements, not that either is the truth.

Writes docs/results/smoother_table.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tauvcore.config import ALL_METHODS, Config, from_dict
from tauvcore.engine.mission import run
from tauvcore.engine.results import block_dims
from tauvcore.engine.simulation import simulate
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.replay import log_config, prepare
from tauvcore.logs import read_log
from tauvcore.sensors.dvl import Outage
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

ROOT = Path(__file__).resolve().parents[1]
ERRORS = (("pos_err_m", "position [m]", ".2f"), ("vel_err_mps", "velocity [m/s]", ".3f"),
          ("tilt_err_deg", "tilt [deg]", ".3f"), ("heading_err_deg", "heading [deg]", ".2f"))
BLOCKS = ("pos", "vel", "tilt", "heading", "sensor")  # the NEES blocks, in the records' order
CASES = (("beams 1 and 2 only", {"beams": (1, 2)}),
         ("a 60 s outage of all four beams (100-160 s)",
          {"outages": (Outage(beams=(1, 2, 3, 4), start_s=100.0, end_s=160.0),)}))


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.asarray(a) ** 2)))


def column_means(a: np.ndarray) -> np.ndarray:
    """The mean of each block's column over epochs and runs, NaN where it has no number."""
    a = np.asarray(a).reshape(-1, a.shape[-1])
    counts = np.isfinite(a).sum(axis=0)
    return np.where(counts > 0, np.nansum(a, axis=0) / np.maximum(counts, 1), np.nan)


def pair(filtered: float, smoothed: float, fmt: str) -> str:
    return f"{format(filtered, fmt)} → {format(smoothed, fmt)}"


def simulated(trajectory: str, dvl: dict, runs: int, seed: int) -> list[str]:
    config = (Config().replace("trajectory", name=trajectory).replace("dvl", **dvl)
              .replace("initial_error", mode="random")
              .replace("run", methods=ALL_METHODS, aiding=("dvl", "depth", "mag"), seed=seed))
    rng = np.random.default_rng(seed)
    results = run(config, simulate(config, rng, runs), rng, smooth=SmoothOptions())
    lines = []
    for method, f in results.items():
        s = f.smoothed
        cells = [pair(rms(getattr(f, q)), rms(getattr(s, q)), fmt) for q, _, fmt in ERRORS]
        dims = np.array([block_dims(method)[b] for b in BLOCKS])
        means = [column_means(r.nees_block) / dims for r in (f, s)]
        nees = [" / ".join(f"{v:.2f}" if np.isfinite(v) else "-" for v in mean) for mean in means]
        lines.append(f"| {method.upper()} | " + " | ".join(cells + nees) + " |")
    return lines


def akit_rows(data: Path, seed: int) -> list[str]:
    spec = importlib.util.spec_from_file_location("akit_to_log", ROOT / "scripts" / "akit_to_log.py")
    akit = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(akit)
    segments = sorted((p for p in data.glob("Trajectory*") if p.is_dir()), key=lambda p: int(p.name[10:]))
    lines = []
    for segment in segments:
        with tempfile.TemporaryDirectory() as tmp:
            akit.convert(segment, Path(tmp))
            log = read_log(tmp)
            base = from_dict(log_config(tmp)[0]).replace("run", seed=seed)
            for label, config in (("LC, 4 beams", base.replace("run", methods=("lc",))),
                                  ("NSV, beams 1-2", base.replace("run", methods=("nsv",)).replace("dvl", beams=(1, 2)))):
                rng = np.random.default_rng(seed)
                config, sim = prepare(config, log, rng)
                (f,) = run(config, sim, rng, smooth=SmoothOptions()).values()
                s = f.smoothed
                cells = [pair(rms(getattr(f, q)), rms(getattr(s, q)), fmt) for q, _, fmt in ERRORS]
                lines.append(f"| {segment.name} | {label} | " + " | ".join(cells) + " |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "akit"))
    args = parser.parse_args()
    started = time.perf_counter()
    head = ("| method | " + " | ".join(label for _, label, _ in ERRORS)
            + " | NEES/dim filtered | NEES/dim smoothed |")
    with fragment.capture() as shown:
        print(f"RMS over {args.runs} Monte Carlo runs (seed {args.seed}) and every output epoch of the 250 s "
              "mission, filtered → smoothed; DVL, depth and magnetometer aiding, random initial errors. NEES/dim "
              "per block: position / velocity / tilt / heading / sensors.\n")
        for title, dvl in CASES:
            for trajectory in TRAJECTORIES:
                print(f"**{trajectory}, {title}**\n")
                print(head)
                print("|---" * (3 + len(ERRORS)) + "|")
                for line in simulated(trajectory, dvl, args.runs, args.seed):
                    print(line, flush=True)
                print()
        data = Path(args.data)
        if any(data.glob("Trajectory*")):
            print("A-KIT segments (about 400 s each), RMS of the errors against the reference over the segment, "
                  "filtered → smoothed (Table 2's tuning, the log's own configuration).\n")
            print("| segment | method | " + " | ".join(label for _, label, _ in ERRORS) + " |")
            print("|---" * (2 + len(ERRORS)) + "|")
            for line in akit_rows(data, args.seed):
                print(line, flush=True)
        else:
            print(f"(A-KIT data not found under {data}: its table is left out.)")
        print(f"\n*{time.perf_counter() - started:.0f} s in all.*")
    print(f"written to {fragment.write('smoother_table', shown.getvalue())}")


if __name__ == "__main__":
    main()
