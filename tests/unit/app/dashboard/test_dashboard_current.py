"""The dashboard's ocean current: its controls (speed, the direction it flows toward, shear and
variation) read strictly into the configuration's NED fields, a current the configuration refuses
named by its control with the configuration's own line, the address carrying it; the truth view,
the Vehicle tab's figure and the 3-D view's arrow showing it."""

from __future__ import annotations

import dataclasses
import threading
import types

import numpy as np
import pytest

from app.dashboard import links
from app.dashboard.control_checks import initial_controls, problems
from app.dashboard.inputs import (
    CURRENT_SHEAR,
    CURRENT_SPEED,
    CURRENT_TOWARD,
    CURRENT_VARIATION,
    Controls,
    InputError,
    config_from_controls,
    config_rows,
    current_fields,
    current_text,
)
from app.dashboard.session_plots import VEHICLE_NOTES, PlotTabs
from app.dashboard.session_scene import SceneView
from app.figures.scene import current_arrow_view, current_head_m, current_label, ned_to_view
from app.figures.vehicle_figures import (
    CURRENT_EAST_NAME,
    CURRENT_NORTH_NAME,
    GROUND_SPEED_NAME,
    WATER_SPEED_NAME,
    current_figure,
    water_and_ground_speed_mps,
)
from tauvcore.config import Config


@pytest.fixture
def good() -> Controls:
    init = {k: v for k, v in initial_controls().items() if k in Controls.__dataclass_fields__}
    return Controls(**init, methods=("ins", "tc"), beams=(1, 2, 3, 4), outages=(("0", "0"),) * 4)


def refused(c: Controls) -> str:
    with pytest.raises(InputError) as info:
        config_from_controls(c)
    message = str(info.value)
    assert "Error" not in message and "Traceback" not in message and "\n" not in message
    return message


# ---------------------------------------------------------------------------------- the controls
def test_a_new_page_is_still_water(good: Controls) -> None:
    assert (good.current_speed, good.current_toward, good.current_shear, good.current_variation) == ("0",) * 4
    config, _ = config_from_controls(good)
    assert config.trajectory == Config().trajectory
    assert dict(config_rows(config, 1))["Current"] == "still water"


@pytest.mark.parametrize(
    "toward, north, east",
    [
        ("0", 0.5, 0.0),
        ("90", 0.0, 0.5),
        ("180", -0.5, 0.0),
        ("270", 0.0, -0.5),
        ("360", 0.5, 0.0),
        ("45", 0.353553390593, 0.353553390593),
        ("1.5e2", -0.433012701892, 0.25),
    ],
)
def test_speed_and_direction_toward_become_the_ned_current(
    good: Controls, toward: str, north: float, east: float
) -> None:
    """Clockwise from north, where the water flows: 90 deg is a current flowing east; a part of a
    right angle's cosine is zero, not 6e-17."""
    c = dataclasses.replace(good, current_speed="0.5", current_toward=toward, current_shear="0.01")
    fields = current_fields(c)
    assert fields["current_n_mps"] == pytest.approx((north, east, 0.0), abs=1e-12)
    assert fields["current_shear_ne_per_s"] == pytest.approx((0.02 * north, 0.02 * east), abs=1e-12)
    assert 0.0 in fields["current_n_mps"][:2] or toward in ("45", "1.5e2")
    config, _ = config_from_controls(c)
    assert config.trajectory.current_n_mps == fields["current_n_mps"]
    assert config.trajectory.current_shear_ne_per_s == fields["current_shear_ne_per_s"]


def test_the_run_s_configuration_names_the_current_as_the_controls_do(good: Controls) -> None:
    c = dataclasses.replace(
        good, current_speed="0.5", current_toward="90", current_shear="-0.01", current_variation="0.1"
    )
    config, _ = config_from_controls(c)
    assert config.trajectory.current_variation_mps == 0.1
    assert dict(config_rows(config, 1))["Current"] == (
        "0.5 m/s toward 90 deg, shear -0.01 1/s, variation 0.1 m/s RMS (600 s, seed 0)"
    )


def test_a_current_from_a_file_is_named_in_full() -> None:
    """A configuration's own current (not the controls'): a vertical part, a shear across it."""
    t = (
        Config()
        .replace(
            "trajectory", truth="dynamic", current_n_mps=(0.0, -0.3, 0.05), current_shear_ne_per_s=(0.01, 0.0)
        )
        .trajectory
    )
    assert current_text(t) == "0.3 m/s toward 270 deg, down 0.05 m/s, shear 0.01 1/s toward 0 deg"


@pytest.mark.parametrize(
    "field, typed, message",
    [
        ("current_speed", "abc", f"{CURRENT_SPEED}: 'abc' is not a number"),
        (
            "current_speed",
            "-0.5",
            f"{CURRENT_SPEED}: '-0.5' is out of range; a current's speed is [0, 3] m/s",
        ),
        ("current_speed", "3.5", f"{CURRENT_SPEED}: '3.5' is out of range"),
        ("current_toward", "nan", f"{CURRENT_TOWARD}: 'nan' is not a number"),
        (
            "current_toward",
            "-90",
            f"{CURRENT_TOWARD}: '-90' is out of range; the direction the water flows toward "
            "is [0, 360] deg clockwise from north",
        ),
        ("current_shear", "0.2", f"{CURRENT_SHEAR}: '0.2' is out of range; a shear is [-0.1, 0.1] 1/s"),
        ("current_variation", "", f"{CURRENT_VARIATION}: empty"),
        (
            "current_variation",
            "-1",
            f"{CURRENT_VARIATION}: '-1' is out of range: trajectory.current_variation_mps",
        ),
    ],
)
def test_a_bad_current_value_is_refused_by_name(good: Controls, field: str, typed: str, message: str) -> None:
    c = dataclasses.replace(good, **{field: typed})
    assert refused(c).startswith(message)
    assert list(problems(c).values()) == [refused(c)]


def test_a_current_reaching_the_vehicle_s_speed_is_named_by_its_speed(good: Controls) -> None:
    """2.5 m/s against the vehicle's 2 m/s: the configuration's own line, behind the control's name
    and the value as typed."""
    message = refused(dataclasses.replace(good, current_speed="2.5", current_toward="45"))
    assert message.startswith(f"{CURRENT_SPEED}: '2.5' is out of range: trajectory.current_n_mps [")
    assert (
        "the current reaches 2.5 m/s, not below the vehicle's speed trajectory.speed_mps 2.0 m/s" in message
    )


def test_a_varying_current_alone_reaching_the_vehicle_s_speed_is_named_by_its_variation(
    good: Controls,
) -> None:
    message = refused(dataclasses.replace(good, current_variation="1"))
    assert message.startswith(f"{CURRENT_VARIATION}: '1' is out of range: trajectory.current_n_mps")
    assert "not below the vehicle's speed" in message


def test_a_crab_beyond_45_deg_is_refused_with_the_kinematic_truth_and_flown_with_the_dynamic(
    good: Controls,
) -> None:
    """The figure eight flies every heading: 1.5 m/s across its 2 m/s track needs a crab beyond
    45 deg somewhere, which the kinematic truth cannot fly; the dynamic vehicle's autopilot crabs."""
    c = dataclasses.replace(good, trajectory="figure8", current_speed="1.5", current_toward="90")
    message = refused(c)
    assert message.startswith(f"{CURRENT_SPEED}: '1.5' is out of range: trajectory.current_n_mps")
    assert "would crab" in message and 'use trajectory.truth = "dynamic"' in message
    found = problems(c)
    assert list(found) == [CURRENT_SPEED] and found[CURRENT_SPEED] == message  # not the direction
    config, _ = config_from_controls(dataclasses.replace(c, truth="dynamic"))
    assert config.trajectory.current_n_mps == (0.0, 1.5, 0.0)


def test_the_current_s_controls_are_checked_together(good: Controls) -> None:
    """Each of them that is not a number is named; numbers, they are one vector: a speed is not
    judged at another control's default direction."""
    both = dataclasses.replace(good, current_speed="fast", current_toward="east", current_variation="0.1")
    assert set(problems(both)) == {CURRENT_SPEED, CURRENT_TOWARD}
    fine = dataclasses.replace(good, current_speed="1.8", current_toward="270", current_shear="0.001")
    assert problems(fine) == {}
    config_from_controls(fine)


def test_a_log_replays_its_own_current_not_the_controls(good: Controls) -> None:
    c = dataclasses.replace(good, source="dive", current_speed="2.5")
    config, _ = config_from_controls(c, {})
    assert config.trajectory.current_n_mps == (0.0, 0.0, 0.0)
    assert "Current" not in dict(config_rows(config, 1, {"directory": "/logs/dive", "name": "dive"}))
    assert refused(dataclasses.replace(c, current_speed="x")) == f"{CURRENT_SPEED}: 'x' is not a number"


def test_the_address_carries_the_current(good: Controls) -> None:
    c = dataclasses.replace(
        good, current_speed="0.5", current_toward="1e2", current_shear="-0.01", current_variation="0.05"
    )
    query = links.encode(c)
    assert "cur=0.5&cto=1e2&csh=-0.01&cvar=0.05" in query
    link = links.parse(query)
    assert not link.problems and links.apply(good, link) == c
    bad = links.parse("?cur=fast&cto=90")
    assert bad.values == {"current_toward": "90"} and bad.problems[0].startswith("cur='fast': Current [m/s]")


# ---------------------------------------------------------------------------------- the Vehicle tab
def test_speed_through_the_water_and_over_ground_known_answer() -> None:
    """Heading north at 1.5 m/s through water flowing north at 0.5 m/s: 2 m/s over ground; heading
    east, the same water: sqrt(1.5^2 + 0.5^2) over ground."""
    east = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # heading 90 deg: x_b east
    C = np.stack([np.eye(3), east])
    water, ground = water_and_ground_speed_mps(
        C, np.array([[1.5, 0, 0], [1.5, 0, 0]]), np.array([[0.5, 0, 0], [0.5, 0, 0]])
    )
    assert water == pytest.approx([1.5, 1.5]) and ground == pytest.approx([2.0, np.hypot(1.5, 0.5)])


def test_the_current_figure_draws_the_current_and_both_speeds() -> None:
    t = np.linspace(0.0, 100.0, 1001)
    current = np.column_stack([np.full_like(t, 0.3), 0.4 + 0.1 * np.sin(t / 10), np.zeros_like(t)])
    fig = current_figure(
        t, current, np.full_like(t, 2.0), np.full_like(t, 2.4), max_points=200, validate=True
    )
    traces = {tr.name: tr for tr in fig.data}
    assert list(traces) == [CURRENT_NORTH_NAME, CURRENT_EAST_NAME, WATER_SPEED_NAME, GROUND_SPEED_NAME]
    assert traces[CURRENT_NORTH_NAME].yaxis == "y" and traces[WATER_SPEED_NAME].yaxis == "y2"
    assert all(len(tr.x) <= 202 and tr.x[-1] == 100.0 for tr in fig.data)
    assert traces[CURRENT_EAST_NAME].y[-1] == pytest.approx(0.4 + 0.1 * np.sin(10.0))
    assert traces[GROUND_SPEED_NAME].y[-1] == 2.4
    mean_east = 0.4 + 0.1 * (1.0 - np.cos(10.0)) / 10.0  # sin(t / 10) over 100 s
    toward_deg = np.degrees(np.arctan2(mean_east, 0.3))  # clockwise from north: 54
    assert f"mean {np.hypot(0.3, mean_east):.2f} m/s toward {toward_deg:.0f} deg" in fig.layout.title.text
    with pytest.raises(ValueError, match="current_n_mps"):
        current_figure(t, current[:, :2], t, t)


def _vehicle_tab(truth_view: dict | None, config: Config) -> types.SimpleNamespace:
    def widget(**kw: object) -> types.SimpleNamespace:
        return types.SimpleNamespace(figure=None, visible=False, content="", **kw)

    return types.SimpleNamespace(
        draw_lock=threading.RLock(),
        state=types.SimpleNamespace(truth_view=truth_view, config=config, replaying=False),
        vehicle_plot=widget(),
        vehicle_note=widget(),
        current_plot=widget(),
        current_note=widget(),
        _with_events=lambda figure, run=0: figure,  # the events: tests/unit/app/figures/test_event_traces.py
    )


@pytest.mark.parametrize("truth", ["kinematic", "dynamic"])
def test_the_vehicle_tab_shows_the_current_for_either_truth_and_nothing_more_in_still_water(
    truth: str,
) -> None:
    from app.dashboard.truth_view import truth_view

    config = Config().replace(
        "trajectory", name="figure8", duration_s=5.0, truth=truth, current_n_mps=(0.3, 0.4, 0.0)
    )
    tab = _vehicle_tab(truth_view(config, 15), config)
    PlotTabs.draw_vehicle_plot(tab)
    assert tab.current_plot.visible and tab.current_note.visible
    assert [t.name for t in tab.current_plot.figure.data][:2] == [CURRENT_NORTH_NAME, CURRENT_EAST_NAME]
    assert tab.vehicle_plot.visible == (truth == "dynamic")
    assert tab.vehicle_note.content == VEHICLE_NOTES[truth]
    still = Config().replace("trajectory", name="figure8", duration_s=5.0, truth=truth)
    tab = _vehicle_tab(truth_view(still, 15), still)
    PlotTabs.draw_vehicle_plot(tab)
    assert not tab.current_plot.visible and not tab.current_note.visible and tab.current_plot.figure is None
    assert (
        tab.vehicle_plot.visible == (truth == "dynamic") and tab.vehicle_note.content == VEHICLE_NOTES[truth]
    )


@pytest.mark.parametrize("truth, water_mps, ground_mps", [("kinematic", 1.5, 2.0), ("dynamic", 2.0, 2.5)])
def test_the_truth_view_carries_the_current_and_the_speed_through_the_water(
    truth: str, water_mps: float, ground_mps: float
) -> None:
    """The straight line north in 0.5 m/s flowing north: the kinematic truth holds its 2 m/s over
    ground (1.5 through the water); the dynamic vehicle's propeller holds 2 m/s through the water
    (2.5 over ground, once its start, at 2 m/s over ground, has settled)."""
    from app.dashboard.truth_view import truth_view

    config = Config().replace("trajectory", duration_s=60.0, truth=truth, current_n_mps=(0.5, 0.0, 0.0))
    view = truth_view(config, 15)
    assert view["current_n_mps"].shape == view["vel_water_b"].shape == (view["t_s"].size, 3)
    np.testing.assert_allclose(
        view["current_n_mps"], np.tile([0.5, 0.0, 0.0], (view["t_s"].size, 1)), atol=1e-12
    )
    water, ground = water_and_ground_speed_mps(view["C_nb"], view["vel_water_b"], view["current_n_mps"])
    assert water[-1] == pytest.approx(water_mps, abs=0.01) and ground[-1] == pytest.approx(
        ground_mps, abs=0.01
    )
    assert ground - water == pytest.approx(
        np.full_like(water, 0.5), abs=0.02
    )  # the current is along the track


def test_the_truth_view_of_still_water_has_no_current() -> None:
    from app.dashboard.truth_view import truth_view

    view = truth_view(Config().replace("trajectory", duration_s=5.0), 15)
    assert view["current_n_mps"] is None and view["vel_water_b"] is None


# ---------------------------------------------------------------------------------- the 3-D view
def test_the_arrow_points_where_the_water_flows_its_length_by_its_speed() -> None:
    arrow = current_arrow_view(np.array([0.0, 0.5, 0.0]), m_per_mps=8.0)  # flowing east
    assert arrow.shape == (1, 2, 3)
    np.testing.assert_allclose(arrow[0], [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0]])  # from its node; view x is east
    north = current_arrow_view(np.array([0.25, 0.0, 0.0]), m_per_mps=8.0)
    np.testing.assert_allclose(north[0, 1] - north[0, 0], ned_to_view(np.array([2.0, 0.0, 0.0])))
    assert current_head_m(np.array([0.5, 0.0, 0.0])) == 0.6 and current_head_m(
        np.array([0.06, 0, 0])
    ) == pytest.approx(0.16)


@pytest.mark.parametrize(
    "current, text",
    [
        ((0.0, 0.5, 0.0), "current 0.50 m/s toward 90 deg"),
        ((-0.3, -0.3, 0.0), "current 0.42 m/s toward 225 deg"),
        ((0.5, 0.0, -0.1), "current 0.50 m/s toward 0 deg, up 0.10 m/s"),
    ],
)
def test_the_arrow_s_label_gives_speed_and_direction(current: tuple, text: str) -> None:
    assert current_label(np.array(current)) == text


class _Prop(types.SimpleNamespace):
    """A scene node recording every property set on it."""

    def __setattr__(self, name: str, value: object) -> None:
        self.__dict__.setdefault("sets", []).append(name)
        super().__setattr__(name, value)


def test_the_arrow_follows_the_vehicle_and_is_redrawn_only_when_the_current_changes() -> None:
    node, arrow, label = _Prop(visible=False), _Prop(visible=True), _Prop(text="")
    for n in (node, arrow, label):
        n.sets = []
    scene = types.SimpleNamespace(
        current_node=node, current_arrow=arrow, current_text=label, current_shown=None
    )
    SceneView._show_current(scene, np.array([0.0, 0.0, 20.0]), np.array([0.0, 0.5, 0.0]))
    assert node.visible and arrow.visible and label.text == "current 0.50 m/s toward 90 deg"
    assert label.position == pytest.approx((4.0, 0.0, 0.5))  # over the arrow's tip
    assert node.position == pytest.approx((0.0, 0.0, -17.0))  # 3 m above the vehicle at 20 m depth
    arrow.sets.clear()
    SceneView._show_current(scene, np.array([10.0, 0.0, 20.0]), np.array([0.0, 0.5, 0.0]))
    assert node.position == pytest.approx((0.0, 10.0, -17.0)) and arrow.sets == []  # moved, not redrawn
    SceneView._show_current(scene, np.array([10.0, 0.0, 20.0]), np.array([0.1, 0.5, 0.0]))
    assert "points" in arrow.sets and label.text == "current 0.51 m/s toward 79 deg"
    SceneView._show_current(scene, np.array([10.0, 0.0, 20.0]), None)  # the next run in still water
    assert not node.visible and scene.current_shown is None


def test_a_scene_built_on_a_viser_server_draws_the_current_over_the_vehicle() -> None:
    """The tab's whole 3-D scene (app.dashboard.session_scene.SceneView) on a real viser scene: the arrow and
    its label made with the scene, hidden before a run and in still water, shown for a run in a
    current, over the vehicle at the slider's time."""
    from app.dashboard.truth_view import truth_view
    from tests.unit.helpers.scene_view import scene_view

    with scene_view() as (view, state):
        assert not view.current_node.visible
        config = Config().replace("trajectory", duration_s=10.0, current_n_mps=(0.0, 0.5, 0.0))
        state.config, state.truth_view = config, truth_view(config, 15)
        view.draw_truth()
        view.show_time(5.0)
        assert view.current_node.visible and view.current_text.text == "current 0.50 m/s toward 90 deg"
        pos_n = state.truth_view["pos_n"][50]
        assert view.current_node.position == pytest.approx(tuple(ned_to_view(pos_n) + [0.0, 0.0, 3.0]))
        np.testing.assert_allclose(view.current_arrow.points[0, 1], [4.0, 0.0, 0.0])
        still = Config().replace("trajectory", duration_s=10.0)
        state.config, state.truth_view = still, truth_view(still, 15)
        view.draw_truth()
        assert not view.current_node.visible
