"""The run's events on the truth's track in the 3-D view follow the Events box."""

from __future__ import annotations

import numpy as np

from app.dashboard.truth_view import truth_view
from app.figures.scene import ned_to_view
from tauvcore.config import Config
from tauvcore.sensors.dvl import Outage
from tests.unit.helpers.scene_view import scene_view


def test_the_track_s_events_go_with_the_events_box_and_come_back() -> None:
    """Given a mission with beams 3 and 4 out 10-20 s, the truth's track carries the outage as a
    stretch of line segments from its start to its end and its label; with the box off
    (``events_shown`` False) every mark is removed; on again, drawn again."""
    config = Config().replace("trajectory", name="figure8", duration_s=30.0)
    config = config.replace("dvl", outages=(Outage(beams=(3, 4), start_s=10.0, end_s=20.0),))
    with scene_view() as (view, state):
        state.config, state.truth_view = config, truth_view(config, 15)
        view.draw_truth()
        names = sorted(handle.name for handle in view.event_marks)
        assert names == ["/events/label_0", "/events/span_0"]
        span = next(h for h in view.event_marks if h.name == "/events/span_0")
        tv = state.truth_view
        start = [np.interp(10.0, tv["t_s"], tv["pos_n"][:, k]) for k in range(3)]
        end = [np.interp(20.0, tv["t_s"], tv["pos_n"][:, k]) for k in range(3)]
        np.testing.assert_allclose(span.points[0, 0], ned_to_view(np.array(start)), atol=1e-5)
        np.testing.assert_allclose(span.points[-1, 1], ned_to_view(np.array(end)), atol=1e-5)
        state.events_shown = False
        view.draw_events()
        assert view.event_marks == [] and view.events_drawn == []
        state.events_shown = True
        view.draw_events()
        assert sorted(handle.name for handle in view.event_marks) == names
