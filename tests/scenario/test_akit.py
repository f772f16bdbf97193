"""Real data: an A-KIT segment converted and replayed. Reads ../shared/data/akit when
present and skips otherwise (the data is not part of the repository; its NOTES.md says why)."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
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


METHODS = ("ins", "lc", "tc", "nsv", "elc")


def _readme_table() -> dict[str, dict[str, float]]:
    """The A-KIT table docs/replay.md shows (docs/results/akit_table.md, written by
    benchmarks/akit_table.py): segment -> method -> position error at the end [m]."""
    assert '--8<-- "docs/results/akit_table.md"' in (ROOT / "docs" / "replay.md").read_text(encoding="utf-8")
    rows = {}
    for line in (ROOT / "docs" / "results" / "akit_table.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if cells[0].startswith("Trajectory") and len(cells) == 3 + len(METHODS):
            rows[cells[0]] = dict(zip(METHODS, map(float, cells[3:]), strict=True))
    return rows


def _replay_json(out: Path, json_path: Path, *argv: str) -> dict:
    """``tauv replay OUT ARGV --json JSON`` in this process: the JSON document it wrote."""
    from app.cli import main

    assert main(["replay", str(out), *argv, "--json", str(json_path)]) == 0
    return json.loads(json_path.read_text())


def _convert(segment: Path, out: Path) -> None:
    """docs/replay.md's command: ``python scripts/akit_to_log.py SEGMENT OUT``."""
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "akit_to_log.py"), str(segment), str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_the_readme_commands_give_the_readme_figures_on_segment_1(tmp_path: Path) -> None:
    """``akit_to_log.py`` then ``tauv replay OUT --method ins,lc``, as docs/replay.md says, with no
    further flag or file: that page's INS and LC on Trajectory1 to their 0.1 m (the log's own
    log.toml applied, the filters starting on the reference), and the JSON says so."""
    out = tmp_path / "akit1"
    _convert(SEGMENT, out)
    proc = subprocess.run([sys.executable, "-m", "app.cli", "replay", str(out), "--method", "ins,lc", "--json",
                           str(tmp_path / "r.json")], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((tmp_path / "r.json").read_text())
    expected = _readme_table()["Trajectory1"]
    for method in ("ins", "lc"):
        assert doc["results"][method]["pos_err_m"][-1] == pytest.approx(expected[method], abs=0.051), method
    log = doc["log"]
    assert log["config_file"] == str(out / "log.toml") and log["start"].startswith("start: on the reference")
    assert doc["config"]["dvl"]["lever_arm_m"] == [-1.86, -0.03, 0.18] and doc["config"]["run"]["ideal"]
    header = proc.stdout.splitlines()[:3]
    assert header[0].startswith("log ") and "akit1" in header[0] and "IDEAL" not in header[0]
    assert "log.toml" in header[1] and "dvl.lever_arm_m" in header[1] and header[2].startswith("start: on")


@pytest.mark.slow
def test_the_readme_commands_give_the_readme_table(tmp_path: Path) -> None:
    """Every segment of that page's table, by its own commands: the INS and LC with four beams,
    TC, NSV and ELC with beams 1 and 2, to the table's 0.1 m."""
    table = _readme_table()
    assert len(table) == 13
    for name, expected in table.items():
        out = tmp_path / name
        _convert(DATA / name, out)
        got = {}
        for argv in (("--method", "ins,lc"), ("--beams", "1,2", "--method", "tc,nsv,elc")):
            results = _replay_json(out, tmp_path / f"{name}.json", *argv)["results"]
            got.update({m: r["pos_err_m"][-1] for m, r in results.items()})
        for method, value in expected.items():
            assert got[method] == pytest.approx(value, abs=0.051), (name, method)


def test_the_dashboards_replay_equals_the_clis(tmp_path: Path) -> None:
    """The dashboard's controls at their defaults with the converted segment as Source (its own
    log.toml under them, app.dashboard.inputs.config_from_controls) and the worker's replay
    (app.dashboard.worker.replay_source): LC's errors equal ``tauv replay OUT --method ins,lc``'s to 1e-9."""
    import dataclasses

    from app.dashboard.inputs import Controls, config_from_controls
    from app.dashboard.worker import replay_source
    from tauvcore.engine.mission import run
    from tauvcore.eval.replay import log_config

    out = tmp_path / "akit1"
    _convert(SEGMENT, out)
    cli = _replay_json(out, tmp_path / "cli.json", "--method", "ins,lc")
    controls = Controls(trajectory="straight", duration="250", methods=("ins", "lc"), vb_nf="20",
                        nsv_epsilon="auto", beams=(1, 2, 3, 4), dropout="0", outages=(("0", "0"),) * 4,
                        accel_bias="0.5", gyro_bias="3", accel_noise="0.072",
                        gyro_noise="0.34", dvl_noise="0.042", dvl_bias="0.005", dvl_sf="0.7", seabed_depth="60",
                        dvl_max_altitude="100", switch_altitude="100", rpm_noise="2", seed="0", runs="1",
                        source="akit1")
    config, runs = config_from_controls(controls, log_config(out)[0])
    assert runs == 1 and config.dvl.lever_arm_m == (-1.86, -0.03, 0.18)
    rng = np.random.default_rng(config.run.seed)
    config, sim, source, _ = replay_source(config, str(out), rng)
    assert source["config_file"] == str(out / "log.toml") and "the dashboard's controls" in source["configuration"]
    ours = run(config, sim, rng)
    for method in ("ins", "lc"):
        a = np.array(cli["results"][method]["pos_err_m"], dtype=float)
        np.testing.assert_allclose(ours[method].pos_err_m[:, 0], a, rtol=0, atol=1e-9 * np.abs(a).max())
    without = config_from_controls(dataclasses.replace(controls), None)[0]
    assert without.dvl.lever_arm_m != config.dvl.lever_arm_m      # the log's own file is what set it
