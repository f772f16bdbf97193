"""Memory of reading a log's table: peak resident memory a CSV or Parquet IMU table costs.

    python benchmarks/log_read_memory.py [--mb 200] [--format csv|parquet]

Writes a valid IMU table of about ``--mb`` megabytes (100 Hz increments, every value to its last
digit as ``tauv run --save-log`` writes them) in a temporary directory, then reads it in a fresh
process with the reader ``tauv replay`` uses (tauvcore.logs.table_io, one table) and prints the process's
peak resident memory beyond what the interpreter and the libraries took before the read, against
the file's size. The target: at most about twice the file (tauvcore.logs.table_io.MAX_LOG_BYTES).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROWS_PER_MB = 6_500
"""Rows of seven full-precision columns in a megabyte of CSV (about 150 bytes a row)."""

READ = """
import sys, time
from pathlib import Path
import numpy, pyarrow, pyarrow.csv, pyarrow.parquet
import tauvcore.logs.table_io as log_tables
def high_water():  # this process's own peak (ru_maxrss would carry the parent's over the exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
before = high_water()
started = time.perf_counter()
columns = log_tables.read_table(Path(sys.argv[1]))
elapsed = time.perf_counter() - started
print(before, high_water(), elapsed, len(next(iter(columns.values()))))
"""


def write_table(path: Path, megabytes: float, fmt: str) -> None:
    rng = np.random.default_rng(0)
    n = int(megabytes * ROWS_PER_MB)
    columns = {"t_s": np.arange(n) / 100.0}
    for name in ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"):
        columns[name] = rng.normal(0.0, 1e-4, n)
    for name in ("dv_x_mps", "dv_y_mps"):
        columns[name] = rng.normal(0.0, 1e-3, n)
    columns["dv_z_mps"] = -0.0980665 + rng.normal(0.0, 1e-3, n)
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        pq.write_table(pa.table(columns), path)
        return
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(columns) + "\n")
        data = np.column_stack(list(columns.values()))
        for start in range(0, n, 100_000):
            fh.writelines(",".join(repr(float(v)) for v in row) + "\n" for row in data[start : start + 100_000])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mb", type=float, default=200.0, help="size of the CSV table to read [MB]")
    parser.add_argument("--format", choices=("csv", "parquet"), default="csv")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"imu.{args.format}"
        write_table(path, args.mb, args.format)
        size = path.stat().st_size
        done = subprocess.run([sys.executable, "-c", READ, str(path)], capture_output=True, text=True, check=True)
    before, peak, elapsed, rows = done.stdout.split()
    grown = int(peak) - int(before)
    print(f"imu.{args.format}: {size / 1e6:.0f} MB, {int(rows):,} rows, read in {float(elapsed):.2f} s")
    print(f"peak resident memory {int(peak) / 1e6:.0f} MB ({int(before) / 1e6:.0f} MB before the read): "
          f"the read took {grown / 1e6:.0f} MB, {grown / size:.2f} times the file (target: at most about 2)")


if __name__ == "__main__":
    main()
