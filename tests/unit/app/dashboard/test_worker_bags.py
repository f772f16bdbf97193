"""``tauv serve --logs DIR`` with ROS bags: the listing finds logs and bags (each named with its
kind), a bag's own mapping is the TOML file beside it, the worker replays a bag to the numbers of
``tauv replay BAG --bag-mapping`` that file (to 1e-9), and a bad mapping or bag is one line
naming the file, topic, key and value while the pool goes on (no browser)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.dashboard.worker import RunPool, run_worker
from tauvcore.config import from_dict, to_dict
from tauvcore.eval.replay import log_config, replay
from tauvcore.logs.bags import bag_kind, find_recordings, mapping_beside, own_mapping, read_bag, read_mapping
from tauvcore.logs.writer import write_log
from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

MAPPING = 'frame = "frd_ned"\n[dvl]\nbeam_ids = [0, 1, 2, 3]\n[config.dvl]\nnoise_mps = 0.03\n'
"""The FRD/NED recording's mapping, with a configuration key of its own (laid under the controls)."""
SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "pos_sigma_m", "vel_sigma_mps", "att_sigma_deg")


class _Queue(list):
    def put(self, message: tuple) -> None:
        self.append(message)


class _NeverStop:
    def is_set(self) -> bool:
        return False


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A directory of recordings: a log, a ROS 1 bag in FLU/ENU (no mapping), an MCAP file in
    FRD/NED with its mapping beside it, a ROS 2 sqlite3 bag directory in a subdirectory."""
    config = mission_config()
    beams, _ = mission_tables(config)
    root = tmp_path_factory.mktemp("logs")
    dvl = "marine_acoustic_msgs/msg/Dvl"
    write_log(root / "dive", beams, "csv")
    write_bag(root / "mission.bag", "ros1", beams, dvl, config.dvl.A_b, frame="flu_enu")
    write_bag(root / "frd.mcap", "mcap", beams, dvl, config.dvl.A_b, frame="frd_ned")
    (root / "frd.toml").write_text(MAPPING)
    (root / "day2").mkdir()
    write_bag(root / "day2" / "run_01", "sqlite3", beams, dvl, config.dvl.A_b, frame="flu_enu")
    (root / ".partial.mcap").write_bytes(b"")                # a writer's temporary: not offered
    return {"config": config, "root": root, "beams": beams}


def test_the_listing_names_logs_and_bags_with_their_kind(logs: dict) -> None:
    root = logs["root"]
    found = find_recordings(root)
    assert found == {
        "day2/run_01 (ROS 2, sqlite3)": str(root / "day2" / "run_01"),
        "dive": str(root / "dive"),
        "frd.mcap (ROS 2, mcap)": str(root / "frd.mcap"),
        "mission.bag (ROS 1)": str(root / "mission.bag"),
    }
    assert bag_kind(root / "day2" / "run_01") == "ROS 2, sqlite3"
    assert find_recordings(root / "day2" / "run_01") == {"run_01 (ROS 2, sqlite3)": str(root / "day2" / "run_01")}
    assert mapping_beside(root / "frd.mcap") == str(root / "frd.toml")
    assert mapping_beside(root / "mission.bag") is None and own_mapping(root / "mission.bag").path is None
    assert mapping_beside(str(root / "day2" / "run_01") + "/") is None
    raw, path = log_config(root / "frd.mcap")                 # the dashboard's "log's own configuration"
    assert raw == {"dvl": {"noise_mps": 0.03}} and path == str(root / "frd.toml")
    assert log_config(root / "mission.bag") == ({}, None)


def _worker_replay(config_dict: dict, path: str) -> _Queue:
    out = _Queue()
    run_worker(config_dict, 1, out, _NeverStop(), log_dir=path)
    return out


def test_the_worker_replays_a_bag_as_tauv_replay_does_to_1e_9(logs: dict, tmp_path: Path) -> None:
    """The MCAP file under its own mapping (frame, beam ids, a [config] key): the worker's results
    equal ``tauv replay BAG --bag-mapping MAPPING --json``'s and tauvcore's replay of the bag."""
    root, bag = logs["root"], str(logs["root"] / "frd.mcap")
    flags = ["--method", "ins,lc,tc", "--aiding", "dvl,depth,mag", "--earth", "flat"]
    out = tmp_path / "replay.json"
    assert main(["replay", bag, "--bag-mapping", str(root / "frd.toml"), *flags, "--json", str(out)]) == 0
    cli = json.loads(out.read_text())
    beside = tmp_path / "beside.json"       # without --bag-mapping: the mapping beside the bag, the same run
    assert main(["replay", bag, *flags, "--json", str(beside)]) == 0
    assert json.loads(beside.read_text())["results"] == cli["results"]
    # the dashboard's controls laid over the bag's own configuration, as tauv replay's flags are
    raw, _ = log_config(bag)
    config = from_dict(raw).replace("earth", model="flat").replace(
        "run", methods=("ins", "lc", "tc"), aiding=("dvl", "depth", "mag"))
    messages = _worker_replay(to_dict(config), bag)
    assert [m[0] for m in messages][:2] == ["config", "truth"] and messages[-1][0] == "done", messages[-1]
    replayed, source = from_dict(messages[0][1]), messages[0][2]
    assert replayed.dvl.noise_mps == 0.03 and cli["config"]["dvl"]["noise_mps"] == 0.03
    assert source["bag_mapping"] == source["config_file"] == str(root / "frd.toml")
    # the JSON's "log" section: the dashboard's (its source, and the bag's name) and tauv replay --json's alike
    for document in (cli, json.loads(beside.read_text())):
        assert set(source) - {"name"} == set(document["log"]), document["log"]
        assert document["log"]["bag_mapping"] == source["bag_mapping"]
    assert source["configuration"][1].startswith("the bag mapping's [config] in") and "dvl.noise_mps" in source[
        "configuration"][1]
    results = messages[-1][1]
    want = replay(config, read_bag(bag, read_mapping(root / "frd.toml"), config.dvl.A_b),
                  np.random.default_rng(config.run.seed))[1]
    assert set(results) == set(want) == set(cli["results"]) == {"ins", "lc", "tc"}
    for method, r in results.items():
        np.testing.assert_array_equal(r.t_s, want[method].t_s)
        np.testing.assert_allclose(r.t_s, cli["results"][method]["t"], rtol=0, atol=1e-9)
        for name in SERIES:
            got = getattr(r, name)[:, 0]
            for expected in (getattr(want[method], name)[:, 0], np.array(cli["results"][method][name], dtype=float)):
                np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * max(np.nanmax(np.abs(expected)), 1.0),
                                           err_msg=f"{method} {name}")
        np.testing.assert_allclose(r.est_pos_n[:, 0, 0], cli["results"][method]["est_north_m"], rtol=0, atol=1e-9)
    # a ROS 1 bag in ROS's own frames, no mapping: the same numbers as tauv replay BAG
    plain = str(root / "mission.bag")
    messages = _worker_replay(to_dict(config.replace("dvl", noise_mps=0.042)), plain)
    assert messages[-1][0] == "done" and messages[0][2]["bag_mapping"] is None and messages[0][2]["config_file"] is None
    assert main(["replay", plain, *flags, "--json", str(tmp_path / "plain.json")]) == 0
    assert json.loads((tmp_path / "plain.json").read_text())["log"]["bag_mapping"] is None
    want = replay(config.replace("dvl", noise_mps=0.042), read_bag(plain, read_mapping(None), config.dvl.A_b),
                  np.random.default_rng(config.run.seed))[1]
    for method, r in messages[-1][1].items():
        np.testing.assert_allclose(r.pos_err_m, want[method].pos_err_m, rtol=0, atol=1e-9)


def _next(handle, timeout: float = 60.0):
    return handle.queue.get(timeout=timeout)


def _error(pool: RunPool, config_dict: dict, path: Path) -> str:
    handle = pool.start(config_dict, 1, log_dir=str(path))
    kind, message = _next(handle)
    assert kind == "error", (kind, message)
    assert "\n" not in message and "Traceback" not in message and "bug" not in message, message
    return message


def test_a_bad_mapping_or_bag_is_one_line_and_the_pool_goes_on(logs: dict, tmp_path: Path) -> None:
    """A bad value in the mapping beside the bag, a topic the bag lacks, a truncated bag: each one
    line naming the file, the key or topic and the value; then a good bag replays."""
    config, root = logs["config"], logs["root"]
    good = root / "mission.bag"
    bags = tmp_path / "bags"
    bags.mkdir()
    bad_value = bags / "bad_value.bag"
    bad_value.write_bytes(good.read_bytes())
    (bags / "bad_value.toml").write_text('frame = "nwu"\n')
    no_topic = bags / "no_topic.bag"
    no_topic.write_bytes(good.read_bytes())
    (bags / "no_topic.toml").write_text('[dvl]\ntopic = "/no/such"\n')
    truncated = bags / "truncated.bag"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    assert set(find_recordings(bags)) == {"bad_value.bag (ROS 1)", "no_topic.bag (ROS 1)", "truncated.bag (ROS 1)"}
    config_dict = to_dict(config)
    pool = RunPool(workers=1)
    try:
        message = _error(pool, config_dict, bad_value)
        assert "bad_value.toml" in message and "frame" in message and "'nwu'" in message, message
        message = _error(pool, config_dict, no_topic)
        assert "no_topic.toml" in message and "dvl.topic" in message and "'/no/such'" in message, message
        message = _error(pool, config_dict, truncated)
        assert "truncated.bag" in message and "cannot be read" in message, message
        handle = pool.start(config_dict, 1, log_dir=str(good))
        while (msg := _next(handle))[0] not in ("done", "error"):
            pass
        assert msg[0] == "done" and msg[1]["lc"].t_s[-1] == pytest.approx(20.0), msg
    finally:
        pool.shutdown()


def test_a_bag_s_name_survives_the_page_s_address() -> None:
    """A bag's name (a slash, spaces, parentheses, a comma) is escaped in the address and read back,
    also as viser's page rewrites the query (percent-decoded, the browser escaping the spaces)."""
    import dataclasses
    from urllib.parse import unquote

    from app.dashboard import links
    from tests.unit.app.dashboard.test_links import DEFAULTS
    name = "day2/run_01 (ROS 2, mcap)"
    query = links.encode(dataclasses.replace(DEFAULTS, source=name))
    for seen in (query, unquote(query).replace(" ", "%20")):
        link = links.parse(seen, ("simulation", name))
        assert link.problems == () and link.values["source"] == name, link
