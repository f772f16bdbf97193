"""Peak memory of ``tauv run`` (with and without ``--json``, with ``--save-log``) and ``tauv replay``
on long missions.

    python benchmarks/run_memory.py                      # every row: 1 h, 10 h and 24 h runs, the 10 h log
    python benchmarks/run_memory.py --hours 1 10
    python benchmarks/run_memory.py --only save-log replay   # those rows; the others kept as they were

The rows: ``run`` (``tauv run --trajectory straight --method all --duration S``) and ``run-json``
(the same with ``--json FILE``) for each of ``--hours``; ``save-log`` (``tauv run --duration S
--save-log DIR --log-format parquet``, the default methods) and ``replay`` (``tauv replay DIR`` of
that log, the default methods) for ``--log-hours``. Each row is one whole command in its own
process, its peak resident memory from the kernel's accounting of that child (``ru_maxrss`` of
``wait4``, what ``/usr/bin/time -v`` reports), its wall time, and the size of what it wrote (the
``--json`` file, the log's directory). The commands reduce the results chunk by chunk
(tauvcore.eval.running), spool the document to disk as they go (app.commands.json_stream) and
append the log to its files chunk by chunk (tauvcore.logs.writer.LogWriter), so their memory does
not grow with the mission; a replay holds the log it reads. Writes docs/results/run_memory.md;
with ``--only`` the rows not named are kept from that file as they were.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

ROWS = ("run", "run-json", "save-log", "replay")
HEADER = ["| command | peak resident [MiB] | wall [s] | of which the run [s] | written [MB] |",
          "|---|---|---|---|---|"]


def command(row: str, hours: float) -> list[str]:
    """The tauv arguments of a row, with DIR and FILE for the paths."""
    duration = f"{hours * 3600:g}"
    if row in ("run", "run-json"):
        argv = ["run", "--trajectory", "straight", "--method", "all", "--duration", duration]
        return argv + (["--json", "FILE"] if row == "run-json" else [])
    if row == "save-log":
        return ["run", "--duration", duration, "--save-log", "DIR", "--log-format", "parquet"]
    return ["replay", "DIR"]


def shown(row: str, hours: float) -> str:
    """A row's command as the table shows it (the replay's with the log's length)."""
    text = "`tauv " + " ".join(command(row, hours)) + "`"
    return text + (f" (the {hours:g} h log)" if row == "replay" else "")


def child(argv: list[str]) -> tuple[str, float, float]:
    """Run ``tauv argv`` in a child process: its stdout, wall time [s] and peak resident memory
    [MiB] (``ru_maxrss`` of that child alone, from ``wait4``)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.monotonic()
        proc = subprocess.Popen([sys.executable, "-m", "app.cli", *argv], stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(proc.pid, 0)
        wall_s = time.monotonic() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if proc.returncode != 0:
            raise RuntimeError(f"tauv {' '.join(argv)} exited {proc.returncode}: {err.read()}")
        return out.read(), wall_s, usage.ru_maxrss / 1024.0


def size_mb(path: str) -> float:
    """A file's size, or the sum of a directory's files' [MB]."""
    if os.path.isdir(path):
        return sum(p.stat().st_size for p in Path(path).rglob("*") if p.is_file()) / 1e6
    return os.path.getsize(path) / 1e6


def measure(row: str, hours: float, tmp: str, log_dir: str) -> dict:
    """One row: its command in a child process, its peak memory, wall time and what it wrote."""
    out = os.path.join(tmp, f"{row}_{hours:g}h.json") if row == "run-json" else None
    if row == "save-log":
        out = log_dir
    argv = [out if a == "FILE" else log_dir if a == "DIR" else a for a in command(row, hours)]
    stdout, wall_s, peak_mib = child(argv)
    run_s = float(re.search(r"\(([\d.]+) s wall\)", stdout).group(1))
    result = {"row": row, "hours": hours, "peak_mib": peak_mib, "wall_s": wall_s, "run_s": run_s,
              "written_mb": size_mb(out) if out is not None else None}
    if row == "run-json":
        os.unlink(out)
    return result


def line(r: dict) -> str:
    written = f"{r['written_mb']:,.0f}" if r["written_mb"] is not None else "-"
    return (f"| {shown(r['row'], r['hours'])} | {r['peak_mib']:.0f} | {r['wall_s']:.0f} | {r['run_s']:.0f} "
            f"| {written} |")


def kept_lines() -> dict[str, str]:
    """The rows of the fragment as it is, by their command cell."""
    path = fragment.RESULTS / "run_memory.md"
    if not path.exists():
        return {}
    return {text.split(" | ")[0].removeprefix("| "): text
            for text in path.read_text(encoding="utf-8").splitlines() if text.startswith("| `tauv ")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0, 24.0],
                        help="the run and run-json rows' mission lengths [h]")
    parser.add_argument("--log-hours", type=float, default=10.0,
                        help="the save-log and replay rows' mission length [h]")
    parser.add_argument("--only", nargs="+", choices=ROWS, default=list(ROWS),
                        help="the rows to measure; the others are kept from docs/results/run_memory.md")
    args = parser.parse_args()
    order = [(row, h) for h in sorted(args.hours) for row in ("run", "run-json")]
    order += [("save-log", args.log_hours), ("replay", args.log_hours)]
    measured: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        log_dir = os.path.join(tmp, "log")
        if "replay" in args.only and "save-log" not in args.only:   # the log it reads, not measured
            child([log_dir if a == "DIR" else a for a in command("save-log", args.log_hours)])
        for row, hours in order:
            if row in args.only:
                result = measure(row, hours, tmp, log_dir)
                measured[shown(row, hours)] = line(result)
                print(result, flush=True)
    partial = set(args.only) != set(ROWS)
    if partial:  # the fragment's rows in their order, those measured replaced, new ones after them
        lines = [measured.pop(cmd, text) for cmd, text in kept_lines().items()] + list(measured.values())
    else:
        lines = list(measured.values())
    table = "\n".join(HEADER + lines) + (
        "\n\n`tauv run` rows: every method (`all`: the standalone INS and the seven 20-state methods), DVL "
        "aiding, seed 0, one run; with `--json` the wall time beyond the run's is the document's writing. "
        "`--save-log` and `tauv replay`: the default trajectory and methods (straight, `ins,lc`); the replay "
        "holds the whole log (IMU and reference at 150 Hz; its peak is the reader's) and makes the rest chunk by "
        "chunk. "
        "Each row is one whole command in its own process; written: the `--json` file or the log's directory.")
    if partial:
        table += " Rows not named by `--only` are kept from the fragment as it was."
    print(table)
    print(f"written to {fragment.write('run_memory', table)}")


if __name__ == "__main__":
    main()
