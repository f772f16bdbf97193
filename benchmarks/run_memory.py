"""Peak memory of ``tauv run`` on long missions, with and without ``--json``.

    python benchmarks/run_memory.py                      # 1 h, 10 h and 24 h, every method
    python benchmarks/run_memory.py --hours 1 10

Each row is one whole command in its own process (``tauv run --trajectory straight --method all
--duration S [--json FILE]``), its peak resident memory from the kernel's accounting of the child
(``ru_maxrss``, what ``/usr/bin/time -v`` reports), its wall time, and with ``--json`` the file's
size and the time the document took to write after the run (the run's own wall time is in the
command's first line). The command reduces the results chunk by chunk (tauvcore.eval.running) and
spools the document to disk as it goes (app.commands.json_stream), so its memory does not grow with the
mission. Writes docs/results/run_memory.md.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)


def measure(hours: float, json_dir: str | None) -> dict:
    """One ``tauv run`` in a child process: its peak memory, wall time and output."""
    cmd = [sys.executable, "-m", "app.cli", "run", "--trajectory", "straight", "--method", "all",
           "--duration", f"{hours * 3600:g}"]
    out = None
    if json_dir is not None:
        out = os.path.join(json_dir, f"run_{hours:g}h.json")
        cmd += ["--json", out]
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.monotonic()
    done = subprocess.run(cmd, check=True, capture_output=True, text=True)
    wall_s = time.monotonic() - t0
    peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if peak_kib < before:  # ru_maxrss is the largest child so far: a smaller one is not seen
        raise RuntimeError("run the largest command last")
    run_s = float(re.search(r"\(([\d.]+) s wall\)", done.stdout).group(1))
    row = {"hours": hours, "json": out is not None, "peak_mib": peak_kib / 1024.0, "wall_s": wall_s, "run_s": run_s}
    if out is not None:
        row["json_mb"] = os.path.getsize(out) / 1e6
        os.unlink(out)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0, 24.0])
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # ru_maxrss of the children is their largest so far: from the smallest command to the largest
        for hours in sorted(args.hours):
            for with_json in (False, True):
                rows.append(measure(hours, tmp if with_json else None))
                print(rows[-1], flush=True)
    lines = ["| command | peak resident [MiB] | wall [s] | of which the run [s] | `--json` file [MB] |",
             "|---|---|---|---|---|"]
    for r in rows:
        command = f"`tauv run --trajectory straight --method all --duration {r['hours'] * 3600:g}" + (
            " --json FILE`" if r["json"] else "`")
        size = f"{r['json_mb']:,.0f}" if r["json"] else "-"
        lines.append(f"| {command} | {r['peak_mib']:.0f} | {r['wall_s']:.0f} | {r['run_s']:.0f} | {size} |")
    table = "\n".join(lines) + (
        "\n\nEvery method (`all`: the standalone INS and the seven 20-state methods), DVL aiding, seed 0, "
        "one run; each row one whole command in its own process; with `--json` the wall time beyond the "
        "run's is the document's writing.")
    print(table)
    print(f"written to {fragment.write('run_memory', table)}")


if __name__ == "__main__":
    main()
