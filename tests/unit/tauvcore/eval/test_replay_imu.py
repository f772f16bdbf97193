"""``tauv replay --imu-errors P --imu Q``: P's errors are added to the log's IMU, the filters are
tuned for Q (tauvcore.eval.replay.prepare's ``imu_tuning``); ``--imu-errors P`` alone tunes them
for P; the header says which."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.replay import prepare, prepare_rows
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors.imu import IMU_PROFILES


@pytest.fixture(scope="module")
def log_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 30 s simulated log at 100 Hz (the IMU rate of both profiles used below)."""
    config = (
        Config()
        .replace("trajectory", name="figure8", duration_s=30.0)
        .replace("imu", **dataclasses.asdict(IMU_PROFILES["phins"]))
    )
    directory = tmp_path_factory.mktemp("imu") / "log"
    write_log(
        directory, simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(4)))]), "csv"
    )
    return directory


def _at(profile: str, rate_hz: float) -> dict:
    return dataclasses.asdict(dataclasses.replace(IMU_PROFILES[profile], rate_hz=rate_hz))


@pytest.mark.parametrize("fed", [prepare, prepare_rows], ids=["prepare", "prepare_rows"])
def test_the_tuning_changes_the_filters_not_the_errors_added(log_dir: Path, fed) -> None:
    """With ``imu_tuning`` the configuration's IMU is that one (at the log's rate), and the IMU
    increments are those ``imu_errors`` alone makes from the same seed: bit for bit the errors of
    ``imu_errors``, not of the tuning's IMU."""
    log = read_log(log_dir)
    errors, tuning = IMU_PROFILES["yoo-table1"], IMU_PROFILES["table2"]
    alone_config, alone = fed(Config(), log, np.random.default_rng(1), errors)
    both_config, both = fed(Config(), log, np.random.default_rng(1), errors, tuning)
    rate = alone_config.imu.rate_hz
    assert dataclasses.asdict(alone_config.imu) == _at("yoo-table1", rate)
    assert dataclasses.asdict(both_config.imu) == _at("table2", rate)
    np.testing.assert_array_equal(both.imu.dtheta_b, alone.imu.dtheta_b)
    np.testing.assert_array_equal(both.imu.dv_b, alone.imu.dv_b)
    _, other = fed(Config(), log, np.random.default_rng(1), tuning)
    assert np.abs(other.imu.dtheta_b - alone.imu.dtheta_b).max() > 1e-6  # another IMU's errors differ


def _replay(
    tmp_path: Path, log_dir: Path, capsys: pytest.CaptureFixture, *argv: str
) -> tuple[list[str], dict]:
    out = tmp_path / f"r{len(list(tmp_path.glob('*.json')))}.json"
    assert main(["replay", str(log_dir), "--method", "ins,lc", "--seed", "5", "--json", str(out), *argv]) == 0
    return capsys.readouterr().out.splitlines(), json.loads(out.read_text())


def test_imu_with_imu_errors_on_the_command_line(
    log_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """``--imu-errors yoo-table1``: the filters tuned for yoo-table1; with ``--imu table2`` as well,
    for table2, over the same IMU (the free INS, which no tuning touches, the same to the bit); the
    header's IMU line and --json's ``"log"`` say so."""
    alone_lines, alone = _replay(tmp_path, log_dir, capsys, "--imu-errors", "yoo-table1")
    both_lines, both = _replay(tmp_path, log_dir, capsys, "--imu-errors", "yoo-table1", "--imu", "table2")
    rate = alone["config"]["imu"]["rate_hz"]
    assert {k: v for k, v in alone["config"]["imu"].items()} == _at("yoo-table1", rate)
    assert {k: v for k, v in both["config"]["imu"].items()} == _at("table2", rate)
    line = "IMU: the log's with the errors of yoo-table1 added (drawn from seed 5); the filters tuned for"
    assert alone["log"]["imu"] == f"{line} yoo-table1" and f"{line} yoo-table1" in alone_lines
    assert both["log"]["imu"] == f"{line} table2" and f"{line} table2" in both_lines
    assert both["results"]["ins"]["pos_err_m"] == alone["results"]["ins"]["pos_err_m"]
    assert both["results"]["lc"]["vel_sigma_mps"] != alone["results"]["lc"]["vel_sigma_mps"]
    plain_lines, plain = _replay(tmp_path, log_dir, capsys, "--imu", "table2")
    assert "imu" not in plain["log"] and not any(s.startswith("IMU: ") for s in plain_lines)
