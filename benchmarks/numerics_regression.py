"""The numerical safeguards (docs/safeguards.md) change nothing on a healthy run: compare with the code before.

    python benchmarks/numerics_regression.py                 # against e1d9656, the commit before them
    python benchmarks/numerics_regression.py --base <commit>

Builds a copy of the working tree's ``tauvcore`` in which the filter, runner, metrics, aiding and
error-model files are replaced by their versions at ``--base`` (so any other change, e.g. to the
configuration, is the same on both sides), runs the same scenarios with both (all eight methods on
the three trajectories with Table 2 settings, and a figure eight with depth, magnetometer, 30 %
beam dropout and three random-initial-error runs), and prints the largest difference over every
error, sigma, NEES, position and update-record series. A record, not a test
(tests/unit/tauvcore/engine/test_numerics.py checks the same with the safeguards switched off in place).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
NUMERICS_FILES = ("tauvcore/filter", "tauvcore/eval", "tauvcore/aiding", "tauvcore/ins/error_model.py")
SERIES = ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m", "nees",
          "est_pos_n")
RECORDS = ("innovation", "innovation_var", "test_ratio", "fused")


def scenarios():
    from tauvcore.config import METHODS, Config
    for trajectory in ("straight", "figure8", "lawnmower"):
        yield trajectory, Config().replace("trajectory", name=trajectory).replace("run", methods=METHODS), 1
    mixed = (Config().replace("trajectory", name="figure8").replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"))
             .replace("dvl", dropout_probability=0.3).replace("initial_error", mode="random"))
    yield "figure8+depth+mag+dropout", mixed, 3


def child(out_path: str) -> None:
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate
    arrays = {}
    for name, config, runs in scenarios():
        rng = np.random.default_rng(5)
        for method, res in run(config, simulate(config, rng, runs), rng).items():
            for f in SERIES:
                arrays[f"{name}/{method}/{f}"] = getattr(res, f)
            for source, rec in res.updates.items():
                for f in RECORDS:
                    arrays[f"{name}/{method}/{source}/{f}"] = getattr(rec, f)
    np.savez(out_path, **arrays)


def base_tree(base: str, into: Path) -> None:
    shutil.copytree(ROOT / "tauvcore", into / "tauvcore", ignore=shutil.ignore_patterns("__pycache__"))
    for rel in NUMERICS_FILES:
        shutil.rmtree(into / rel, ignore_errors=True)
        (into / rel).unlink(missing_ok=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", base, rel], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="e1d9656")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child)
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp)
        base_tree(args.base, tmp_path / "base")
        for label, pythonpath in (("base", str(tmp_path / "base")), ("now", str(ROOT))):
            subprocess.run([sys.executable, __file__, "--child", str(tmp_path / f"{label}.npz")], check=True,
                           cwd=tmp, env={"PYTHONPATH": pythonpath, "PATH": "/usr/bin:/bin"})
        old, new = np.load(tmp_path / "base.npz"), np.load(tmp_path / "now.npz")
        assert set(old.files) == set(new.files), set(old.files) ^ set(new.files)
        worst, where = 0.0, ""
        for key in old.files:
            a, b = old[key].astype(float), new[key].astype(float)
            assert a.shape == b.shape and np.array_equal(np.isnan(a), np.isnan(b)), key
            diff = float(np.nanmax(np.abs(a - b))) if a.size else 0.0
            if diff > worst:
                worst, where = diff, key
    print(f"{len(old.files)} series compared against {args.base}: largest absolute difference {worst:g}"
          + (f" ({where})" if where else ""))


if __name__ == "__main__":
    main()
