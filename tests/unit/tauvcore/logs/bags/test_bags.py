"""ROS bags replayed as logs (tauvcore.logs.bags): a simulated mission written as a ROS 1 bag, a ROS 2
sqlite3 bag and an MCAP file with rosbags' own writers, for each DVL message type and the
twist-only case, replays to the same numbers as the same mission's CSV log; FLU/ENU recordings as
FRD/NED ones; ``tauv log info`` and ``tauv log convert``; bad inputs are one line and exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from tauvcore.eval.replay import replay
from tauvcore.logs import LogError, read_log
from tauvcore.logs.bags import BagMapping, bag_config, read_bag, read_mapping
from tauvcore.logs.bags.frames import mounting_matrix
from tauvcore.logs.writer import write_log
from tests.unit.helpers.bag_fixtures import (
    DVL_TYPES,
    FIX_TOPICS,
    INCREMENT_TOPICS,
    LEVER_ARM_B_M,
    TOPICS,
    USBL_TOPIC,
    geodetic_tables,
    increment_tables,
    mission_config,
    mission_tables,
    write_bag,
)

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


@pytest.fixture(scope="module")
def usbl_mission(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A mission with ``--aiding dvl,depth,mag,usbl`` (a fix every 2 s), its CSV log and its replay."""
    config = mission_config().replace("run", aiding=("dvl", "depth", "mag", "usbl")).replace("usbl", interval_s=2.0)
    beams, _ = mission_tables(config)
    root = tmp_path_factory.mktemp("usbl")
    write_log(root / "log", beams, "csv")
    expected = replay(config, read_log(root / "log"), np.random.default_rng(0))[1]
    assert expected["lc"].updates["usbl"].fused.any()
    return {"config": config, "beams": beams, "replay": expected}


@pytest.mark.parametrize(("storage", "frame", "usbl_as"), [
    ("mcap", "flu_enu", "geometry_msgs/msg/PointStamped"),
    ("ros1", "frd_ned", "geometry_msgs/msg/PoseWithCovarianceStamped"),
    ("sqlite3", "flu_enu", "geometry_msgs/msg/PoseWithCovarianceStamped"),
])
def test_a_plugin_source_from_its_own_topic_replays_as_the_csv_log(usbl_mission: dict, tmp_path: Path, storage: str,
                                                                   frame: str, usbl_as: str) -> None:
    """The USBL's table from the topic the mapping names ([usbl] topic), of a type the plug-in declares
    (PointStamped, PoseWithCovarianceStamped; world vectors to NED): the same numbers as the CSV log to
    1e-9. Not named, it is never found by type (a PoseWithCovarianceStamped is not taken for the reference)."""
    config = usbl_mission["config"]
    bag = write_bag(tmp_path / STORAGES[storage], storage, usbl_mission["beams"], "marine_acoustic_msgs/msg/Dvl",
                    config.dvl.A_b, frame=frame, usbl_as=usbl_as)
    mapping = _mapping(tmp_path / "map.toml", f'frame = "{frame}"\n[usbl]\ntopic = "{USBL_TOPIC}"\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    for axis in ("north_m", "east_m", "down_m"):
        np.testing.assert_array_equal(log.sources["usbl"][axis], usbl_mission["beams"]["usbl"][axis])
    _same(replay(config, log, np.random.default_rng(0))[1], usbl_mission["replay"])
    if usbl_as.endswith("PointStamped"):
        unnamed = _mapping(tmp_path / "unnamed.toml", f'frame = "{frame}"\n')
        assert "usbl" not in read_bag(bag, read_mapping(unnamed), config.dvl.A_b).sources


def test_a_plugin_topic_of_a_wrong_type_is_one_line_naming_what_it_takes(usbl_mission: dict, tmp_path: Path,
                                                                         capsys: pytest.CaptureFixture) -> None:
    config = usbl_mission["config"]
    bag = write_bag(tmp_path / "m.mcap", "mcap", usbl_mission["beams"], "marine_acoustic_msgs/msg/Dvl",
                    config.dvl.A_b, frame="flu_enu")
    wrong = _mapping(tmp_path / "wrong.toml", f'[usbl]\ntopic = "{TOPICS["imu"]}"\n')
    words = ("usbl.topic", f"'{TOPICS['imu']}'", "sensor_msgs/msg/Imu", "geometry_msgs/msg/PointStamped",
             "geometry_msgs/msg/PoseWithCovarianceStamped")
    with pytest.raises(LogError) as caught:
        read_bag(bag, read_mapping(wrong), config.dvl.A_b)
    assert all(w in str(caught.value) for w in words), caught.value
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(wrong), "--aiding", "dvl,usbl"], *words)


def test_the_dvl_mounting_from_tf_static_equals_the_mapping_s(mission: dict, tmp_path: Path,
                                                              capsys: pytest.CaptureFixture) -> None:
    """DVL beams rotated by a mounting yaw of 45 deg: with the transform base_link -> dvl in /tf_static
    (FLU frames, C_frd = D R D) the bag replays as with mounting_rpy_deg in the mapping, and as the
    CSV log; its translation is the DVL's lever arm (FRD); the mapping's mounting wins over /tf_static."""
    config = mission["config"]
    C = mounting_matrix((0.0, 0.0, 45.0))
    tf = write_bag(tmp_path / "tf.mcap", "mcap", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                   frame="flu_enu", C_b_dvl=C, tf_static=True)
    plain = write_bag(tmp_path / "plain.mcap", "mcap", mission["beams"], "marine_acoustic_msgs/msg/Dvl",
                      config.dvl.A_b, frame="flu_enu", C_b_dvl=C)
    mapped = read_mapping(_mapping(tmp_path / "map.toml", "[dvl]\nmounting_rpy_deg = [0.0, 0.0, 45.0]\n"))
    from_tf = read_bag(tf, BagMapping(), config.dvl.A_b)
    assert any("/tf_static base_link -> dvl" in note for note in from_tf.notes)
    results = replay(config, from_tf, np.random.default_rng(0))[1]
    _same(results, replay(config, read_bag(plain, mapped, config.dvl.A_b), np.random.default_rng(0))[1])
    _same(results, mission["replay_beams"])
    raw, source = bag_config(BagMapping(), tf)
    np.testing.assert_allclose(raw["dvl"]["lever_arm_m"], LEVER_ARM_B_M, rtol=0, atol=1e-12)
    assert source is not None and "/tf_static" in source
    assert bag_config(BagMapping(), plain) == ({}, None)
    with pytest.raises(LogError, match="configured beam"):  # the mapping's (no rotation) wins
        read_bag(tf, read_mapping(_mapping(tmp_path / "zero.toml", "[dvl]\nmounting_rpy_deg = [0.0, 0.0, 0.0]\n")),
                 config.dvl.A_b)
    assert main(["log", "info", str(tf)]) == 0
    assert "dvl mounting: /tf_static base_link -> dvl" in capsys.readouterr().out
    assert main(["log", "info", str(tf), "--bag-mapping", str(tmp_path / "map.toml")]) == 0
    assert "dvl mounting: the mapping's mounting_rpy_deg" in capsys.readouterr().out


def test_a_plugin_s_covariance_diagonal_fills_its_sigma_columns_in_ned() -> None:
    """A source declaring a world vector and a covariance's sigma columns (the USBL has none): from a
    FLU/ENU message, north = ENU y, east = x, down = -z; sigma north = sqrt(cov[7]), east = sqrt(cov[0]),
    down = sqrt(cov[14]), NaN for ROS's -1 (unknown); a column no field fills is NaN."""
    from types import SimpleNamespace

    from tauvcore.aiding.source import BagField, BagMessage
    from tauvcore.logs.bags.mapping import TopicRule
    from tauvcore.logs.bags.messages import plugin_row
    from tauvcore.logs.bags.ros_reader import _plugin

    spec = BagMessage("geometry_msgs/msg/PoseWithCovarianceStamped", (
        BagField(("north_m", "east_m", "down_m"), "pose.pose.position"),
        BagField(("sigma_north_m", "sigma_east_m", "sigma_down_m"), "pose.covariance", "world_sigma")))
    covariance = [0.0] * 36
    covariance[0], covariance[7], covariance[14] = 4.0, 9.0, -1.0
    position = SimpleNamespace(x=1.0, y=2.0, z=3.0)
    msg = SimpleNamespace(pose=SimpleNamespace(pose=SimpleNamespace(position=position), covariance=covariance))
    columns = ("north_m", "east_m", "down_m", "sigma_north_m", "sigma_east_m", "sigma_down_m", "quality")
    out = _plugin(spec, np.array([plugin_row(spec)(msg)]), TopicRule("x", "/fix", frame="flu_enu"), columns)
    assert [float(out[c][0]) for c in columns[:5]] == [2.0, 1.0, -3.0, 3.0, 2.0]
    assert np.isnan(out["sigma_down_m"][0]) and np.isnan(out["quality"][0])


@pytest.fixture(scope="module")
def increments(mission: dict) -> dict:
    """The mission with its IMU as increments, its CSV log (increment columns) and that log's replay."""
    config, root = mission["config"], mission["root"]
    tables = increment_tables(mission["beams"])
    write_log(root / "log_increments", tables, "csv")
    return {"tables": tables, "replay": replay(config, read_log(root / "log_increments"), np.random.default_rng(0))[1]}


INCREMENTS_MAPPING = (f'[imu]\nform = "increments"\ntopic = "{INCREMENT_TOPICS["topic"]}"\n'
                      f'velocity_topic = "{INCREMENT_TOPICS["velocity_topic"]}"\n')


@pytest.mark.parametrize(("storage", "frame"), [("ros1", "flu_enu"), ("sqlite3", "frd_ned"), ("mcap", "flu_enu")])
def test_an_imu_of_increments_replays_as_the_csv_log_of_increments(mission: dict, increments: dict, tmp_path: Path,
                                                                  storage: str, frame: str) -> None:
    """Angle increments as QuaternionStamped (the Xsens driver's /imu/dq) and velocity increments as
    Vector3Stamped (/imu/dv), FLU converted to FRD: the log's dtheta and dv columns to 1e-15, and the
    replay the CSV log's (increment columns) to 1e-9."""
    config = mission["config"]
    tables = increments["tables"]
    bag = write_bag(tmp_path / STORAGES[storage], storage, tables, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame=frame)
    mapping = _mapping(tmp_path / "map.toml", f'frame = "{frame}"\n' + INCREMENTS_MAPPING)
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    for i, a in enumerate("xyz"):
        np.testing.assert_allclose(log.dtheta_b[1:, i], tables["imu"][f"dtheta_{a}_rad"][1:], rtol=0, atol=1e-15)
        np.testing.assert_allclose(log.dv_b[1:, i], tables["imu"][f"dv_{a}_mps"][1:], rtol=0, atol=1e-15)
    _same(replay(config, log, np.random.default_rng(0))[1], increments["replay"])


def test_imu_increments_that_do_not_pair_are_one_line(mission: dict, increments: dict, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    """A velocity message left out (the counts and, from there, the stamps differ), a velocity topic the
    bag lacks, increments without their velocity topic: one line naming the bag, topic, message; exit 2."""
    config = mission["config"]
    tables = increments["tables"]
    bag = write_bag(tmp_path / "skip.mcap", "mcap", tables, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu", velocity_skip=5)
    mapping = _mapping(tmp_path / "map.toml", INCREMENTS_MAPPING)
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(mapping)], "skip.mcap", "topic '/imu/dv' (imu)",
           "message 6", "'/imu/dq'", "pair one to one")
    last = write_bag(tmp_path / "last.bag", "ros1", tables, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                     frame="flu_enu", velocity_skip=len(tables["imu"]["t_s"]) - 1)
    count = len(tables["imu"]["t_s"])
    _fails(capsys, ["replay", str(last), "--bag-mapping", str(mapping)], "last.bag", "topic '/imu/dq' (imu)",
           f"message {count}", "is missing", f"{count - 1}")
    missing = _mapping(tmp_path / "missing.toml", INCREMENTS_MAPPING.replace("/imu/dv", "/imu/none"))
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(missing)], "missing.toml", "imu.velocity_topic",
           "'/imu/none'", "skip.mcap")
    alone = _mapping(tmp_path / "alone.toml", INCREMENTS_MAPPING.split("velocity_topic")[0])
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(alone)], "alone.toml", "imu.velocity_topic",
           "increments")
    rates = _mapping(tmp_path / "rates.toml", '[imu]\nform = "rates"\ntopic = "/imu/dq"\n')
    _fails(capsys, ["replay", str(bag), "--bag-mapping", str(rates)], "imu.topic", "'/imu/dq'",
           "geometry_msgs/msg/QuaternionStamped", "sensor_msgs/msg/Imu")


def test_a_quaternion_s_rotation_vector() -> None:
    """The rotation vector of a quaternion: the same rotation whatever the quaternion's sign or norm,
    a small angle to 1e-18, a zero quaternion NaN."""
    from tauvcore.logs.bags.increments import rotation_vectors

    theta = np.array([[0.3, -0.2, 0.1], [1e-9, 2e-9, -3e-9], [0.0, 0.0, 0.0], [0.0, 3.0, 0.0]])
    angle = np.linalg.norm(theta, axis=-1)
    axis = theta / np.where(angle > 0, angle, 1.0)[:, None]
    q = np.concatenate([axis * np.sin(angle / 2)[:, None], np.cos(angle / 2)[:, None]], axis=-1)
    np.testing.assert_allclose(rotation_vectors(q), theta, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(rotation_vectors(-2.0 * q), theta, rtol=1e-12, atol=1e-18)
    assert np.isnan(rotation_vectors(np.zeros((1, 4)))).all()


def test_a_tf_static_chain_gives_the_direct_transform_s_mounting(mission: dict, tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture) -> None:
    """base_link -> sensor_mount, then dvl -> sensor_mount (the second edge written the other way round):
    the composed rotation and lever arm equal those of the direct base_link -> dvl to 1e-9; a chain
    broken between base_link and the DVL's frame is one line naming the frames."""
    from tauvcore.logs.bags import bag_tables

    config = mission["config"]
    C = mounting_matrix((0.0, 0.0, 45.0))
    t = np.asarray(LEVER_ARM_B_M)
    C1, t1 = mounting_matrix((5.0, -20.0, 30.0)), np.array([0.2, -0.1, 0.3])
    C2, t2 = C1.T @ C, C1.T @ (t - t1)                      # sensor_mount -> dvl
    edges = (("base_link", "sensor_mount", C1, t1), ("dvl", "sensor_mount", C2.T, -C2.T @ t2))
    args = (mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b)
    direct = write_bag(tmp_path / "direct.mcap", "mcap", *args, frame="flu_enu", C_b_dvl=C, tf_static=True)
    chained = write_bag(tmp_path / "chain.bag", "ros1", *args, frame="flu_enu", C_b_dvl=C, tf_chain=edges)
    want = bag_tables(direct, BagMapping(), config.dvl.A_b).mounting
    got = bag_tables(chained, BagMapping(), config.dvl.A_b).mounting
    assert want is not None and got is not None and want.r_b_m is not None and got.r_b_m is not None
    assert got.source == "/tf_static base_link -> sensor_mount -> dvl" and want.source == "/tf_static base_link -> dvl"
    np.testing.assert_allclose(got.C_b_dvl, want.C_b_dvl, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.C_b_dvl, C, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.r_b_m, want.r_b_m, rtol=0, atol=1e-9)
    raw, _ = bag_config(BagMapping(), chained)
    np.testing.assert_allclose(raw["dvl"]["lever_arm_m"], LEVER_ARM_B_M, rtol=0, atol=1e-9)
    broken = write_bag(tmp_path / "broken.mcap", "mcap", *args, frame="flu_enu", C_b_dvl=C,
                       tf_chain=(edges[0], ("dvl", "other_mount", C2.T, -C2.T @ t2)))
    with pytest.raises(LogError, match="no chain"):
        read_bag(broken, BagMapping(), config.dvl.A_b)
    _fails(capsys, ["replay", str(broken)], "broken.mcap", "/tf_static", "'base_link'", "'dvl'", "'other_mount'")


def test_replay_and_convert_open_a_bag_once(mission: dict, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``tauv replay`` and ``tauv log convert`` take the DVL's lever arm from /tf_static in the read of
    the bag's messages (one open of the bag), laid under --config as the bag's own configuration."""
    import json

    from rosbags.highlevel import AnyReader

    config = mission["config"]
    bag = write_bag(tmp_path / "tf.bag", "ros1", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu", C_b_dvl=mounting_matrix((0.0, 0.0, 45.0)), tf_static=True)
    opened: list[int] = []
    real_open = AnyReader.open

    def counted(self: AnyReader) -> None:
        opened.append(1)
        real_open(self)

    monkeypatch.setattr(AnyReader, "open", counted)
    out = tmp_path / "run.json"
    flags = ["--method", "ins,lc", "--aiding", "dvl,depth,mag", "--earth", "flat"]
    assert main(["replay", str(bag), *flags, "--json", str(out)]) == 0
    assert len(opened) == 1
    document = json.loads(out.read_text())
    np.testing.assert_allclose(document["config"]["dvl"]["lever_arm_m"], LEVER_ARM_B_M, rtol=0, atol=1e-12)
    assert document["log"]["config_file"] == f"{bag}:/tf_static"
    assert any(layer.startswith("the bag's") and "dvl.lever_arm_m" in layer for layer in document["log"]["configuration"])
    opened.clear()
    assert main(["log", "convert", str(bag), str(tmp_path / "log")]) == 0
    assert len(opened) == 1
    assert "lever_arm_m" in (tmp_path / "log" / "log.toml").read_text()


def test_replay_s_read_frees_each_table_once_read(mission: dict, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Both of a bag's reads (read_bag; read_bag_configured, which ``tauv replay`` takes) assemble the
    log dropping each table once read (log_from_tables' ``release``), as a log's files are read: a
    1 h bag's tables held to the end cost about 80 MiB."""
    import tauvcore.logs.bags as bags

    config = mission["config"]
    bag = write_bag(tmp_path / "m.mcap", "mcap", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu")
    released: list[bool] = []
    real = bags.log_from_tables

    def spy(*args, **kwargs):
        released.append(kwargs.get("release", False))
        return real(*args, **kwargs)

    monkeypatch.setattr(bags, "log_from_tables", spy)
    bags.read_bag(bag, BagMapping(), config.dvl.A_b)
    bags.read_bag_configured(bag, BagMapping(), config.dvl.A_b, {}, None)
    assert released == [True, True]


def test_no_log_config_drops_both_the_tf_static_rotation_and_lever_arm(mission: dict, tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture) -> None:
    """``--no-log-config`` with a bag whose DVL is mounted 45 deg by /tf_static: the rotation goes (its beams
    are then not the configured ones: one line, exit 2) and so does the lever arm (with the mapping's
    mounting_rpy_deg the run takes the configuration's default lever arm, and no /tf_static note)."""
    import json

    from tauvcore.config import Config

    config = mission["config"]
    bag = write_bag(tmp_path / "tf.mcap", "mcap", mission["beams"], "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b,
                    frame="flu_enu", C_b_dvl=mounting_matrix((0.0, 0.0, 45.0)), tf_static=True)
    flags = ["--method", "ins,lc", "--aiding", "dvl,depth,mag", "--earth", "flat"]
    _fails(capsys, ["replay", str(bag), *flags, "--no-log-config"], "topic '/dvl'", "configured beam")
    mapping = _mapping(tmp_path / "rpy.toml", "[dvl]\nmounting_rpy_deg = [0.0, 0.0, 45.0]\n")
    runs = {}
    for name, extra in (("kept", []), ("ignored", ["--no-log-config"])):
        out = tmp_path / f"{name}.json"
        assert main(["replay", str(bag), "--bag-mapping", str(mapping), *flags, *extra, "--json", str(out)]) == 0
        runs[name] = json.loads(out.read_text())
    capsys.readouterr()
    np.testing.assert_allclose(runs["kept"]["config"]["dvl"]["lever_arm_m"], LEVER_ARM_B_M, rtol=0, atol=1e-12)
    assert runs["ignored"]["config"]["dvl"]["lever_arm_m"] == list(Config().dvl.lever_arm_m)
    assert runs["ignored"]["log"]["config_file"] is None
    assert any("--no-log-config" in layer and "/tf_static" in layer for layer in runs["ignored"]["log"]["configuration"])
    assert not any("/tf_static" in note for note in runs["ignored"]["log"]["notes"])
