"""The plug-in aiding sources' controls (app.dashboard.controls), driven by the registry: each field of a
source's section is a control with its Setting's label, unit and range; the controls read into
``Config.sources`` and ``run.aiding`` strictly; the address carries them and reads them back."""

from __future__ import annotations

import dataclasses

import pytest

from app.dashboard import links
from app.dashboard.budget import estimate_run
from app.dashboard.controls import DEFAULT_SOURCE_FIELDS, PLUGIN_FIELDS, PLUGIN_SOURCES
from app.dashboard.inputs import InputError, config_from_controls, config_markdown
from tauvcore.aiding.source import settings
from tauvcore.aiding.sources import FUSED, SOURCES
from tauvcore.config import Config
from tests.unit.app.dashboard.test_links import DEFAULTS


def with_fields(**typed: str | bool) -> tuple[tuple[str, str | bool], ...]:
    held = dict(DEFAULT_SOURCE_FIELDS)
    for key, value in typed.items():
        held[key.replace("__", ".")] = value
    return tuple(held.items())


def test_every_field_of_every_plug_in_has_a_control_with_its_default() -> None:
    assert [s.name for s in PLUGIN_SOURCES] == list(FUSED) == ["depth", "mag", "usbl"]
    # data for Yoo's methods, and the DVL's beams (its controls are the mission's: app/dashboard/control_table.py)
    assert set(SOURCES) - set(FUSED) == {"dvl", "echo", "rpm"}
    for source in FUSED.values():
        keys = [f"{source.section_name}.{name}" for name, _, _ in settings(source.config_type)]
        assert keys == [k for k in PLUGIN_FIELDS if k.startswith(source.section_name + ".")]
    config, _ = config_from_controls(DEFAULTS)
    assert config.sources == Config().sources and config.run.aiding == ("dvl",)
    assert (config.pressure, config.magnetometer) == (Config().pressure, Config().magnetometer)


def test_the_depth_and_magnetometer_controls_reach_their_own_sections() -> None:
    """The sources aboard are ticked and set as a plug-in is: their sections are ``[pressure]`` and
    ``[magnetometer]``, their controls' keys ``pressure.<field>`` and ``magnetometer.<field>``."""
    assert PLUGIN_FIELDS["pressure.noise_pa"].label == "Depth (pressure) noise [Pa]"
    assert PLUGIN_FIELDS["magnetometer.yaw_noise_deg"].label == "Magnetometer yaw noise [deg]"
    c = dataclasses.replace(
        DEFAULTS,
        aid_sources=("depth", "mag"),
        source_fields=with_fields(pressure__noise_pa="500", magnetometer__yaw_noise_deg="2.5"),
    )
    config, _ = config_from_controls(c)
    assert config.run.aiding == ("dvl", "depth", "mag")
    assert config.pressure.noise_pa == 500.0 and config.magnetometer.yaw_noise_deg == 2.5
    bad = dataclasses.replace(DEFAULTS, source_fields=with_fields(pressure__noise_pa="2e5"))
    with pytest.raises(InputError, match=r"Depth \(pressure\) noise \[Pa\]"):
        config_from_controls(bad)


def test_the_usbl_controls_carry_label_unit_and_range() -> None:
    interval = PLUGIN_FIELDS["usbl.interval_s"]
    assert (interval.label, interval.kind, interval.default) == ("USBL fix interval [s]", "number", "10")
    assert "[0.5, 600] s" in interval.hint
    assert PLUGIN_FIELDS["usbl.compensate_latency"].kind == "flag"
    lever = PLUGIN_FIELDS["usbl.lever_arm_b_m"]
    assert (lever.kind, lever.default) == ("vector", "0,0,-0.3") and "+-10 m" in lever.hint


def test_ticked_usbl_reads_into_its_section_and_the_aiding() -> None:
    c = dataclasses.replace(DEFAULTS, aid_sources=("usbl",), source_fields=with_fields(
        usbl__interval_s="2.5", usbl__compensate_latency=False, usbl__lever_arm_b_m=" 0.1, -0.2 ,1e-1"))
    config, _ = config_from_controls(c)
    usbl = config.section("usbl")
    assert config.run.aiding == ("dvl", "usbl")
    assert (usbl.interval_s, usbl.compensate_latency, usbl.lever_arm_b_m) == (2.5, False, (0.1, -0.2, 0.1))
    table = config_markdown(config, 1)
    assert "| USBL fix interval [s] | 2.5 |" in table and "| USBL compensates its latency | off |" in table
    # counted in the run's memory budget: its fixes are updates of every aided method
    assert estimate_run(config, 1).total_bytes > estimate_run(config_from_controls(DEFAULTS)[0], 1).total_bytes


@pytest.mark.parametrize(("key", "typed", "message"), [
    ("usbl.interval_s", "0.1",
     "USBL fix interval [s]: '0.1' is out of range: usbl.interval_s must be within [0.5, 600], got 0.1"),
    ("usbl.interval_s", "1e", "USBL fix interval [s]: '1e' is not a number"),
    ("usbl.lever_arm_b_m", "1,2", "USBL lever arm [m]: '1,2' is not three numbers separated by commas"),
    ("usbl.lever_arm_b_m", "0,0,11",
     "USBL lever arm [m]: '0,0,11' is out of range: usbl.lever_arm_b_m[2] must be within [-10, 10], got 11.0"),
    ("usbl.transceiver_n_m", "0,0,60",
     "USBL transceiver NED [m]: '0,0,60' is out of range: usbl.transceiver_n_m[2] must be within [0, 50], "
     "got 60.0"),
])
def test_a_bad_value_is_one_line_naming_the_control_and_the_value(key: str, typed: str, message: str) -> None:
    c = dataclasses.replace(DEFAULTS, aid_sources=("usbl",), source_fields=with_fields(**{key.replace(".", "__"): typed}))
    with pytest.raises(InputError) as info:
        config_from_controls(c)
    assert str(info.value) == message


def test_the_address_carries_the_plug_ins_and_reads_them_back() -> None:
    c = dataclasses.replace(DEFAULTS, aid_sources=("usbl",), source_fields=with_fields(
        usbl__interval_s="5", usbl__compensate_latency=False, usbl__transceiver_n_m="10,-20,1e+1"))
    query = links.address(c)
    assert "&usbl=1&" in query and "&usbl.interval_s=5&" in query and "usbl.transceiver_n_m=10,-20,1e1&" in query
    back = links.apply(DEFAULTS, links.parse(query))
    assert back == dataclasses.replace(c, source_fields=with_fields(
        usbl__interval_s="5", usbl__compensate_latency=False, usbl__transceiver_n_m="10,-20,1e1"))
    assert config_from_controls(back)[0] == config_from_controls(c)[0]
    # a hand-written link names some of them; a bad one is named and the rest applies
    link = links.parse("usbl=1&usbl.interval_s=5&usbl.lever_arm_b_m=0,x,0")
    assert link.problems == ("usbl.lever_arm_b_m='0,x,0': USBL lever arm [m]: '0,x,0' is not three numbers "
                             "separated by commas",)
    partial = links.apply(DEFAULTS, link)
    assert partial.aid_sources == ("usbl",) and dict(partial.source_fields)["usbl.interval_s"] == "5"
    assert links.apply(partial, links.parse("usbl=0")).aid_sources == ()
