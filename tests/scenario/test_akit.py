"""Real data (issue 10): an A-KIT segment converted and replayed. Reads ../shared/data/akit when
present and skips otherwise (the data is not part of the repository; its NOTES.md says why)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "akit"
SEGMENT = DATA / "Trajectory1"

pytestmark = pytest.mark.skipif(not (SEGMENT / "IMU.csv").exists(), reason="A-KIT data not present")


def _module(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_an_akit_segment_converts_and_the_dvl_methods_beat_the_ins(tmp_path: Path) -> None:
    """Segment 1: the clock offsets the notes report (IMU about 0.4 s, DVL about 1 s after it),
    a log that reads back, and on replay LC within metres of the reference after 400 s while
    the free INS is tens of metres off."""
    table = _module(ROOT / "benchmarks" / "akit_table.py", "akit_table")
    offsets = table.akit.convert(SEGMENT, tmp_path)
    assert 0.3 <= abs(offsets["imu_shift_s"]) <= 0.6
    assert 0.8 <= abs(offsets["dvl_shift_s"] - offsets["imu_shift_s"]) <= 1.3
    from tauvcore.logs import read_log
    log = read_log(tmp_path)
    assert log.dt_s == pytest.approx(0.01) and log.duration_s == pytest.approx(398.0, abs=1.0)
    assert log.ref_geodetic and log.dvl_body_mps is not None
    row = table.segment_row(SEGMENT, None)
    assert np.isfinite([row[m] for m in ("ins", "lc", "tc", "nsv", "elc")]).all()
    assert row["lc"] < 10.0 < row["ins"]
    assert row["tc"] < row["ins"] and row["nsv"] < row["ins"]
