"""A run's events on a figure's time axes (app.figures.event_traces): a band per span and panel
behind the data, markers with the events' hover texts on an invisible axis over each panel, the
time cursor kept first."""

from __future__ import annotations

import json

import numpy as np

from app.figures.event_traces import (
    EVENT_COLORS,
    MAX_SPANS,
    event_shapes,
    merged_spans,
    time_panels,
    with_events,
)
from app.figures.shared import CURSOR_NAME, make_figure, stacked_layout, with_cursor
from tauvcore.eval.events import EVENT_KINDS, Event

OUTAGE = Event("outage", 100.0, 150.0, None, (3, 4), "scheduled DVL outage: beams 3,4 lost 100-150 s")
REJECTION = Event("rejection", 120.0, 120.0, "lc", (), "LC: DVL update rejected by the gate at 120 s", "dvl")
RPM = Event("rpm", 100.0, 150.0, "tc", (), "TC: RPM velocity in place of the DVL 100-150 s")
DIVERGED = Event("diverged", 170.0, 170.0, "tc", (), "TC: divergence flagged at 170 s (the monitor's first flag)")


def _two_panels():
    t = np.linspace(0.0, 200.0, 11)
    data = [{"type": "scatter", "x": t, "y": t}, {"type": "scatter", "x": t, "y": t, "xaxis": "x2", "yaxis": "y2"}]
    return with_cursor(make_figure(data, stacked_layout("two", ["a", "b"], 400)), 10.0)


def test_every_panel_gets_the_outage_band_and_the_markers():
    figure = with_events(_two_panels(), [OUTAGE, REJECTION, RPM, DIVERGED])
    layout = json.loads(figure.to_json())["layout"]
    shapes = layout["shapes"]
    assert shapes[0]["name"] == CURSOR_NAME
    bands = [s for s in shapes if s.get("name") == "event outage"]
    assert [(s["xref"], s["yref"], s["x0"], s["x1"], s["y0"], s["y1"], s["layer"]) for s in bands] == [
        ("x", "y domain", 100.0, 150.0, 0.0, 1.0, "below"), ("x2", "y2 domain", 100.0, 150.0, 0.0, 1.0, "below")]
    strips = [s for s in shapes if s.get("name") == "event rpm"]
    assert len(strips) == 2 and all(s["y0"] > 0.9 and s["y1"] == 1.0 for s in strips)  # a method's: along the top
    assert len([s for s in shapes if s.get("name") == "event diverged"]) == 2  # a line in each panel
    markers = [d for d in figure.data if d.name in EVENT_KINDS.values()]
    assert {(d.name, d.xaxis, d.yaxis) for d in markers} == {
        (EVENT_KINDS[k], x, y) for k in ("outage", "rejection", "rpm", "diverged") for x, y in (("x", "y51"), ("x2", "y52"))}
    outage = next(d for d in markers if d.name == EVENT_KINDS["outage"] and d.xaxis == "x")
    assert list(outage.x) == [100.0, 125.0, 150.0] and set(outage.hovertext) == {OUTAGE.text}
    assert outage.marker.color == EVENT_COLORS["outage"] and outage.showlegend
    assert sum(bool(d.showlegend) for d in markers) == 4  # each kind once in the legend
    assert layout["yaxis51"]["overlaying"] == "y" and layout["yaxis52"]["overlaying"] == "y2"
    assert layout["yaxis51"]["visible"] is False and layout["yaxis51"]["range"] == [0.0, 1.0]


def test_no_events_leave_the_figure_as_it_was():
    figure = _two_panels()
    before = figure.to_json()
    assert with_events(figure, []).to_json() == before


def test_panels_of_an_overlaid_axis_are_its_base():
    data = [{"type": "scatter", "x": [0, 1], "y": [0, 1]}, {"type": "scatter", "x": [0, 1], "y": [0, 1], "yaxis": "y2"}]
    figure = make_figure(data, {"yaxis2": {"overlaying": "y", "side": "right"}})
    assert time_panels(figure) == [("x", "y")]
    assert time_panels(with_events(figure, [OUTAGE])) == [("x", "y")]  # not its own markers' axis


def test_many_spans_are_drawn_merged_with_a_count():
    spans = [Event("dropout", float(k), k + 0.5, None, (1 + k % 2,), f"d{k}") for k in range(2 * MAX_SPANS)]
    drawn = merged_spans(spans)
    assert len(drawn) <= MAX_SPANS
    assert drawn[0].start_s == 0.0 and drawn[-1].end_s == spans[-1].end_s
    assert drawn[0].beams == (1, 2) and "× DVL beams lost" in drawn[0].text
    assert len(event_shapes(spans, [("x", "y")])) == len(drawn)


def test_track_marks_lie_on_the_track_at_the_events_times():
    """A straight track north at 2 m/s: the outage 100-150 s is the stretch 200-300 m north, the
    rejection at 120 s a dot at 240 m, labels name the outage and the divergence and count the rest."""
    from app.figures.event_traces import track_marks

    t = np.arange(0.0, 201.0)
    pos_n = np.stack([2.0 * t, np.zeros_like(t), np.full_like(t, 10.0)], axis=-1)
    spans, instants, labels = track_marks([OUTAGE, REJECTION, DIVERGED], t, pos_n)
    ((event, stretch),) = spans
    assert event == OUTAGE
    assert stretch[0, 0] == 200.0 and stretch[-1, 0] == 300.0 and np.all(np.diff(stretch[:, 0]) > 0)
    np.testing.assert_allclose(instants["rejection"], [[240.0, 0.0, 10.0]])
    np.testing.assert_allclose(instants["diverged"], [[340.0, 0.0, 10.0]])
    assert [text for text, _ in labels] == [
        "DVL outage beams 3,4 100-150 s", "TC diverged 170 s", "1 × gate rejection"]
