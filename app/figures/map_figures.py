"""The map: a top-down north-east view of the truth and every method's track, with the filters'
horizontal position covariance as ellipses at the time cursor and along the track.

East is on x and north on y at one scale (equal aspect: a circle stays a circle). The ellipses are
those of ``MethodResult.pos_cov_ne_m2`` (P_NN, P_NE, P_EE [m^2]): for k-sigma, the points ``x`` with
``x^T P^-1 x = k^2``, whose semi-axes are ``k sqrt(lambda_i)`` along P's eigenvectors
(:func:`ellipse_ne`). A track is coloured by its method, by its horizontal position error against
the truth, or by the DVL's beam state (how many beams returned at the latest ping,
``updates["dvl"].beams_available``). Methods without a position state (Yoo 2014's family) draw
their track without ellipses.

The cursor's traces (each method's 1- and 3-sigma ellipse and position, the truth's position) are
the figure's last and are named in ``layout.meta`` (:data:`MAP_META`), so that the page moves them
alone when the time slider moves (:func:`cursor_traces`, app.dashboard.session_map).

A run's events (tauvcore.eval.events) lie on the truth's track as on the 3-D view's
(app.figures.event_traces.track_marks): each span a broad translucent stretch of the track in its
kind's colour, each instant a marker, with the event's own words on hover. The view opens on the
truth and the aided tracks (:func:`fitted_range`): the free INS's track and the ellipses may reach
beyond it (plotly's autoscale shows all).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.event_traces import EVENT_COLORS, EVENT_SYMBOLS, track_marks
from app.figures.shared import TRUTH_COLOR, hex_to_rgba, make_figure, method_color
from tauvcore.engine.results import MethodResult
from tauvcore.eval.events import EVENT_KINDS, Event

COLOUR_BY = ("method", "error", "beam state")
"""What a track can be coloured by."""
SIGMAS = (1.0, 3.0)
"""The ellipses drawn: 1-sigma and 3-sigma."""
ELLIPSE_POINTS = 49  # points of an ellipse's outline, the last equal to the first
ELLIPSE_EVERY_S = 20.0  # along the track, an ellipse pair every this many seconds of mission
MAP_META = "map"
"""``layout.meta["tauv"]`` of the map: the page's scripts leave it out of the time cursor."""
BEAM_STATE_COLORS = {4: "#2ca02c", 3: "#e7ba52", 2: "#ff7f0e", 1: "#d62728", 0: "#7f7f7f"}
"""The colour of a track point by the DVL beams that returned at the latest ping (0: none, or no ping yet)."""
ERROR_SCALE = "Viridis"


def covariance_ne(cov: np.ndarray) -> np.ndarray:
    """The 2x2 north-east covariance of a record's row ``cov`` (3,): P_NN, P_NE, P_EE [m^2]."""
    c = np.asarray(cov, dtype=float)
    return np.array([[c[0], c[1]], [c[1], c[2]]])


def ellipse_ne(P_ne: np.ndarray, k: float, points: int = ELLIPSE_POINTS) -> np.ndarray:
    """The k-sigma ellipse of a 2x2 north-east covariance ``P_ne`` [m^2] about the origin.

    With ``P = V diag(lambda) V^T`` (eigen-decomposition), the points
    ``x(theta) = V diag(k sqrt(lambda)) (cos theta, sin theta)`` satisfy ``x^T P^-1 x = k^2``:
    semi-axes ``k sqrt(lambda_i)`` along the eigenvectors.

    Parameters
    ----------
    P_ne : numpy.ndarray
        Shape (2, 2): [[P_NN, P_NE], [P_NE, P_EE]] [m^2], symmetric positive definite.
    k : float
        How many sigma.
    points : int
        Points of the outline (the last equal to the first, so a line closes it).

    Returns
    -------
    numpy.ndarray
        Shape (points, 2): north, east offsets [m].
    """
    lam, V = np.linalg.eigh(np.asarray(P_ne, dtype=float))
    theta = np.linspace(0.0, 2.0 * np.pi, points)
    unit = np.stack([np.cos(theta), np.sin(theta)])  # (2, points)
    return (V @ (k * np.sqrt(np.maximum(lam, 0.0))[:, None] * unit)).T


def epoch_at(t_s: np.ndarray, t: float) -> int:
    """The latest output epoch at or before ``t`` [s] (the first before the first)."""
    return int(np.clip(np.searchsorted(np.asarray(t_s), t, side="right") - 1, 0, max(len(t_s) - 1, 0)))


def _ellipses_xy(centre_ne: np.ndarray, P_ne: np.ndarray, k: float) -> tuple[list[float], list[float]]:
    """x (east), y (north) of the k-sigma ellipse about ``centre_ne`` (north, east); empty where P
    is not a finite covariance."""
    if not np.all(np.isfinite(P_ne)) or not np.all(np.isfinite(centre_ne)):
        return [], []
    pts = ellipse_ne(P_ne, k) + np.asarray(centre_ne)[:2]
    return pts[:, 1].tolist(), pts[:, 0].tolist()


@dataclass(frozen=True)
class MapTrack:
    """One method's track of one run: times, north-east positions and covariance."""

    method: str
    t_s: np.ndarray  # (T,) [s]
    ne_m: np.ndarray  # (T, 2) north, east [m]
    cov_ne_m2: np.ndarray | None  # (T, 3) P_NN, P_NE, P_EE [m^2]; None: no position state
    beams: np.ndarray | None  # (T,) beams that returned at the latest ping; None: no DVL updates


def map_tracks(results: Mapping[str, MethodResult], run: int = 0, smoothed: bool = False) -> list[MapTrack]:
    """Each method's :class:`MapTrack` of run ``run`` (0-based; the last where it has fewer); with
    ``smoothed`` the smoother's estimates and covariance where the method has them."""
    tracks = []
    for method, result in results.items():
        r = result.smoothed if smoothed and result.smoothed is not None else result
        if len(r.t_s) == 0:
            continue
        j = min(run, r.est_pos_n.shape[1] - 1)
        cov = None if r.pos_cov_ne_m2 is None else np.asarray(r.pos_cov_ne_m2[:, j])
        tracks.append(
            MapTrack(method, np.asarray(r.t_s), np.asarray(r.est_pos_n[:, j, :2]), cov, _beams(result, j))
        )
    return tracks


def _beams(result: MethodResult, run: int) -> np.ndarray | None:
    """(T,) the beams that returned at the latest DVL update at or before each output epoch of
    ``result`` (0 before the first), or None without DVL updates."""
    record = result.updates.get("dvl")
    if record is None or record.beams_available is None or len(record.t_s) == 0:
        return None
    count = np.asarray(record.beams_available[:, run]).sum(axis=-1)
    k = np.searchsorted(np.asarray(record.t_s), np.asarray(result.t_s), side="right") - 1
    return np.where(k >= 0, count[np.maximum(k, 0)], 0)


def _truth_at(truth_t_s: np.ndarray, truth_ne_m: np.ndarray, t_s: np.ndarray) -> np.ndarray:
    """The truth's north-east position (T, 2) at the epochs ``t_s`` (the nearest truth epoch)."""
    k = np.clip(np.searchsorted(truth_t_s, t_s), 0, len(truth_t_s) - 1)
    before = np.clip(k - 1, 0, len(truth_t_s) - 1)
    k = np.where(np.abs(truth_t_s[before] - t_s) <= np.abs(truth_t_s[k] - t_s), before, k)
    return truth_ne_m[k]


def horizontal_error_m(track: MapTrack, truth_t_s: np.ndarray, truth_ne_m: np.ndarray) -> np.ndarray:
    """(T,) the track's horizontal position error |estimate - truth| [m] at its epochs."""
    return np.linalg.norm(
        track.ne_m - _truth_at(np.asarray(truth_t_s), np.asarray(truth_ne_m), track.t_s), axis=-1
    )


def _hover(name: str) -> str:
    return f"{name}<br>t = %{{customdata:.1f}} s<br>north %{{y:.1f}} m, east %{{x:.1f}} m<extra></extra>"


def _track_trace(
    track: MapTrack, colour_by: str, values: np.ndarray | None, scale_max: float, first: bool
) -> dict[str, Any]:
    """A method's track: a line in its colour; coloured by error or beam state, markers on it."""
    color = method_color(track.method)
    trace: dict[str, Any] = {
        "type": "scatter",
        "x": track.ne_m[:, 1],
        "y": track.ne_m[:, 0],
        "customdata": track.t_s,
        "mode": "lines",
        "name": track.method.upper(),
        "legendgroup": track.method,
        "line": {"color": color, "width": 2},
        "hovertemplate": _hover(track.method.upper()),
    }
    if colour_by == "error" and values is not None:
        trace["mode"] = "lines+markers"
        trace["line"] = {"color": hex_to_rgba(color, 0.5), "width": 1}
        trace["marker"] = {
            "size": 5,
            "color": values,
            "colorscale": ERROR_SCALE,
            "cmin": 0.0,
            "cmax": scale_max,
            "showscale": first,
            "colorbar": {"title": {"text": "horizontal<br>error [m]"}, "thickness": 12},
        }
    elif colour_by == "beam state" and values is not None:
        trace["mode"] = "lines+markers"
        trace["line"] = {"color": hex_to_rgba(color, 0.5), "width": 1}
        trace["marker"] = {"size": 5, "color": [BEAM_STATE_COLORS[int(v)] for v in values]}
    return trace


def _along_track_trace(track: MapTrack, every_s: float) -> dict[str, Any]:
    """The 1- and 3-sigma ellipses of a track every ``every_s`` seconds (and at its last epoch), one
    trace, the outlines separated by gaps."""
    xs: list[float | None] = []
    ys: list[float | None] = []
    if track.cov_ne_m2 is not None and every_s > 0:
        marks = np.arange(track.t_s[0], track.t_s[-1] + 1e-9, every_s)
        for i in sorted({epoch_at(track.t_s, t) for t in marks} | {len(track.t_s) - 1}):
            for k in SIGMAS:
                x, y = _ellipses_xy(track.ne_m[i], covariance_ne(track.cov_ne_m2[i]), k)
                xs += [*x, None]
                ys += [*y, None]
    return {
        "type": "scatter",
        "x": xs,
        "y": ys,
        "mode": "lines",
        "name": f"{track.method.upper()} 1σ, 3σ every {every_s:g} s",
        "legendgroup": track.method,
        "showlegend": False,
        "hoverinfo": "skip",
        "line": {"color": hex_to_rgba(method_color(track.method), 0.45), "width": 1},
    }


def map_event_traces(
    events: list[Event], truth_t_s: np.ndarray, truth_ne_m: np.ndarray
) -> list[dict[str, Any]]:
    """``events`` on the truth's track (north-east, module docstring): a trace per span of the
    mission's or the sensor's own (broad) or a method's (narrower), a trace of markers per kind of
    instant whose points carry their time (a click goes there), one legend entry per kind."""
    if not events or len(truth_t_s) < 2:
        return []
    pos_n = np.column_stack([truth_ne_m, np.zeros(len(truth_t_s))])
    spans, instants, _ = track_marks(events, truth_t_s, pos_n)
    data: list[dict[str, Any]] = []
    legend: set[str] = set()

    def entry(kind: str) -> dict[str, Any]:
        shown = kind not in legend
        legend.add(kind)
        return {"name": EVENT_KINDS[kind], "legendgroup": f"event {kind}", "showlegend": shown}

    for event, points in spans:
        width = 10 if event.method is None else 6
        data.append({"type": "scatter", "x": points[:, 1], "y": points[:, 0], "mode": "lines",
                     "line": {"color": hex_to_rgba(EVENT_COLORS[event.kind], 0.35), "width": width},
                     "hovertext": event.text, "hoverinfo": "text", **entry(event.kind)})  # fmt: skip
    for kind, points in instants.items():
        chosen = [e for e in events if e.instant and e.kind == kind]
        data.append({"type": "scatter", "x": points[:, 1], "y": points[:, 0], "mode": "markers",
                     "customdata": [e.start_s for e in chosen], "hovertext": [e.text for e in chosen],
                     "hoverinfo": "text", "marker": {"color": EVENT_COLORS[kind], "size": 9,
                     "symbol": EVENT_SYMBOLS[kind], "line": {"width": 1, "color": "white"}},
                     **entry(kind)})  # fmt: skip
    return data


FIT_MARGIN = 0.08  # of the fitted view's extent, added on every side


def fitted_range(
    tracks: list[MapTrack], truth_ne_m: np.ndarray
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The east and north ranges [m] the map opens on: the truth and every aided track (every track
    when the free INS is the only one), with :data:`FIT_MARGIN`; None: nothing to fit."""
    aided = [t.ne_m for t in tracks if t.method != "ins"] or [t.ne_m for t in tracks]
    points = [p for p in (truth_ne_m, *aided) if len(p)]
    if not points:
        return None
    ne = np.concatenate(points)
    ne = ne[np.isfinite(ne).all(axis=1)]
    if not len(ne):
        return None
    lo, hi = ne.min(axis=0), ne.max(axis=0)
    pad = FIT_MARGIN * max(float(np.max(hi - lo)), 1.0)
    return (float(lo[1] - pad), float(hi[1] + pad)), (float(lo[0] - pad), float(hi[0] + pad))


def _legend_only(name: str, color: str) -> dict[str, Any]:
    return {
        "type": "scatter",
        "x": [None],
        "y": [None],
        "mode": "markers",
        "name": name,
        "legendgroup": "beams",
        "marker": {"size": 8, "color": color},
    }


def cursor_traces(
    tracks: list[MapTrack], truth_t_s: np.ndarray, truth_ne_m: np.ndarray, t: float
) -> list[tuple[list[float], list[float]]]:
    """x (east) and y (north) of the map's cursor traces at time ``t`` [s], in the figure's order:
    the truth's position, then for each track its 1-sigma ellipse, its 3-sigma ellipse (empty
    without a covariance) and its position, at its latest epoch at or before ``t``."""
    out: list[tuple[list[float], list[float]]] = []
    if len(truth_t_s):
        ne = np.asarray(truth_ne_m)[epoch_at(truth_t_s, t)]
        out.append(([float(ne[1])], [float(ne[0])]))
    else:
        out.append(([], []))
    for track in tracks:
        i = epoch_at(track.t_s, t)
        for k in SIGMAS:
            if track.cov_ne_m2 is None:
                out.append(([], []))
            else:
                out.append(_ellipses_xy(track.ne_m[i], covariance_ne(track.cov_ne_m2[i]), k))
        out.append(([float(track.ne_m[i, 1])], [float(track.ne_m[i, 0])]))
    return out


def _cursor_trace_styles(tracks: list[MapTrack]) -> list[dict[str, Any]]:
    """The cursor traces without their points (:func:`cursor_traces` gives those), same order."""
    common = {"type": "scatter", "showlegend": False, "customdata": None, "hoverinfo": "skip"}
    styles = [{**common, "name": "truth at the cursor", "mode": "markers",
               "marker": {"symbol": "x", "size": 10, "color": TRUTH_COLOR}}]  # fmt: skip
    for track in tracks:
        color, name = method_color(track.method), track.method.upper()
        for k, width in zip(SIGMAS, (2.0, 1.5)):
            styles.append({**common, "name": f"{name} {k:g}σ at the cursor", "mode": "lines",
                           "legendgroup": track.method, "line": {"color": color, "width": width,
                           "dash": "solid" if k == 1 else "dash"}})  # fmt: skip
        styles.append({**common, "name": f"{name} at the cursor", "mode": "markers", "legendgroup": track.method,
                       "marker": {"size": 9, "color": color, "line": {"color": "white", "width": 1}}})  # fmt: skip
    return styles


def _colour_values(
    tracks: list[MapTrack], colour_by: str, truth_t_s: np.ndarray, truth_ne_m: np.ndarray
) -> tuple[list[np.ndarray | None], float]:
    """Each track's values to colour by (horizontal error [m] or beams) and the error scale's top."""
    if colour_by == "error" and len(truth_t_s):
        values: list[np.ndarray | None] = [horizontal_error_m(tr, truth_t_s, truth_ne_m) for tr in tracks]
        finite = [v[np.isfinite(v)] for v in values if v is not None]
        top = max((float(v.max()) for v in finite if v.size), default=1.0)
        return values, top if top > 0 else 1.0
    if colour_by == "beam state":
        return [tr.beams for tr in tracks], 4.0
    return [None] * len(tracks), 1.0


def map_figure(
    tracks: list[MapTrack],
    truth_t_s: np.ndarray,
    truth_ne_m: np.ndarray,
    t: float,
    colour_by: str = "method",
    every_s: float = ELLIPSE_EVERY_S,
    height_px: int = 520,
    key: str = "",
    events: list[Event] | None = None,
    validate: bool = False,
) -> go.Figure:
    """The map (module docstring): east on x, north on y at one scale.

    Parameters
    ----------
    tracks : list[MapTrack]
        The methods' tracks (:func:`map_tracks`).
    truth_t_s, truth_ne_m : numpy.ndarray
        The truth's epochs (N,) [s] and north-east positions (N, 2) [m]; empty: no truth.
    t : float
        The time cursor [s]: where the cursor's ellipses and positions are drawn.
    colour_by : str
        One of :data:`COLOUR_BY`: each track in its method's colour, or marked by its horizontal
        error against the truth (one colour scale for all), or by the DVL's beams at the latest ping.
    every_s : float
        Seconds of mission between two ellipse pairs along a track (0: none).
    height_px : int
        The figure's height [px].
    key : str
        Names the results drawn (``layout.meta["key"]``): the page moves the cursor traces only
        of the figure of the results it moves them for.
    events : list[Event] or None
        The run's events, drawn on the truth's track (:func:`map_event_traces`); None: none.
    validate : bool
        Whether plotly validates the figure (app.figures.shared.make_figure).

    Returns
    -------
    plotly.graph_objects.Figure
        The truth, each track, its ellipses along it, a legend entry per beam state when
        coloured by it, the events, and last the cursor's traces (``layout.meta["cursor"]``: the
        first's index).
    """
    if colour_by not in COLOUR_BY:
        raise ValueError(f"colour_by must be one of {', '.join(COLOUR_BY)}, got {colour_by!r}")
    truth_t_s, truth_ne_m = np.asarray(truth_t_s, dtype=float), np.asarray(truth_ne_m, dtype=float)
    data: list[dict[str, Any]] = []
    if len(truth_t_s):
        data.append({"type": "scatter", "x": truth_ne_m[:, 1], "y": truth_ne_m[:, 0], "customdata": truth_t_s,
                     "mode": "lines", "name": "truth", "line": {"color": TRUTH_COLOR, "width": 2, "dash": "dot"},
                     "hovertemplate": _hover("truth")})  # fmt: skip
    values, top = _colour_values(tracks, colour_by, truth_t_s, truth_ne_m)
    for i, (track, v) in enumerate(zip(tracks, values)):
        data.append(_track_trace(track, colour_by, v, top, first=i == 0))
        data.append(_along_track_trace(track, every_s))
    if colour_by == "beam state":
        data += [_legend_only(f"{n} beams" if n != 1 else "1 beam", c) for n, c in BEAM_STATE_COLORS.items()]
    data += map_event_traces(list(events or ()), truth_t_s, truth_ne_m)
    first_cursor = len(data)
    for style, (x, y) in zip(_cursor_trace_styles(tracks), cursor_traces(tracks, truth_t_s, truth_ne_m, t)):
        data.append({**style, "x": x, "y": y})
    layout = {
        "title": {"text": "Map: tracks with 1σ and 3σ position ellipses (north up)", "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 60, "r": 10, "t": 35, "b": 40},
        "hovermode": "closest",
        "legend": {"orientation": "h", "yanchor": "top", "y": -0.12},
        "xaxis": {"title": {"text": "east [m]"}, "zeroline": False},
        "yaxis": {"title": {"text": "north [m]"}, "zeroline": False, "scaleanchor": "x", "scaleratio": 1},
        "meta": {"tauv": MAP_META, "cursor": first_cursor, "key": key},
        "template": "plotly_white",
    }
    fitted = fitted_range(tracks, truth_ne_m)
    if fitted is not None:
        layout["xaxis"]["range"], layout["yaxis"]["range"] = list(fitted[0]), list(fitted[1])
    return make_figure(data, layout, validate=validate)


__all__ = [
    "BEAM_STATE_COLORS",
    "COLOUR_BY",
    "ELLIPSE_EVERY_S",
    "MAP_META",
    "SIGMAS",
    "MapTrack",
    "covariance_ne",
    "cursor_traces",
    "ellipse_ne",
    "epoch_at",
    "fitted_range",
    "horizontal_error_m",
    "map_event_traces",
    "map_figure",
    "map_tracks",
]
