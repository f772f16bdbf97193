"""A plug-in aiding source in the dashboard (app.dashboard.controls, from tauvcore.aiding.sources): ticked
with its section's controls it aids a simulation and a replay of a log that holds its table; a bad
value in one of its controls is one notification naming the control and the value, and the
server goes on serving (no browser: viser's protocol)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from app.dashboard.controls import PLUGIN_FIELDS
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs.writer import simulation_tables, write_log
from tests.server.conftest import Server
from tests.server.viser_client import ViserClient

INTERVAL = PLUGIN_FIELDS["usbl.interval_s"].label


def _notification(client: ViserClient, mark: int) -> dict:
    _, message = client.wait_for(lambda m: m.get("type") == "NotificationShowMessage", 120.0, "a notification",
                                 since=mark)
    return message["props"]


def test_usbl_ticked_aids_a_simulation_and_a_replay_and_a_bad_value_is_named(tmp_path: Path) -> None:
    config = Config().replace("trajectory", name="figure8", duration_s=20.0).replace("run", aiding=("dvl", "usbl"))
    sim = simulate(config, np.random.default_rng(2))
    tables = simulation_tables([SimChunk.whole(sim)])
    assert len(tables["usbl"]["t_s"]) > 0
    write_log(tmp_path / "logs" / "fixed", tables)
    server = Server(tmp_path / "server.log", extra=["--logs", str(tmp_path / "logs")])
    try:
        client = ViserClient(server.url)
        client.wait_for(lambda m: "replaceState" in str(m.get("source", "")), 60.0, "the page's address")
        assert client.find("USBL") is not None and client.find(INTERVAL) is not None
        client.set_value("Duration [s]", "20")
        client.set_value("USBL", True)
        client.set_value(INTERVAL, "0.1")
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Cannot run", props
        assert props["body"] == (f"{INTERVAL}: '0.1' is out of range: usbl.interval_s must be within [0.5, 600], "
                                 "got 0.1"), props
        client.set_value(INTERVAL, "abc")
        mark = client.mark()
        client.click("Run")
        assert _notification(client, mark)["body"] == f"{INTERVAL}: 'abc' is not a number"
        # the address carries the source and its fields
        mark = client.mark()
        client.set_value(INTERVAL, "2")
        client.wait_for(lambda m: "usbl=1&" in str(m.get("source", "")) and "usbl.interval_s=2&" in str(m["source"]),
                        30.0, "the address with the USBL", since=mark)
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run complete", props
        table = client.value(client.markdown_containing("Configuration run"))
        assert re.search(r"\|\s*Aiding\s*\|\s*dvl, usbl\s*\|", table), table
        assert re.search(rf"\|\s*{re.escape(INTERVAL)}\s*\|\s*2\s*\|", table), table
        # a log with a usbl table replays aided by it
        mark = client.mark()
        client.set_value("Source", "fixed")
        assert _notification(client, mark)["title"] == "Log fixed"
        mark = client.mark()
        client.click("Run")
        props = _notification(client, mark)
        assert props["title"] == "Run complete", props
        table = client.value(client.markdown_containing("Configuration run"))
        assert re.search(r"\|\s*Source\s*\|\s*log fixed\s*\|", table), table
        assert re.search(r"\|\s*Aiding\s*\|\s*dvl, usbl\s*\|", table), table
        assert "Traceback" not in server.text()
        client.close()
    finally:
        server.kill()
