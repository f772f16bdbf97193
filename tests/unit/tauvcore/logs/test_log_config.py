"""A simulated log carries its configuration (``tauv run --save-log`` writes ``log.toml``), so a
replay filters it as the run did; ``tauv replay --imu PROFILE`` tunes the filters over it."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, to_dict
from tauvcore.logs import CONFIG_FILE
from tauvcore.sensors.imu import IMU_PROFILES


def _cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "app.cli", *argv], check=False, capture_output=True, text=True,
                          timeout=180)


def _json(tmp_path: Path, *argv: str) -> dict:
    out = tmp_path / f"{argv[0]}-{len(list(tmp_path.glob('*.json')))}.json"
    proc = _cli(*argv, "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    return json.loads(out.read_text())


@pytest.fixture(scope="module")
def longrange_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    """``tauv run --trajectory longrange`` (Yoo's IMU, the DVL at 5 Hz) saved as a log, and its JSON."""
    tmp = tmp_path_factory.mktemp("longrange")
    ran = _json(tmp, "run", "--trajectory", "longrange", "--duration", "120", "--method", "ins,lc,tc",
                "--seed", "3", "--save-log", str(tmp / "log"))
    return tmp / "log", ran


def test_longrange_replay_reproduces_the_run(longrange_log: tuple[Path, dict], tmp_path: Path) -> None:
    """The replay with --initial-errors and the run's seed equals the run to 1e-9: the log's
    own file gives the filters Yoo's IMU tuning and the DVL's 5 Hz, not Table 2's."""
    log, ran = longrange_log
    replayed = _json(tmp_path, "replay", str(log), "--method", "ins,lc,tc", "--initial-errors", "--seed", "3")
    for method, series in ran["results"].items():
        for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "nees_pos", "nees_vel"):
            a = np.array(series[name], dtype=float)
            b = np.array(replayed["results"][method][name], dtype=float)
            np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9 * np.abs(a).max(), err_msg=f"{method} {name}")
    assert replayed["log"]["config_file"] == str(log / CONFIG_FILE)


def test_saved_log_config_holds_the_sensors_sections(longrange_log: tuple[Path, dict]) -> None:
    """log.toml names the scenario and holds the IMU profile and the DVL's rate whole; not the
    run's methods or seed."""
    log, _ = longrange_log
    raw = tomllib.loads((log / CONFIG_FILE).read_text(encoding="utf-8"))
    assert raw["trajectory"]["name"] == "longrange"
    yoo = dataclasses.asdict(IMU_PROFILES["yoo-table1"])
    assert raw["imu"] == pytest.approx(yoo)
    assert raw["dvl"]["rate_hz"] == 5.0
    assert "run" not in raw and "replay" not in raw
    assert "outages" not in raw["dvl"] and "dropout_probability" not in raw["dvl"]


def test_to_log_toml_sections() -> None:
    """Only the sections that differ are written, whole; the DVL's simulated outages and dropouts
    (already in the log's tables) are not; the defaults give no file."""
    from tauvcore.config import to_log_toml

    assert to_log_toml(Config()) is None
    config = Config().replace("dvl", noise_mps=0.01, dropout_probability=0.1).replace("earth", model="flat")
    config = config.replace("run", seed=7)
    raw = tomllib.loads(to_log_toml(config) or "")
    assert set(raw) == {"dvl", "earth"}
    assert raw["dvl"]["noise_mps"] == 0.01 and "dropout_probability" not in raw["dvl"]
    assert raw["earth"] == to_dict(config)["earth"]
    back = from_dict(raw)
    assert back.dvl == dataclasses.replace(config.dvl, dropout_probability=0.0) and back.earth == config.earth


def test_replay_imu_flag_over_the_log_file(longrange_log: tuple[Path, dict], tmp_path: Path) -> None:
    """``tauv replay --imu phins`` tunes the filters for that profile over the log's own [imu]
    (Yoo's) and over --config's; the log still fixes the IMU's rate."""
    log, _ = longrange_log
    config_file = tmp_path / "tuning.toml"
    config_file.write_text('[imu]\ngyro_noise_deg_per_sqrt_h = 0.5\n[dvl]\nnoise_mps = 0.02\n', encoding="utf-8")
    out = _json(tmp_path, "replay", str(log), "--method", "lc", "--imu", "phins", "--config", str(config_file))
    phins = dataclasses.asdict(IMU_PROFILES["phins"])
    assert out["config"]["imu"] == pytest.approx({**phins, "rate_hz": 100.0})
    assert out["config"]["dvl"]["noise_mps"] == 0.02 and out["config"]["dvl"]["rate_hz"] == 5.0
    assert "--imu" in out["log"]["configuration"][-1]
    without = _json(tmp_path, "replay", str(log), "--method", "lc")
    assert without["config"]["imu"] == pytest.approx(dataclasses.asdict(IMU_PROFILES["yoo-table1"]))


def test_replay_imu_flag_unknown(longrange_log: tuple[Path, dict]) -> None:
    log, _ = longrange_log
    proc = _cli("replay", str(log), "--method", "lc", "--imu", "nope")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        "tauv: error: --imu: unknown IMU profile 'nope' (choose from table2, yoo-table1, phins)"
    )
