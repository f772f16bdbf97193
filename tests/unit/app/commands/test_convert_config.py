"""``tauv log convert`` writes the configuration the conversion used as the log's own ``log.toml``
(tauvcore.config.to_log_toml, as ``tauv run --save-log`` writes a simulation's): a replay of the
converted log is configured as a replay of the bag, and gives its numbers."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from tauvcore.config import from_dict, to_dict
from tauvcore.eval.replay import log_config
from tauvcore.logs import CONFIG_FILE
from tests.unit.helpers.bag_fixtures import LEVER_ARM_B_M, mission_config, mission_tables, write_bag

MAPPING = """
[config.earth]
model = "flat"

[config.dvl]
noise_mps = 0.03

[config.reference]
yaw_deg = 0.2
"""
"""A bag mapping whose [config] sets the earth model, the DVL's noise and the reference's sigma;
the lever arm comes from the bag's /tf_static."""


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("bag")
    config = mission_config()
    beams, _ = mission_tables(config)
    bag = write_bag(
        root / "m.mcap",
        "mcap",
        beams,
        "marine_acoustic_msgs/msg/Dvl",
        config.dvl.A_b,
        frame="flu_enu",
        tf_static=True,
    )
    mapping = root / "mapping.toml"
    mapping.write_text(MAPPING)
    return bag, mapping


def _replay(target: Path, json_path: Path, *argv: str) -> dict:
    flags = ("--method", "ins,lc", "--aiding", "dvl,depth,mag")
    assert main(["replay", str(target), *flags, "--json", str(json_path), *argv]) == 0
    return json.loads(json_path.read_text())


def test_a_converted_bag_carries_the_configuration_it_was_converted_with(
    bag: tuple[Path, Path], tmp_path: Path
) -> None:
    """log.toml holds the mapping's [config] sections and the /tf_static lever arm, whole; the
    replay reading it has the configuration and the numbers of the replay of the bag."""
    path, mapping = bag
    out = tmp_path / "log"
    assert main(["log", "convert", str(path), str(out), "--bag-mapping", str(mapping)]) == 0
    raw = tomllib.loads((out / CONFIG_FILE).read_text(encoding="utf-8"))
    assert set(raw) == {"earth", "dvl", "reference"}  # the sections that differ from the defaults
    np.testing.assert_allclose(raw["dvl"]["lever_arm_m"], LEVER_ARM_B_M, rtol=0, atol=1e-12)
    assert raw["dvl"]["noise_mps"] == 0.03 and raw["earth"]["model"] == "flat"
    assert raw["reference"]["yaw_deg"] == 0.2
    assert to_dict(from_dict(raw))["dvl"] == raw["dvl"] | {"outages": [], "dropout_probability": 0.0}
    from_bag = _replay(path, tmp_path / "bag.json", "--bag-mapping", str(mapping))
    from_log = _replay(out, tmp_path / "log.json")
    assert log_config(out)[1] == str(out / CONFIG_FILE)
    assert from_log["config"] == from_bag["config"]
    assert from_log["log"]["reference"] == from_bag["log"]["reference"]
    for method in ("ins", "lc"):
        for name in ("pos_err_m", "vel_err_mps", "nees_tilt", "nees_heading"):
            np.testing.assert_allclose(
                np.array(from_log["results"][method][name], dtype=float),
                np.array(from_bag["results"][method][name], dtype=float),
                rtol=1e-12,
                atol=1e-12,
                err_msg=f"{method} {name}",
            )


def test_a_bag_with_nothing_to_say_gives_no_log_toml(bag: tuple[Path, Path], tmp_path: Path) -> None:
    """A bag without a mapping or /tf_static converts with the defaults: no log.toml, as a
    simulation at its defaults writes none (nothing differs to be said)."""
    config = mission_config()
    beams, _ = mission_tables(config)
    plain = write_bag(
        tmp_path / "p.mcap", "mcap", beams, "marine_acoustic_msgs/msg/Dvl", config.dvl.A_b, frame="flu_enu"
    )
    assert main(["log", "convert", str(plain), str(tmp_path / "log")]) == 0
    assert not (tmp_path / "log" / CONFIG_FILE).exists()
