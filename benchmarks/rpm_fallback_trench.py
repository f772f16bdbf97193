"""The first paper's methods over the longrange mission's trenches, from a `tauv mc` study's
per-epoch table: velocity error RMS and velocity NEES per dimension where the seabed is out of
DVL range (5-8 and 15-16 minutes), and at the end (docs/models.md, "Beyond DVL range", the --rpm-fallback
table). An accuracy table, not a test.

    tauv mc --trajectory longrange --runs 20 --method all [--rpm-fallback] --out DIR --workers 2
    python benchmarks/rpm_fallback_trench.py DIR [DIR ...]

Writes its tables to docs/results/rpm_fallback_trench.md (benchmarks/fragment.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

sys.path.insert(0, str(Path(__file__).resolve().parent))   # benchmarks/: fragment.py, when imported
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

TRENCHES_S = ((300.0, 480.0), (900.0, 960.0))
METHODS = ("lc", "tc", "vb", "nsv", "plcf", "vhv", "elc")


def table(study: Path) -> list[str]:
    """Markdown rows: method, trench velocity RMS [m/s], trench and whole velocity NEES/3, end
    velocity RMS [m/s] and end position RMS [m] over the runs."""
    data = pq.read_table(study / "runs.parquet", columns=["method", "t_s", "vel_err_mps", "pos_err_m", "nees_vel"])
    col = {name: data.column(name).to_numpy(zero_copy_only=False) for name in data.schema.names}
    rows = []
    for method in METHODS:
        sel = col["method"] == method
        if not sel.any():
            continue
        t, vel, pos, nees = col["t_s"][sel], col["vel_err_mps"][sel], col["pos_err_m"][sel], col["nees_vel"][sel]
        trench = np.zeros(t.shape, bool)
        for start, end in TRENCHES_S:
            trench |= (t > start) & (t < end)
        last = t == t.max()
        rows.append(
            f"| {method.upper()} | {np.sqrt(np.mean(vel[trench] ** 2)):.3f} | {np.nanmean(nees[trench]) / 3:.2f} "
            f"| {np.nanmean(nees) / 3:.2f} | {np.sqrt(np.mean(vel[last] ** 2)):.3f} | {np.sqrt(np.mean(pos[last] ** 2)):.1f} |"
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("studies", nargs="+", type=Path, help="directories written by tauv mc --out")
    args = parser.parse_args()
    with fragment.capture() as shown:
        for study in args.studies:
            print(f"\n**{study}**\n")
            print("| method | trench vel RMS [m/s] | trench vel NEES/dim | vel NEES/dim | end vel [m/s] | end pos [m] |")
            print("|---|---|---|---|---|---|")
            print("\n".join(table(study)))
    print(f"written to {fragment.write('rpm_fallback_trench', shown.getvalue())}")


if __name__ == "__main__":
    main()
