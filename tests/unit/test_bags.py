"""ROS bags replayed as logs (tauvcore.bags): a simulated mission written as a ROS 1 bag, a ROS 2
sqlite3 bag and an MCAP file with rosbags' own writers, for each DVL message type and the
twist-only case, replays to the same numbers as the same mission's CSV log; FLU/ENU recordings as
FRD/NED ones; ``tauv log info`` and ``tauv log convert``; bad inputs are one line and exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from bag_fixtures import (
    DVL_TYPES,
    FIX_TOPICS,
    TOPICS,
    geodetic_tables,
    mission_config,
    mission_tables,
    write_bag,
)

from app.cli import main
from tauvcore.bags import BagMapping, read_bag, read_mapping
from tauvcore.eval.replay import replay
from tauvcore.log_writer import write_log
from tauvcore.logs import LogError, read_log

SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "est_pos_n", "pos_sigma_m", "vel_sigma_mps", "att_sigma_deg")
STORAGES = {"ros1": "mission.bag", "sqlite3": "mission", "mcap": "mission.mcap"}


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The mission's tables, its two CSV logs (DVL as beams, DVL as a body velocity) and their replays."""
    config = mission_config()
    beams, body = mission_tables(config)
    root = tmp_path_factory.mktemp("bags")
    out = {"config": config, "beams": beams, "body": body, "root": root}
    for name, tables in (("beams", beams), ("body", body)):
        write_log(root / f"log_{name}", tables, "csv")
        out[f"replay_{name}"] = replay(config, read_log(root / f"log_{name}"), np.random.default_rng(0))[1]
    return out


def _same(results: dict, expected: dict) -> None:
    for method, want in expected.items():
        for name in SERIES:
            a, b = getattr(want, name), getattr(results[method], name)
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * max(np.nanmax(np.abs(a)), 1e-9), err_msg=f"{method} {name}")
        for src, rec in want.updates.items():
            np.testing.assert_array_equal(results[method].updates[src].fused, rec.fused, err_msg=f"{method} {src}")


def _mapping(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@pytest.mark.parametrize("storage", list(STORAGES))
@pytest.mark.parametrize("dvl_type", DVL_TYPES)
def test_a_bag_replays_as_its_csv_log_to_1e_9(mission: dict, tmp_path: Path, storage: str, dvl_type: str) -> None:
    """Per-beam types equal the log with beams; twist types the log with the body velocity (projected
    onto the configured beams), whatever order a message lists its beams in; FRD/NED by mapping."""
    config = mission["config"]
    twist = dvl_type.startswith("geometry_msgs")
    bag = write_bag(tmp_path / STORAGES[storage], storage, mission["body" if twist else "beams"], dvl_type,
                    config.dvl.A_b, frame="frd_ned")
    mapping = _mapping(tmp_path / "map.toml", 'frame = "frd_ned"\n[dvl]\nbeam_ids = [0, 1, 2, 3]\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    assert (log.dvl_body_mps is not None) == twist
    _same(replay(config, log, np.random.default_rng(0))[1], mission["replay_body" if twist else "replay_beams"])


@pytest.mark.parametrize("dvl_type", ["marine_acoustic_msgs/msg/Dvl", "uuv_sensor_ros_plugins_msgs/msg/DVL",
                                      "geometry_msgs/msg/TwistWithCovarianceStamped"])
def test_a_flu_enu_recording_equals_the_frd_ned_one(mission: dict, tmp_path: Path, dvl_type: str) -> None:
    """ROS REP-103 frames (the default, no mapping) converted: the same numbers to 1e-9."""
    config = mission["config"]
    twist = dvl_type.startswith("geometry_msgs")
    bag = write_bag(tmp_path / "enu.mcap", "mcap", mission["body" if twist else "beams"], dvl_type, config.dvl.A_b,
                    frame="flu_enu")
    log = read_bag(bag, BagMapping(), config.dvl.A_b)
    _same(replay(config, log, np.random.default_rng(0))[1], mission["replay_body" if twist else "replay_beams"])


def test_depth_as_a_float64_topic_and_receive_times(mission: dict, tmp_path: Path) -> None:
    """A std_msgs/Float64 depth topic named in the mapping; receive times equal the stamps here."""
    config = mission["config"]
    bag = write_bag(tmp_path / "d.bag", "ros1", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu", depth_as="float64")
    mapping = _mapping(tmp_path / "map.toml", 'time = "receive"\n[depth]\ntopic = "/depth"\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    _same(replay(config, log, np.random.default_rng(0))[1], mission["replay_beams"])


@pytest.mark.parametrize(("storage", "frame"), [("mcap", "flu_enu"), ("ros1", "frd_ned")])
def test_a_navsatfix_reference_replays_as_the_geodetic_csv_log(mission: dict, tmp_path: Path, storage: str,
                                                               frame: str) -> None:
    """A sensor_msgs/NavSatFix reference (latitude, longitude in degrees) with its attitude from
    reference.orientation_topic (a QuaternionStamped) and its depth from reference.depth_topic (a
    std_msgs/Float64) replays as the CSV log whose reference is geodetic (lat_deg, lon_deg,
    depth_m) with the same numbers, to 1e-9; its velocity is the fixes' differences in both."""
    config = mission["config"]
    tables = geodetic_tables(mission["beams"], config)
    write_log(tmp_path / "log", tables, "csv")
    expected = replay(config, read_log(tmp_path / "log"), np.random.default_rng(0))[1]
    bag = write_bag(tmp_path / STORAGES[storage], storage, tables, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame=frame)
    options = "".join(f'{key} = "{topic}"\n' for key, topic in FIX_TOPICS.items())
    mapping = _mapping(tmp_path / "map.toml", f'frame = "{frame}"\n[attitude]\ntopic = "{TOPICS["attitude"]}"\n'
                                              f"[reference]\n{options}")
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    assert log.ref_geodetic
    np.testing.assert_array_equal(log.ref_position[:, 2], tables["reference"]["depth_m"])  # the depth topic's
    _same(replay(config, log, np.random.default_rng(0))[1], expected)


def test_log_info_and_convert(mission: dict, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``tauv log info`` lists each topic with the table it feeds; ``tauv log convert`` writes a log
    that replays to the same numbers, and refuses a directory that is not empty."""
    config = mission["config"]
    bag = write_bag(tmp_path / "m.bag", "ros1", mission["beams"], "ds_sensor_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu")
    assert main(["log", "info", str(bag)]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split() for line in out.splitlines()[2:]}
    for table, topic in TOPICS.items():
        assert rows[topic][-1] == table, out
    assert "ds_sensor_msgs/msg/Dvl" in out and "1001" in out
    for fmt in ("csv", "parquet"):
        assert main(["log", "convert", str(bag), str(tmp_path / fmt), "--log-format", fmt]) == 0
        _same(replay(config, read_log(tmp_path / fmt), np.random.default_rng(0))[1], mission["replay_beams"])
    assert main(["log", "convert", str(bag), str(tmp_path / "csv")]) == 2
    assert "not an empty directory" in capsys.readouterr().err


def _fails(capsys: pytest.CaptureFixture, argv: list[str], *words: str) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tauv: error: "), err
    for word in words:
        assert word in err, err


def test_bad_inputs_are_one_line_naming_the_thing(mission: dict, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    config = mission["config"]
    bag = write_bag(tmp_path / "m.bag", "ros1", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu")
    out = tmp_path / "out"
    unknown = _mapping(tmp_path / "unknown.toml", '[dvl]\ntopic = "/no/such"\n')
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(unknown)], "dvl.topic", "'/no/such'", "unknown.toml")
    _fails(capsys, ["log", "convert", str(bag), str(out), "--bag-mapping", str(unknown)], "'/no/such'")
    wrong = _mapping(tmp_path / "wrong.toml", '[imu]\ntopic = "/odom"\n')
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(wrong)], "'/odom'", "nav_msgs/msg/Odometry", "imu")
    bad_value = _mapping(tmp_path / "bad.toml", 'frame = "nwu"\n')
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(bad_value)], "frame", "'nwu'", "bad.toml")
    two = write_bag(tmp_path / "two.mcap", "mcap", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu", imu_topics=("/imu/a", "/imu/b"))
    _fails(capsys, ["replay", str(two)], "'/imu/a'", "'/imu/b'", "imu", "mapping")
    _fails(capsys, ["log", "convert", str(two), str(out)], "'/imu/a'")
    corrupt = tmp_path / "corrupt.bag"
    corrupt.write_bytes(bag.read_bytes()[: bag.stat().st_size // 2])
    _fails(capsys, ["replay", str(corrupt)], "corrupt.bag")
    _fails(capsys, ["log", "convert", str(corrupt), str(out)], "corrupt.bag")
    frd = write_bag(tmp_path / "frd.bag", "ros1", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="frd_ned")
    _fails(capsys, ["replay", str(frd)], "topic '/dvl'", "message 1", "configured beam")
    assert not out.exists()                                   # nothing written by any of them
    with pytest.raises(LogError, match="not a topic"):
        read_bag(bag, read_mapping(unknown), config.dvl.A_b)


def test_a_bag_mapping_for_a_log_directory_is_refused(mission: dict, capsys: pytest.CaptureFixture) -> None:
    root = mission["root"]
    mapping = _mapping(root / "m.toml", "")
    _fails(capsys, ["replay", str(root / "log_beams"), "--bag-mapping", str(mapping)], "--bag-mapping", "not a ROS bag")
    shutil.rmtree(root / "nothing", ignore_errors=True)
