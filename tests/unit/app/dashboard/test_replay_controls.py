"""A replay's controls and the tab's notices, without a browser: the controls a log does not read
disabled with their reason, the settings a replay runs with named, red notices removed by the next
successful run, the Smoothed boxes unticked for a run without smoothed series, and the lime
water-track beams drawn beside the bottom-track ones with water-track "both"."""

from __future__ import annotations

import threading
import types

import numpy as np

from app.dashboard import inputs
from app.dashboard.session_controls import SIMULATION_ONLY, ControlPanel, replay_settings_note
from app.dashboard.session_plots import PlotTabs
from app.dashboard.session_scene import SceneView
from app.dashboard.session_state import clear_notices, notify
from app.figures.scene import BEAM_RETURNING, BEAM_WATER, water_beside, water_ranges_m
from tauvcore.config import Config
from tauvcore.sensors.dvl import Outage


class _Handle:
    def __init__(self, hint=None, value=False) -> None:
        self.hint, self.disabled, self.value, self.removed = hint, False, value, 0

    def remove(self) -> None:
        self.removed += 1


def _panel() -> types.SimpleNamespace:
    panel = types.SimpleNamespace(own_hints={}, source=_Handle(value="dive"))
    for attr in SIMULATION_ONLY:
        setattr(panel, attr, _Handle(hint=f"own hint of {attr}"))
    return panel


def test_a_log_disables_the_simulation_s_controls_with_the_reason_and_a_simulation_restores_them() -> None:
    panel = _panel()
    assert {"trajectory", "duration", "truth", "current_speed"} <= set(SIMULATION_ONLY)
    ControlPanel._simulation_only(panel, False)
    assert all(getattr(panel, a).disabled for a in SIMULATION_ONLY)
    assert panel.duration.hint == "set by the log: a replay runs the log's whole length"
    assert panel.trajectory.hint.startswith("set by the log")
    ControlPanel.show_log_facts(panel, Config().replace("trajectory", duration_s=398.0))
    assert panel.duration.hint == "set by the log: 398 s"
    ControlPanel._simulation_only(panel, True)
    assert not any(getattr(panel, a).disabled for a in SIMULATION_ONLY)
    assert all(getattr(panel, a).hint == f"own hint of {a}" for a in SIMULATION_ONLY)
    panel.source.value = inputs.SIMULATION
    ControlPanel.show_log_facts(panel, Config().replace("trajectory", duration_s=398.0))
    assert panel.duration.hint == "own hint of duration"


def test_a_replay_s_status_names_the_outages_and_sensor_settings_it_runs_with() -> None:
    config = Config().replace("dvl", outages=(Outage((3, 4), 100.0, 150.0),), noise_mps=0.05)
    assert replay_settings_note(config, "dive") == "; with DVL noise 0.05 m/s, DVL outages beams 3,4 off 100-150 s"
    # what the log sets, or does not read, is not named: its length, its current, the DVL's range
    ignored = Config().replace("trajectory", duration_s=398.0, current_n_mps=(0.3, 0.0, 0.0))
    assert replay_settings_note(ignored.replace("dvl", max_altitude_m=30.0), "dive") == ""


def test_red_notices_are_kept_and_removed_by_clear_notices_green_ones_are_not() -> None:
    shown = []
    client = types.SimpleNamespace(add_notification=lambda *a, **k: shown.append(_Handle()) or shown[-1])
    notices = []
    notify(client, "Cannot run", "Duration [s]: x", error=True, notices=notices)
    notify(client, "Run complete", "ok", notices=notices)
    assert notices == [shown[0]]
    clear_notices(notices)
    assert notices == [] and shown[0].removed == 1 and shown[1].removed == 0


def test_the_smoothed_boxes_untick_for_final_results_without_smoothed_series() -> None:
    boxes = [_Handle(value=True), _Handle(value=True)]
    plots = types.SimpleNamespace(show_smoothed=boxes[0], show_smoothed_nees=boxes[1], _unticking=False)
    PlotTabs._smoothed_boxes(plots, False, final=False)       # a smoothed run's live results: greyed, kept
    assert [(b.value, b.disabled) for b in boxes] == [(True, True)] * 2
    PlotTabs._smoothed_boxes(plots, False)
    assert [(b.value, b.disabled) for b in boxes] == [(False, True)] * 2
    PlotTabs._smoothed_boxes(plots, True)                     # enabled, not ticked for the user
    assert [(b.value, b.disabled) for b in boxes] == [(False, False)] * 2


def test_water_track_both_draws_a_lime_beam_beside_each_bottom_track_beam() -> None:
    config = Config().replace("dvl", water_track="both", water_layer_m=10.0)
    layer = water_ranges_m(np.eye(3), config.dvl.A_b, 10.0)
    ranges = np.array([40.0, 5.0, 45.0, np.inf])
    states = [BEAM_RETURNING] * 3 + ["lost"]
    np.testing.assert_array_equal(water_beside("both", states, layer, ranges), [True, False, True, False])
    assert not water_beside("off", states, layer, ranges).any()

    class Node:
        def __init__(self, points, colors, visible) -> None:
            self.points, self.colors, self.visible = points, colors, visible

    added = []
    scene = types.SimpleNamespace(add_line_segments=lambda name, points, colors, **k: added.append(
        Node(points, colors, k["visible"])) or added[-1])
    view = types.SimpleNamespace(draw_lock=threading.RLock(), client=types.SimpleNamespace(scene=scene))
    pos_n = np.array([0.0, 0.0, 20.0])
    SceneView.show_beams_static(view, config, pos_n, np.eye(3), [BEAM_RETURNING] * 4, np.full(4, 40.0))
    lime = [[n.visible and n.colors == (0, 255, 0) for n in beam] for beam in view.beam_nodes]
    assert all(sum(row) == 1 for row in lime)                               # one lime beam each
    assert all(beam[0].visible for beam in view.beam_nodes)                 # beside the blue one
    SceneView.show_beams_static(view, config.replace("dvl", water_track="off"), pos_n, np.eye(3),
                                [BEAM_RETURNING] * 4, np.full(4, 40.0))
    assert len(added) == 20 and not any(beam[4].visible for beam in view.beam_nodes)
    assert BEAM_WATER == "water-track"
