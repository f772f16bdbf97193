"""The tuning's known answer: logs simulated with Yoo 2014's IMU (``--imu yoo-table1``), tuned from
Table 2 by ``tauv tune``'s search (tauvcore.eval.tuning), against the values they were made with.

    python benchmarks/tuning_known_answer.py [--seeds 20] [--trajectory straight] [--duration 400]
        [--params gyro_noise,accel_noise,dvl_noise,accel_bias_walk,gyro_bias_walk] [--half 1]
        [--start datasheet|table2] [--workers 2]

``--start datasheet`` (the default): the filter starts from the simulation's own IMU section
(its turn-on bias sigmas, scale factors and misalignments: a datasheet's figures, which a log does
not determine, docs/tuning.md) with every tuned key at Table 2's value; ``--start table2``: Table
2's IMU throughout. Per seed a log of ``--duration`` s is simulated (tauvcore.engine.simulation.simulate, written by
tauvcore.logs.writer as ``tauv run --save-log`` writes it) with the ``yoo-table1`` IMU and Table 2's
DVL, its noise halved on the last ``--half`` seeds; LC is tuned on it from Table 2's values (the
log's own log.toml left out), the filters started off the reference by initial errors drawn from
the seed (``tauv tune --initial-errors`` with ``initial_error.mode = "random"``), and replayed
before and after with the gate as configured. Printed: per seed each tuned value over the true one
with its 1-sigma factor, the NEES/dim of each block and the DVL's NIS/dof after; then the median
ratio and the fraction within 20 % per parameter, and the NEES/dim per block over the seeds
(each seed's mean, averaged), before and after. A parameter the filter does not model in the
simulation (Yoo 2014's IMU has scale factors and misalignments, which the 20-state filter takes
into its biases) has no true value to meet: its "truth" is the simulation's configured figure.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from tauvcore.config import Config, to_log_toml
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval import tuning
from tauvcore.eval.running import summarise
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors.imu import IMU_PROFILES

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # benchmarks/, this script's own directory

BLOCKS = ("pos", "vel", "tilt", "heading")
BAND = (0.5, 2.0)
WITHIN = 0.2


def _truth(trajectory: str, duration_s: float, seed: int, dvl_noise_mps: float) -> Config:
    return (
        Config()
        .replace("trajectory", name=trajectory, duration_s=duration_s)
        .replace("imu", **IMU_PROFILES["yoo-table1"].__dict__)
        .replace("dvl", noise_mps=dvl_noise_mps)
        .replace("run", seed=seed)
    )


def one_seed(
    seed: int, trajectory: str, duration_s: float, names: tuple[str, ...], half: bool, datasheet: bool
) -> dict:
    """Simulate, tune and replay one seed; its row."""
    truth = _truth(trajectory, duration_s, seed, Config().dvl.noise_mps * (0.5 if half else 1.0))
    with tempfile.TemporaryDirectory() as tmp:
        sim = simulate(truth, np.random.default_rng(seed))
        write_log(tmp, simulation_tables([SimChunk.whole(sim)]), "csv", config_toml=to_log_toml(truth))
        log = read_log(tmp)
    config = (
        tuning.with_values(
            Config().replace("imu", **truth.imu.__dict__) if datasheet else Config(),
            tuning.parameter_values(Config(), names),
        )
        .replace("run", methods=("lc",), seed=seed)
        .replace("replay", initial_errors=True)
        .replace("initial_error", mode="random")
    )
    case = tuning.TuningLog(f"seed {seed}", log, config)
    t0 = time.perf_counter()
    prepared = tuning.PreparedLog(case)
    result = tuning.tune([prepared], names)
    elapsed = time.perf_counter() - t0
    row = {"seed": seed, "half": half, "time_s": elapsed, "evaluations": result.evaluations, "still": None}
    true = tuning.parameter_values(truth, names)
    for n in names:
        row[n] = (
            result.tuned[n] / true[n],
            math.exp(result.sigma_ln[n]) if np.isfinite(result.sigma_ln[n]) else math.inf,
        )
    row["still"] = result.start_from.get("gyro_noise", "configuration") != "configuration"
    for label, values in (("before", tuning.parameter_values(config, names)), ("after", result.tuned)):
        s = summarise(prepared.results(values, tuning=False))["lc"].consistency
        row[label] = {b: s.nees[b].per_dim for b in BLOCKS} | {"dvl": s.nis["dvl"].per_dof}
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--trajectory", default="straight")
    parser.add_argument("--duration", type=float, default=400.0)
    parser.add_argument(
        "--params",
        default="gyro_noise,accel_noise,dvl_noise,accel_bias_walk,gyro_bias_walk",
        help="the parameters tuned (tauvcore.eval.tuning.PARAMETERS)",
    )
    parser.add_argument(
        "--half", type=int, default=1, help="the last this many seeds' DVL noise is half Table 2's"
    )
    parser.add_argument(
        "--start",
        default="datasheet",
        choices=("datasheet", "table2"),
        help="the filter's untuned IMU figures: the simulation's (a datasheet's) or Table 2's",
    )
    parser.add_argument("--workers", type=int, default=1, help="seeds at once, one process each")
    args = parser.parse_args()
    names = tuple(args.params.split(","))
    unknown = [n for n in names if n not in tuning.PARAMETERS]
    if unknown or args.seeds < 1 or not 0 <= args.half <= args.seeds or args.workers < 1:
        parser.error(f"bad --params {unknown}, --seeds, --half or --workers")
    seeds = range(1, args.seeds + 1)
    halves = [s > args.seeds - args.half for s in seeds]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.workers) as pool:
        rows = []
        for row in pool.map(
            one_seed,
            seeds,
            [args.trajectory] * args.seeds,
            [args.duration] * args.seeds,
            [names] * args.seeds,
            halves,
            [args.start == "datasheet"] * args.seeds,
        ):
            rows.append(row)
            print(
                f"seed {row['seed']}: {row['evaluations']} evaluations, {row['time_s']:.0f} s",
                file=sys.stderr,
            )
    wall = time.perf_counter() - t0
    with fragment.capture() as shown:
        print(
            f"LC tuned from Table 2 on {args.seeds} {args.trajectory} logs of {args.duration:g} s made with the "
            f"yoo-table1 IMU ({args.half} with half Table 2's DVL noise), the untuned IMU figures "
            + ("the simulation's (a datasheet's)" if args.start == "datasheet" else "Table 2's")
            + "; tuned / true (1-sigma factor):\n"
        )
        head = ["seed", "DVL", *names, *(f"{b} after" for b in BLOCKS), "NIS after", "evals", "time [s]"]
        print("| " + " | ".join(head) + " |")
        print("|" + "---|" * len(head))
        for r in rows:
            cells = [str(r["seed"]), "half" if r["half"] else "T2"]
            cells += [f"{r[n][0]:.3f} (x/{r[n][1]:.2g})" for n in names]
            cells += [f"{r['after'][b]:.2f}" for b in BLOCKS] + [f"{r['after']['dvl']:.2f}"]
            cells += [str(r["evaluations"]), f"{r['time_s']:.0f}"]
            print("| " + " | ".join(cells) + " |")
        print()
        print("| parameter | median tuned/true | within 20 % |")
        print("|---|---|---|")
        for n in names:
            ratios = np.array([r[n][0] for r in rows])
            print(
                f"| {n} | {np.median(ratios):.3f} | {np.mean(np.abs(ratios - 1.0) <= WITHIN) * 100:.0f} % |"
            )
        print()
        print(f"| block | NEES/dim before | NEES/dim after | after within [{BAND[0]:g}, {BAND[1]:g}] |")
        print("|---|---|---|---|")
        for b in (*BLOCKS, "dvl"):
            before = np.mean([r["before"][b] for r in rows])
            after = np.mean([r["after"][b] for r in rows])
            print(
                f"| {b if b != 'dvl' else 'DVL NIS/dof'} | {before:.2f} | {after:.2f} | {'yes' if BAND[0] <= after <= BAND[1] else 'no'} |"
            )
        still = sum(bool(r["still"]) for r in rows)
        print(
            f"\n{still} of {args.seeds} logs had a still stretch (the IMU's white noise from its Allan deviation); "
            f"median {np.median([r['time_s'] for r in rows]):.0f} s and {np.median([r['evaluations'] for r in rows]):.0f} "
            f"evaluations per log; {wall:.0f} s wall with {args.workers} worker(s)"
        )
    print(f"written to {fragment.write('tuning_known_answer', shown.getvalue())}")


if __name__ == "__main__":
    main()
