"""Yoo 2014's long-range mission in an ocean current: what a current the filters ignore costs.

    python benchmarks/current_table.py [--runs 20] [--seed 0]

The mission (``--trajectory longrange``: 24 minutes north at 10 knots, bottom lock lost over the
two trenches from 5 to 8 and from 15 to 16 minutes) with DVL, depth and magnetometer aiding and
random initial errors, in still water and in a 0.3 m/s current across the track (east) and along
it (against the vehicle, south). The kinematic truth keeps its track over ground and crabs into
the current; the DVL's bottom-track measures velocity over ground, the propeller speed through
the water. Per method, over the runs: the RMS of the position error at the end, of the
velocity error inside the trenches, and the velocity NEES per dimension inside the trenches; for
``vkf`` also the learned bias of eq. 20 less the speed model's true bias at the end, which takes
up the current's along-hull part.

Methods: INS, INS-DVL and VKF (Yoo 2014's 12-state filter), LC with ``run.rpm_fallback`` (the VKF's
RPM velocity where the DVL gives none); in the cross current also LC and TC with the RPM
fallback and VKF, each with the current as states (the RPM's velocity through the water); and
LC, TC, NSV, IEKF, INS-DVL and VKF with the DVL water-tracking beyond bottom range
(``dvl.water_track = "beyond_range"``) and the current as two error states
(``dvl.current_states = "random-walk"``): the current's error at the end (the norm of its north
and east parts, RMS over the runs) and its NEES per dimension over the run.

Writes docs/results/current_table.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from tauvcore.config import Config, from_dict, trajectory_preset
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

TRENCHES_S = ((300.0, 480.0), (900.0, 960.0))
METHODS = ("ins", "ins-dvl", "vkf", "lc")
CURRENT = {"current_states": "random-walk", "current_walk_mps_per_sqrt_s": 1e-4}
"""The filters estimating the current as two states."""
STATES = {"water_track": "beyond_range", **CURRENT}
"""The DVL water-tracking beyond bottom range, the filters estimating the current."""
CASES = (
    ("still water", (0.0, 0.0, 0.0), {}, METHODS),
    ("0.3 m/s across the track (toward east)", (0.0, 0.3, 0.0), {}, METHODS),
    (
        "0.3 m/s across the track, current states, --rpm-fallback (VKF: its own RPM velocity)",
        (0.0, 0.3, 0.0),
        CURRENT,
        ("lc", "tc", "vkf"),
    ),
    (
        "0.3 m/s across the track, water-track beyond range and current states",
        (0.0, 0.3, 0.0),
        STATES,
        ("lc", "tc", "nsv", "iekf", "ins-dvl", "vkf"),
    ),
    ("0.3 m/s along the track (toward south, against the vehicle)", (-0.3, 0.0, 0.0), {}, METHODS),
)


def rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.asarray(a) ** 2)))


def case_rows(
    current_n_mps: tuple[float, float, float], dvl: dict, methods: tuple[str, ...], runs: int, seed: int
) -> list[str]:
    config = (
        from_dict(trajectory_preset("longrange"), Config().replace("trajectory", name="longrange"))
        .replace("trajectory", current_n_mps=current_n_mps)
        .replace("dvl", **dvl)
        .replace("initial_error", mode="random")
        .replace(
            "run",
            methods=methods,
            aiding=("dvl", "depth", "mag"),
            seed=seed,
            rpm_fallback="water_track" not in dvl,
        )
    )
    rng = np.random.default_rng(seed)
    results = run(config, simulate(config, rng, runs), rng)
    rows = []
    for method, r in results.items():
        t = np.asarray(r.t_s)
        trench = np.zeros(t.shape, bool)
        for start, end in TRENCHES_S:
            trench |= (t > start) & (t < end)
        nees_vel = np.asarray(r.nees_block)[..., 1] / 3.0
        bias = "-"
        if method == "vkf" and r.vkf_trace is not None:
            tr = r.vkf_trace
            bias = f"{rms(np.asarray(tr['x'])[-1, ..., 2] - np.asarray(tr['b_true'])[-1]):.3f}"
        current = nees_current = "-"
        if r.state_est is not None and r.state_true is not None and r.block_dims is not None:
            err = np.linalg.norm(np.asarray(r.state_est)[-1] - np.asarray(r.state_true)[-1], axis=-1)
            current = f"{rms(err):.3f}"
            block = [b for b in r.block_dims if b != "full"].index("current")
            nees_current = f"{np.nanmean(np.asarray(r.nees_block)[..., block]) / 2.0:.2f}"
        label = method.upper() + (
            " (--rpm-fallback)" if method in ("lc", "tc") and "water_track" not in dvl else ""
        )
        rows.append(
            f"| {label} | {rms(np.asarray(r.pos_err_m)[-1]):.1f} | {rms(np.asarray(r.vel_err_mps)[trench]):.3f} "
            f"| {np.nanmean(nees_vel[trench]):.2f} | {bias} | {current} | {nees_current} |"
        )
    return rows


def yoo_cost(seed: int) -> str:
    """Wall time of one run of the whole mission with ``ins-dvl,vkf`` in the cross current with
    water-track beyond range, with the current states and without (the compiled loop both); best
    of two, the simulation apart."""
    times = {}
    for label, dvl in (("with current states", STATES), ("without", {"water_track": "beyond_range"})):
        config = (
            from_dict(trajectory_preset("longrange"), Config().replace("trajectory", name="longrange"))
            .replace("trajectory", current_n_mps=(0.0, 0.3, 0.0))
            .replace("dvl", **dvl)
            .replace("run", methods=("ins-dvl", "vkf"), aiding=("dvl", "depth", "mag"), seed=seed)
        )
        sim = simulate(config, np.random.default_rng(seed), 1)
        best = np.inf
        for _ in range(2):
            started = time.perf_counter()
            run(config, sim, np.random.default_rng(seed))
            best = min(best, time.perf_counter() - started)
        times[label] = best
    with_s, without_s = times["with current states"], times["without"]
    return (
        f"Yoo's methods with current states: one run of the mission, `ins-dvl,vkf`, {with_s:.2f} s with the "
        f"current states against {without_s:.2f} s without, {with_s / without_s:.2f} times (best of two, "
        "the simulation apart)."
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    with fragment.capture() as shown:
        print(
            f"Long-range mission, {args.runs} Monte Carlo runs (seed {args.seed}), DVL, depth and magnetometer "
            "aiding, random initial errors; RMS over the runs. Trench: 5-8 and 15-16 minutes, no bottom lock.\n"
        )
        for title, current, dvl, methods in CASES:
            print(f"**{title}**\n")
            print(
                "| method | end position [m] | trench velocity RMS [m/s] | trench velocity NEES/3 "
                "| VKF bias less true, end [m/s] | current error, end [m/s] | current NEES/2 |"
            )
            print("|---|---|---|---|---|---|---|")
            for line in case_rows(current, dvl, methods, args.runs, args.seed):
                print(line, flush=True)
            print()
        print(yoo_cost(args.seed) + "\n")
        print(f"*{time.perf_counter() - started:.0f} s in all.*")
    print(f"written to {fragment.write('current_table', shown.getvalue())}")


if __name__ == "__main__":
    main()
