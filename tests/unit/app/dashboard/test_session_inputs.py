"""The dashboard's typed values: read strictly, never coerced.

Each case of the issue has a test: before, the browser's number field and the server's casts
turned "1e3" into 13 s, Seed 1e30 into 130, "abc", "NaN" and an empty Duration into 250 s,
Seed 2.5 into 2 and Duration 0.5 into 0, and Gyro noise 1e6 reached the worker and came back as
"LinAlgError: Singular matrix".
"""

from __future__ import annotations

import dataclasses

import pytest

from app.dashboard.controls import DEFAULT_SOURCE_FIELDS, PLUGIN_SOURCES
from app.dashboard.inputs import (
    ACCEL_BIAS,
    ACCEL_NOISE,
    DURATION,
    DVL_MAX_ALTITUDE,
    GYRO_BIAS,
    GYRO_NOISE,
    NSV_EPSILON,
    RPM_FALLBACK,
    RPM_NOISE,
    SEABED_DEPTH,
    SWITCH_ALTITUDE,
    TRUTH,
    VB_NF,
    Controls,
    InputError,
    config_from_controls,
    config_markdown,
    parse_float,
    parse_float_or_auto,
    parse_int,
    preset_controls,
    preset_headline,
    preset_note,
)
from tauvcore.config import (
    RUN_METHODS,
    Config,
    from_dict,
    merge,
    to_dict,
    trajectory_preset,
)
from tauvcore.validation import SHOW_CHARS

DEFAULTS = Controls(trajectory="straight", duration="250", methods=("ins", "lc", "tc", "nsv", "elc"),
                    vb_nf="20", nsv_epsilon="auto",
                    beams=(1, 2, 3, 4), dropout="0", outages=(("0", "0"),) * 4,
                    accel_bias="0.5", gyro_bias="3", accel_noise="0.072", gyro_noise="0.34", dvl_noise="0.042",
                    dvl_bias="0.005", dvl_sf="0.7", seabed_depth="60", dvl_max_altitude="100", switch_altitude="100",
                    rpm_noise="2", seed="0", runs="1")


def read(**changes: object) -> tuple[Config, int]:
    return config_from_controls(dataclasses.replace(DEFAULTS, **changes))


def refused(**changes: object) -> str:
    with pytest.raises(InputError) as info:
        read(**changes)
    message = str(info.value)
    assert "Error" not in message and "Traceback" not in message     # no exception class names
    return message


def test_the_defaults_read_back_as_the_default_configuration() -> None:
    config, runs = read()
    d = Config()
    assert runs == 1
    assert config.trajectory == d.trajectory and config.imu == d.imu
    assert config.dvl.noise_mps == d.dvl.noise_mps and config.dvl.scale_factor_pct == d.dvl.scale_factor_pct
    assert config.run.methods == ("ins", "lc", "tc", "nsv", "elc") and config.run.seed == 0
    assert config.partial == d.partial


def test_duration_1e3_is_1000_s_not_13() -> None:
    """Scientific notation is a number: "1e3" is 1000 s (the browser's number field made it 13)."""
    config, _ = read(duration="1e3")
    assert config.trajectory.duration_s == 1000.0


def test_seed_1e30_is_refused_not_130() -> None:
    message = refused(seed="1e30")
    assert message.startswith("Seed: '1e30'")


@pytest.mark.parametrize("typed", ["abc", "NaN", "nan", "inf", "-Infinity", "0x10", "1_000", "1e", "--5", "250 s"])
def test_a_duration_that_is_not_a_number_is_refused_not_250_s(typed: str) -> None:
    assert refused(duration=typed) == f"Duration [s]: {typed!r} is not a number"


@pytest.mark.parametrize("typed", ["", "   "])
def test_an_empty_duration_is_refused_not_250_s(typed: str) -> None:
    assert refused(duration=typed) == "Duration [s]: empty; type a number"


def test_seed_2_5_is_refused_not_2() -> None:
    assert refused(seed="2.5") == "Seed: '2.5' is not a whole number (digits only)"


def test_duration_0_5_is_refused_not_0() -> None:
    message = refused(duration="0.5")
    assert message.startswith("Duration [s]: '0.5' is out of range: trajectory.duration_s")


def test_gyro_noise_1e6_is_refused_by_name_before_the_run() -> None:
    """Was a raw "LinAlgError: Singular matrix" from the worker; now the configuration's range,
    with the control's label and the value as typed, before anything runs."""
    message = refused(gyro_noise="1e6")
    assert message.startswith("Gyro noise [deg/sqrt(h)]: '1e6' is out of range: imu.gyro_noise_deg_per_sqrt_h")
    assert "LinAlg" not in message and "Singular" not in message


@pytest.mark.parametrize("typed, problem", [("0", "out of range"), ("3000", "out of range"), ("1.5", "whole number"),
                                            ("1e2", "whole number"), ("", "empty")])
def test_runs_must_be_a_whole_number_within_its_bound(typed: str, problem: str) -> None:
    message = refused(runs=typed)
    assert message.startswith("Runs: ") and problem in message


def test_duration_86401_s_is_refused_with_the_control_named() -> None:
    message = refused(duration="86401")
    assert message.startswith("Duration [s]: '86401' is out of range")


def test_a_long_typed_value_is_shortened_in_the_message() -> None:
    message = refused(dvl_noise="9" * 5000)
    assert message.startswith("DVL noise [m/s]: '" + "9" * SHOW_CHARS + "'... (5000 characters)")
    assert len(message) < 200


def test_out_of_range_sensor_values_name_their_control() -> None:
    assert refused(dvl_noise="-0.1").startswith("DVL noise [m/s]: '-0.1' is out of range: dvl.noise_mps")
    assert refused(dropout="1.5").startswith("Dropout probability: '1.5' is out of range: dvl.dropout_probability")


def test_outages_are_read_strictly() -> None:
    outages = (("0", "0"), ("50", "100"), ("0", "0"), ("0", "0"))
    config, _ = read(outages=outages)
    assert [(o.beams, o.start_s, o.end_s) for o in config.dvl.outages] == [((2,), 50.0, 100.0)]
    assert refused(outages=(("0", "0"), ("200", "50"), ("0", "0"), ("0", "0"))).startswith("Beam 2 outage ends")
    assert refused(outages=(("x", "0"),) + (("0", "0"),) * 3) == "Beam 1 outage start: 'x' is not a number"


def test_parsers_accept_plain_and_scientific_notation_only() -> None:
    assert parse_float("X", " 2.5 ") == 2.5 and parse_float("X", "-.5E-1") == -0.05 and parse_float("X", "7.") == 7.0
    assert parse_int("X", "+42") == 42
    with pytest.raises(InputError, match="too large"):
        parse_float("X", "1e400")
    with pytest.raises(InputError, match="not a whole number"):
        parse_int("X", "4.0")


def test_the_configuration_run_is_shown_as_a_table() -> None:
    config, runs = read(duration="1e1", methods=("ins", "vb"), beams=(1, 3), seed="7", runs="3", aid_sources=("mag",),
                        gyro_noise="0.5", outages=(("0", "0"), ("0", "0"), ("2", "4"), ("0", "0")))
    table = config_markdown(config, runs)
    rows = dict((cell.strip() for cell in line.strip("|").split("|")) for line in table.splitlines()
                if line.startswith("| ") and "---" not in line)
    assert rows["Duration [s]"] == "10" and rows["Methods"] == "INS, VB" and rows["DVL beams"] == "1, 3"
    assert rows["Seed"] == "7" and rows["Runs"] == "3" and rows["Aiding"] == "dvl, mag"
    assert rows["Gyro noise [deg/sqrt(h)]"] == "0.5" and rows["Outages"] == "beam 3 2-4 s"


# ---------------------------------------------------------------- partial-beam methods: n_f and epsilon
@pytest.mark.parametrize("typed, value", [("20", 20.0), ("5", 5.0), (" 1e2 ", 100.0), ("1", 1.0), ("2.5", 2.5)])
def test_vb_nf_reaches_the_configuration(typed: str, value: float) -> None:
    config, _ = read(vb_nf=typed)
    assert config.partial.vb_nf == value
    assert config.partial.nsv_epsilon_m2_per_s2 == "auto"


@pytest.mark.parametrize("typed, value", [("auto", "auto"), (" AUTO ", "auto"), ("0.5", 0.5), ("1e-3", 0.001),
                                          ("100", 100.0)])
def test_nsv_epsilon_reaches_the_configuration(typed: str, value: float | str) -> None:
    config, _ = read(nsv_epsilon=typed)
    assert config.partial.nsv_epsilon_m2_per_s2 == value
    assert config.partial.vb_nf == 20.0
    if value != "auto":
        assert config.nsv_epsilon_value_m2_per_s2() == value


@pytest.mark.parametrize("typed, message", [
    ("0", "VB n_f: '0' is out of range: partial.vb_nf"),
    ("-1", "VB n_f: '-1' is out of range: partial.vb_nf"),
    ("0.5", "VB n_f: '0.5' is out of range: partial.vb_nf"),
    ("101", "VB n_f: '101' is out of range: partial.vb_nf"),
    ("nan", "VB n_f: 'nan' is not a number"),
    ("inf", "VB n_f: 'inf' is not a number"),
    ("1e999", "VB n_f: '1e999' is too large"),
    ("abc", "VB n_f: 'abc' is not a number"),
    ("auto", "VB n_f: 'auto' is not a number"),
    ("", "VB n_f: empty; type a number"),
])
def test_a_bad_vb_nf_is_refused_by_name(typed: str, message: str) -> None:
    got = refused(vb_nf=typed)
    assert got.startswith(message), got
    assert "\n" not in got


@pytest.mark.parametrize("typed, message", [
    ("0", "NSV epsilon [m^2/s^2]: '0' is out of range: partial.nsv_epsilon_m2_per_s2"),
    ("-1", "NSV epsilon [m^2/s^2]: '-1' is out of range: partial.nsv_epsilon_m2_per_s2"),
    ("100.5", "NSV epsilon [m^2/s^2]: '100.5' is out of range: partial.nsv_epsilon_m2_per_s2"),
    ("nan", "NSV epsilon [m^2/s^2]: 'nan' is not a number or \"auto\""),
    ("1e999", "NSV epsilon [m^2/s^2]: '1e999' is too large"),
    ("abc", "NSV epsilon [m^2/s^2]: 'abc' is not a number or \"auto\""),
    ("autox", "NSV epsilon [m^2/s^2]: 'autox' is not a number or \"auto\""),
    ("  ", "NSV epsilon [m^2/s^2]: empty; type a number or \"auto\""),
])
def test_a_bad_nsv_epsilon_is_refused_by_name(typed: str, message: str) -> None:
    got = refused(nsv_epsilon=typed)
    assert got.startswith(message), got
    assert "\n" not in got


def test_n_f_and_epsilon_are_checked_whatever_methods_run() -> None:
    """A bad value is refused even when no partial-beam method is selected: the field shows it."""
    assert refused(methods=("ins", "tc"), vb_nf="0").startswith("VB n_f: '0'")
    assert refused(methods=("ins",), nsv_epsilon="-1").startswith("NSV epsilon [m^2/s^2]: '-1'")


def test_parse_float_or_auto() -> None:
    assert parse_float_or_auto("X", "Auto") == "auto" and parse_float_or_auto("X", "2e-1") == 0.2
    with pytest.raises(InputError, match="^X: 'auto!' is not a number or \"auto\"$"):
        parse_float_or_auto("X", "auto!")


def test_the_configuration_run_shows_n_f_and_epsilon() -> None:
    """n_f as typed; epsilon as typed, and for "auto" also the value the run derived and used."""
    def rows(**changes: object) -> dict[str, str]:
        table = config_markdown(*read(**changes))
        return dict((cell.strip() for cell in line.strip("|").split("|")) for line in table.splitlines()
                    if line.startswith("| ") and "---" not in line)
    shown = rows(vb_nf="7.5", nsv_epsilon="0.5")
    assert shown[VB_NF] == "7.5" and shown[NSV_EPSILON] == "0.5"
    derived = Config().nsv_epsilon_value_m2_per_s2()
    assert 0.0 < derived < 100.0
    assert rows()[NSV_EPSILON] == f"auto ({derived:.3g})" == "auto (0.259)"
    figure8 = rows(trajectory="figure8")[NSV_EPSILON]
    assert figure8 == f"auto ({Config().replace('trajectory', name='figure8').nsv_epsilon_value_m2_per_s2():.3g})"


class _Spy:
    """A control that records whether the run read it."""

    def __init__(self, uid: str, value: object, read_ids: set[str]) -> None:
        self._impl = type("Impl", (), {"uuid": uid})()
        self._value, self._read = value, read_ids

    @property
    def value(self) -> object:
        self._read.add(self._impl.uuid)
        return self._value


def _spy_tab(read_ids: set[str], truth: str = "kinematic", source: str = "simulation",
             methods: tuple[str, ...] = RUN_METHODS, rpm_fallback: bool = False) -> object:
    """What ControlPanel.controls and ControlPanel._confirmed_inputs read of a tab, each control a _Spy."""
    from types import SimpleNamespace

    from app.dashboard.session_controls import ControlPanel
    count = iter(range(1000))

    def spy(value: object) -> _Spy:
        return _Spy(f"id{next(count)}", value, read_ids)
    tab = SimpleNamespace(
        trajectory=spy("figure8"), truth=spy(truth), duration=spy("250"),
        method_boxes={m: spy(m in methods) for m in RUN_METHODS}, rpm_fallback=spy(rpm_fallback),
        vb_nf=spy("20"), nsv_epsilon=spy("auto"), beam_boxes=[spy(True) for _ in range(4)], dropout=spy("0"),
        outage=[(spy("0"), spy("0")) for _ in range(4)],
        accel_bias=spy("0.5"), gyro_bias=spy("3"), accel_noise=spy("0.072"), gyro_noise=spy("0.34"),
        dvl_noise=spy("0.042"), dvl_bias=spy("0.005"), dvl_sf=spy("0.7"), seabed_depth=spy("60"),
        dvl_max_altitude=spy("100"), switch_altitude=spy("100"), rpm_noise=spy("2"), seed=spy("0"), runs=spy("1"),
        smoother=spy(False), smoother_mb=spy("256"), water_track=spy("off"), current_states=spy("off"),
        current_speed=spy("0"), current_toward=spy("0"), current_shear=spy("0"), current_variation=spy("0"),
        source=spy(source),     # the Source control of tauv serve --logs
        source_boxes={p.name: spy(False) for p in PLUGIN_SOURCES},
        source_fields={key: spy(value) for key, value in DEFAULT_SOURCE_FIELDS})
    tab.selected_methods = lambda: ControlPanel.selected_methods(tab)
    return tab


def test_every_control_the_run_reads_is_confirmed_with_the_page() -> None:
    """ControlPanel.controls() reads exactly the controls ControlPanel.confirm_page_state asks the page for
    (n_f, epsilon and Truth included): a control missing from the confirmation could lose a change."""
    from app.dashboard.session_controls import ControlPanel
    read_ids: set[str] = set()
    tab = _spy_tab(read_ids)
    controls = ControlPanel.controls(tab)
    assert controls.vb_nf == "20" and controls.nsv_epsilon == "auto"
    confirmed = set(ControlPanel._confirmed_inputs(tab))
    assert {tab.vb_nf._impl.uuid, tab.nsv_epsilon._impl.uuid, tab.truth._impl.uuid} <= confirmed
    assert {tab.rpm_fallback._impl.uuid, tab.method_boxes["ins-dvl"]._impl.uuid,
            tab.method_boxes["vkf"]._impl.uuid} <= confirmed
    assert {tab.seabed_depth._impl.uuid, tab.dvl_max_altitude._impl.uuid, tab.switch_altitude._impl.uuid,
            tab.rpm_noise._impl.uuid} <= confirmed
    plugins = {*tab.source_boxes.values(), *tab.source_fields.values()}
    assert plugins and {h._impl.uuid for h in plugins} <= confirmed
    assert read_ids == confirmed


@pytest.mark.parametrize("truth", ["kinematic", "dynamic"])
def test_the_truth_dropdown_reaches_the_configuration(truth: str) -> None:
    """The tab's Truth control, read by ControlPanel.controls, is the run's trajectory.truth and is
    shown in the "Configuration run" table."""
    from app.dashboard.session_controls import ControlPanel
    config, _ = config_from_controls(ControlPanel.controls(_spy_tab(set(), truth=truth)))
    assert config.trajectory.truth == truth and config.trajectory.name == "figure8"
    assert f"| {TRUTH} | {truth} |" in config_markdown(config, 1)


def test_a_log_ignores_the_truth_control() -> None:
    """A log replays its own reference: Truth (disabled on the page for a log) does not reach it."""
    from app.dashboard.session_controls import ControlPanel
    config, _ = config_from_controls(ControlPanel.controls(_spy_tab(set(), truth="dynamic", source="dive")))
    assert config.trajectory.truth == "kinematic"


def test_an_unknown_truth_is_refused_by_name() -> None:
    """A value the dropdown does not offer (a scripted client can send one) is a message, not a traceback."""
    assert refused(truth="moon") == "Truth: trajectory.truth must be one of kinematic, dynamic, got 'moon'"


# ---------------------------------------------------------------- the page's answer at Run
@pytest.fixture(scope="module")
def handles():
    """Real viser handles (server-level GUI: no browser needed)."""
    import socket

    import viser
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = viser.ViserServer(host="127.0.0.1", port=port, verbose=False)
    made = {"box": server.gui.add_checkbox("PLCF", False), "text": server.gui.add_text("Duration [s]", "250"),
            "choice": server.gui.add_dropdown("Trajectory", ("straight", "figure8"), initial_value="straight")}
    yield {h._impl.uuid: h for h in made.values()}, made
    server.stop()


def answer(values: dict) -> str:
    import json
    return json.dumps({"t": 0, "values": values})


def test_the_page_values_replace_what_the_server_heard(handles) -> None:
    """The lost change: the page shows PLCF ticked, the server never heard it; at Run the page's
    answer wins."""
    from app.dashboard.session_controls import ControlPanel
    by_id, made = handles
    ids = {name: h._impl.uuid for name, h in made.items()}
    changed = ControlPanel.apply_page_values(by_id, answer({ids["box"]: True, ids["text"]: "1e3", ids["choice"]: "figure8"}))
    assert changed == 3
    assert made["box"].value is True and made["text"].value == "1e3" and made["choice"].value == "figure8"
    assert ControlPanel.apply_page_values(by_id, answer({ids["box"]: True})) == 0      # nothing new
    assert ControlPanel.apply_page_values(by_id, None) == 0                           # a scripted client


@pytest.mark.parametrize("bad", ["not json", "[]", '{"values": 3}'])
def test_an_unreadable_page_answer_is_refused(handles, bad: str) -> None:
    from app.dashboard.session_controls import ControlPanel
    with pytest.raises(InputError, match="cannot read; reload the page"):
        ControlPanel.apply_page_values(handles[0], bad)


def test_a_page_value_a_control_cannot_hold_is_refused(handles) -> None:
    from app.dashboard.session_controls import ControlPanel
    by_id, made = handles
    ids = {name: h._impl.uuid for name, h in made.items()}
    with pytest.raises(InputError, match=r"^PLCF: the page shows 'yes'"):
        ControlPanel.apply_page_values(by_id, answer({ids["box"]: "yes"}))
    with pytest.raises(InputError, match=r"^Trajectory: the page shows 'moon'"):
        ControlPanel.apply_page_values(by_id, answer({ids["choice"]: "moon"}))
    with pytest.raises(InputError, match=r"^Duration \[s\]: the page shows '9+'\.\.\. \(5000 characters\)"):
        ControlPanel.apply_page_values(by_id, answer({ids["text"]: "9" * 5000}))



# ---------------------------------------------------------------- a scenario's preset
PRESET_LABELS = {DURATION: "duration", SEABED_DEPTH: "seabed_depth", ACCEL_BIAS: "accel_bias", GYRO_BIAS: "gyro_bias",
                 ACCEL_NOISE: "accel_noise", GYRO_NOISE: "gyro_noise"}


def test_the_longrange_preset_fills_in_the_duration_and_the_paper_s_imu() -> None:
    assert preset_controls("longrange") == {DURATION: "1440", SEABED_DEPTH: "110", ACCEL_BIAS: "1", GYRO_BIAS: "1",
                                            ACCEL_NOISE: "0.0588399", GYRO_NOISE: "0.125"}
    # leaving it: the same controls at their defaults, which are the tab's initial texts
    defaults = preset_controls("longrange", Config())
    assert defaults == {label: getattr(DEFAULTS, field) for label, field in PRESET_LABELS.items()}
    assert preset_controls("straight") == {} and preset_note("straight") == ""


def test_a_run_of_longrange_with_its_preset_controls_flies_the_paper_s_mission() -> None:
    """Given longrange picked and its preset filled in, the run's configuration is the preset's
    (as `tauv run --trajectory longrange` makes it), also where no control reaches (speed, depth,
    seabed, IMU rate and its other errors, DVL rate), and the "Configuration run" table says so."""
    typed = {PRESET_LABELS[label]: text for label, text in preset_controls("longrange").items()}
    config, _ = read(trajectory="longrange", **typed)
    expected = from_dict(merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange"}}))
    assert config.trajectory == expected.trajectory
    assert config.dvl.rate_hz == 5.0 and config.imu.rate_hz == 100.0
    for key, value in to_dict(expected)["imu"].items():
        assert getattr(config.imu, key) == pytest.approx(value, rel=1e-11, abs=0), key
    rows = dict((cell.strip() for cell in line.strip("|").split("|")) for line in config_markdown(config, 1).splitlines()
                if line.startswith("| ") and "---" not in line)
    assert rows["Rates"] == "IMU 100 Hz, DVL 5 Hz" and rows["Speed, depth"] == "5.14 m/s at 50 m"
    assert rows["Seabed"] == "flat, 110 m" and rows[DURATION] == "1440"
    # the controls still win where they reach: a shortened longrange keeps the rest of the preset
    short, _ = read(trajectory="longrange", duration="330")
    assert short.trajectory.duration_s == 330.0 and short.trajectory.depth_m == 50.0 and short.dvl.rate_hz == 5.0


def test_other_trajectories_keep_the_defaults_where_no_control_reaches() -> None:
    config, _ = read(trajectory="figure8")
    d = Config()
    assert config.imu.rate_hz == d.imu.rate_hz and config.dvl.rate_hz == d.dvl.rate_hz
    assert config.trajectory.speed_mps == d.trajectory.speed_mps
    assert config.trajectory.seabed_depth_m == d.trajectory.seabed_depth_m


def test_the_preset_note_names_every_setting_the_preset_brings() -> None:
    note = preset_note("longrange")
    assert note.startswith("**longrange** preset applied: ")
    for sec, values in trajectory_preset("longrange").items():
        for key in values:
            assert f"{sec}.{key}" in note or any(label in note for label in PRESET_LABELS), key
    for key in ("trajectory.speed_mps 5.144", "trajectory.depth_m 50", f"{SEABED_DEPTH} 110",
                "imu.rate_hz 100", "dvl.rate_hz 5", f"{DURATION} 1440"):
        assert key in note
    assert "trajectory.seabed_depth_m" not in note          # it has a control now
    headline = preset_headline("longrange")
    assert headline == (f"{DURATION}, {SEABED_DEPTH}, {ACCEL_BIAS}, {GYRO_BIAS}, {ACCEL_NOISE}, {GYRO_NOISE} filled in; "
                        "10 settings without a control apply at Run (listed under the Run button).")
    assert preset_headline("straight") == ""


# ---------------------------------------------------------------- Yoo 2014's methods and the RPM fallback
def test_both_papers_methods_reach_the_configuration_in_their_order() -> None:
    """The INS-DVL and VKF checkboxes sit beside the first paper's methods: any mix of them runs,
    in tauvcore.config.ALL_METHODS order, and the "Configuration run" table names them."""
    config, _ = read(methods=("vkf", "lc", "ins-dvl", "ins"))
    assert config.run.methods == ("ins", "lc", "ins-dvl", "vkf")
    assert config.run.rpm_fallback is False
    rows = dict((cell.strip() for cell in line.strip("|").split("|")) for line in config_markdown(config, 1).splitlines()
                if line.startswith("| ") and "---" not in line)
    assert rows["Methods"] == "INS, LC, INS-DVL, VKF" and rows[RPM_FALLBACK] == "off"
    assert read(methods=("vkf",))[0].run.methods == ("vkf",)


def test_the_rpm_fallback_checkbox_reaches_the_configuration() -> None:
    """From the tab's controls (ControlPanel.controls) to run.rpm_fallback and the "Configuration run" table."""
    from app.dashboard.session_controls import ControlPanel
    tab = _spy_tab(set(), methods=("ins", "lc", "ins-dvl", "vkf"), rpm_fallback=True)
    controls = ControlPanel.controls(tab)
    assert controls.rpm_fallback is True and controls.methods == ("ins", "lc", "ins-dvl", "vkf")
    config, _ = config_from_controls(controls)
    assert config.run.rpm_fallback is True and config.run.methods == ("ins", "lc", "ins-dvl", "vkf")
    assert f"| {RPM_FALLBACK} | on |" in config_markdown(config, 1)
    assert config_from_controls(ControlPanel.controls(_spy_tab(set())))[0].run.rpm_fallback is False


def test_ins_dvl_with_two_beams_is_refused_like_lc() -> None:
    """INS-DVL, like LC, fuses no DVL velocity from fewer than three beams; VKF (the RPM) and, with
    the RPM fallback, LC do."""
    assert refused(methods=("ins", "ins-dvl"), beams=(1, 2)).startswith("INS-DVL needs three or more beams, but only 2")
    assert refused(methods=("lc", "ins-dvl"), beams=(1, 2)).startswith("LC and INS-DVL need three or more beams")
    assert refused(methods=("lc",), beams=(1, 2)).startswith("LC needs three or more beams")
    assert read(methods=("ins-dvl", "vkf"), beams=(1, 2))[0].run.methods == ("ins-dvl", "vkf")
    assert read(methods=("lc",), beams=(1, 2), rpm_fallback=True)[0].run.rpm_fallback is True
    assert refused(methods=("ins-dvl",), beams=(1, 2), rpm_fallback=True).startswith("INS-DVL needs")


# ---------------------------------------------------------------- seabed, DVL range, VKF switch, RPM noise
def test_an_untouched_tab_reads_back_as_the_default_configuration() -> None:
    """The four controls start at the configuration's defaults (the tab's initial texts, as
    app.dashboard.server writes them), so an untouched tab runs exactly Config() with its methods."""
    d = Config()
    assert (DEFAULTS.seabed_depth, DEFAULTS.dvl_max_altitude, DEFAULTS.switch_altitude, DEFAULTS.rpm_noise) == (
        f"{d.trajectory.seabed_depth_m:g}", f"{d.dvl.max_altitude_m:g}", f"{d.vkf.switch_altitude_m:g}",
        f"{d.rpm.noise_rpm:g}")
    config, _ = read()
    assert config == d.replace("run", methods=DEFAULTS.methods)


def test_the_seabed_and_rpm_controls_reach_the_configuration() -> None:
    config, _ = read(seabed_depth="80", dvl_max_altitude="5e1", switch_altitude=" 40 ", rpm_noise="0")
    assert config.trajectory.seabed_depth_m == 80.0 and config.dvl.max_altitude_m == 50.0
    assert config.vkf.switch_altitude_m == 40.0 and config.rpm.noise_rpm == 0.0
    rows = dict((cell.strip() for cell in line.strip("|").split("|")) for line in config_markdown(config, 1).splitlines()
                if line.startswith("| ") and "---" not in line)
    assert rows["Seabed"] == "flat, 80 m" and rows[DVL_MAX_ALTITUDE] == "50"
    assert rows[SWITCH_ALTITUDE] == "40" and rows[RPM_NOISE] == "0"


@pytest.mark.parametrize("field, typed, message", [
    ("switch_altitude", "-5",
     "Switch altitude [m]: '-5' is out of range: vkf.switch_altitude_m must be within (0, 11000], got -5.0"),
    ("switch_altitude", "NaN", "Switch altitude [m]: 'NaN' is not a number"),
    ("switch_altitude", "0", "Switch altitude [m]: '0' is out of range: vkf.switch_altitude_m"),
    ("dvl_max_altitude", "0",
     "DVL max altitude [m]: '0' is out of range: dvl.max_altitude_m must be within (0, 11000], got 0.0"),
    ("dvl_max_altitude", "-1", "DVL max altitude [m]: '-1' is out of range: dvl.max_altitude_m"),
    # deeper than the deepest ocean, the bound tauvcore.truth.kinematic.TrajectoryConfig enforces
    ("seabed_depth", "12000",
     "Seabed depth [m]: '12000' is out of range: trajectory.seabed_depth_m must be within (0, 11000], got 12000.0"),
    ("seabed_depth", "0", "Seabed depth [m]: '0' is out of range: trajectory.seabed_depth_m"),
    ("rpm_noise", "-1", "RPM noise [rpm]: '-1' is out of range: rpm.noise_rpm must be within [0, 1000], got -1.0"),
    ("rpm_noise", "nan", "RPM noise [rpm]: 'nan' is not a number"),
])
def test_a_bad_seabed_or_rpm_value_is_refused_by_name(field: str, typed: str, message: str) -> None:
    got = refused(**{field: typed})
    assert got.startswith(message), got
    assert "\n" not in got
    # refused also where no method uses it (INS alone): the field shows the bad value
    assert refused(methods=("ins",), **{field: typed}) == got


def test_picking_longrange_fills_in_its_seabed_and_leaving_it_restores_the_default() -> None:
    """app.dashboard.session_controls.ControlPanel.apply_trajectory_preset sets the Seabed depth control to longrange's
    110 m (and back to 60 m on the straight line); the filled-in tab reads back as the preset."""
    from types import SimpleNamespace

    from app.dashboard.session_controls import ControlPanel
    names = ("duration", "accel_bias", "gyro_bias", "accel_noise", "gyro_noise", "dvl_noise", "dvl_bias", "dvl_sf",
             "dropout", "vb_nf", "nsv_epsilon", "seabed_depth", "dvl_max_altitude", "switch_altitude", "rpm_noise",
             "seed", "water_track", "current_states")
    notes: list[str] = []
    tab = SimpleNamespace(trajectory=SimpleNamespace(value="longrange"), preset=None, status=SimpleNamespace(content=""),
                          notify=lambda title, body, error=False: notes.append(title),
                          **{n: SimpleNamespace(value=getattr(DEFAULTS, n)) for n in names})
    tab._text_fields = lambda: ControlPanel._text_fields(tab)
    ControlPanel.apply_trajectory_preset(tab)
    assert tab.seabed_depth.value == "110" and tab.duration.value == "1440" and notes == ["Preset longrange applied"]
    assert (tab.dvl_max_altitude.value, tab.switch_altitude.value, tab.rpm_noise.value) == ("100", "100", "2")
    config, _ = read(trajectory="longrange", **{n: getattr(tab, n).value for n in names})
    assert config.trajectory.seabed_depth_m == trajectory_preset("longrange")["trajectory"]["seabed_depth_m"]
    tab.trajectory.value = "straight"
    ControlPanel.apply_trajectory_preset(tab)
    assert tab.seabed_depth.value == "60" and tab.duration.value == "250" and notes[-1] == "Defaults restored"


# ---------------------------------------------------------------- the control table (app/dashboard/control_table.py)
def test_a_new_page_built_from_the_control_table_reads_back_as_the_defaults_and_round_trips() -> None:
    """The Mission tab's controls as app.dashboard.control_table builds them (a server-level GUI: no browser)
    hold the default Controls, which run exactly Config() with its methods; every field written
    through the table reads back as written, and a control already holding its value is not set."""
    import socket
    from types import SimpleNamespace

    import viser

    from app.dashboard import control_table
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = viser.ViserServer(host="127.0.0.1", port=port, verbose=False)
    try:
        panel = SimpleNamespace(**control_table.build(server.gui, {}))
        assert panel.source is None                               # no logs: no Source control

        def controls() -> Controls:
            return Controls(**{c.field: control_table.read(panel, c) for c in control_table.CONTROLS})
        assert controls() == DEFAULTS
        assert read()[0] == Config().replace("run", methods=DEFAULTS.methods)
        changed = dataclasses.replace(
            DEFAULTS, trajectory="figure8", truth="dynamic", duration="1e3", methods=("lc", "vkf"), beams=(1, 3),
            outages=(("0", "0"), ("10", "20"), ("0", "0"), ("0", "0")), rpm_fallback=True,
            seed="7", runs="2", aid_sources=tuple(p.name for p in PLUGIN_SOURCES), current_speed="0.5",
            current_toward="90", current_shear="0.01", current_variation="0.1", water_track="always",
            current_states="random-walk")
        for c in control_table.CONTROLS:
            control_table.write(panel, c, getattr(changed, c.field))
        assert controls() == changed
        confirmed = [h for c in control_table.CONTROLS for h in control_table.handles(panel, c)]
        # 28 single controls, a box per method, 4 beams, 4 outages of two texts, the sources and their fields
        assert len({id(h) for h in confirmed}) == len(confirmed) == 28 + len(RUN_METHODS) + 4 + 8 + len(
            PLUGIN_SOURCES) + len(DEFAULT_SOURCE_FIELDS)
    finally:
        server.stop()
