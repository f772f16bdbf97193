"""Replaying a ROS bag against replaying the same mission's Parquet log: the whole ``tauv replay``
command's wall time and peak resident memory (the targets: within 1.5x of the Parquet log's time,
under 400 MB, 381 MiB).

    python benchmarks/bag_replay.py                       # 1 h at a 200 Hz IMU, 3 counted rounds
    python benchmarks/bag_replay.py --hours 0.25 --rate 150 --runs 5

Makes a figure-eight mission (flat earth) of ``--hours`` at an IMU of ``--rate`` Hz, with the
tables a bag carries exactly (tests/unit/helpers/bag_fixtures.py: IMU rates, whole-nanosecond stamps),
and writes it three ways in a temporary directory: the log format as Parquet
(tauvcore.logs.writer.write_log), an MCAP file and a ROS 1 bag (bag_fixtures.write_bag, rosbags'
own writers; FLU/ENU frames, the DVL as marine_acoustic_msgs/Dvl, the reference as
nav_msgs/Odometry at the IMU's rate). Then each round runs ``tauv replay PATH --method ins,lc,tc
--aiding dvl,depth,mag --earth flat`` on the three in turn, each a process of its own under
``/usr/bin/time -v`` (wall time; peak resident memory, ``Maximum resident set size``), after one
round not counted (the compiled kernels loaded, the files in the page cache). A bag's ratio is
taken round by round against the Parquet run of the same round, so a drift of the machine's speed
cancels; the round not counted also compiles the bag reader's kernels into numba's cache
(tauvcore.logs.bags.scan), as any first bag replay after an install does. Each bag's printed results
must equal the log's (all but the first line, which names the input and its wall time). Writes
docs/results/bag_replay.md.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py
sys.path.insert(0, str(ROOT))  # tests.unit.helpers.bag_fixtures: the mission and the bag writer
import fragment  # noqa: E402

from tauvcore.logs.writer import write_log  # noqa: E402
from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag  # noqa: E402

FLAGS = ["--method", "ins,lc,tc", "--aiding", "dvl,depth,mag", "--earth", "flat"]
INPUTS = (("log", "Parquet log"), ("mission.mcap", "MCAP (ROS 2)"), ("mission.bag", "ROS 1 bag"))


def make_inputs(directory: Path, hours: float, rate_hz: float) -> dict[str, float]:
    """The mission as a Parquet log, an MCAP file and a ROS 1 bag in ``directory``; the seconds
    each took to make."""
    config = mission_config(hours * 3600.0, rate_hz)
    took: dict[str, float] = {}
    t0 = time.monotonic()
    tables, _ = mission_tables(config)
    took["simulate"] = time.monotonic() - t0
    t0 = time.monotonic()
    write_log(directory / "log", tables, "parquet")
    took["log"] = time.monotonic() - t0
    for name, storage in (("mission.mcap", "mcap"), ("mission.bag", "ros1")):
        t0 = time.monotonic()
        write_bag(directory / name, storage, tables, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b, frame="flu_enu")
        took[name] = time.monotonic() - t0
    return took


def size_mb(path: Path) -> float:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) / 1e6
    return path.stat().st_size / 1e6


def replay(path: Path) -> tuple[float, float, str]:
    """``tauv replay path FLAGS`` under /usr/bin/time -v: wall [s], peak resident [MiB], stdout."""
    argv = ["/usr/bin/time", "-v", sys.executable, "-m", "app.cli", "replay", str(path), *FLAGS]
    proc = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} exited {proc.returncode}: {proc.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (?:(\d+):)?(\d+):([\d.]+)", proc.stderr)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    assert wall is not None and peak is not None, proc.stderr
    wall_s = int(wall.group(1) or 0) * 3600 + int(wall.group(2)) * 60 + float(wall.group(3))
    return wall_s, int(peak.group(1)) / 1024.0, proc.stdout


def spread(values: list[float], fmt: str) -> str:
    """Median (min-max)."""
    return f"{statistics.median(values):{fmt}} ({min(values):{fmt}}-{max(values):{fmt}})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=1.0, help="the mission's length [h] (default 1)")
    parser.add_argument("--rate", type=float, default=200.0, help="the IMU's rate [Hz] (default 200)")
    parser.add_argument("--runs", type=int, default=3, help="counted rounds (default 3)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        took = make_inputs(directory, args.hours, args.rate)
        print("made in", {k: f"{v:.0f} s" for k, v in took.items()}, flush=True)
        walls: dict[str, list[float]] = {name: [] for name, _ in INPUTS}
        peaks: dict[str, list[float]] = {name: [] for name, _ in INPUTS}
        expected = ""
        for round_ in range(args.runs + 1):
            for name, _ in INPUTS:
                wall_s, peak_mib, out = replay(directory / name)
                results = out.split("\n", 1)[1]
                if name == "log":
                    expected = results
                elif results != expected:
                    raise RuntimeError(f"{name} replays to other numbers than the Parquet log:\n{out}\n{expected}")
                print(f"round {round_}{' (not counted)' if round_ == 0 else ''}: {name} {wall_s:.2f} s, "
                      f"{peak_mib:.0f} MiB", flush=True)
                if round_:
                    walls[name].append(wall_s)
                    peaks[name].append(peak_mib)
        sizes = {name: size_mb(directory / name) for name, _ in INPUTS}
        messages = int(args.hours * 3600 * args.rate) * 2
    lines = [
        "| input | size [MB] | wall [s], median (min-max) | against the Parquet log, median (min-max) "
        "| peak resident [MiB], max |",
        "|---|---|---|---|---|",
    ]
    for name, label in INPUTS:
        ratios = [b / a for a, b in zip(walls["log"], walls[name], strict=True)]
        ratio = "1" if name == "log" else spread(ratios, ".2f") + "x"
        lines.append(f"| {label} | {sizes[name]:,.0f} | {spread(walls[name], '.1f')} | {ratio} "
                     f"| {max(peaks[name]):.0f} |")
    table = "\n".join(lines) + (
        f"\n\n`tauv replay PATH {' '.join(FLAGS)}` on one figure-eight mission of {args.hours:g} h at a "
        f"{args.rate:g} Hz IMU (about {messages:,} IMU and reference messages in a bag), {args.runs} rounds "
        "after one not counted, each command a process of its own (`/usr/bin/time -v`); the ratio is taken "
        "round by round. Every bag replays to the numbers the log prints. A bag is read chunk by chunk "
        "(tauvcore.logs.bags.scan: each chunk decompressed, its records walked by a compiled loop, the IMU's and "
        "the reference's numbers read from the chunk's bytes into their arrays); the targets are 1.5x the "
        "log's time and 400 MB (381 MiB).")
    print(table)
    print(f"written to {fragment.write('bag_replay', table)}")


if __name__ == "__main__":
    main()
