"""The dashboard with the DVL's water-track and the filters' current states: the two controls read
into the configuration (a refused combination is one line naming a control), carried in the
address and filled in from a log's configuration; the Consistency tab's NEES of the block
"current", the Sensors tab's figure of the current's estimate against its truth, the live view's
thinning and the JSON's ``nees_current``; a run without current states keeps its figures and
document as they were."""

from __future__ import annotations

import dataclasses
import types

import numpy as np
import pytest

from app.dashboard import control_checks as validation
from app.dashboard import control_table, links
from app.dashboard.inputs import (
    DVL_CURRENT_STATES,
    DVL_MAX_ALTITUDE,
    DVL_WATER_TRACK,
    SEABED_FOLDER,
    InputError,
    config_from_controls,
    config_rows,
)
from app.dashboard.session_controls import ControlPanel
from app.dashboard.session_plots import STATES_NOTE, PlotTabs
from app.dashboard.worker import thin
from app.figures.error_figures import nees_blocks, nees_figure
from app.figures.innovation_figures import innovation_figure, innovation_sources
from app.figures.sensor_figures import source_states_figure, state_methods, state_name_unit
from app.reports.payload import result_series, result_to_json
from tauvcore.config import from_dict
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.sensors.dvl import CURRENT_STATES, WATER_TRACK
from tests.unit.app.dashboard.test_links import DEFAULTS

CURRENT_E_MPS = 0.3  # the mission's current, toward the east [m/s]
PLAIN_SERIES = [
    "t", "est_north_m", "est_east_m", "est_down_m", "est_vel_north_mps", "est_vel_east_mps", "est_vel_down_mps",
    "est_roll_deg", "est_pitch_deg", "est_yaw_deg", "vel_err_mps", "att_err_deg", "tilt_err_deg",
    "heading_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "tilt_sigma_deg", "heading_sigma_deg",
    "pos_sigma_m", "nees", "nees_pos", "nees_vel", "nees_tilt", "nees_heading", "nees_sensor",
]
"""A method's series in the JSON document of a run without current states (before them, as now)."""


def _run(current_states: str, methods: tuple[str, ...] = ("ins", "lc", "vkf")) -> dict[str, MethodResult]:
    config = from_dict({
        "trajectory": {"name": "lawnmower", "duration_s": 60.0, "current_n_mps": [0.0, CURRENT_E_MPS, 0.0]},
        "dvl": {"water_track": "always", "current_states": current_states},
        "run": {"methods": list(methods)},
    })
    return run_streaming(config, np.random.default_rng(0), 1)


@pytest.fixture(scope="module")
def with_states() -> dict[str, MethodResult]:
    return _run("random-walk")


@pytest.fixture(scope="module")
def without_states() -> dict[str, MethodResult]:
    return _run("off")


def refused(log: dict | None = None, **changes: object) -> str:
    with pytest.raises(InputError) as info:
        config_from_controls(dataclasses.replace(DEFAULTS, **changes), log)
    message = str(info.value)
    assert "\n" not in message and "Error" not in message and "Traceback" not in message
    return message


# ------------------------------------------------------------------------------------------ controls
def test_the_choices_are_the_configuration_s_own_in_the_seabed_and_range_folder() -> None:
    by_field = {c.field: c for c in control_table.CONTROLS}
    assert by_field["water_track"].options == WATER_TRACK and by_field["current_states"].options == CURRENT_STATES
    assert {by_field[f].folder for f in ("water_track", "current_states", "dvl_max_altitude")} == {SEABED_FOLDER}
    assert all(by_field[f].hint for f in ("water_track", "current_states"))
    assert (DEFAULTS.water_track, DEFAULTS.current_states) == ("off", "off")      # a new page: off, as Config()


@pytest.mark.parametrize("water_track", WATER_TRACK)
@pytest.mark.parametrize("current_states", CURRENT_STATES)
def test_every_choice_reaches_the_configuration_and_its_table(water_track: str, current_states: str) -> None:
    config, _ = config_from_controls(
        dataclasses.replace(DEFAULTS, water_track=water_track, current_states=current_states)
    )
    assert (config.dvl.water_track, config.dvl.current_states) == (water_track, current_states)
    rows = dict(config_rows(config, 1))
    assert rows[DVL_WATER_TRACK].split(",")[0] == water_track
    assert rows[DVL_CURRENT_STATES].split(",")[0] == current_states


def test_water_track_beyond_range_with_a_log_s_noisy_beams_is_named_by_the_water_track() -> None:
    """A log whose configuration keeps noisy beams beyond range (no control sets it) refuses
    water-track "beyond_range": the Run's one line names Water-track, so does the check as you type."""
    log = {"dvl": {"beyond_range": "noisy"}}
    message = refused(log, source="pool", water_track="beyond_range")
    assert message.startswith(f'{DVL_WATER_TRACK}: dvl.water_track "beyond_range" needs dvl.beyond_range "lost"')
    controls = dataclasses.replace(DEFAULTS, source="pool", water_track="beyond_range")
    assert validation.problems(controls, log) == {DVL_WATER_TRACK: message}
    config_from_controls(dataclasses.replace(controls, water_track="always"), log)   # always: no conflict


def test_a_water_layer_beyond_the_range_is_named_by_the_range_with_the_water_track() -> None:
    """The layer (10 m below the head) has no control: a DVL max altitude below it, with water-track
    on, names that field and the water-track; with water-track off the same range runs."""
    message = refused(water_track="always", dvl_max_altitude="5")
    assert message == (
        f"{DVL_MAX_ALTITUDE}: '5' is out of range with {DVL_WATER_TRACK} 'always': dvl.water_layer_m 10 m "
        "lies beyond the DVL's range dvl.max_altitude_m 5 m"
    )
    found = validation.problems(dataclasses.replace(DEFAULTS, water_track="always", dvl_max_altitude="5"))
    assert found == {DVL_MAX_ALTITUDE: message}                  # the field marked on the page is the range
    config_from_controls(dataclasses.replace(DEFAULTS, dvl_max_altitude="5"))


def test_current_states_with_the_smoother_run_for_every_method() -> None:
    """Every method's smoother takes the current states: nothing is refused."""
    controls = dataclasses.replace(DEFAULTS, current_states="gauss-markov", smoother=True, methods=("lc", "vkf"))
    assert DVL_CURRENT_STATES not in validation.problems(controls)
    config_from_controls(controls)


def test_the_address_carries_both_and_refuses_a_choice_it_does_not_know() -> None:
    controls = dataclasses.replace(DEFAULTS, water_track="always", current_states="random-walk")
    query = links.address(controls)
    assert "&alt=100&wt=always&cst=random-walk&" in query
    assert links.apply(DEFAULTS, links.parse(query)) == controls
    link = links.parse("wt=sometimes&cst=gauss-markov")
    assert link.values == {"current_states": "gauss-markov"}
    assert link.problems == (f"wt='sometimes': {DVL_WATER_TRACK}: choose from {', '.join(WATER_TRACK)}",)


def test_a_log_s_configuration_fills_in_the_two_choices() -> None:
    """A log configured with water-track and current states replays with them until the page
    changes them, as its DVL noise fills in its field."""
    handles = {c.attr: types.SimpleNamespace(value=getattr(DEFAULTS, c.field))
               for c in control_table.CONTROLS if c.label in control_table.FILLED_LABELS}
    notes: list[tuple[str, str]] = []
    tab = types.SimpleNamespace(
        **handles, source=types.SimpleNamespace(value="pool"), logs={"pool": "/nowhere/pool"}, source_fields={},
        notify=lambda title, body, error=False: notes.append((title, body)),
        log_config=lambda source: {"dvl": {"water_track": "always", "current_states": "gauss-markov"}},
    )
    tab._text_fields = lambda: ControlPanel._text_fields(tab)
    tab.fill_fields = lambda raw: ControlPanel.fill_fields(tab, raw)
    ControlPanel.apply_log_config(tab)
    assert (tab.water_track.value, tab.current_states.value) == ("always", "gauss-markov")
    assert notes and f"{DVL_WATER_TRACK}" in notes[-1][1] and f"{DVL_CURRENT_STATES}" in notes[-1][1]


# ------------------------------------------------------------------------------------------ figures
def test_the_nees_of_the_current_skips_the_methods_without_it(
    with_states: dict[str, MethodResult], without_states: dict[str, MethodResult]
) -> None:
    """Given LC, INS and VKF (Yoo 2014's 12 states) with current states beside a VKF run without
    them, when the Consistency tab draws block "current", then LC's, INS's and VKF's curves are
    NEES/2, the run without is named in the title as having none, and the band is that of
    dimension 2."""
    both = {**with_states, "vkf-still": without_states["vkf"]}
    assert nees_blocks(with_states) == (*BLOCK_DIMS, "current")
    figure = nees_figure(both, "current", max_points=None, validate=True)
    names = [trace.name for trace in figure.data]
    assert {"LC", "INS", "VKF"} <= set(names) and "VKF-STILL" not in names and "99 % band" in names
    title = figure.layout.title.text
    assert "current (north, east) (dim 2; no current: VKF-STILL)" in title
    from tauvcore.eval.consistency import nees_series
    for name, method in (("LC", "lc"), ("VKF", "vkf")):
        trace = next(trace for trace in figure.data if trace.name == name)
        np.testing.assert_allclose(np.asarray(trace.y, float), nees_series(with_states[method], "current")[:, 0] / 2)


def test_a_run_without_current_states_draws_no_current_but_says_why(without_states) -> None:
    assert nees_blocks(without_states) == tuple(BLOCK_DIMS)
    figure = nees_figure(without_states, "current")                    # a kept run overlaid, say
    assert not figure.data and "no method of this run has it" in figure.layout.title.text
    with pytest.raises(ValueError, match="block must be one of"):
        nees_figure(without_states, "salinity")
    assert not state_methods(without_states)


def test_the_current_s_estimate_is_drawn_against_its_truth(with_states: dict[str, MethodResult]) -> None:
    """Per panel (north, east): LC's and VKF's estimates over their 1-sigma bands, the true current
    dashed; INS, which fuses nothing, is not drawn."""
    assert state_name_unit("current_north_mps") == ("Current north", "m/s")
    assert state_methods(with_states) == ("lc", "vkf")
    figure = source_states_figure(with_states, validate=True)
    by_name = {trace.name: trace for trace in figure.data}
    assert {"LC current north", "LC current east", "true current north", "true current east",
            "LC +1 sigma", "LC -1 sigma"} <= set(by_name)
    assert "VKF current east" in by_name and not any(name.startswith("INS") for name in by_name)
    np.testing.assert_allclose(np.asarray(by_name["true current east"].y, float), CURRENT_E_MPS)
    lc = with_states["lc"]
    assert lc.state_est is not None and lc.state_sigma is not None
    east = np.asarray(by_name["LC current east"].y, float)
    np.testing.assert_allclose(east, lc.state_est[:, 0, 1])
    # the water-track beams observe it: within 3 sigma of the truth at the end, far tighter than the prior
    assert abs(east[-1] - CURRENT_E_MPS) < 3 * lc.state_sigma[-1, 0, 1] < 0.5
    assert "Current at the vehicle" in figure.layout.title.text


def test_the_sensors_tab_shows_the_current_and_hides_it_for_a_run_without(with_states, without_states) -> None:
    def handle(**kw: object) -> types.SimpleNamespace:
        return types.SimpleNamespace(**kw)
    tabs = types.SimpleNamespace(state=handle(cursor_t=None), state_note=handle(content=""),
                                 state_plot=handle(visible=False, aspect=0.6, figure=None))
    tabs._fit = PlotTabs._fit
    tabs._with_events = lambda figure, run=0: figure  # the events: tests/unit/app/figures/test_event_traces.py
    PlotTabs._draw_states(tabs, with_states, 0)
    assert tabs.state_plot.visible and tabs.state_note.content.startswith(STATES_NOTE)
    assert "Not drawn: INS (" in tabs.state_note.content
    assert tabs.state_plot.figure.data
    PlotTabs._draw_states(tabs, without_states, 0)
    assert not tabs.state_plot.visible and tabs.state_note.content == ""


def test_the_nees_dropdown_gains_current_and_loses_it_again(with_states, without_states) -> None:
    tabs = types.SimpleNamespace(
        nees_block=types.SimpleNamespace(options=tuple(BLOCK_DIMS), value="full"), overlay_runs=lambda: [],
        show_smoothed_nees=types.SimpleNamespace(value=False), nees_plot=types.SimpleNamespace(figure=None, aspect=0.6),
        state=types.SimpleNamespace(cursor_t=None), _fit=PlotTabs._fit, _with_events=lambda figure, run=0: figure)
    PlotTabs._draw_nees(tabs, with_states)
    assert tabs.nees_block.options == (*BLOCK_DIMS, "current")
    tabs.nees_block.value = "current"
    PlotTabs._draw_nees(tabs, with_states)
    assert "current (north, east)" in tabs.nees_plot.figure.layout.title.text
    PlotTabs._draw_nees(tabs, without_states)                 # the next run has none: the full state
    assert tabs.nees_block.options == tuple(BLOCK_DIMS)
    assert "full state" in tabs.nees_plot.figure.layout.title.text


def test_the_innovations_list_the_water_track_beams(with_states: dict[str, MethodResult]) -> None:
    assert innovation_sources(with_states) == ("dvl", "water")
    figure = innovation_figure(with_states, "water", validate=True)
    titles = [figure.layout[f"yaxis{k or ''}"].title.text for k in (0, 2, 3, 4)]
    assert all(title.startswith(f"beam {n}") for n, title in enumerate(titles, start=1)), titles


def test_the_live_view_thins_the_states_with_the_epochs(with_states: dict[str, MethodResult]) -> None:
    lc = with_states["lc"]
    thinned = thin(with_states, 50)["lc"]
    assert thinned.state_est is not None and lc.state_est is not None
    assert thinned.state_est.shape[0] == len(thinned.t_s) < len(lc.t_s)
    np.testing.assert_array_equal(thinned.state_est[-1], lc.state_est[-1])


# ------------------------------------------------------------------------------------------ JSON
def test_the_json_exports_the_current_s_nees_and_keeps_a_plain_run_s_keys(with_states, without_states) -> None:
    assert list(result_series(without_states["lc"])) == PLAIN_SERIES
    assert list(result_series(with_states["lc"])) == [*PLAIN_SERIES, "nees_current"]
    assert list(result_series(with_states["vkf"])) == [*PLAIN_SERIES, "nees_current"]  # Yoo 2014's too
    assert list(result_series(without_states["vkf"])) == PLAIN_SERIES
    document = result_to_json(with_states["lc"])
    assert len(document["nees_current"]) == len(document["t"])
    assert document["consistency"]["nees"]["current"]["dim"] == 2
