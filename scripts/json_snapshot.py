"""Every method's output on a fixed set of commands, recorded once and compared after a change that
must not change a number (a restructuring of the engine, a faster path).

    python scripts/json_snapshot.py record DIR     # run the commands, keep their outputs in DIR
    python scripts/json_snapshot.py compare DIR    # run them again, compare with DIR's

The commands cover both banks (the 20-state methods and Yoo 2014's), every trajectory, the
kinematic and the dynamic truth, every aiding source, beams off, outages and dropout, the
RPM fallback, the smoother, a current with water-track and current states, a simulated log's
replay (plain and smoothed), A-KIT segment 1's replay when ``../shared/data/akit`` (or the
directory ``TAUV_AKIT`` names) holds it, and
a Monte Carlo study on local processes and on a local Dask cluster. Each command's ``--json``
file (a study's summary.json and runs.parquet) is kept; ``compare`` walks both and reports every
number that differs by more than 1e-9 of its scale (``max(1, |a|, |b|)``; runs.parquet's float32
columns by more than their own precision, 2**-23), every string, key or
length that differs, and exits 1 if anything does. A command that fails stops the script with its
output.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
AKIT = Path(os.environ.get("TAUV_AKIT", ROOT.parent / "shared" / "data" / "akit")) / "Trajectory1"
TOLERANCE = 1e-9
FLOAT32_TOLERANCE = 2.0**-23
"""A study's runs.parquet keeps its series as float32 (24-bit mantissa): a float64 number that moved by
1e-16 can round to the neighbouring float32, one unit in the last place, 2**-23 of its scale at most."""
FLOAT32_COLUMNS: set[str] = set()
"""The outputs' columns held as float32 (``<name>/runs/<column>``), compared at FLOAT32_TOLERANCE."""
YOO = "ins-dvl,vkf"
ALL = "ins,lc,tc,vb,nsv,plcf,vhv,elc,iekf," + YOO

CURRENT_TOML = """\
[trajectory]
current_n_mps = [0.2, -0.25, 0.0]
[dvl]
water_track = "always"
current_states = "gauss-markov"
"""

RUNS: dict[str, list[str]] = {
    "straight_all": ["run", "--trajectory", "straight", "--method", ALL],
    "figure8_all": ["run", "--trajectory", "figure8", "--method", ALL, "--seed", "3"],
    "lawnmower_dynamic": [
        "run",
        "--trajectory",
        "lawnmower",
        "--truth",
        "dynamic",
        "--method",
        ALL,
        "--seed",
        "5",
    ],
    "longrange_fallback": [
        "run",
        "--trajectory",
        "longrange",
        "--duration",
        "600",
        "--method",
        "ins,lc,tc," + YOO,
        "--rpm-fallback",
        "--seed",
        "2",
    ],
    "beams_sources": [
        "run",
        "--trajectory",
        "figure8",
        "--method",
        ALL,
        "--aiding",
        "dvl,depth,mag,usbl",
        "--beams",
        "1,2,3",
        "--outage",
        "3@60:120",
        "--dropout",
        "0.1",
        "--seed",
        "7",
    ],
    "flat_earth_two_beams": [
        "run",
        "--trajectory",
        "lawnmower",
        "--method",
        ALL,
        "--earth",
        "flat",
        "--beams",
        "1,2",
        "--imu",
        "yoo-table1",
        "--seed",
        "11",
    ],
    "smoothed": [
        "run",
        "--trajectory",
        "figure8",
        "--method",
        "lc,tc,iekf,nsv," + YOO,
        "--smooth",
        "--seed",
        "4",
    ],
    "current_smoothed": [
        "run",
        "--trajectory",
        "lawnmower",
        "--duration",
        "200",
        "--method",
        "lc,tc," + YOO,
        "--config",
        "{current}",
        "--smooth",
        "--seed",
        "6",
    ],
}
"""Commands whose ``--json`` file is kept; ``{current}`` is CURRENT_TOML's file."""


def _commands(work: Path) -> list[tuple[str, list[str], str]]:
    """(name, tauv arguments, what to keep: "json" or "study") in the order they run."""
    current = work / "current.toml"
    current.write_text(CURRENT_TOML)
    log = work / "figure8_log"
    out = [
        (
            name,
            [a.replace("{current}", str(current)) for a in args] + ["--json", str(work / f"{name}.json")],
            "json",
        )
        for name, args in RUNS.items()
    ]
    out.append(
        (
            "save_log",
            [
                "run",
                "--trajectory",
                "figure8",
                "--duration",
                "200",
                "--method",
                "lc",
                "--seed",
                "8",
                "--save-log",
                str(log),
                "--json",
                str(work / "save_log.json"),
            ],
            "json",
        )
    )
    out.append(
        (
            "replay",
            [
                "replay",
                str(log),
                "--method",
                "ins,lc,tc,iekf," + YOO,
                "--initial-errors",
                "--seed",
                "8",
                "--json",
                str(work / "replay.json"),
            ],
            "json",
        )
    )
    out.append(
        (
            "replay_smoothed",
            [
                "replay",
                str(log),
                "--method",
                "lc,tc," + YOO,
                "--smooth",
                "--seed",
                "8",
                "--json",
                str(work / "replay_smoothed.json"),
            ],
            "json",
        )
    )
    if AKIT.is_dir():
        akit = work / "akit1"
        out.append(("akit1", ["{convert}", str(AKIT), str(akit)], "none"))
        out.append(
            (
                "akit1_replay",
                [
                    "replay",
                    str(akit),
                    "--method",
                    "ins,lc,tc,iekf",
                    "--json",
                    str(work / "akit1_replay.json"),
                ],
                "json",
            )
        )
    out.append(
        (
            "mc",
            [
                "mc",
                "--trajectory",
                "figure8",
                "--duration",
                "120",
                "--method",
                "lc,tc,elc," + YOO,
                "--runs",
                "6",
                "--workers",
                "2",
                "--out",
                str(work / "mc"),
            ],
            "study",
        )
    )
    out.append(
        (
            "mc_dask",
            [
                "mc",
                "--trajectory",
                "lawnmower",
                "--duration",
                "120",
                "--method",
                "lc,nsv,vkf",
                "--runs",
                "4",
                "--dask",
                "{dask}",
                "--smooth",
                "--out",
                str(work / "mc_dask"),
            ],
            "study",
        )
    )
    return out


def _run(name: str, args: list[str]) -> float:
    if args[0] == "{convert}":
        cmd = [sys.executable, str(ROOT / "scripts" / "akit_to_log.py"), *args[1:]]
    else:
        cmd = [sys.executable, "-m", "app.cli", *args]
    t0 = time.perf_counter()
    done = subprocess.run(
        cmd, cwd=ROOT, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}
    )
    if done.returncode != 0:
        sys.exit(
            f"{name}: {' '.join(cmd)} exited {done.returncode}\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
        )
    return time.perf_counter() - t0


def _outputs(work: Path, name: str, kind: str) -> dict[str, object]:
    """What a command left: its JSON, or a study's summary.json and runs.parquet's columns."""
    if kind == "json":
        return {name: json.loads((work / f"{name}.json").read_text())}
    if kind == "study":
        import pyarrow.parquet as pq

        study = work / name
        table = pq.read_table(study / "runs.parquet")
        FLOAT32_COLUMNS.update(f"{name}/runs/{f.name}" for f in table.schema if str(f.type) == "float")
        runs = table.to_pydict()
        return {f"{name}/summary": json.loads((study / "summary.json").read_text()), f"{name}/runs": runs}
    return {}


def collect(work: Path) -> dict[str, object]:
    """Run every command in ``work`` and return its outputs by name; ``{dask}`` is the address of
    a local Dask cluster (two worker processes) started for the commands that name it."""
    from distributed import LocalCluster

    outputs: dict[str, object] = {}
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        for name, args, kind in _commands(work):
            seconds = _run(name, [a.replace("{dask}", cluster.scheduler_address) for a in args])
            print(f"{name}: {seconds:.1f} s", file=sys.stderr)
            outputs.update(_outputs(work, name, kind))
    return outputs


WORK_DIR = re.compile(r"/[^'\"\s]*tauv-snapshot-[A-Za-z0-9_]+")
"""The temporary directory the commands ran in, as strings name it (not compared)."""

VOLATILE = {"elapsed_s", "wall_s", "created", "version", "command", "date", "python", "machine"}
"""Keys whose values are the run's circumstances, not its numbers (not compared)."""


def differences(a: object, b: object, where: str = "", found: list[str] | None = None) -> list[str]:
    """Where ``a`` and ``b`` differ: numbers by more than TOLERANCE of their scale, anything else
    by value; the first 50 places."""
    found = [] if found is None else found
    if len(found) >= 50:
        return found
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            found.append(f"{where}: keys {sorted(set(a) ^ set(b))} in one only")
        for key in a.keys() & b.keys():
            if key not in VOLATILE:
                differences(a[key], b[key], f"{where}/{key}", found)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            found.append(f"{where}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b, strict=False)):
            differences(x, y, f"{where}[{i}]", found)
    elif isinstance(a, str) and isinstance(b, str):
        if WORK_DIR.sub("{work}", a) != WORK_DIR.sub("{work}", b):
            found.append(f"{where}: {a!r} != {b!r}")
    elif (
        isinstance(a, bool)
        or isinstance(b, bool)
        or not isinstance(a, (int, float))
        or not isinstance(b, (int, float))
    ):
        if a != b:
            found.append(f"{where}: {a!r} != {b!r}")
    else:
        x, y = float(a), float(b)
        if math.isnan(x) and math.isnan(y):
            return found
        tolerance = FLOAT32_TOLERANCE if where.split("[", 1)[0] in FLOAT32_COLUMNS else TOLERANCE
        if not (abs(x - y) <= tolerance * max(1.0, abs(x), abs(y))):
            found.append(f"{where}: {x!r} != {y!r}")
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("record", "compare"))
    parser.add_argument("directory", type=Path)
    args = parser.parse_args()
    snapshot = args.directory / "snapshot.json"
    if args.action == "record" and snapshot.exists():
        sys.exit(f"{snapshot} exists: choose a new directory")
    if args.action == "compare" and not snapshot.exists():
        sys.exit(f"{snapshot} does not exist: record it first")
    work = Path(tempfile.mkdtemp(prefix="tauv-snapshot-"))
    try:
        outputs = collect(work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if args.action == "record":
        args.directory.mkdir(parents=True, exist_ok=True)
        snapshot.write_text(json.dumps(outputs))
        print(f"recorded {len(outputs)} outputs in {snapshot}")
        return 0
    recorded = json.loads(snapshot.read_text())
    bad = 0
    for name in sorted(recorded.keys() | outputs.keys()):
        if name not in outputs or name not in recorded:
            print(f"{name}: in one snapshot only")
            bad += 1
            continue
        found = differences(recorded[name], outputs[name], name)
        same = "equal to 1e-9 (float32 columns to 2**-23)" if name.endswith("/runs") else "equal to 1e-9"
        print(f"{name}: {same if not found else f'{len(found)} differences'}")
        for line in found[:10]:
            print(f"    {line}")
        bad += bool(found)
    print("all equal" if not bad else f"{bad} outputs differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
