"""A run's events (tauvcore.eval.events) drawn on a figure's time axes: every panel of the figure
(each pair of x and y axes its traces use) gets

- a translucent band behind the data (a layout shape, ``layer="below"``) for each span: the
  mission's and the sensor's own (a scheduled outage, a dropout) over the panel's full height, a
  method's (the RPM velocity in place of the DVL) as a strip along the panel's top edge;
- a dashed vertical line for each lock-out reset and divergence flag;
- a marker along the panel's top edge at each instant and at the start, middle and end of each
  span, one scatter per kind whose legend entry names the kind and its colour
  (:data:`tauvcore.eval.events.EVENT_KINDS`) and whose hover text is the event's own (what, which
  method, which beams, when, in seconds).

The markers sit on an invisible y axis of their own over each panel (``yaxis51`` over the first,
``yaxis52`` over the second, ...: :data:`EVENT_AXIS_BASE`), from 0 at the panel's bottom to 1 at its
top, so they stay at the top edge whatever the panel's scale (log, categories).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.shared import hex_to_rgba
from tauvcore.eval.events import EVENT_KINDS, Event, beams_text, seconds

EVENT_COLORS = {
    "outage": "#7f7f7f",
    "dropout": "#ff7f0e",
    "rpm": "#9467bd",
    "rejection": "#d62728",
    "reset": "#17becf",
    "diverged": "#000000",
}
"""Each kind's colour (its band, line and marker), named in its legend entry."""
EVENT_SYMBOLS = {
    "outage": "square",
    "dropout": "square",
    "rpm": "square",
    "rejection": "x",
    "reset": "diamond",
    "diverged": "star",
}
"""Each kind's marker symbol."""
SPAN_ALPHA = 0.15  # a band of the mission's or the sensor's (full height): pale, the data shows through
STRIP_ALPHA = 0.45  # a method's band (a strip along the top edge)
STRIP_DOMAIN = (0.94, 1.0)  # a method's band: the top 6 % of the panel
MARKER_Y = 0.985  # the markers' height in their panel (0 bottom, 1 top)
LINE_KINDS = ("reset", "diverged")  # instants also drawn as a dashed line across the panel
EVENT_AXIS_BASE = 50  # the markers' y axes: yaxis51 over the first panel, yaxis52 over the second, ...
MAX_SPANS = 200  # bands of one kind and method in one panel at most: closer ones are drawn merged
EVENT_SHAPE_PREFIX = "event "  # the name of every shape drawn here ("event outage", ...)
EVENT_LEGEND_GROUP = "events"


def time_panels(figure: go.Figure) -> list[tuple[str, str]]:
    """The panels of ``figure``: each pair of x and y axes its traces use, in order of first use,
    a y axis laid over another (``overlaying``) counted as that one (("x", "y") for a figure
    without traces)."""
    layout = figure.layout
    panels: list[tuple[str, str]] = []
    for trace in figure.data:
        x = getattr(trace, "xaxis", None) or "x"
        y = getattr(trace, "yaxis", None) or "y"
        key = _layout_key(y)
        over = getattr(layout[key], "overlaying", None) if key in layout else None  # a Layout has no get
        if isinstance(over, str) and over.startswith("y"):
            y = over
        if int(y[1:] or 1) > EVENT_AXIS_BASE:  # our own markers' axes
            continue
        if (x, y) not in panels:
            panels.append((x, y))
    return panels or [("x", "y")]


def _layout_key(ref: str) -> str:
    """ "y" -> "yaxis", "x3" -> "xaxis3"."""
    return f"{ref[0]}axis{ref[1:]}"


def merged_spans(spans: Sequence[Event], max_spans: int = MAX_SPANS) -> list[Event]:
    """``spans`` (of one kind and method, sorted by start) with at most about ``max_spans`` left:
    bands closer than the run's time span / ``max_spans`` drawn as one (its text says how many)."""
    if len(spans) <= max_spans:
        return list(spans)
    gap_s = (max(e.end_s for e in spans) - spans[0].start_s) / max_spans
    groups: list[list[Event]] = [[spans[0]]]
    for e in spans[1:]:
        if e.start_s - max(g.end_s for g in groups[-1]) <= gap_s:
            groups[-1].append(e)
        else:
            groups.append([e])
    out = []
    for group in groups:
        first, end = group[0], max(e.end_s for e in group)
        if len(group) == 1:
            out.append(first)
            continue
        who = f"{first.method.upper()}: " if first.method else ""
        beams = tuple(sorted({b for e in group for b in e.beams}))
        text = f"{who}{len(group)} × {EVENT_KINDS[first.kind]} {seconds(first.start_s)}-{seconds(end)} s"
        out.append(Event(first.kind, first.start_s, end, first.method, beams, text, first.source))
    return out


def event_shapes(events: Sequence[Event], panels: Sequence[tuple[str, str]]) -> list[dict[str, Any]]:
    """The layout shapes of ``events`` in every panel: a band per span (:func:`merged_spans`), a
    dashed line per reset and divergence flag (module docstring)."""
    spans = [e for e in events if not e.instant]
    keys = list(dict.fromkeys((e.kind, e.method) for e in spans))
    drawn = [
        s
        for kind, method in keys
        for s in merged_spans([e for e in spans if (e.kind, e.method) == (kind, method)])
    ]
    lines = [e for e in events if e.instant and e.kind in LINE_KINDS]
    shapes: list[dict[str, Any]] = []
    for x, y in panels:
        for e in drawn:
            color = EVENT_COLORS[e.kind]
            low, high = (0.0, 1.0) if e.method is None else STRIP_DOMAIN
            alpha = SPAN_ALPHA if e.method is None else STRIP_ALPHA
            shapes.append(
                {
                    "type": "rect",
                    "name": EVENT_SHAPE_PREFIX + e.kind,
                    "xref": x,
                    "yref": f"{y} domain",
                    "x0": e.start_s,
                    "x1": e.end_s,
                    "y0": low,
                    "y1": high,
                    "fillcolor": hex_to_rgba(color, alpha),
                    "line": {"width": 0},
                    "layer": "below",
                }
            )
        for e in lines:
            shapes.append(
                {
                    "type": "line",
                    "name": EVENT_SHAPE_PREFIX + e.kind,
                    "xref": x,
                    "yref": f"{y} domain",
                    "x0": e.start_s,
                    "x1": e.start_s,
                    "y0": 0.0,
                    "y1": 1.0,
                    "line": {"color": EVENT_COLORS[e.kind], "width": 1.2, "dash": "dash"},
                    "layer": "below",
                }
            )
    return shapes


def _marker_points(events: Sequence[Event]) -> tuple[list[float], list[str]]:
    """Times and hover texts of one kind's markers: an instant at its time, a span at its start,
    middle and end."""
    x: list[float] = []
    text: list[str] = []
    for e in events:
        times = [e.start_s] if e.instant else [e.start_s, 0.5 * (e.start_s + e.end_s), e.end_s]
        x += times
        text += [e.text] * len(times)
    return x, text


def event_traces(
    events: Sequence[Event], panels: Sequence[tuple[str, str]]
) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any]]]:
    """The markers of ``events`` (module docstring): one scatter per kind and panel (in the legend
    once, under the kind's name) and the invisible y axes they sit on, layout key -> axis."""
    traces: list[dict[str, Any]] = []
    axes: dict[str, dict[str, Any]] = {}
    kinds = [k for k in EVENT_KINDS if any(e.kind == k for e in events)]
    for k, (x, y) in enumerate(panels):
        ref = f"y{EVENT_AXIS_BASE + k + 1}"
        axes[_layout_key(ref)] = {
            "overlaying": y,
            "anchor": x,
            "range": [0.0, 1.0],
            "visible": False,
            "fixedrange": True,
        }
        for kind in kinds:
            chosen = [e for e in events if e.kind == kind]
            if not (chosen[0].instant or kind in LINE_KINDS):
                keys = list(dict.fromkeys(e.method for e in chosen))
                chosen = [s for m in keys for s in merged_spans([e for e in chosen if e.method == m])]
            times, texts = _marker_points(chosen)
            traces.append(
                {
                    "type": "scatter",
                    "x": times,
                    "y": [MARKER_Y] * len(times),
                    "xaxis": x,
                    "yaxis": ref,
                    "mode": "markers",
                    "name": EVENT_KINDS[kind],
                    "hovertext": texts,
                    "hovertemplate": "%{hovertext}<extra></extra>",
                    "marker": {"color": EVENT_COLORS[kind], "symbol": EVENT_SYMBOLS[kind], "size": 7},
                    "cliponaxis": False,
                    "legendgroup": f"{EVENT_LEGEND_GROUP}-{kind}",
                    "showlegend": k == 0,
                }
            )
    return traces, axes


def with_events(figure: go.Figure, events: Sequence[Event]) -> go.Figure:
    """``figure`` with ``events`` drawn on every panel (module docstring): a new figure (``figure``
    itself when there are no events or no data). The shapes come after those it has (the time
    cursor stays the first). Built from plain dicts without plotly's checks (as
    app.figures.shared.make_figure does): adding them to ``figure`` through plotly's setters took
    five times as long as building the figure."""
    if not events or not figure.data:
        return figure
    panels = time_panels(figure)
    traces, axes = event_traces(events, panels)
    plain = figure.to_plotly_json()
    layout = plain["layout"]
    layout.update(axes)
    layout["shapes"] = [*layout.get("shapes", ()), *event_shapes(events, panels)]
    return go.Figure(data=[*plain["data"], *traces], layout=layout, _validate=False)


TRACK_LABELLED = ("outage", "dropout", "diverged")  # kinds labelled on the 3-D track, each event
MAX_TRACK_LABELS = 12  # labels on the track at most (the first ones in time)


def track_marks(
    events: Sequence[Event], t_s: np.ndarray, pos_n: np.ndarray, max_points: int = 200
) -> tuple[list[tuple[Event, np.ndarray]], dict[str, np.ndarray], list[tuple[str, np.ndarray]]]:
    """Where ``events`` lie on a track: the positions ``pos_n`` (T, 3) NED [m] at the times
    ``t_s`` (T,) [s] (the truth's).

    Returns
    -------
    spans : list[tuple[Event, numpy.ndarray]]
        Each span (:func:`merged_spans`) with the track's positions (n, 3) NED [m] from its start
        to its end (interpolated at both ends, at most about ``max_points`` between).
    instants : dict[str, numpy.ndarray]
        Kind -> the track's positions (n, 3) NED [m] at its instants.
    labels : list[tuple[str, numpy.ndarray]]
        A short text and its position (3,) NED [m] for the first :data:`MAX_TRACK_LABELS` events of
        the kinds :data:`TRACK_LABELLED` and the first of each other kind ("3 × gate rejection").
    """
    t_s = np.asarray(t_s, dtype=float)

    def at(times: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(times, t_s, pos_n[:, k]) for k in range(3)], axis=-1)

    spans_out: list[tuple[Event, np.ndarray]] = []
    keys = list(dict.fromkeys((e.kind, e.method) for e in events if not e.instant))
    for kind, method in keys:
        for e in merged_spans([e for e in events if not e.instant and (e.kind, e.method) == (kind, method)]):
            inside = t_s[(t_s > e.start_s) & (t_s < e.end_s)]
            inside = inside[:: max(1, inside.size // max_points)]
            spans_out.append((e, at(np.r_[e.start_s, inside, e.end_s])))
    instants = {
        kind: at(np.array([e.start_s for e in events if e.instant and e.kind == kind]))
        for kind in EVENT_KINDS
        if any(e.instant and e.kind == kind for e in events)
    }
    labels: list[tuple[str, np.ndarray]] = []
    for e in events:
        if e.kind in TRACK_LABELLED and len(labels) < MAX_TRACK_LABELS:
            labels.append((_track_label(e), at(np.array([e.start_s]))[0]))
    for kind, points in instants.items():
        if kind not in TRACK_LABELLED:
            labels.append((f"{len(points)} × {EVENT_KINDS[kind]}", points[0]))
    return spans_out, instants, labels


def _track_label(e: Event) -> str:
    """A short label of ``e`` on the track: "DVL outage beams 3,4 100-150 s", "LC diverged 343.4 s"."""
    if e.kind == "diverged":
        return f"{e.method.upper() if e.method else ''} diverged {seconds(e.start_s)} s".strip()
    what = "DVL outage" if e.kind == "outage" else EVENT_KINDS[e.kind]
    beams = f" {beams_text(e.beams)}" if e.beams else ""
    return f"{what}{beams} {seconds(e.start_s)}-{seconds(e.end_s)} s"


__all__ = [
    "EVENT_COLORS",
    "EVENT_SYMBOLS",
    "event_shapes",
    "event_traces",
    "merged_spans",
    "time_panels",
    "track_marks",
    "with_events",
]
