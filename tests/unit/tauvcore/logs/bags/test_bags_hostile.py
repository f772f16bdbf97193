"""Hostile bags and mappings: special files refused before they are opened (a FIFO never blocks,
a device is never read), corrupt MCAP and ROS 1 files one line naming the file and the byte,
mappings checked against the bag (a topic used twice, a form that does not fit its type, an empty
topic), ``msg_paths`` errors naming the mapping, non-finite DVL velocities refused with no numpy
warning; each through the CLI, exit 2 and one line."""

from __future__ import annotations

import os
import resource
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import app
from app.cli import main
from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

ROOT = Path(app.__file__).resolve().parents[1]
"""The tree whose code the CLI subprocesses run (the one imported here)."""
FRD_FLAT = 'frame = "frd_ned"\n\n[config.earth]\nmodel = "flat"\n'
"""A mapping's lines for write_bag's FRD/NED bags of a flat-earth mission."""


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Small valid bags (3 s): ROS 1 and MCAP with per-beam DVL messages, MCAP with a twist DVL,
    and the tables they were written from."""
    config = mission_config(duration_s=3.0)
    beams, body = mission_tables(config)
    root = tmp_path_factory.mktemp("hostile-bags")
    out = {"root": root, "config": config, "beams": beams, "body": body}
    out["ros1"] = write_bag(root / "m.bag", "ros1", beams, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b)
    out["mcap"] = write_bag(root / "m.mcap", "mcap", beams, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b)
    out["twist"] = write_bag(root / "t.mcap", "mcap", body, "geometry_msgs/msg/TwistWithCovarianceStamped",
                             config.dvl.A_b)
    return out


def _cli(argv: list[str], capsys: pytest.CaptureFixture) -> tuple[int, str]:
    code = main(argv)
    err = capsys.readouterr().err
    return code, err


def _one_line(code: int, err: str, *parts: str) -> str:
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("tauv: error: "), err
    for part in parts:
        assert part in lines[0], (part, lines[0])
    assert "Traceback" not in err
    return lines[0]


ADDRESS_SPACE_BYTES = 6 << 30
"""The address space a CLI subprocess may take: a runaway read (of /dev/zero) ends there."""


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_BYTES, resource.getrlimit(resource.RLIMIT_AS)[1]))


def _run_subprocess(argv: list[str], cwd: Path, timeout: float = 60.0) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "app.cli", *argv], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout, preexec_fn=_limit_memory, check=False)


# ------------------------------------------------------------------------- 1, 2: special files
@pytest.mark.parametrize("command", ["info", "replay", "convert"])
def test_a_fifo_named_as_a_bag_is_refused_without_blocking(tmp_path: Path, command: str) -> None:
    for name in ("f.bag", "f.mcap"):
        fifo = tmp_path / name
        os.mkfifo(fifo)
        argv = {"info": ["log", "info", name], "replay": ["replay", name, "--method", "ins"],
                "convert": ["log", "convert", name, "out"]}[command]
        done = _run_subprocess(argv, tmp_path, timeout=20.0)  # the old code blocks here for ever
        assert done.returncode == 2, done.stderr
        assert done.stderr.strip() == f"tauv: error: '{name}': is a FIFO (a named pipe), not a bag file"
        assert not (tmp_path / "out").exists()
        fifo.unlink()


def test_a_link_to_dev_zero_is_refused_before_it_is_read(tmp_path: Path) -> None:
    (tmp_path / "z.bag").symlink_to("/dev/zero")
    for argv in (["log", "info", "z.bag"], ["replay", "z.bag"]):  # the old code: 18.8 GB, or a MemoryError
        done = _run_subprocess(argv, tmp_path)
        _one_line(done.returncode, done.stderr, "z.bag", "is a character device", "/dev/zero", "not a bag file")


def test_a_symlink_loop_and_a_dangling_link_say_what_they_are(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "loop.bag").symlink_to("loop.bag")
    (tmp_path / "gone.mcap").symlink_to("nowhere.mcap")
    _one_line(*_cli(["log", "info", str(tmp_path / "loop.bag")], capsys), "loop.bag", "is a symbolic link loop")
    _one_line(*_cli(["replay", str(tmp_path / "gone.mcap")], capsys), "gone.mcap", "dangling symbolic link",
              "nowhere.mcap")


def test_a_directory_named_as_a_bag_is_neither_a_log_nor_a_ros2_bag(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "d.bag").mkdir()
    for argv in (["replay", str(tmp_path / "d.bag")], ["log", "info", str(tmp_path / "d.bag")]):
        line = _one_line(*_cli(argv, capsys), "d.bag", "is a directory", "neither a log", "nor a ROS 2 bag",
                         "metadata.yaml")
        assert "no imu.csv or imu.parquet" in line


# ----------------------------------------------------------------- 3, 6: corrupt files, named
def test_the_mcap_magic_alone_is_truncated_not_a_traceback(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "m.mcap").write_bytes(b"\x89MCAP0\r\n")
    _one_line(*_cli(["log", "info", str(tmp_path / "m.mcap")], capsys), "m.mcap", "truncated", "byte 8")
    _one_line(*_cli(["replay", str(tmp_path / "m.mcap")], capsys), "m.mcap", "truncated")


@pytest.mark.parametrize("length", [0xFFFF_FFFF_FFFF_FFFF, 1 << 40])
def test_an_mcap_summary_record_claiming_more_than_the_file_is_named_at_its_byte(
    bags: dict, tmp_path: Path, capsys: pytest.CaptureFixture, length: int
) -> None:
    data = bytearray(bags["mcap"].read_bytes())
    summary = struct.unpack_from("<Q", data, len(data) - 37 + 9)[0]
    data[summary + 1 : summary + 9] = struct.pack("<Q", length)
    bad = tmp_path / "s.mcap"
    bad.write_bytes(bytes(data))
    line = _one_line(*_cli(["log", "info", str(bad)], capsys), "s.mcap", "truncated or corrupt at byte",
                     str(length))
    assert f"byte {summary + 9}" in line


def test_a_ros1_record_length_beyond_the_file_is_named_at_its_byte(bags: dict, tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture) -> None:
    data = bytearray(bags["ros1"].read_bytes())
    at = len(b"#ROSBAG V2.0\n")
    data[at : at + 4] = struct.pack("<I", 0xFFFF_FFF0)  # the bag header record's header length
    bad = tmp_path / "r.bag"
    bad.write_bytes(bytes(data))
    _one_line(*_cli(["log", "info", str(bad)], capsys), "r.bag", f"truncated or corrupt at byte {at + 4}",
              str(0xFFFF_FFF0))


def test_a_file_of_another_format_says_which(bags: dict, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "x.bag").write_bytes(bags["mcap"].read_bytes())
    _one_line(*_cli(["log", "info", str(tmp_path / "x.bag")], capsys), "x.bag", "an MCAP file named .bag",
              "rename it .mcap")
    (tmp_path / "y.bag").write_bytes(b"PK\x03\x04 not a bag at all")
    _one_line(*_cli(["replay", str(tmp_path / "y.bag")], capsys), "y.bag", "not a ROS 1 bag", "it starts with")
    (tmp_path / "e.mcap").write_bytes(b"")
    _one_line(*_cli(["replay", str(tmp_path / "e.mcap")], capsys), "e.mcap", "is empty")


def test_a_malformed_metadata_yaml_is_named_and_said_malformed(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    bag = tmp_path / "run"
    bag.mkdir()
    for text, what in (("rosbag2_bagfile_information: abc\n", "rosbag2_bagfile_information"),
                       ("rosbag2_bagfile_information: {version: x}\n", "version"),
                       ("a: [b\n", "not YAML")):
        (bag / "metadata.yaml").write_text(text)
        _one_line(*_cli(["log", "info", str(bag)], capsys), "metadata.yaml", "malformed", what)
    (bag / "metadata.yaml").unlink()
    os.mkfifo(bag / "metadata.yaml")
    _one_line(*_cli(["log", "info", str(bag)], capsys), "metadata.yaml", "FIFO")


# ------------------------------------------------------------------------- 4: mapping checks
def _mapping(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "m.toml"
    path.write_text(FRD_FLAT + text)
    return path


def test_a_water_track_topic_naming_the_dvl_s_own_topic_is_refused(bags: dict, tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture) -> None:
    mapping = _mapping(tmp_path, '[dvl]\nwater_track_topic = "/dvl"\n')
    for argv in (["replay", str(bags["mcap"]), "--method", "ins,lc", "--bag-mapping", str(mapping)],
                 ["log", "convert", str(bags["ros1"]), str(tmp_path / "out"), "--bag-mapping", str(mapping)]):
        _one_line(*_cli(argv, capsys), "m.toml", "dvl.water_track_topic", "'/dvl'", "the DVL's own topic")
    assert not (tmp_path / "out").exists()
    named = _mapping(tmp_path, '[dvl]\ntopic = "/dvl"\nwater_track_topic = "/dvl"\n')
    _one_line(*_cli(["replay", str(bags["mcap"]), "--bag-mapping", str(named)], capsys), "m.toml",
              "dvl.water_track_topic", "'/dvl'")


def test_form_beams_on_a_twist_topic_is_refused(bags: dict, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    mapping = _mapping(tmp_path, '[dvl]\nform = "beams"\n')
    _one_line(*_cli(["replay", str(bags["twist"]), "--method", "ins,lc", "--bag-mapping", str(mapping)], capsys),
              "m.toml", "dvl.form", "'beams'", "TwistWithCovarianceStamped", "body velocity only")


def test_an_empty_imu_topic_names_the_mapping_and_the_key(bags: dict, tmp_path: Path,
                                                           capsys: pytest.CaptureFixture) -> None:
    mapping = _mapping(tmp_path, '[imu]\ntopic = ""\n')
    _one_line(*_cli(["replay", str(bags["mcap"]), "--bag-mapping", str(mapping)], capsys), "m.toml", "imu.topic",
              "a replay needs an IMU")
    mapping = _mapping(tmp_path, '[dvl]\nwater_track_topic = ""\n')
    _one_line(*_cli(["log", "info", str(bags["mcap"]), "--bag-mapping", str(mapping)], capsys), "m.toml",
              "dvl.water_track_topic", "a topic name is needed")
    mapping = _mapping(tmp_path, '[reference]\ntopic = ""\n[attitude]\ntopic = ""\n')
    _one_line(*_cli(["replay", str(bags["mcap"]), "--bag-mapping", str(mapping)], capsys), "m.toml",
              "reference.topic = ''", "attitude.topic = ''")


def test_msg_paths_errors_name_the_mapping_file(bags: dict, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    bad = tmp_path / "my_msgs" / "msg" / "Bad.msg"
    bad.parent.mkdir(parents=True)
    bad.write_text("float64[ x\n")
    mapping = _mapping(tmp_path, "").read_text()
    (tmp_path / "m.toml").write_text('msg_paths = ["my_msgs/msg/Bad.msg"]\n' + mapping)
    _one_line(*_cli(["replay", str(bags["mcap"]), "--bag-mapping", str(tmp_path / "m.toml")], capsys), "m.toml",
              "msg_paths", "Bad.msg")
    bad.unlink()
    os.mkfifo(bad)  # never opened
    _one_line(*_cli(["log", "info", str(bags["mcap"]), "--bag-mapping", str(tmp_path / "m.toml")], capsys),
              "m.toml", "msg_paths", "Bad.msg", "FIFO")


# ------------------------------------------------------------------------- 5: non-finite DVL
@pytest.mark.parametrize("frame", ["frd_ned", "flu_enu"])
def test_an_infinite_twist_velocity_is_refused_without_a_warning(bags: dict, tmp_path: Path, frame: str) -> None:
    config = bags["config"]
    body = {**bags["body"], "dvl": {k: v.copy() for k, v in bags["body"]["dvl"].items()}}
    body["dvl"]["vel_x_mps"][1] = np.inf
    with np.errstate(invalid="ignore"):  # the writer's FLU conversion of inf: inf * 0 in y and z
        bag = write_bag(tmp_path / "inf.mcap", "mcap", body, "geometry_msgs/msg/TwistWithCovarianceStamped",
                        config.dvl.A_b, frame=frame)
    (tmp_path / "inf.toml").write_text(f'frame = "{frame}"\n\n[config.earth]\nmodel = "flat"\n')
    done = _run_subprocess(["replay", str(bag), "--method", "ins,lc"], tmp_path)
    assert done.returncode == 2, done.stderr
    assert "Warning" not in done.stderr, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    for part in ("inf.mcap", "'/dvl'", "message 2", "twist.twist.linear.x", "inf", "not a finite number"):
        assert part in lines[0], (part, lines[0])
