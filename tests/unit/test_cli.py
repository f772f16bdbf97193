"""The ``tauv`` command line: contract of run/config, and one clear line for every bad input."""

import json
import subprocess
import sys
import tomllib

import pytest

from app.cli import main
from tauvcore.config import Config, from_dict


def _run(capsys: pytest.CaptureFixture, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("argv, field", [
    (["run", "--trajectory", "spiral"], "'spiral'"),
    (["run", "--method", "ins,kalman"], "'kalman'"),
    (["run", "--duration", "-5"], "-5"),
    (["run", "--duration", "0"], "0"),
    (["run", "--duration", "ten"], "'ten'"),
    (["run", "--seed", "-1"], "-1"),
    (["run", "--aiding", "gps"], "'gps'"),
    (["run", "--config", "/no/such/file.toml"], "/no/such/file.toml"),
    (["run", "--json", "/no/such/dir/out.json"], "/no/such/dir/out.json"),
    (["run", "--nonsense"], "--nonsense"),
])
def test_bad_flags_give_one_line_and_exit_2(capsys, argv, field) -> None:
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and field in lines[0] and "Traceback" not in err


@pytest.mark.parametrize("toml, field, value", [
    ("[imu]\ngyro_noise_deg_per_sqrt_h = nan\n", "imu.gyro_noise_deg_per_sqrt_h", "nan"),
    ("[dvl]\nnoise_mps = -0.1\n", "dvl.noise_mps", "-0.1"),
    ("[dvl]\nunknown_key = 1\n", "dvl.unknown_key", ""),
    ("[gps]\nrate_hz = 1\n", "gps", ""),
    ("[trajectory]\nduration_s = 0\n", "trajectory.duration_s", "0"),
    ("[trajectory\nname = 'x'\n", "malformed TOML", ""),
    ("[dvl]\nbeams = [1, 7]\n", "dvl.beams", "7"),
    ("[run]\nmethods = ['lc', 'magic']\n", "run.methods", "'magic'"),
])
def test_bad_config_files_give_one_line_and_exit_2(capsys, tmp_path, toml, field, value) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(toml)
    code, out, err = _run(capsys, "run", "--config", str(path))
    assert code == 2
    line = err.strip()
    assert "\n" not in line and field in line and value in line


def test_config_prints_full_defaults_that_read_back(capsys, tmp_path) -> None:
    code, out, _ = _run(capsys, "config")
    assert code == 0
    assert from_dict(tomllib.loads(out)) == Config()
    # partial file: only one key changes
    partial = tmp_path / "p.toml"
    partial.write_text("[dvl]\nnoise_mps = 0.08\n")
    code, out, _ = _run(capsys, "config", "--config", str(partial))
    resolved = from_dict(tomllib.loads(out))
    assert resolved.dvl.noise_mps == 0.08 and resolved.replace("dvl", noise_mps=0.042) == Config()


def test_run_writes_the_json_contract_and_a_summary(capsys, tmp_path) -> None:
    out_json = tmp_path / "out.json"
    code, out, err = _run(capsys, "run", "--trajectory", "figure8", "--method", "ins,lc", "--duration", "20",
                          "--seed", "3", "--aiding", "dvl,depth", "--json", str(out_json))
    assert code == 0, err
    data = json.loads(out_json.read_text())
    assert data["config"]["trajectory"]["name"] == "figure8"
    assert data["config"]["trajectory"]["duration_s"] == 20.0
    assert data["config"]["run"]["seed"] == 3 and data["config"]["run"]["aiding"] == ["dvl", "depth"]
    assert set(data["results"]) == {"ins", "lc"}
    keys = {"t", "vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m"}
    for series in data["results"].values():
        assert set(series) == keys
        assert len({len(v) for v in series.values()}) == 1 and series["t"][-1] == pytest.approx(20.0)
    assert data["results"]["lc"]["vel_err_mps"][-1] < data["results"]["ins"]["vel_err_mps"][-1]
    assert "INS" in out and "LC" in out and "vel final" in out


def test_console_script_entry_point_runs() -> None:
    """The installed module runs as a program (what the ``tauv`` script calls)."""
    proc = subprocess.run([sys.executable, "-m", "app.cli", "run", "--duration", "2", "--ideal", "--method", "ins"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "IDEAL" in proc.stdout
