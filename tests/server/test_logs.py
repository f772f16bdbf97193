"""``tauv serve --logs DIR``: a tab picks a recorded log as its source and replays it; a bad log
is a notification and the server goes on serving (no browser: viser's protocol)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from tauvcore.config import Config
from tauvcore.eval.runner import SimChunk, simulate
from tauvcore.logs import simulation_tables, write_log
from tests.server.conftest import Server
from tests.server.viser_client import ViserClient


def _notification(client: ViserClient, mark: int) -> dict:
    _, message = client.wait_for(lambda m: m.get("type") == "NotificationShowMessage", 120.0, "a notification",
                                 since=mark)
    return message["props"]


def test_a_tab_replays_a_log_and_a_bad_one_is_a_notification(tmp_path: Path) -> None:
    config = Config().replace("trajectory", name="figure8", duration_s=20.0)
    sim = simulate(config, np.random.default_rng(2))
    write_log(tmp_path / "logs" / "good", simulation_tables([SimChunk.whole(sim)]))
    write_log(tmp_path / "logs" / "bad", simulation_tables([SimChunk.whole(sim)]))
    (tmp_path / "logs" / "bad" / "imu.csv").write_text("t_s,dtheta_x_rad\n0.0,0.0\n0.01,0.0\n0.02,0.0\n")
    server = Server(tmp_path / "server.log", extra=["--logs", str(tmp_path / "logs")])
    try:
        client = ViserClient(server.url)
        source = client.find("Source")
        assert source is not None
        # Truth picks a simulation's generator: a log replays its own reference, so it is disabled
        truth = client.find("Truth")
        client.set_value("Truth", "dynamic")
        mark = client.mark()
        client.set_value("Source", "good")
        client.wait_for(lambda m: m.get("type") == "GuiUpdateMessage" and m.get("uuid") == truth
                        and m["updates"].get("disabled") is True, 10.0, "Truth disabled", since=mark)
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run complete", props
        table = client.value(client.markdown_containing("Configuration run"))
        assert re.search(r"\|\s*Duration \[s\]\s*\|\s*20\s*\|", table), table      # the log's length, not 250 s
        assert re.search(r"\|\s*Truth\s*\|\s*kinematic\s*\|", table), table          # not the disabled control's
        assert client.markdown_containing("a recorded log has no actuator record") is not None
        client.set_value("Source", "bad")
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run failed" and "imu.csv" in props["body"] and "dtheta_y_rad" in props["body"]
        client.set_value("Source", "good")
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
