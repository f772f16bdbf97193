"""The ``tauv`` command line: contract of run/config, and one clear line for every bad input."""

import dataclasses
import json
import os
import resource
import shlex
import subprocess
import sys
import time
import tomllib

import numpy as np
import pytest

from app.cli import build_parser, main, resolve_config
from app.reports.tables import _cell
from tauvcore.config import METHODS, Config, from_dict
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import method_consistency
from tauvcore.sensors.dvl import Outage

SPLIT_AND_NEES_KEYS = ("tilt_err_deg", "heading_err_deg", "tilt_sigma_deg", "heading_sigma_deg", "nees", "nees_pos",
                       "nees_vel", "nees_tilt", "nees_heading", "nees_sensor")
"""Per-epoch series --json carries (attitude apart, NEES per block)."""
ESTIMATE_KEYS = ("est_north_m", "est_east_m", "est_down_m", "est_lat_deg", "est_lon_deg", "est_depth_m",
                 "est_vel_north_mps", "est_vel_east_mps", "est_vel_down_mps", "est_roll_deg", "est_pitch_deg",
                 "est_yaw_deg")
"""The estimate itself."""


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
    (["run", "--imu", "hg9900"], "'hg9900'"),
    (["run", "--truth", "6dof"], "'6dof'"),
    (["run", "--config", "\ud800"], "--config"),          # a lone surrogate: found by tests/fuzz (UnicodeEncodeError)
    (["mc", "--runs", "2", "--out", "\udfff"], "--out"),
    (["mc", "--truth", "", "--runs", "2", "--out", "/tmp/x"], "--truth"),
    (["mc", "--imu", "", "--runs", "2", "--out", "/tmp/x"], "--imu"),
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
    ("[trajectory]\ntruth = 'cfd'\n", "trajectory.truth", "'cfd'"),
    ("[trajectory]\ncurrent_n_mps = [0.0, 0.0, 0.2]\n", "trajectory.current_n_mps", "0.2"),
    ("[trajectory]\ncurrent_n_mps = [0.0, 2.5, 0.0]\n", "trajectory.current_n_mps", "2.5"),
    ("[trajectory]\ncurrent_n_mps = [1.0, 1.2, 0.0]\n", "trajectory.current_n_mps", "crab 50 deg"),
    ("[trajectory]\ncurrent_shear_ne_per_s = [0.5, 0.0]\n", "trajectory.current_shear_ne_per_s[0]", "0.5"),
    ("[trajectory]\ntruth = 'dynamic'\ncurrent_n_mps = [0.0, 9.0, 0.0]\n", "trajectory.current_n_mps[1]", "9.0"),
    ("[dvl]\nwater_track = 'sometimes'\n", "dvl.water_track", "'sometimes'"),
    ("[dvl]\nwater_track = 'always'\nwater_layer_m = 150.0\n", "dvl.water_layer_m 150 m", "dvl.max_altitude_m 100 m"),
    ("[dvl]\nwater_track = 'beyond_range'\nbeyond_range = 'noisy'\n", "dvl.water_track \"beyond_range\"",
     'dvl.beyond_range "lost", got "noisy"'),
    ("[dvl]\nwater_layer_m = 0.1\n", "dvl.water_layer_m", "0.1"),
    ("[dvl]\nwater_track = 'both'\nwater_layer_m = 150.0\n", "dvl.water_layer_m 150 m", "dvl.max_altitude_m 100 m"),
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
    keys = {"t", "vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m",
            *SPLIT_AND_NEES_KEYS, *ESTIMATE_KEYS}
    for series in data["results"].values():
        assert set(series) == keys | {"diverged", "diverged_at_s", "p_floor_count", "nis", "consistency", "counts"}
        assert len({len(series[k]) for k in keys}) == 1 and series["t"][-1] == pytest.approx(20.0)
        assert series["diverged"] is False and series["diverged_at_s"] is None and series["p_floor_count"] >= 0
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


def _tables(out: str) -> tuple[dict[str, str], dict[str, str]]:
    """The rows of the errors table and of the consistency table, by method name (the updates per
    source between them)."""
    title, errors, counts, consistency = out.strip("\n").split("\n\n")
    assert title.startswith("trajectory ") and counts.startswith("Updates per source")
    assert consistency.startswith("Consistency")
    return ({line.split()[0]: line for line in errors.splitlines()[2:]},
            {line.split()[0]: line for line in consistency.splitlines()[3:]})


def test_run_all_methods_with_two_beams_lists_every_method(capsys) -> None:
    code, out, err = _run(capsys, "run", "--method", "all", "--beams", "1,2", "--duration", "10")
    assert code == 0, err
    errors, consistency = _tables(out)
    assert list(errors) == list(consistency) == [m.upper() for m in METHODS]


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
    (["serve", "--workers", "0"], "--workers"),
    (["serve", "--workers", "two"], "'two'"),
    (["serve", "--workers", "1000"], "1000"),
])
def test_serve_rejects_bad_addresses(capsys, argv, text) -> None:
    code, out, err = _run(capsys, *argv)
    assert code == 2 and text in err and len(err.strip().splitlines()) == 1


def test_serve_refuses_a_bad_run_budget_before_it_starts(capsys, monkeypatch) -> None:
    monkeypatch.setenv("TAUV_RUN_BUDGET_MB", "lots")
    code, out, err = _run(capsys, "serve", "--port", "1")
    assert code == 2 and "TAUV_RUN_BUDGET_MB" in err and "'lots'" in err and len(err.strip().splitlines()) == 1


def test_serve_refuses_a_busy_port_instead_of_moving(capsys) -> None:
    """viser would quietly take the next port; the user must hear that theirs is taken."""
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        code, out, err = _run(capsys, "serve", "--port", str(port))
    assert code == 2 and str(port) in err and "in use" in err


# --- hostile input: one clear line and exit status 2, never a traceback. --------------------------------

def _one_line_error(code: int, err: str, *needles: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def _cli(*argv: str, timeout: float = 60.0, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "app.cli", *argv], capture_output=True, text=True,
                          timeout=timeout, **kwargs)


def test_config_that_is_not_utf8_is_refused(capsys, tmp_path) -> None:
    path = tmp_path / "b.toml"
    path.write_bytes(b"\xff")
    _one_line_error(*_run(capsys, "run", "--config", str(path))[::2], "b.toml", "UTF-8", "0xff")


def test_deeply_nested_config_is_refused(capsys, tmp_path) -> None:
    path = tmp_path / "deep.toml"
    path.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    _one_line_error(*_run(capsys, "run", "--config", str(path))[::2], "deep.toml", "nested too deeply")


def test_config_symlink_loop_too_long_name_and_not_a_directory_are_refused(capsys, tmp_path) -> None:
    loop = tmp_path / "loop.toml"
    loop.symlink_to(loop)
    _one_line_error(*_run(capsys, "run", "--config", str(loop))[::2], "loop.toml", "symbolic links")
    long_name = str(tmp_path / ("x" * 300))
    line = _one_line_error(*_run(capsys, "run", "--config", long_name)[::2], "too long", "characters)")
    assert long_name not in line                      # the name is shortened, not echoed whole
    plain = tmp_path / "plain.toml"
    plain.write_text("")
    _one_line_error(*_run(capsys, "run", "--config", str(plain / "x.toml"))[::2], "x.toml", "Not a directory")


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads a file whatever its mode")
def test_unreadable_config_is_refused(capsys, tmp_path) -> None:
    path = tmp_path / "secret.toml"
    path.write_text("")
    path.chmod(0)
    _one_line_error(*_run(capsys, "run", "--config", str(path))[::2], "secret.toml", "ermission")


def test_config_that_is_a_device_or_too_large_is_refused_without_reading(capsys, tmp_path) -> None:
    # in a process with 1 GB of address space: the old code read /dev/zero until MemoryError
    hard = resource.getrlimit(resource.RLIMIT_AS)[1]
    proc = _cli("run", "--config", "/dev/zero", preexec_fn=lambda: resource.setrlimit(
        resource.RLIMIT_AS, (1 << 30, hard)))
    _one_line_error(proc.returncode, proc.stderr, "/dev/zero", "not a regular file")
    big = tmp_path / "big.toml"
    big.write_bytes(b"#" * (2 << 20))
    _one_line_error(*_run(capsys, "run", "--config", str(big))[::2], "big.toml", "larger than 1048576 bytes")


def test_fifo_as_config_is_refused_at_once(tmp_path) -> None:
    """Opening a FIFO for reading blocks until a writer comes: the old code hung for ever."""
    fifo = tmp_path / "f.toml"
    os.mkfifo(fifo)
    started = time.monotonic()
    proc = _cli("run", "--config", str(fifo), timeout=60.0)
    _one_line_error(proc.returncode, proc.stderr, "f.toml", "not a regular file")
    assert time.monotonic() - started < 30.0        # an interpreter start, not a hang (measured ~1 s)


def test_closed_stdout_ends_quietly() -> None:
    """``tauv config | head -1``: the reader goes away; no BrokenPipeError traceback, exit 0."""
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "config"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()                              # the reader is gone before the first write
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 0, err
    assert err == ""


def test_closed_stdout_after_a_run_ends_quietly(tmp_path) -> None:
    proc = subprocess.run(f"{shlex.quote(sys.executable)} -m app.cli run --duration 2 --method ins | head -c 1; "
                          "exit ${PIPESTATUS[0]}", shell=True, executable="/bin/bash", capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and "Traceback" not in proc.stderr and "Error" not in proc.stderr, proc.stderr


@pytest.mark.parametrize("flag", ["--config", "--json"])
def test_empty_file_names_are_refused(capsys, flag) -> None:
    _one_line_error(*_run(capsys, "run", "--duration", "2", "--method", "ins", flag, "")[::2], flag, "''")


@pytest.mark.parametrize("toml, field", [
    ('[run]\nmethods = ["lc", "lc"]\n', "run.methods"),
    ('[run]\naiding = ["dvl", "dvl"]\n', "run.aiding"),
    ("[dvl]\nbeams = [1, 1]\n", "dvl.beams"),
])
def test_duplicate_list_entries_in_a_file_are_refused(capsys, tmp_path, toml, field) -> None:
    path = tmp_path / "dup.toml"
    path.write_text(toml)
    _one_line_error(*_run(capsys, "run", "--config", str(path))[::2], field)


def test_a_section_that_is_not_a_table_is_not_hidden_by_duration(capsys, tmp_path) -> None:
    path = tmp_path / "t.toml"
    path.write_text("trajectory = true\n")
    _one_line_error(*_run(capsys, "run", "--config", str(path), "--duration", "3")[::2], "[trajectory]", "True")


@pytest.mark.parametrize("argv", [["--dur", "3"], ["--meth", "lc"], ["--ide"]])
def test_abbreviated_flags_are_refused(capsys, argv) -> None:
    _one_line_error(*_run(capsys, "run", *argv)[::2], argv[0])


@pytest.mark.parametrize("link", ["same", "symlink", "hardlink", "relative"])
def test_json_naming_the_config_file_is_refused_before_running(capsys, tmp_path, monkeypatch, link) -> None:
    config = tmp_path / "c.toml"
    text = "[trajectory]\nduration_s = 2.0\n[run]\nmethods = [\"ins\"]\n"
    config.write_text(text)
    target = {"same": config, "symlink": tmp_path / "s.json", "hardlink": tmp_path / "h.json",
              "relative": "./c.toml"}[link]
    if link == "symlink":
        target.symlink_to(config)
    elif link == "hardlink":
        os.link(config, target)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", lambda *a, **k: pytest.fail("ran before refusing --json"))
    _one_line_error(*_run(capsys, "run", "--config", str(config), "--json", str(target))[::2], "--json",
                    "--config file")
    assert config.read_text() == text


@pytest.mark.parametrize("target, reason", [(".", "is a directory"), ("/dev/null", "not a regular file")])
def test_json_to_a_directory_or_device_is_refused(capsys, tmp_path, monkeypatch, target, reason) -> None:
    monkeypatch.chdir(tmp_path)
    _one_line_error(*_run(capsys, "run", "--duration", "2", "--method", "ins", "--json", target)[::2], reason)


def test_default_methods_are_ins_and_lc_as_the_help_says(capsys) -> None:
    assert Config().run.methods == ("ins", "lc")
    help_text = " ".join(build_parser()._subparsers._group_actions[0].choices["run"].format_help().split())
    assert "(default: ins,lc)" in help_text
    code, out, err = _run(capsys, "run", "--duration", "2")
    assert code == 0, err
    assert [list(table) for table in _tables(out)] == [["INS", "LC"], ["INS", "LC"]]


@pytest.mark.parametrize("flag, value, shown", [
    ("--dropout", "-inf", "'-inf'"), ("--duration", "-1e5", "-100000"), ("--duration", "-inf", "'-inf'"),
    ("--seed", "-x", "'-x'"), ("--trajectory", "-straight", "'-straight'"), ("--method", "-lc", "'-lc'"),
    ("--beams", "-1", "'-1'"), ("--outage", "-3@1:2", "'-3'"), ("--dropout", "-nan", "'-nan'"),
])
def test_values_beginning_with_a_dash_reach_their_flag(capsys, flag, value, shown) -> None:
    """argparse used to answer "expected one argument" without naming the value."""
    _one_line_error(*_run(capsys, "run", "--method", "ins", flag, value)[::2], flag, shown)


@pytest.mark.parametrize("argv", [
    ["run", "--dropout", "x" * 500_000],
    ["run", "--trajectory", "y" * 500_000],
    ["run", "--method", "z" * 500_000],
    ["run", "--duration", "9" * 500_000],
    ["run", "w" * 500_000],
])
def test_long_values_are_shortened_in_messages(capsys, argv) -> None:
    line = _one_line_error(*_run(capsys, *argv)[::2], "(500000 characters)")
    assert len(line) < 300, len(line)


@pytest.mark.parametrize("argv", [["--method=--"], ["--outage=--"], ["--json=--"], ["--config=--"]])
def test_a_value_of_two_dashes_is_refused(capsys, argv) -> None:
    """Found by the fuzzer: argparse turned ``--method=--`` into [] and the run crashed."""
    _one_line_error(*_run(capsys, "run", "--duration", "2", *argv)[::2], argv[0].split("=")[0], "'--'")


@pytest.mark.parametrize("flag", ["--config", "--json"])
def test_a_nul_in_a_file_name_is_refused(capsys, flag) -> None:
    """Found by the fuzzer (main(argv) in-process): os.stat raised ValueError."""
    _one_line_error(*_run(capsys, "run", "--duration", "2", flag, "a\x00b")[::2], flag, "NUL", "'a\\x00b'")


def test_a_newline_in_a_value_stays_on_one_line(capsys) -> None:
    _one_line_error(*_run(capsys, "run", "--trajectory", "a\nb")[::2], "--trajectory", "'a\\nb'")
    _one_line_error(*_run(capsys, "run", "a\nb")[::2], "a\\nb")


def _fake_results(diverged: bool, poison: bool):
    """A short real run, then (optionally) a NaN and an infinity in the series and a diverged flag."""
    config = Config().replace("trajectory", duration_s=2.0).replace("run", methods=("ins", "lc"))
    rng = np.random.default_rng(0)
    real = run_streaming(config, rng)

    def fake(*args, **kwargs):
        out = {}
        for name, r in real.items():
            vel = r.vel_err_mps.copy()
            if poison:
                vel[1, 0], vel[2, 0] = np.nan, np.inf
            out[name] = dataclasses.replace(
                r, vel_err_mps=vel, diverged=np.array([diverged and name == "lc"]),
                diverged_at_s=np.array([1.5 if diverged and name == "lc" else np.nan]),
                p_floor_count=np.array([3 if name == "lc" else 0]))
        sinks = kwargs.get("sinks")
        if sinks is not None and sinks.on_chunk is not None:  # the streaming contract: the results handed out
            sinks.on_chunk(out)
        return out
    return fake


def _strict_json(text: str):
    def refuse(name: str):
        raise AssertionError(f"not JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def test_json_is_strict_and_carries_the_divergence_verdict(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", _fake_results(diverged=True, poison=True))
    out_json = tmp_path / "out.json"
    code, out, err = _run(capsys, "run", "--duration", "2", "--json", str(out_json))
    assert code == 0, err
    data = _strict_json(out_json.read_text())
    lc, ins = data["results"]["lc"], data["results"]["ins"]
    assert lc["vel_err_mps"][1] is None and lc["vel_err_mps"][2] is None and lc["vel_err_mps"][3] is not None
    assert lc["diverged"] is True and lc["diverged_at_s"] == 1.5 and lc["p_floor_count"] == 3
    assert ins["diverged"] is False and ins["diverged_at_s"] is None and ins["p_floor_count"] == 0
    rows = _tables(out)[0]
    assert "diverged at 1.5 s" in rows["LC"] and "diverged" not in rows["INS"]


@pytest.mark.parametrize("failure", [OSError(28, "No space left on device"), KeyboardInterrupt()])
def test_a_failed_or_interrupted_write_leaves_no_file(capsys, tmp_path, monkeypatch, failure) -> None:
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", _fake_results(diverged=False, poison=False))
    real_dump = json.dump

    def dump_half_then_fail(obj, fh, **kwargs):
        fh.write(json.dumps(obj, **kwargs)[:100])        # a partial file exists at this point
        raise failure
    monkeypatch.setattr("app.commands.outputs.json.dump", dump_half_then_fail)
    fresh = tmp_path / "fresh.json"
    code, out, err = _run(capsys, "run", "--duration", "2", "--json", str(fresh))
    assert code == (130 if isinstance(failure, KeyboardInterrupt) else 2), err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not fresh.exists() and list(tmp_path.iterdir()) == []       # no temporary file either
    # an existing file is left exactly as it was
    old = tmp_path / "old.json"
    old.write_text('{"previous": true}')
    _run(capsys, "run", "--duration", "2", "--json", str(old))
    assert old.read_text() == '{"previous": true}' and sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]
    monkeypatch.setattr("app.commands.outputs.json.dump", real_dump)
    assert _run(capsys, "run", "--duration", "2", "--json", str(old))[0] == 0
    assert "previous" not in _strict_json(old.read_text())


# --- the partial methods' assumptions as flags; tilt and heading apart; consistency ---------

@pytest.mark.parametrize("flag, value, shown", [
    ("--vb-nf", "0", "0"), ("--vb-nf", "-3", "-3"), ("--vb-nf", "nan", "'nan'"), ("--vb-nf", "101", "101"),
    ("--vb-nf", "-inf", "'-inf'"), ("--vb-nf", "many", "'many'"),
    ("--nsv-epsilon", "-1", "-1"), ("--nsv-epsilon", "nan", "'nan'"), ("--nsv-epsilon", "inf", "'inf'"),
    ("--nsv-epsilon", "bogus", "'bogus'"), ("--nsv-epsilon", "0", "0"), ("--nsv-epsilon", "AUTO", "'AUTO'"),
    ("--nsv-epsilon", "-inf", "'-inf'"),
])
def test_bad_partial_method_flags_give_one_line_and_exit_2(capsys, flag, value, shown) -> None:
    for argv in ([flag, value], [f"{flag}={value}"]):
        line = _one_line_error(*_run(capsys, "run", "--method", "vb,nsv", "--beams", "1,2", *argv)[::2], shown)
        assert line.startswith(f"tauv: error: {flag}: "), line     # the old code: "unrecognized arguments"


@pytest.mark.parametrize("argv", [["run", "--vb-nf=--"], ["run", "--nsv-epsilon=--"], ["serve", "--workers=--"]])
def test_a_value_of_two_dashes_is_refused_for_dashed_flags(capsys, argv) -> None:
    """The dest of ``--vb-nf`` is ``vb_nf``; ``--workers`` was missing from VALUE_FLAGS: both crashed
    with a TypeError traceback on ``=--``."""
    _one_line_error(*_run(capsys, *argv)[::2], argv[1].split("=")[0], "'--'")


def test_serve_workers_beginning_with_a_dash_reaches_its_flag(capsys) -> None:
    _one_line_error(*_run(capsys, "serve", "--workers", "-inf")[::2], "--workers", "'-inf'")


def test_vb_nf_and_nsv_epsilon_reach_the_configuration_over_the_file(tmp_path) -> None:
    path = tmp_path / "p.toml"
    path.write_text("[partial]\nvb_nf = 7.0\nnsv_epsilon_m2_per_s2 = 0.5\n")
    parse = build_parser().parse_args
    assert resolve_config(parse(["run", "--config", str(path)])).partial == dataclasses.replace(
        Config().partial, vb_nf=7.0, nsv_epsilon_m2_per_s2=0.5)
    config = resolve_config(parse(["run", "--config", str(path), "--vb-nf", "5", "--nsv-epsilon", "auto"]))
    assert config.partial.vb_nf == 5.0 and config.partial.nsv_epsilon_m2_per_s2 == "auto"
    assert resolve_config(parse(["run", "--nsv-epsilon", "0.05"])).nsv_epsilon_value_m2_per_s2() == 0.05
    assert "--vb-nf N" in parse.__self__._subparsers._group_actions[0].choices["run"].format_help()
    assert "--nsv-epsilon E" in parse.__self__._subparsers._group_actions[0].choices["run"].format_help()


def _json_run(capsys, path, *argv: str) -> dict:
    code, _, err = _run(capsys, "run", "--trajectory", "figure8", "--beams", "1,2", "--duration", "12",
                        "--seed", "4", *argv, "--json", str(path))
    assert code == 0, err
    return _strict_json(path.read_text())


def test_vb_nf_and_nsv_epsilon_change_the_results(capsys, tmp_path) -> None:
    out = tmp_path / "o.json"
    default = _json_run(capsys, out, "--method", "vb,nsv")
    assert _json_run(capsys, out, "--method", "vb,nsv", "--nsv-epsilon", "auto") == default
    vb5 = _json_run(capsys, out, "--method", "vb,nsv", "--vb-nf", "5")
    assert vb5["config"]["partial"]["vb_nf"] == 5.0 and default["config"]["partial"]["vb_nf"] == 20.0
    assert vb5["results"]["vb"]["vel_err_mps"] != default["results"]["vb"]["vel_err_mps"]
    assert vb5["results"]["nsv"] == default["results"]["nsv"]              # n_f is VB's (and VHV's) alone
    eps = _json_run(capsys, out, "--method", "vb,nsv", "--nsv-epsilon", "0.01")
    assert eps["config"]["partial"]["nsv_epsilon_m2_per_s2"] == 0.01
    assert eps["config"]["partial"]["nsv_epsilon_value_m2_per_s2"] == 0.01
    assert default["config"]["partial"]["nsv_epsilon_value_m2_per_s2"] == pytest.approx(
        Config().nsv_epsilon_value_m2_per_s2())
    assert eps["results"]["nsv"]["vel_err_mps"] != default["results"]["nsv"]["vel_err_mps"]
    assert eps["results"]["vb"] == default["results"]["vb"]


def _same(json_value, number: float) -> bool:
    return json_value is None if not np.isfinite(number) else json_value == pytest.approx(number, rel=1e-12)


def test_json_carries_tilt_heading_nees_nis_and_the_consistency_of_the_run(capsys, tmp_path) -> None:
    argv = ("--method", "ins,lc,tc,vb,nsv", "--aiding", "dvl,depth,mag")
    data = _json_run(capsys, tmp_path / "o.json", *argv)
    config = resolve_config(build_parser().parse_args(
        ["run", "--trajectory", "figure8", "--beams", "1,2", "--duration", "12", "--seed", "4", *argv]))
    rng = np.random.default_rng(config.run.seed)
    results = run_streaming(config, rng)
    for name, r in results.items():
        series = data["results"][name]
        n = len(series["t"])
        for key in SPLIT_AND_NEES_KEYS:
            assert len(series[key]) == n, key
        assert series["tilt_err_deg"] == pytest.approx(r.tilt_err_deg[:, 0].tolist())
        assert series["nees_heading"] == pytest.approx(r.nees_block[:, 0, 3].tolist())
        assert set(series["nis"]) == set(r.updates) == ({"dvl", "depth", "mag"} if name != "ins" else set())
        c = method_consistency(r)
        consistency = series["consistency"]
        assert set(consistency["nees"]) == set(BLOCK_DIMS) and set(consistency["nis"]) == set(r.updates)
        for block, s in c.nees.items():
            got = consistency["nees"][block]
            assert got["dim"] == s.dim == BLOCK_DIMS[block]
            assert _same(got["per_dim"], s.per_dim) and _same(got["in_band"], s.in_band)
        for source, s in c.nis.items():
            got = consistency["nis"][source]
            assert _same(got["per_dof"], s.per_dof) and _same(got["in_band"], s.in_band)
            assert got["count"] == s.count
            nis = series["nis"][source]
            assert len(nis["t"]) == len(nis["nis"]) == len(nis["dof"]) == len(r.updates[source].t_s)
            assert sum(v is not None for v in nis["nis"]) == s.count       # null where nothing was measured
            assert all(d == 0 for v, d in zip(nis["nis"], nis["dof"]) if v is None)
    # two beams: LC has no DVL measurement at all, so its DVL NIS is null, not NaN
    assert data["results"]["lc"]["consistency"]["nis"]["dvl"] == {"per_dof": None, "in_band": None, "count": 0}
    assert data["results"]["tc"]["consistency"]["nis"]["dvl"]["count"] > 0


def test_summary_splits_attitude_and_prints_the_consistency_table(capsys) -> None:
    argv = ["--trajectory", "figure8", "--method", "ins,lc,vb", "--beams", "1,2", "--duration", "12", "--seed", "4",
            "--aiding", "dvl,depth,mag"]
    code, out, err = _run(capsys, "run", *argv)
    assert code == 0, err
    assert max(len(line) for line in out.splitlines()) <= 130
    assert "tilt RMS" in out and "head RMS" in out and "att RMS" in out
    assert "1 = consistent" in out and "over-confident" in out and "99 % band" in out
    consistency = _tables(out)[1]
    config = resolve_config(build_parser().parse_args(["run", *argv]))
    rng = np.random.default_rng(config.run.seed)
    results = run_streaming(config, rng)
    for name, r in results.items():
        c = method_consistency(r)
        cells = [_cell(c.nees[b].per_dim, c.nees[b].in_band) for b in BLOCK_DIMS]
        cells += [_cell(c.nis[s].per_dof, c.nis[s].in_band) if s in c.nis else "-" for s in ("dvl", "depth", "mag")]
        assert consistency[name.upper()].split(None, 1)[1].split() == " ".join(cells).split()
    assert consistency["LC"].split()[1 + 2 * len(BLOCK_DIMS)] == "-"   # no DVL measurement with two beams
    assert "nan" not in out.lower()
    assert consistency["INS"].split()[-3:] == ["-", "-", "-"]


def test_imu_profile_flag_sets_the_whole_imu_section(capsys, tmp_path) -> None:
    """``--imu yoo-table1`` replaces the file's [imu] section with the profile; what
    ``tauv config`` prints with it reads back as the same configuration."""
    from tauvcore.config import from_dict, read_toml
    from tauvcore.sensors.imu import imu_profile
    cfg = tmp_path / "c.toml"
    cfg.write_text("[imu]\ngyro_bias_deg_per_h = 7.0\n")
    code, out, _ = _run(capsys, "config", "--config", str(cfg), "--imu", "yoo-table1")
    assert code == 0
    printed = tmp_path / "printed.toml"
    printed.write_text(out)
    assert from_dict(read_toml(str(printed))).imu == imu_profile("yoo-table1")


def test_json_carries_the_estimate_in_ned_geodetic_velocity_and_attitude() -> None:
    """Issue 10: the results carry the estimated trajectory, not only error norms. With ideal
    sensors the estimate is the truth: NED from the surface point, latitude, longitude and depth,
    NED velocity, roll, pitch, yaw."""
    from app.reports.payload import result_to_json
    from tauvcore.config import Config
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate
    config = (Config().replace("trajectory", name="figure8", duration_s=30.0).replace("run", ideal=True, methods=("lc",))
              .replace("earth", latitude_deg=-41.3, longitude_deg=174.8))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng)
    result = run(config, sim, rng)["lc"]
    out = result_to_json(result, origin_rad=(config.earth.latitude_rad, config.earth.longitude_rad))
    rows = np.arange(0, sim.truth.num_samples, 15)
    truth = sim.truth
    np.testing.assert_allclose(out["est_north_m"], truth.pos_n[rows, 0], atol=1e-3)
    np.testing.assert_allclose(out["est_down_m"], truth.pos_n[rows, 2], atol=1e-3)
    np.testing.assert_allclose(out["est_lat_deg"], np.degrees(truth.pos_nav[rows, 0]), atol=1e-8)
    np.testing.assert_allclose(out["est_lon_deg"], np.degrees(truth.pos_nav[rows, 1]), atol=1e-8)
    np.testing.assert_allclose(out["est_depth_m"], truth.depth_m[rows], atol=1e-3)
    np.testing.assert_allclose(out["est_vel_east_mps"], truth.vel_n[rows, 1], atol=1e-4)
    yaw_diff = np.angle(np.exp(1j * np.radians(np.array(out["est_yaw_deg"]) - np.degrees(truth.euler[rows, 2]))))
    assert np.abs(yaw_diff).max() < 1e-5
    np.testing.assert_allclose(out["est_pitch_deg"], np.degrees(truth.euler[rows, 1]), atol=1e-5)


def test_truth_flag_flies_the_vehicle_and_reaches_the_json(capsys, tmp_path) -> None:
    """``--truth dynamic``: the summary names the truth, the JSON's configuration
    carries it, and a file's current reads back."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[trajectory]\ncurrent_n_mps = [0.1, -0.2, 0.05]\ntruth = 'dynamic'\n")
    out_json = tmp_path / "r.json"
    code, out, _ = _run(capsys, "run", "--config", str(cfg), "--truth", "dynamic", "--duration", "10",
                        "--json", str(out_json))
    assert code == 0 and "(dynamic truth)" in out
    data = json.loads(out_json.read_text())
    assert data["config"]["trajectory"]["truth"] == "dynamic"
    assert data["config"]["trajectory"]["current_n_mps"] == [0.1, -0.2, 0.05]
    code, _, err = _run(capsys, "run", "--config", str(cfg), "--truth", "kinematic")
    assert code == 2 and "--truth" in err and "current_n_mps" in err
