"""A replay says what its NEES is measured against: the reference as exact, or with the 1-sigma its
log's own ``log.toml`` (or ``--config``) states in ``[reference]``; the text output, ``--json`` and
the dashboard's configuration table alike."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs import CONFIG_FILE
from tauvcore.logs.writer import simulation_tables, write_log

STATED = "[reference]\npos_horizontal_m = 0.5\nvel_mps = 0.02\nroll_pitch_deg = 0.01\nyaw_deg = 0.05\n"
STATED_LINE = (
    "NEES against the reference with its stated 1-sigma: position 0.5 m horizontal, 0 m vertical; "
    "velocity 0.02 m/s; attitude 0.01/0.05 deg (roll/pitch, yaw)"
)
EXACT_LINE = "NEES against the reference as exact (no [reference] sigma)"


@pytest.fixture(scope="module")
def tables() -> dict:
    """A 30 s simulated mission's tables (its reference is its truth)."""
    config = Config().replace("trajectory", name="figure8", duration_s=30.0)
    return simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(2)))])


def _log(root: Path, tables: dict, own: str | None) -> Path:
    directory = root / "log"
    write_log(directory, tables, "csv", config_toml=own)
    return directory


def _replay(
    capsys: pytest.CaptureFixture, directory: Path, json_path: Path, *argv: str
) -> tuple[list[str], dict]:
    assert main(["replay", str(directory), "--method", "lc,ins-dvl", "--json", str(json_path), *argv]) == 0
    return capsys.readouterr().out.splitlines(), json.loads(json_path.read_text())


def test_the_log_s_own_reference_sigma_is_applied_and_said(
    tables: dict, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """log.toml's [reference] reaches the filters' NEES (lower than against an exact reference, the
    errors the same) and is named in the header after the start, in --json's "log" and its config."""
    stated = _log(tmp_path / "stated", tables, STATED)
    exact = _log(tmp_path / "exact", tables, None)
    lines, doc = _replay(capsys, stated, tmp_path / "stated.json")
    assert lines[3] == STATED_LINE and lines[2].startswith("start: ")
    assert "reference.pos_horizontal_m" in lines[1]
    assert doc["log"]["reference"] == STATED_LINE
    assert doc["config"]["reference"]["vel_mps"] == 0.02
    plain_lines, plain = _replay(capsys, exact, tmp_path / "exact.json")
    assert plain_lines[3] == EXACT_LINE and plain["log"]["reference"] == EXACT_LINE
    for method in ("lc", "ins-dvl"):
        a, b = plain["results"][method], doc["results"][method]
        assert a["vel_err_mps"] == b["vel_err_mps"]
        for block in ("vel", "tilt", "heading"):
            ours, theirs = np.array(b[f"nees_{block}"], float), np.array(a[f"nees_{block}"], float)
            assert np.all(ours[1:] < theirs[1:]), (method, block)


def test_config_s_reference_lies_over_the_log_s(
    tables: dict, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    stated = _log(tmp_path, tables, STATED)
    over = tmp_path / "over.toml"
    over.write_text(
        "[reference]\npos_horizontal_m = 0.0\nvel_mps = 0.0\nroll_pitch_deg = 0.0\nyaw_deg = 0.0\n"
    )
    lines, doc = _replay(capsys, stated, tmp_path / "r.json", "--config", str(over))
    assert lines[3] == EXACT_LINE and doc["log"]["reference"] == EXACT_LINE


def test_a_bad_reference_sigma_in_log_toml_is_one_line(
    tables: dict, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    directory = _log(tmp_path, tables, "[reference]\nvel_mps = -0.1\n")
    assert main(["replay", str(directory), "--method", "lc"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "reference.vel_mps" in err[0] and "-0.1" in err[0] and CONFIG_FILE in err[0]


def test_the_dashboard_labels_the_replay_with_its_reference(tables: dict, tmp_path: Path) -> None:
    """The worker's description of a replayed log (app.dashboard.worker.replay_source) carries the line, and
    the Results tab's configuration table (app.dashboard.inputs.config_rows) shows it as "Reference"."""
    from app.dashboard.inputs import config_rows
    from app.dashboard.worker import replay_source
    from tauvcore.config import from_dict
    from tauvcore.eval.replay import log_config

    directory = _log(tmp_path, tables, STATED)
    config = from_dict(log_config(directory)[0]).replace("run", methods=("lc",))
    config, _, source, _ = replay_source(config, str(directory), np.random.default_rng(0))
    assert source["reference"] == STATED_LINE
    assert ("Reference", STATED_LINE) in config_rows(config, 1, source)
