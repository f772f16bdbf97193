"""A run's results as MCAP (app.reports.mcap_export), read back with the mcap library and its ROS 2
decoder (mcap, mcap-ros2-support: not the writer's rosbags): the topics, one message per output
epoch and update, the decoded numbers equal to the results'."""

import numpy as np
import pytest

from app.reports.mcap_export import (
    MAGIC,
    McapResults,
    innovation_layout,
    odometry_layout,
    scalars_layout,
    typestore,
)
from tauvcore.config import Config
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.geo.rotations import C_nb_from_euler

mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2_decoder = pytest.importorskip("mcap_ros2.decoder")

T_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
D_FLU = np.diag([1.0, -1.0, -1.0])


def read_back(path) -> dict[str, list]:
    """Topic -> [(log time [ns], decoded message)] in log-time order, by the mcap library."""
    with open(path, "rb") as fh:
        assert fh.read(8) == MAGIC
        fh.seek(0)
        reader = mcap_reader.make_reader(fh, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        topics: dict[str, list] = {}
        for _, channel, message, ros in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, ros))
    return topics


def matrix(q) -> np.ndarray:
    """The rotation matrix of a decoded quaternion (x, y, z, w)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()


@pytest.fixture(scope="module")
def config() -> Config:
    # a tight gate (1 sigma) so that the gate rejects some pings; an outage so beams go missing
    from tauvcore.sensors.dvl import Outage

    config = Config().replace("trajectory", name="figure8", duration_s=30.0)
    config = config.replace("dvl", outages=(Outage(beams=(3, 4), start_s=10.0, end_s=15.0),))
    config = config.replace("filter", gate_sigma=1.0)
    return config.replace("run", methods=("ins", "lc", "tc", "vkf"), aiding=("dvl", "depth"))


@pytest.fixture(scope="module")
def written(config, tmp_path_factory):
    """The results held whole, and the same run's MCAP file written chunk by chunk (truth too)."""
    path = str(tmp_path_factory.mktemp("mcap") / "run.mcap")
    writer = McapResults(path, config)
    results = run_streaming(
        config,
        np.random.default_rng(3),
        chunk_s=7.0,
        sinks=Sinks(on_chunk=writer.add, on_sim_chunk=lambda chunk: writer.add_truth(chunk.truth, chunk.k0)),
    )
    writer.finish()
    return results, path, read_back(path)


def test_topics_and_counts(config, written) -> None:
    results, _, topics = written
    expected = {"/tauv/truth/odometry", "/tauv/events"}
    for method, r in results.items():
        expected |= {f"/tauv/{method}/{name}" for name in ("odometry", "sigma", "error")}
        expected |= {f"/tauv/{method}/innovations/{source}" for source in r.updates}
        for name in ("odometry", "sigma", "error"):
            assert len(topics[f"/tauv/{method}/{name}"]) == r.t_s.size
        for source, record in r.updates.items():
            assert len(topics[f"/tauv/{method}/innovations/{source}"]) == record.t_s.size
    assert set(topics) == expected
    assert "/tauv/tc/innovations/dvl" in topics and "/tauv/lc/innovations/depth" in topics
    t_s = results["lc"].t_s
    truth = topics["/tauv/truth/odometry"]
    assert [ns for ns, _ in truth] == list(np.round(t_s * 1e9).astype(np.int64))


def test_estimate_and_sigma_equal_the_results(written) -> None:
    results, _, topics = written
    for method in ("lc", "vkf"):
        r = results[method]
        for k in (0, r.t_s.size // 2, r.t_s.size - 1):
            ns, odo = topics[f"/tauv/{method}/odometry"][k]
            assert ns == round(r.t_s[k] * 1e9)
            assert odo.header.stamp.sec * 10**9 + odo.header.stamp.nanosec == ns
            assert odo.header.frame_id == "tauv_enu" and odo.child_frame_id == "base_link"
            p = odo.pose.pose.position
            np.testing.assert_allclose(T_ENU @ [p.x, p.y, p.z], r.est_pos_n[k, 0], rtol=0, atol=1e-9)
            C_nb = T_ENU @ matrix(odo.pose.pose.orientation) @ D_FLU
            np.testing.assert_allclose(C_nb, C_nb_from_euler(r.est_euler_rad[k, 0]), rtol=0, atol=1e-9)
            v = odo.twist.twist.linear
            v_n = C_nb @ D_FLU @ [v.x, v.y, v.z]
            np.testing.assert_allclose(v_n, r.est_vel_n[k, 0], rtol=0, atol=1e-9)
            cov = np.reshape(odo.pose.covariance, (6, 6))
            # NaN where the method has no such state (vkf: no position)
            np.testing.assert_allclose(cov[0, 0] + cov[1, 1] + cov[2, 2], r.pos_sigma_m[k, 0] ** 2, rtol=1e-12)
            np.testing.assert_allclose(np.sqrt(cov[5, 5]), np.radians(r.heading_sigma_deg[k, 0]), rtol=1e-12)
            if r.pos_cov_ne_m2 is not None:   # the filter's own horizontal block, ENU: x east, y north
                p_nn, p_ne, p_ee = r.pos_cov_ne_m2[k, 0]
                np.testing.assert_array_equal(cov[:2, :2], [[p_ee, p_ne], [p_ne, p_nn]])
                assert (k == 0 or p_ne != 0.0) and cov[2, 2] > 0.0   # the initial P is diagonal
            else:
                assert method == "vkf"
            _, sigma = topics[f"/tauv/{method}/sigma"][k]
            for name in ("pos_sigma_m", "vel_sigma_mps", "att_sigma_deg", "tilt_sigma_deg", "heading_sigma_deg"):
                np.testing.assert_array_equal(getattr(sigma, name), getattr(r, name)[k, 0])
            _, error = topics[f"/tauv/{method}/error"][k]
            for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "nees"):
                np.testing.assert_array_equal(getattr(error, name), getattr(r, name)[k, 0])


def test_innovations_and_rejections(written) -> None:
    results, _, topics = written
    record = results["tc"].updates["dvl"]
    rejected = np.flatnonzero(record.rejected[:, 0])
    accepted = np.flatnonzero(record.fused[:, 0])
    assert rejected.size and accepted.size  # the 1-sigma gate refuses some pings, takes others
    messages = topics["/tauv/tc/innovations/dvl"]
    for u in (rejected[0], accepted[0], record.t_s.size - 1):
        ns, m = messages[u]
        assert ns == round(record.t_s[u] * 1e9)
        np.testing.assert_array_equal(m.innovation, record.innovation[u, 0])
        np.testing.assert_array_equal(m.innovation_var, record.innovation_var[u, 0])
        np.testing.assert_array_equal(m.z, record.z[u, 0])
        assert m.rejected == bool(record.rejected[u, 0]) and m.fused == bool(record.fused[u, 0])
        assert list(m.rejected_rows) == record.rejected_rows[u, 0].tolist()
        assert list(m.beams_available) == record.beams_available[u, 0].tolist()
        assert m.mode == record.mode[u, 0] and m.nis_dof == record.nis_dof[u, 0]
    assert messages[rejected[0]][1].rejected is True
    lost = [m for _, m in messages if not all(m.beams_available)]  # the outage of beams 3 and 4
    assert lost and all(list(m.beams_available) == [True, True, False, False] for m in lost)
    depth = topics["/tauv/lc/innovations/depth"][0][1]
    assert list(depth.beams_available) == [] and depth.mode == -1


def test_events_are_those_of_the_whole_results(config, written) -> None:
    """The events written from the chunks are tauvcore.eval.events.run_events of the whole results:
    the scheduled outage, the 1-sigma gate's rejections, each stamped at its start."""
    from tauvcore.eval.events import run_events

    results, _, topics = written
    expected = run_events(results, config, 0)
    assert {e.kind for e in expected} >= {"outage", "rejection"}

    def key(e):
        return (e.kind, e.start_s, e.end_s, e.method or "", tuple(e.beams), e.text, e.source or "")

    messages = topics["/tauv/events"]
    assert all(ns == round(m.start_s * 1e9) for ns, m in messages)
    assert sorted(key(m) for _, m in messages) == sorted(key(e) for e in expected)
    outage = next(m for _, m in messages if m.kind == "outage")
    assert (outage.start_s, outage.end_s, list(outage.beams), outage.method) == (10.0, 15.0, [3, 4], "")


def test_truth_is_the_simulation(config, written) -> None:
    from tauvcore.truth import truth_stream

    results, _, topics = written
    whole = truth_stream(config.trajectory, config.earth, config.imu.rate_hz, chunk_samples=10**6)
    _, truth = next(iter(whole))
    step = round(config.imu.rate_hz / config.filter.output_rate_hz)
    for k in (0, 100, results["lc"].t_s.size - 1):
        _, odo = topics["/tauv/truth/odometry"][k]
        p = odo.pose.pose.position
        np.testing.assert_allclose(T_ENU @ [p.x, p.y, p.z], truth.pos_n[k * step], rtol=0, atol=1e-9)
        C_nb = T_ENU @ matrix(odo.pose.pose.orientation) @ D_FLU
        np.testing.assert_allclose(C_nb, truth.C_nb[k * step], rtol=0, atol=1e-9)


def test_packed_bytes_are_rosbags_serializer(config) -> None:
    """The numpy layouts give the bytes rosbags' CDR serializer gives the same message."""
    store = typestore()
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=12, nanosec=345)
    header = types["std_msgs/msg/Header"](stamp=stamp, frame_id="")
    vec = types["geometry_msgs/msg/Vector3"]
    cov = np.arange(36.0)
    odometry = types["nav_msgs/msg/Odometry"](
        header=types["std_msgs/msg/Header"](stamp=stamp, frame_id="tauv_enu"),
        child_frame_id="base_link",
        pose=types["geometry_msgs/msg/PoseWithCovariance"](
            pose=types["geometry_msgs/msg/Pose"](
                position=types["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0),
                orientation=types["geometry_msgs/msg/Quaternion"](x=0.1, y=0.2, z=0.3, w=0.9),
            ),
            covariance=cov,
        ),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](
            twist=types["geometry_msgs/msg/Twist"](linear=vec(x=4.0, y=5.0, z=6.0), angular=vec(x=7.0, y=8.0, z=9.0)),
            covariance=-cov,
        ),
    )
    packed = odometry_layout().pack(
        1,
        {"sec": 12, "nanosec": 345, "position": [1.0, 2.0, 3.0], "orientation": [0.1, 0.2, 0.3, 0.9],
         "pose_covariance": cov, "linear": [4.0, 5.0, 6.0], "angular": [7.0, 8.0, 9.0], "twist_covariance": -cov},
    )[0]
    assert packed == bytes(store.serialize_cdr(odometry, "nav_msgs/msg/Odometry"))
    sigma = types["tauv_msgs/msg/Sigma"](header=header, pos_sigma_m=1.5, vel_sigma_mps=2.5, att_sigma_deg=3.5,
                                          tilt_sigma_deg=4.5, heading_sigma_deg=5.5)
    values = {"sec": 12, "nanosec": 345, "pos_sigma_m": 1.5, "vel_sigma_mps": 2.5, "att_sigma_deg": 3.5,
              "tilt_sigma_deg": 4.5, "heading_sigma_deg": 5.5}
    assert scalars_layout("tauv_msgs/msg/Sigma").pack(1, values)[0] == bytes(
        store.serialize_cdr(sigma, "tauv_msgs/msg/Sigma"))
    for rows, beams in ((4, 4), (1, 0), (3, 0)):
        z = np.arange(rows) + 0.5
        flags = np.arange(rows) % 2 == 0
        message = types["tauv_msgs/msg/Innovation"](
            header=header, z=z, innovation=-z, innovation_var=z * z, fused_rows=flags, rejected_rows=~flags,
            test_ratio=0.7, nis=3.25, nis_dof=rows, valid=True, fused=False, rejected=True, unusable=False,
            beams_available=np.ones(beams, dtype=bool), mode=2 if beams else -1, reset=bool(beams))
        packed = innovation_layout(rows, beams).pack(
            1, {"sec": 12, "nanosec": 345, "z": z, "innovation": -z, "innovation_var": z * z, "fused_rows": flags,
                "rejected_rows": ~flags, "test_ratio": 0.7, "nis": 3.25, "nis_dof": rows, "valid": True,
                "fused": False, "rejected": True, "unusable": False, "beams_available": np.ones(beams, dtype=bool),
                "mode": 2 if beams else -1, "reset": bool(beams)})[0]
        assert packed == bytes(store.serialize_cdr(message, "tauv_msgs/msg/Innovation")), (rows, beams)


def test_discard_leaves_nothing(config, tmp_path) -> None:
    writer = McapResults(str(tmp_path / "out.mcap"), config)
    writer.discard()
    assert list(tmp_path.iterdir()) == []


def _run(capsys, *argv: str) -> tuple[int, str]:
    from app.cli import main

    code = main(list(argv))
    return code, capsys.readouterr().err


def test_cli_run_and_replay_write_their_files(capsys, tmp_path) -> None:
    """`tauv run --mcap` with the smoother, its log saved; `tauv replay LOG --mcap` of that log:
    the log's reference as the truth, stamped by the log's clock."""
    out, log, replayed = tmp_path / "run.mcap", tmp_path / "log", tmp_path / "replay.mcap"
    code, err = _run(capsys, "run", "--duration", "12", "--method", "lc", "--smooth", "--mcap", str(out),
                     "--save-log", str(log))
    assert code == 0, err
    topics = read_back(out)
    epochs = len(topics["/tauv/lc/odometry"])
    assert epochs == 121
    for name in ("/tauv/truth/odometry", "/tauv/lc/smoothed/odometry", "/tauv/lc/smoothed/sigma"):
        assert len(topics[name]) == epochs, name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log", "run.mcap"]  # nothing else left

    code, err = _run(capsys, "replay", str(log), "--method", "lc", "--mcap", str(replayed))
    assert code == 0, err
    again = read_back(replayed)
    assert len(again["/tauv/lc/odometry"]) == epochs and len(again["/tauv/truth/odometry"]) == epochs
    assert [ns for ns, _ in again["/tauv/truth/odometry"]] == [ns for ns, _ in topics["/tauv/truth/odometry"]]
    p, q = again["/tauv/truth/odometry"][-1][1].pose.pose.position, topics["/tauv/truth/odometry"][-1][1].pose.pose.position
    np.testing.assert_allclose([p.x, p.y, p.z], [q.x, q.y, q.z], rtol=0, atol=1e-6)  # the log's CSV rounding
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log", "replay.mcap", "run.mcap"]


@pytest.mark.parametrize("target, reason", [
    ("missing/out.mcap", "no such directory"),
    (".", "is a directory"),
    ("same.json", "is the --json file"),
    ("cfg.toml", "is the --config file"),
])
def test_cli_refuses_bad_paths_and_leaves_nothing(capsys, tmp_path, monkeypatch, target, reason) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cfg.toml").write_text("")
    before = sorted(p.name for p in tmp_path.iterdir())
    code, err = _run(capsys, "run", "--duration", "2", "--method", "ins", "--config", "cfg.toml",
                     "--json", "same.json", "--mcap", target)
    assert code == 2 and err.count("\n") == 1 and err.startswith("tauv: error: --mcap: ") and reason in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_cli_replay_refuses_a_file_in_the_log(capsys, tmp_path) -> None:
    log = tmp_path / "log"
    assert _run(capsys, "run", "--duration", "2", "--method", "ins", "--save-log", str(log))[0] == 0
    before = sorted(p.name for p in log.iterdir())
    code, err = _run(capsys, "replay", str(log), "--mcap", str(log / "imu.csv"))
    assert code == 2 and "--mcap" in err and "the log directory" in err, err
    assert sorted(p.name for p in log.iterdir()) == before


def test_an_interrupted_run_leaves_nothing(capsys, tmp_path, monkeypatch) -> None:
    """A failure during the run (here Ctrl-C at the second chunk) removes the temporary bag; the
    output is not made."""
    from app.reports import mcap_export

    calls = []

    def add(self, results):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(mcap_export.McapResults, "add", add)
    code, _ = _run(capsys, "run", "--duration", "30", "--method", "ins", "--mcap", str(tmp_path / "out.mcap"))
    assert code == 130 and len(calls) == 2
    assert list(tmp_path.iterdir()) == []


def test_the_dashboard_download_is_the_cli_s_file(capsys, tmp_path) -> None:
    """The dashboard's MCAP download of a run holds the messages `tauv run --mcap` writes for the
    same setup (the truth made again from the configuration); of a Monte Carlo, run 0's."""
    from app import cli
    from app.dashboard import export

    argv = ["--trajectory", "straight", "--duration", "10", "--method", "lc,tc", "--seed", "3"]
    config = cli.resolve_config(cli.build_parser().parse_args(["run", *argv]))
    finished = export.finished_run(config, run_streaming(config, np.random.default_rng(config.run.seed)))
    download = export.make("mcap", finished)
    assert download.name.endswith(".mcap") and download.content.startswith(MAGIC)
    (tmp_path / "page.mcap").write_bytes(download.content)
    assert _run(capsys, "run", *argv, "--mcap", str(tmp_path / "cli.mcap"))[0] == 0
    page, line = read_back(tmp_path / "page.mcap"), read_back(tmp_path / "cli.mcap")
    assert sorted(page) == sorted(line)
    for topic in line:
        assert [(ns, repr(m)) for ns, m in page[topic]] == [(ns, repr(m)) for ns, m in line[topic]], topic

    study = config.replace("initial_error", mode="random")  # as the dashboard runs Runs > 1
    two = export.finished_run(config, run_streaming(study, np.random.default_rng(3), 2))
    (tmp_path / "two.mcap").write_bytes(export.make("mcap", two).content)
    odometry = read_back(tmp_path / "two.mcap")["/tauv/lc/odometry"]
    p = odometry[-1][1].pose.pose.position
    np.testing.assert_array_equal(T_ENU @ [p.x, p.y, p.z], two.results["lc"].est_pos_n[-1, 0])


def test_a_log_replay_is_stamped_by_the_log_s_clock(capsys, tmp_path) -> None:
    """`tauv replay LOG --mcap` of a log whose clock starts at 5000 s: the results' stamps are the
    log's own times (its first IMU time plus the mission time), so they line up with the log; its
    reference is the truth topic at the same stamps."""
    from tauvcore.logs.writer import write_log
    from tests.unit.helpers.bag_fixtures import mission_config, mission_tables

    config = mission_config()
    tables, _ = mission_tables(config)
    shifted = {name: {**table, "t_s": table["t_s"] + 5000.0} for name, table in tables.items()}
    write_log(tmp_path / "dive", shifted, "csv")
    code, err = _run(capsys, "replay", str(tmp_path / "dive"), "--method", "lc", "--earth", "flat",
                     "--mcap", str(tmp_path / "out.mcap"))
    assert code == 0, err
    topics = read_back(tmp_path / "out.mcap")
    odometry = topics["/tauv/lc/odometry"]
    assert abs(odometry[0][0] - round(float(shifted["imu"]["t_s"][0]) * 1e9)) < 1000  # float seconds' resolution
    assert [ns for ns, _ in topics["/tauv/truth/odometry"]] == [ns for ns, _ in odometry]
