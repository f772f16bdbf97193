"""The ``tauv`` command line: contract of run/config, and one clear line for every bad input."""

import json
import subprocess
import sys
import tomllib

import pytest

from app.cli import build_parser, main, resolve_config
from tauvcore.config import METHODS, Config, from_dict
from tauvcore.sensors.dvl import Outage


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


@pytest.mark.parametrize("argv, flag, value", [
    (["--beams", "1,5"], "--beams", "5"),
    (["--beams", "0"], "--beams", "0"),
    (["--beams", "1,1"], "--beams", "1,1"),
    (["--outage", "3,4@200:50"], "--outage", "200:50"),
    (["--outage", "3,4@50:300"], "--outage", "50:300"),           # past the default 250 s run
    (["--duration", "100", "--outage", "3,4@50:200"], "--outage", "50:200"),   # past the shortened run
    (["--outage", "3@x:1"], "--outage", "x:1"),
    (["--outage", "3,4"], "--outage", "3,4"),
    (["--outage", "7@1:2"], "--outage", "7"),
    (["--dropout", "1.5"], "--dropout", "1.5"),
    (["--dropout", "-0.1"], "--dropout", "-0.1"),
    (["--dropout", "abc"], "--dropout", "abc"),
    (["--dropout", "nan"], "--dropout", "nan"),
])
def test_bad_partial_dvl_flags_give_one_line_and_exit_2(capsys, argv, flag, value) -> None:
    code, out, err = _run(capsys, "run", "--method", "ins", *argv)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert flag in lines[0] and value in lines[0] and "Traceback" not in err, lines[0]


def test_run_all_methods_with_two_beams_lists_every_method(capsys) -> None:
    code, out, err = _run(capsys, "run", "--method", "all", "--beams", "1,2", "--duration", "10")
    assert code == 0, err
    rows = [line.split()[0] for line in out.splitlines() if line.split()]
    assert [r for r in rows if r.lower() in METHODS] == [m.upper() for m in METHODS]


def test_beams_outage_and_dropout_reach_the_configuration() -> None:
    args = build_parser().parse_args(["run", "--beams", "1,2,3", "--outage", "3,4@50:200", "--outage", "1@10:20",
                                      "--dropout", "0.05"])
    config = resolve_config(args)
    assert config.dvl.beams == (1, 2, 3)
    assert config.dvl.outages == (Outage((3, 4), 50.0, 200.0), Outage((1,), 10.0, 20.0))
    assert config.dvl.dropout_probability == 0.05


@pytest.mark.parametrize("argv, text", [
    (["serve", "--port", "70000"], "70000"),
    (["serve", "--port", "http"], "'http'"),
    (["serve", "--host", " "], "--host"),
])
def test_serve_rejects_bad_addresses(capsys, argv, text) -> None:
    code, out, err = _run(capsys, *argv)
    assert code == 2 and text in err and len(err.strip().splitlines()) == 1


def test_serve_refuses_a_busy_port_instead_of_moving(capsys) -> None:
    """viser would quietly take the next port; the user must hear that theirs is taken."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        code, out, err = _run(capsys, "serve", "--port", str(port))
    assert code == 2 and str(port) in err and "in use" in err
