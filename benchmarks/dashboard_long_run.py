"""Peak memory and wall time of a dashboard run of a long mission: the worker (app.dashboard.worker.run_worker)
reduces its results to time bins as it streams (tauvcore.eval.envelope), so neither its memory
nor what it sends the server grows with the mission.

    python benchmarks/dashboard_long_run.py                   # 1 h and 10 h at 150 Hz and 50 Hz
    python benchmarks/dashboard_long_run.py --hours 10 --rate 50

Each row runs the dashboard's five default methods (app.dashboard.control_table.DEFAULT_METHODS) on the
figure eight, one Monte Carlo run, in a process of its own, as a worker does: every message is
pickled as the pipe to the server pickles it. It reports the peak resident memory of that process
(``VmHWM``) and above its baseline once app.dashboard.worker is imported, the run's wall time, the largest
message (the final results) pickled, the bins, and app.dashboard.budget's estimate of the worker's peak.
Writes docs/results/dashboard_long_run.md.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import textwrap
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/: fragment.py, when imported
import fragment  # benchmarks/, this script's own directory

MEASURE = textwrap.dedent("""
    import json, pickle, sys, threading, time
    from app.dashboard import budget, worker
    from app.dashboard.control_table import DEFAULT_METHODS
    from tauvcore.config import Config, to_dict

    def status_bytes(key):
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) * 1024 for line in f if line.startswith(key + ":"))

    class PicklingQueue:
        largest = 0
        def put(self, message):
            if message[0] == "error":
                raise SystemExit(message[1])
            self.largest = max(self.largest, len(pickle.dumps(message)))
            if message[0] == "done":
                self.done = message

    hours, rate_hz = json.loads(sys.argv[1])
    config = (Config().replace("trajectory", name="figure8", duration_s=hours * 3600.0)
              .replace("imu", rate_hz=rate_hz).replace("run", methods=DEFAULT_METHODS))
    base = status_bytes("VmRSS")
    queue = PicklingQueue()
    t0 = time.perf_counter()
    worker.run_worker(to_dict(config), 1, queue, threading.Event())
    wall = time.perf_counter() - t0
    results = queue.done[1]
    first = next(iter(results.values()))
    print(json.dumps({
        "peak": status_bytes("VmHWM"), "base": base, "wall": wall, "largest": queue.largest,
        "bins": len(first.t_s), "bin_s": float(getattr(first, "bin_s", float("nan"))),
        "estimate": budget.estimate_run(config, 1).worker_peak_bytes,
    }))
""")
HEADER = [
    (
        "| mission | IMU [Hz] | output epochs | bins (width) | peak resident [MiB] | above baseline [MiB] "
        "| estimate [MiB] | wall [s] | final results pickled [MB] |"
    ),
    "|---|---|---|---|---|---|---|---|---|",
]


def measure(hours: float, rate_hz: float) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", MEASURE, json.dumps([hours, rate_hz])],
        capture_output=True, text=True, check=False,
    )
    if out.returncode != 0:
        raise SystemExit(out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=[1.0, 10.0])
    parser.add_argument("--rate", type=float, nargs="+", default=[150.0, 50.0], help="IMU rates [Hz]")
    args = parser.parse_args()
    rows = []
    for rate_hz in args.rate:
        for hours in args.hours:
            m = measure(hours, rate_hz)
            epochs = round(hours * 36000) + 1
            row = (
                f"| {hours:g} h | {rate_hz:g} | {epochs:,} | {m['bins']:,} ({m['bin_s']:.3g} s) "
                f"| {m['peak'] / 2**20:.0f} | {(m['peak'] - m['base']) / 2**20:.0f} "
                f"| {m['estimate'] / 2**20:.0f} | {m['wall']:.0f} | {m['largest'] / 1e6:.1f} |"
            )
            print(row, flush=True)
            rows.append(row)
    note = (
        "The dashboard's worker on the figure eight, five default methods, one run "
        "(`python benchmarks/dashboard_long_run.py`): results reduced to at most 4,000 time bins "
        "as the mission streams (tauvcore.eval.envelope)."
    )
    table = "\n".join([note, "", *HEADER, *rows])
    print(f"written to {fragment.write('dashboard_long_run', table)}")


if __name__ == "__main__":
    main()
