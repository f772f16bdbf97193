"""The dashboard's controls in the page's address (app/dashboard/links.py).

Every control round-trips through the query; the query survives viser's own rewrite of it (the
page's client decodes it and writes it back unescaped on connect); a bad key or value is refused
with one line naming the key and the value while the rest still applies.
"""

from __future__ import annotations

import dataclasses
import re
from urllib.parse import parse_qsl, quote

import pytest

from app.dashboard import links
from app.dashboard.controls import PLUGIN_SOURCES
from app.dashboard.inputs import SIMULATION, Controls, config_from_controls
from tauvcore.config import RUN_METHODS

DEFAULTS = Controls(trajectory="straight", duration="250", methods=("ins", "lc", "tc", "nsv", "elc"),
                    vb_nf="20", nsv_epsilon="auto",
                    beams=(1, 2, 3, 4), dropout="0", outages=(("0", "0"),) * 4,
                    accel_bias="0.5", gyro_bias="3", accel_noise="0.072", gyro_noise="0.34", dvl_noise="0.042",
                    dvl_bias="0.005", dvl_sf="0.7", seabed_depth="60", dvl_max_altitude="100", switch_altitude="100",
                    rpm_noise="2", seed="0", runs="1")
"""What a new page's controls hold (as tests/unit/app/dashboard/test_session_inputs.py has them)."""
CHANGED = Controls(trajectory="figure8", duration="1e3", methods=("lc", "vb", "ins-dvl", "vkf"), vb_nf="7.5",
                   nsv_epsilon="0.05", beams=(1, 3), dropout="0.05",
                   outages=(("0", "0"), ("10", "20.5"), ("0", "0"), ("50", "2E2")),
                   accel_bias="0.25", gyro_bias="1.5", accel_noise="0.1", gyro_noise="0.5", dvl_noise="0.08",
                   dvl_bias="0.01", dvl_sf="1", seabed_depth="110", dvl_max_altitude="90", switch_altitude="80",
                   rpm_noise="0", seed="42", runs="3", source="pool-log_2", truth="dynamic", rpm_fallback=True,
                   aid_sources=("depth", "mag"), water_track="beyond_range", current_states="gauss-markov")
"""Every control away from its default."""
SOURCES = (SIMULATION, "pool-log_2")


def read(query: str, sources: tuple[str, ...] = SOURCES) -> tuple[Controls, links.Link]:
    link = links.parse(query, sources)
    return links.apply(DEFAULTS, link), link


def viser_rewrite(query: str) -> str:
    """What viser's page makes of the query on connect (client/src/SearchParamsUtils.ts): read
    with URLSearchParams (percent-decoded, ``+`` as a space) and written back as ``k=v`` without
    escapes; the browser then escapes what an address cannot hold (a space as %20)."""
    pairs = parse_qsl(query.lstrip("?"), keep_blank_values=True)
    raw = "&".join(f"{k}={v}" for k, v in pairs)
    return "?" + quote(raw, safe="&=,:.-_~+/?")


def test_every_control_has_one_key() -> None:
    fields = {f.name for f in dataclasses.fields(Controls)}
    assert {k.field for k in links.KEYS} == fields
    assert len({k.key for k in links.KEYS}) == len(links.KEYS)
    assert all(k.kind in links.KINDS for k in links.KEYS)


@pytest.mark.parametrize("controls", [DEFAULTS, CHANGED], ids=["defaults", "every-control-changed"])
def test_every_control_round_trips(controls: Controls) -> None:
    query = links.address(controls)
    back, link = read(query)
    assert link.problems == () and back == controls
    # only characters a query needs no escape for: viser's rewrite leaves it as it is
    assert re.fullmatch(r"\?[A-Za-z0-9._~,:=&-]*", query), query
    assert viser_rewrite(query) == query


def test_the_link_of_a_simulation_names_no_source_and_a_log_s_does() -> None:
    assert "src=" not in links.encode(DEFAULTS)
    assert links.encode(CHANGED).startswith("src=pool-log_2&traj=figure8&truth=dynamic&dur=1e3&m=lc,vb,ins-dvl,vkf")


def test_a_link_reads_back_into_the_same_configuration() -> None:
    back, _ = read(links.address(dataclasses.replace(CHANGED, source=SIMULATION, runs="1")))
    assert config_from_controls(back) == config_from_controls(dataclasses.replace(CHANGED, source=SIMULATION,
                                                                                  runs="1"))


def test_a_plus_sign_is_dropped_and_a_space_viser_made_of_it_is_read_back() -> None:
    typed = dataclasses.replace(DEFAULTS, duration=" 1e+3 ", accel_bias="+0.5", outages=(("1e+1", "+20"),) * 4)
    query = links.address(typed)
    assert "+" not in query and "dur=1e3" in query and "ab=0.5" in query and "o1=1e1:20" in query
    # a link typed by hand with a "+": viser's page turns it into a space before the server reads it
    back, link = read(viser_rewrite("?dur=1e+3&o2=1e+1:2e+1&seed=5"))
    assert link.problems == ()
    assert back.duration == "1e+3" and back.outages[1] == ("1e+1", "2e+1") and back.seed == "5"


def test_a_partial_link_sets_only_what_it_names() -> None:
    back, link = read("?traj=lawnmower&m=tc&b=1,2&o3=50:200")
    assert link.keys == ("traj", "m", "b", "o3")
    assert back == dataclasses.replace(DEFAULTS, trajectory="lawnmower", methods=("tc",), beams=(1, 2),
                                       outages=(("0", "0"), ("0", "0"), ("50", "200"), ("0", "0")))
    assert link.labels() >= {"Trajectory", "Methods", "DVL beams", "Beam 3 outage start", "Beam 3 outage end"}


def test_empty_lists_are_no_methods_and_no_beams() -> None:
    back, link = read("?m=&b=")
    assert link.problems == () and back.methods == () and back.beams == ()


@pytest.mark.parametrize("part, named", [
    ("zzz=1", "'zzz'='1': unknown key"),
    ("dur=abc", "dur='abc': Duration [s]: 'abc' is not a number"),
    ("dur=nan", "dur='nan'"),
    ("dur=", "dur='': Duration [s]: empty"),
    ("traj=spiral", "traj='spiral': Trajectory: choose from straight, figure8"),
    ("truth=6dof", "truth='6dof'"),
    ("src=elsewhere", "src='elsewhere'"),
    ("m=ins,kalman", "m='ins,kalman': 'kalman' is not a method"),
    ("m=lc,lc", "m='lc,lc': a repeated entry"),
    ("b=1,5", "b='1,5': '5' is not a beam"),
    ("fb=yes", "fb='yes': expected 1 (on) or 0 (off)"),
    ("o3=50", "o3='50': expected start:end"),
    ("o3=a:200", "o3='a:200': Beam 3 outage start: 'a' is not a number"),
    ("eps=autox", "eps='autox'"),
    ("seed=2.5", "seed='2.5': Seed: '2.5' is not a whole number"),
    ("runs=1e3", "runs='1e3'"),
    ("nf=" + "9" * 50, "nf='999"),
    ("%E9t%E9=1", "unknown key"),
])
def test_a_bad_key_or_value_is_named_and_the_rest_applies(part: str, named: str) -> None:
    back, link = read(f"?dep=1&{part}&seed=7")
    assert len(link.problems) == 1, link.problems
    assert named in link.problems[0]
    assert "Error" not in link.problems[0] and "Traceback" not in link.problems[0]
    assert "depth" in back.aid_sources and back.seed == "7"  # dep: the depth's short key


def test_a_repeated_key_is_named_and_the_first_applies() -> None:
    back, link = read("?dur=10&dur=20")
    assert back.duration == "10"
    assert link.problems == ("dur='20': dur is given twice; the first one applies",)


def test_viser_s_own_parameters_are_kept_not_refused() -> None:
    link = links.parse("?darkMode&initialCameraPosition=1,2,3&traj=figure8")
    assert link.problems == () and link.viser_params == ("darkMode", "initialCameraPosition=1,2,3")
    query = links.address(DEFAULTS, link.viser_params)
    assert query.startswith("?darkMode&initialCameraPosition=1,2,3&traj=straight&")


def test_an_overlong_query_is_refused_whole() -> None:
    link = links.parse("?seed=1&" + "x" * links.MAX_QUERY_CHARS)
    assert link.values == {} and len(link.problems) == 1 and "characters long" in link.problems[0]


def test_no_query_sets_nothing() -> None:
    for query in ("", "?", "?&&"):
        link = links.parse(query)
        assert link.values == {} and link.problems == () and link.keys == ()


def test_methods_are_written_in_the_page_s_order() -> None:
    reordered = dataclasses.replace(DEFAULTS, methods=tuple(reversed(RUN_METHODS)))
    assert f"m={','.join(RUN_METHODS)}&" in links.encode(reordered)


class _Tab:
    """The controls of app.dashboard.session_controls.ControlPanel as plain values, with its link methods."""

    def __init__(self) -> None:
        from types import SimpleNamespace

        from app.dashboard.session_controls import ControlPanel

        def handle(value: object) -> SimpleNamespace:
            return SimpleNamespace(value=value)
        self.source = None
        self.preset = None
        self.notes: list[tuple[str, str]] = []
        self.status = SimpleNamespace(content="Ready. Choose a mission and press **Run**.")
        for name in ("trajectory", "truth", "duration", "vb_nf", "nsv_epsilon", "dropout", "rpm_fallback",
                     "accel_bias", "gyro_bias", "accel_noise", "gyro_noise", "dvl_noise",
                     "dvl_bias", "dvl_sf", "seabed_depth", "dvl_max_altitude", "switch_altitude", "rpm_noise", "seed",
                     "runs", "smoother", "smoother_mb", "current_speed", "current_toward", "current_shear",
                     "current_variation", "water_track", "current_states"):
            setattr(self, name, handle(getattr(DEFAULTS, name)))
        self.method_boxes = {m: handle(m in DEFAULTS.methods) for m in RUN_METHODS}
        self.beam_boxes = [handle(True) for _ in range(4)]
        self.outage = [(handle("0"), handle("0")) for _ in range(4)]
        self.source_boxes = {p.name: handle(p.name in DEFAULTS.aid_sources) for p in PLUGIN_SOURCES}
        self.source_fields = {key: handle(value) for key, value in DEFAULTS.source_fields}
        for method in ("controls", "set_controls", "selected_methods", "apply_trajectory_preset", "apply_link",
                       "_text_fields"):
            setattr(self, method, getattr(ControlPanel, method).__get__(self))

    def notify(self, title: str, body: str, error: bool = False) -> None:
        self.notes.append((title, body))


def test_the_page_applies_a_link_over_the_preset_it_does_not_cover() -> None:
    """A hand-written ``?traj=longrange&seed=4`` gets longrange's preset (Duration 1440 s, Seabed
    110 m), as picking it in the dropdown does, and then its own seed; a full link of longrange
    sets every control itself, and its bad key is named in one notification."""
    tab = _Tab()
    tab.apply_link("?traj=longrange&seed=4")
    c = tab.controls()
    assert (c.trajectory, c.duration, c.seabed_depth, c.seed) == ("longrange", "1440", "110", "4")
    assert [title for title, _ in tab.notes] == ["Preset longrange applied"] and tab.preset == "longrange"
    assert tab.status.content.startswith("Ready. The page's address set 2 control(s)")

    full = dataclasses.replace(DEFAULTS, trajectory="longrange", duration="30", seabed_depth="90")
    other = _Tab()
    other.apply_link(links.address(full) + "&bad=1")
    assert other.controls() == full and other.preset == "longrange"
    assert other.notes == [("Address: settings not applied",
                            "'bad'='1': unknown key (the keys are " + ", ".join([*links.BY_KEY, *links.VIEW_KEYS]) + ")")]


def test_the_view_keys_are_read_kept_and_refused_by_name() -> None:
    """The time, the zoomed time range and the camera ride in the address beside the controls:
    parsed into Link.view (not controls), written back by address(), and a bad value is refused
    in one line naming the key and the value, the rest still applied."""
    view = {"t": 60.0, "x": (20.0, 80.5), "cam": ((10.0, -20.0, 5.0), (0.0, 0.0, -30.0))}
    query = links.address(DEFAULTS, (), view)
    assert "&t=60.00&x=20.000:80.500&cam=10.00,-20.00,5.00,0.00,0.00,-30.00" in query
    link = links.parse(query)
    assert link.problems == () and link.view == view and "t" not in link.keys
    assert links.apply(DEFAULTS, link) == DEFAULTS
    bad = links.parse("?seed=4&t=abc&x=50:20&cam=1,2,3&t=5")
    assert bad.values == {"seed": "4"} and bad.view == {"t": 5.0} and len(bad.problems) == 3
    assert bad.problems[0].startswith("t='abc': Time [s]: 'abc'")
    assert bad.problems[1] == "x='50:20': Time range [s]: '50:20' does not end after it starts"
    assert bad.problems[2] == "cam='1,2,3': Camera: expected 6 numbers separated by ','"
    assert links.parse("?t=-1").problems == ("t='-1': Time [s]: '-1' is before the start (0 s)",)
    assert links.parse("?t=1&t=2").problems == ("t='2': t is given twice; the first one applies",)


def test_the_series_picks_ride_in_the_address_as_typed() -> None:
    """The Series tab's two pick lists are view keys: written with their slashes, commas and the
    XY's semicolon readable, read back as typed (a plus the address holds read as the space it
    was), and a character no series name has refused by name."""
    view = {"series": "lc/vel_err_mps, tc/dvl/nis", "xy": "lc/est_east_m; lc/est_north_m"}
    query = links.address(DEFAULTS, (), view)
    assert "&series=lc/vel_err_mps,%20tc/dvl/nis&xy=lc/est_east_m;%20lc/est_north_m" in query
    link = links.parse(query)
    assert link.problems == () and link.view == view
    assert links.parse("?series=lc/a_m,+tc/b_m").view == {"series": "lc/a_m, tc/b_m"}
    bad = links.parse("?series=lc/a_m<script>")
    assert bad.view == {} and bad.problems == ("series='lc/a_m<script>': Time plot: 'lc/a_m<script>' holds '<>', which no series name has",)
