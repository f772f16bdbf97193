"""``tauv serve --logs DIR``: a tab picks a recorded log or a ROS bag as its source and replays it;
a bad log, bag or bag mapping is a notification and the server goes on serving (no browser:
viser's protocol)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs.writer import simulation_tables, write_log
from tests.server.conftest import Server
from tests.server.viser_client import ViserClient


def _notification(client: ViserClient, mark: int) -> dict:
    # a run's notification: seconds alone, minutes while the suite's other workers load the machine
    _, message = client.wait_for(lambda m: m.get("type") == "NotificationShowMessage", 300.0, "a notification",
                                 since=mark)
    return message["props"]


def test_a_tab_replays_a_log_and_a_bad_one_is_a_notification(tmp_path: Path) -> None:
    config = Config().replace("trajectory", name="figure8", duration_s=20.0)
    sim = simulate(config, np.random.default_rng(2))
    write_log(tmp_path / "logs" / "good", simulation_tables([SimChunk.whole(sim)]))
    # the log's own configuration: a control's field (DVL noise) and one without a control
    (tmp_path / "logs" / "good" / "log.toml").write_text("[dvl]\nnoise_mps = 0.05\nlever_arm_m = [0.5, 0.0, 0.2]\n")
    write_log(tmp_path / "logs" / "bad", simulation_tables([SimChunk.whole(sim)]))
    (tmp_path / "logs" / "bad" / "imu.csv").write_text("t_s,dtheta_x_rad\n0.0,0.0\n0.01,0.0\n0.02,0.0\n")
    server = Server(tmp_path / "server.log", extra=["--logs", str(tmp_path / "logs")])
    try:
        client = ViserClient(server.url)
        # the tab's callbacks are in place once it has shown its controls in the page's address
        client.wait_for(lambda m: "replaceState" in str(m.get("source", "")), 60.0, "the page's address")
        source = client.find("Source")
        assert source is not None
        # Truth picks a simulation's generator: a log replays its own reference, so it is disabled
        truth = client.find("Truth")
        client.set_value("Truth", "dynamic")
        mark = client.mark()
        client.set_value("Source", "good")
        client.wait_for(lambda m: m.get("type") == "GuiUpdateMessage" and m.get("uuid") == truth
                        and m["updates"].get("disabled") is True, 30.0, "Truth disabled", since=mark)
        props = _notification(client, mark)
        assert props["title"] == "Log good: its log.toml applied", props
        assert "DVL noise" in props["body"] and "dvl.lever_arm_m apply at Run" in props["body"], props
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run complete", props
        done = client.markdown_containing("Run complete: log good, 20 s")
        assert done is not None
        status = client.value(done)
        assert "with DVL noise 0.05 m/s" in status, status          # the settings the replay ran with
        table = client.value(client.markdown_containing("Configuration run"))
        assert re.search(r"\|\s*Duration \[s\]\s*\|\s*20\s*\|", table), table      # the log's length, not 250 s
        assert re.search(r"\|\s*Source\s*\|\s*log good\s*\|", table), table
        assert re.search(r"\|\s*Log configuration\s*\|\s*\S*good/log.toml\s*\|", table), table
        assert re.search(r"\|\s*Start\s*\|\s*start: on the reference", table), table
        assert re.search(r"\|\s*DVL noise[^|]*\|\s*0.05\s*\|", table), table       # the log's own value
        assert "Trajectory" not in table and "| Truth" not in table and "Seabed" not in table, table
        assert client.markdown_containing("a recorded log has no actuator record") is not None
        mark = client.mark()
        client.set_value("Source", "bad")
        props = _notification(client, mark)
        assert props["title"] == "Log bad" and "No configuration file" in props["body"], props
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run failed" and "imu.csv" in props["body"] and "dtheta_y_rad" in props["body"]
        mark = client.mark()
        client.set_value("Source", "good")
        assert _notification(client, mark)["title"] == "Log good: its log.toml applied"
        client.set_value("Runs", "3")
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Cannot run" and "replayed once" in props["body"]
        mark = client.mark()
        client.set_value("Source", "simulation")
        client.wait_for(lambda m: m.get("type") == "GuiUpdateMessage" and m.get("uuid") == truth
                        and m["updates"].get("disabled") is False, 10.0, "Truth enabled again", since=mark)
        assert "Traceback" not in server.text()
        client.close()
    finally:
        server.kill()


def test_a_tab_replays_a_bag_under_its_own_mapping_and_a_bad_one_is_a_notification(tmp_path: Path) -> None:
    """An MCAP file in FRD/NED with its mapping beside it (frd.toml, a [config] key), a bag whose
    mapping has a bad value, a bag whose mapping names a topic it lacks."""
    from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

    config = mission_config()
    beams, _ = mission_tables(config)
    logs = tmp_path / "logs"
    logs.mkdir()
    write_bag(logs / "frd.mcap", "mcap", beams, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b, frame="frd_ned")
    (logs / "frd.toml").write_text('frame = "frd_ned"\n[config.dvl]\nnoise_mps = 0.03\n[config.earth]\nmodel = "flat"\n')
    (logs / "nwu.bag").write_bytes(b"")  # never opened: its mapping is refused first
    (logs / "nwu.toml").write_text('frame = "nwu"\n')
    (logs / "lost.toml").write_text('[dvl]\ntopic = "/no/such"\n')
    write_bag(logs / "lost.bag", "ros1", beams, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b, frame="flu_enu")
    server = Server(tmp_path / "server.log", extra=["--logs", str(logs)])
    try:
        client = ViserClient(server.url)
        client.wait_for(lambda m: "replaceState" in str(m.get("source", "")), 60.0, "the page's address")
        mark = client.mark()
        client.set_value("Source", "frd.mcap (ROS 2, mcap)")
        props = _notification(client, mark)
        assert props["title"].startswith("Bag frd.mcap (ROS 2, mcap): its mapping's [config]"), props
        assert "frd.toml" in props["title"] and "DVL noise" in props["body"], props
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run complete", props
        table = client.value(client.markdown_containing("Configuration run"))
        assert re.search(r"\|\s*Source\s*\|\s*log frd.mcap\s*\|", table), table
        assert re.search(r"\|\s*Bag mapping\s*\|\s*\S*frd.toml\s*\|", table), table
        assert re.search(r"\|\s*DVL noise[^|]*\|\s*0.03\s*\|", table), table
        assert re.search(r"\|\s*Duration \[s\]\s*\|\s*20\s*\|", table), table
        mark = client.mark()
        client.set_value("Source", "nwu.bag (ROS 1)")
        props = _notification(client, mark)
        assert props["title"] == "Log configuration not applied" and "nwu.toml" in props["body"], props
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Cannot run" and "frame" in props["body"] and "'nwu'" in props["body"], props
        mark = client.mark()
        client.set_value("Source", "lost.bag (ROS 1)")
        props = _notification(client, mark)
        assert props["title"] == "Bag lost.bag (ROS 1)" and "lost.toml has no [config]" in props["body"], props
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run failed", props
        assert "lost.toml" in props["body"] and "dvl.topic" in props["body"] and "'/no/such'" in props["body"], props
        assert "Traceback" not in server.text()
        client.close()
    finally:
        server.kill()
