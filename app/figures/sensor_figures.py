"""Plotly figures of the Sensors tab: a run's raw measurements (the IMU's rates and specific force,
every aiding source's columns, the DVL beams' states), what every method estimated of the states
its aiding sources add (the DVL's current, north and east) with its 1-sigma against their truth,
and what a method estimated of the sensors' errors (IMU biases, DVL beam biases and scale factor)
with its 3-sigma against their truth.

Both are stacked panels on one time axis, each panel named in its top-left corner with its unit
and its curves' colours (no legend: a shared one would list the same x, y, z in every panel).
Angles are drawn in degrees, the IMU's biases in mg and deg/h, the DVL's in mm/s and percent:
the units a data sheet gives them in.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.scene import BEAM_COLORS, BEAM_WATER
from app.figures.sensor_view import BEAM_STATE_CODES, SensorView, SourceView
from app.figures.shared import (
    TIME_AXIS,
    TRUTH_COLOR,
    band_alpha,
    bin_label,
    decimate,
    envelope_traces,
    hex_to_rgba,
    make_figure,
    merge_bins,
    merged_envelope,
    method_color,
    panel_domains,
)
from tauvcore.engine.results import MethodResult, sensor_states
from tauvcore.eval.envelope import is_decimated
from tauvcore.units import DEG_PER_HOUR, MG

AXIS_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
"""The curves of one panel, in column order (x, y, z; beams 1-4)."""
TRUTH_DASH = "dash"
PANEL_HEIGHT_PX = 120
MAX_POINTS = 800
DISPLAY_UNITS: dict[str, tuple[float, str]] = {
    "rad": (np.degrees(1.0), "deg"),
    "rad/s": (np.degrees(1.0), "deg/s"),
}
"""SI unit -> (factor, unit shown) of a raw column; others are shown in their SI unit."""
SENSOR_DISPLAY: dict[str, tuple[float, str, str]] = {
    "ba": (1.0 / MG, "mg", "Accelerometer bias"),
    "bg": (1.0 / DEG_PER_HOUR, "deg/h", "Gyro bias"),
    "b_dvl": (1e3, "mm/s", "DVL beam bias"),
    "sf_dvl": (1e2, "%", "DVL scale factor"),
}
"""A sensor-error block -> (factor from SI, unit shown, title); a block not named here is drawn
in its SI unit under its own name."""
_BEAM_STATE_COLORS = [f"rgb{BEAM_COLORS[state]}" for state in BEAM_STATE_CODES]
"""The colour of each DVL beam state (BEAM_STATE_CODES, by code): the 3-D view's."""
STATE_UNITS = {"mps": "m/s", "mps2": "m/s^2", "m": "m", "rad": "rad", "radps": "rad/s"}
"""The unit suffix of a source state's label (``MethodResult.state_labels``: "current_north_mps")
-> the unit shown."""


def _pretty(column: str) -> str:
    """A log column's name without its unit: ``beam1_mps`` -> ``beam1``, ``roll_rad`` -> ``roll``."""
    for suffix in ("_mps", "_m", "_rad", "_deg", "_rpm", "_mps2"):
        if column.endswith(suffix):
            return column[: -len(suffix)]
    return column


def _key(names: Sequence[str], colors: Sequence[str]) -> str:
    return " ".join(f'<span style="color:{c}">{n}</span>' for n, c in zip(names, colors))


def _stack(title: str, panels: list[dict[str, Any]], height_px: int | None) -> dict[str, Any]:
    """The layout of ``panels`` (each {"label": str, "unit": str}) stacked on one time axis."""
    n = max(1, len(panels))
    layout: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px or PANEL_HEIGHT_PX * n + 70,
        "margin": {"l": 55, "r": 10, "t": 35, "b": 30},
        "showlegend": False,
        "template": "plotly_white",
        "annotations": [],
    }
    for k, ((lo, hi), panel) in enumerate(zip(panel_domains(n, gap=0.045), panels)):
        suffix = "" if k == 0 else str(k + 1)
        last = k == n - 1
        layout[f"xaxis{suffix}"] = (
            {"anchor": f"y{suffix}", **TIME_AXIS}
            if last
            else {"anchor": f"y{suffix}", "matches": f"x{n if n > 1 else ''}", "showticklabels": False}
        )
        layout[f"yaxis{suffix}"] = {
            "domain": [lo, hi],
            "title": {"text": panel["unit"], "font": {"size": 10}},
            "zeroline": True,
        }
        layout["annotations"].append(
            {
                "text": panel["label"],
                "showarrow": False,
                "xref": "paper",
                "yref": "paper",
                "x": 0.0,
                "y": hi,
                "xanchor": "left",
                "yanchor": "bottom",
                "font": {"size": 11},
            }
        )
    return layout


def _line(
    x: np.ndarray, y: np.ndarray, name: str, color: str, panel: int, dash: str | None = None, **extra: Any
) -> dict[str, Any]:
    suffix = "" if panel == 0 else str(panel + 1)
    return {
        "type": "scatter",
        "x": x,
        "y": y,
        "name": name,
        "mode": "lines",
        "line": {"color": color, "width": 1.3, **({"dash": dash} if dash else {})},
        "xaxis": f"x{suffix}",
        "yaxis": f"y{suffix}",
        **extra,
    }


def raw_sensor_figure(view: SensorView, height_px: int | None = None, validate: bool = False) -> go.Figure:
    """The run's raw measurements against time: the gyro's angular rate [deg/s] and the
    accelerometer's specific force [m/s^2] (body axes x, y, z), one panel per aiding source with
    its columns (angles in degrees; where the simulation knows the true value, dashed), and the DVL
    beams' states at every ping (returning, lost, switched off: the colours of the 3-D view).

    A beam that did not return has no velocity: its curve has a gap there, not a zero.

    Parameters
    ----------
    view : app.figures.sensor_view.SensorView of one run.
    height_px : the figure's height (None: :data:`PANEL_HEIGHT_PX` per panel).
    """
    data: list[dict[str, Any]] = []
    panels: list[dict[str, Any]] = []
    t = np.asarray(view["t_s"], float)
    keep = decimate(t.size, MAX_POINTS)
    for quantity, arr, factor, unit in (
        ("Gyro", view["gyro_b_radps"], np.degrees(1.0), "deg/s"),
        ("Accelerometer", view["accel_b_mps2"], 1.0, "m/s^2"),
    ):
        k = len(panels)
        panels.append({"label": f"<b>{quantity}</b> {_key('xyz', AXIS_COLORS)}", "unit": unit})
        values = np.asarray(arr)[keep] * factor
        data += [
            _line(t[keep], values[:, i], f"{quantity.lower()} {axis}", AXIS_COLORS[i], k)
            for i, axis in enumerate("xyz")
        ]
    for source in view["sources"].values():
        ts = np.asarray(source["t_s"], float)
        sel = decimate(ts.size, MAX_POINTS)
        panel, traces = _source_panel(source, ts[sel], sel, len(panels))
        panels.append(panel)
        data += traces
        states = source.get("beam_state")
        if states is not None and len(states):
            panels.append(
                {"label": f"<b>DVL beams</b> {_key(BEAM_STATE_CODES, _BEAM_STATE_COLORS)}", "unit": "beam"}
            )
            data += _beam_state_traces(ts[sel], np.asarray(states)[sel], len(panels) - 1)
            beside = source.get("water_beside")
            if beside is not None:
                data += _water_beside_trace(ts[sel], np.asarray(beside)[sel], len(panels) - 1)
    run_note = f", run {view['run'] + 1} of {view['runs']}" if view["runs"] > 1 else ""
    layout = _stack(f"Raw sensors{run_note}", panels, height_px)
    beam_axis = next((k for k, p in enumerate(panels) if p["unit"] == "beam"), None)
    if beam_axis is not None:
        suffix = "" if beam_axis == 0 else str(beam_axis + 1)
        layout[f"yaxis{suffix}"].update({"range": [0.5, 4.5], "tickvals": [1, 2, 3, 4], "zeroline": False})
    return make_figure(data, layout, validate)


def _source_panel(
    source: SourceView, t: np.ndarray, sel: slice, panel: int
) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """Panel ``panel`` of :func:`raw_sensor_figure`: an aiding source's columns at its epochs
    ``sel`` (times ``t`` [s]), in the unit they share (none if they differ), one curve each (with
    markers when there are few epochs) and its truth dashed where the simulation knows it; its
    label and unit, and its traces."""
    columns = list(source["columns"])
    units = {source["units"].get(c, "") for c in columns}
    unit = units.pop() if len(units) == 1 else ""
    factor, shown = DISPLAY_UNITS.get(unit, (1.0, unit))
    # a truth column is drawn beside the column it is the truth of ("true_altitude_m" beside
    # "altitude_m"); the others (the DVL's true beam biases) are the sensor-error figure's
    truths = {c: source["truth"][f"true_{c}"] for c in columns if f"true_{c}" in source["truth"]}
    truth_note = " (dashed: true)" if truths else ""
    names = [_pretty(c) for c in columns]
    mode = "lines+markers" if np.size(source["t_s"]) <= 400 else "lines"
    data = []
    for i, column in enumerate(columns):
        color = AXIS_COLORS[i % len(AXIS_COLORS)]
        values = np.asarray(source["columns"][column], float)[sel] * factor
        data.append(_line(t, values, names[i], color, panel, mode=mode, marker={"size": 3}))
        if column in truths:
            true = np.asarray(truths[column], float)[sel] * factor
            data.append(_line(t, true, f"{names[i]} (true)", color, panel, TRUTH_DASH))
    label = f"<b>{source['label']}</b> {_key(names, AXIS_COLORS)}{truth_note}"
    return {"label": label, "unit": shown}, data


def _beam_state_traces(t: np.ndarray, states: np.ndarray, panel: int) -> list[dict[str, Any]]:
    """The DVL beams' states (``states`` (P, 4) codes at the pings ``t`` [s]) in ``panel``: one
    trace of markers per state, at the beam's number."""
    suffix = "" if panel == 0 else str(panel + 1)
    data = []
    for code, (state, color) in enumerate(zip(BEAM_STATE_CODES, _BEAM_STATE_COLORS)):
        ping, beam = np.nonzero(states == code)
        if ping.size == 0:
            continue
        data.append(
            {
                "type": "scatter",
                "x": t[ping],
                "y": beam + 1,
                "name": state,
                "mode": "markers",
                "marker": {"color": color, "size": 4, "symbol": "square"},
                "xaxis": f"x{suffix}",
                "yaxis": f"y{suffix}",
            }
        )
    return data


WATER_BESIDE_OFFSET = 0.3
"""How far above its beam's row a water-track beside the bottom-track is marked (beam units)."""


def _water_beside_trace(t: np.ndarray, beside: np.ndarray, panel: int) -> list[dict[str, Any]]:
    """The pings at ``t`` [s] where a beam water-tracked beside its bottom-track (``beside`` (P, 4)
    bool, water-track "both"), in ``panel``: lime markers just above the beam's row (none: [])."""
    ping, beam = np.nonzero(beside)
    if ping.size == 0:
        return []
    suffix = "" if panel == 0 else str(panel + 1)
    return [
        {
            "type": "scatter",
            "x": t[ping],
            "y": beam + 1 + WATER_BESIDE_OFFSET,
            "name": f"{BEAM_WATER} (beside bottom-track)",
            "mode": "markers",
            "marker": {"color": f"rgb{BEAM_COLORS[BEAM_WATER]}", "size": 4, "symbol": "square"},
            "xaxis": f"x{suffix}",
            "yaxis": f"y{suffix}",
        }
    ]


def sensor_panels(method: str) -> list[tuple[str, list[int]]]:
    """The sensor-error blocks of ``method``'s filter in state order, each with its columns of
    ``MethodResult.sensor_est`` (tauvcore.engine.results.sensor_states)."""
    blocks: dict[str, list[int]] = {}
    for i, state in enumerate(sensor_states(method)):
        blocks.setdefault(state.block, []).append(i)
    return list(blocks.items())


def sensor_error_figure(
    result: MethodResult, run: int = 0, height_px: int | None = None, validate: bool = False
) -> go.Figure:
    """What ``result``'s filter estimated of the sensors' errors in run ``run`` (0-based): each
    state's estimate (a line) with its +-3-sigma (a band, the filter's own covariance) and its truth
    (dashed, where known: a simulation; a log knows none), one panel per block (accelerometer bias
    [mg], gyro bias [deg/h], DVL beam biases [mm/s], DVL scale factor [%]).

    A consistent filter keeps the truth inside its 3-sigma about 99.7 % of the time; a sigma that
    shrinks while the estimate wanders off the truth is a filter claiming what it cannot observe.

    A long run reduced to time bins (tauvcore.eval.envelope.DecimatedResult) draws each estimate
    at every bin's last epoch with its 3-sigma there, over a darker band from the estimate's
    minimum to its maximum within the bin.
    """
    if result.sensor_est is None or result.sensor_sigma is None or result.sensor_true is None:
        raise ValueError(f"{result.method}'s results carry no sensor errors (run with sensor_errors=True)")
    states = sensor_states(result.method)
    t = np.asarray(result.t_s, float)
    binned = is_decimated(result)
    keep, starts = merge_bins(t.size, MAX_POINTS) if binned else (decimate(t.size, MAX_POINTS), None)
    t = t[keep]
    run = min(max(int(run), 0), result.sensor_est.shape[1] - 1)
    est = result.sensor_est[keep, run]
    sigma = result.sensor_sigma[keep, run]
    true = result.sensor_true[keep, run]
    data: list[dict[str, Any]] = []
    panels: list[dict[str, Any]] = []
    any_truth = False
    for k, (block, columns) in enumerate(sensor_panels(result.method)):
        factor, unit, title = SENSOR_DISPLAY.get(block, (1.0, states[columns[0]].unit, block))
        labels = [states[i].label for i in columns]
        keys = [states[i].name.removeprefix(block).lstrip("_") or "error" for i in columns]
        colors = [AXIS_COLORS[j % len(AXIS_COLORS)] for j in range(len(columns))]
        truth_known = bool(np.isfinite(true[:, columns]).any())
        any_truth |= truth_known
        panels.append({"label": f"<b>{title}</b> {_key(keys, colors)}", "unit": unit})
        for j, i in enumerate(columns):
            color = colors[j]
            e, s = est[:, i] * factor, 3.0 * sigma[:, i] * factor
            band = {"hoverinfo": "skip", "line": {"width": 0, "color": color}}
            data.append({**_line(t, e + s, f"{labels[j]} +3 sigma", color, k), **band})
            data.append(
                {**_line(t, e - s, f"{labels[j]} -3 sigma", color, k), **band}
                | {"fill": "tonexty", "fillcolor": hex_to_rgba(color, 0.12)}
            )
            if binned:
                lo, hi = merged_envelope(
                    result.low["sensor_est"][:, run, i],
                    result.high["sensor_est"][:, run, i],
                    starts,
                )
                suffix = "" if k == 0 else str(k + 1)
                data += envelope_traces(
                    t,
                    lo * factor,
                    hi * factor,
                    f"{labels[j]} estimate",
                    color,
                    result.bin_s,
                    labels[j],
                    xaxis=f"x{suffix}",
                    yaxis=f"y{suffix}",
                )
            data.append(_line(t, e, f"{labels[j]} estimate", color, k))
            if truth_known:
                data.append(_line(t, true[:, i] * factor, f"{labels[j]} true", color, k, TRUTH_DASH))
    runs = result.sensor_est.shape[1]
    run_note = f", run {run + 1} of {runs}" if runs > 1 else ""
    key = "line: estimate, band: &plusmn;3 sigma" + (", dashed: true" if any_truth else "")
    if binned:
        key += ", dark band: " + bin_label(result.bin_s)
    title = f"{result.method.upper()}: sensor errors{run_note} <span style='font-size:11px'>({key})</span>"
    return make_figure(data, _stack(title, panels, height_px), validate)


def state_name_unit(label: str) -> tuple[str, str]:
    """A source state's label as a panel names it: its words and its unit.

    Parameters
    ----------
    label : str
        One of ``MethodResult.state_labels``, its unit last (``"current_north_mps"``).

    Returns
    -------
    tuple[str, str]
        ``("Current north", "m/s")``; a label without a known unit suffix (:data:`STATE_UNITS`)
        whole, with no unit.
    """
    name, _, suffix = label.rpartition("_")
    if not name or suffix not in STATE_UNITS:
        return label, ""
    return name.replace("_", " ").capitalize(), STATE_UNITS[suffix]


def state_methods(results: Mapping[str, MethodResult]) -> tuple[str, ...]:
    """The methods of ``results`` whose estimate of the sources' states :func:`source_states_figure`
    draws: those that carry the states (``MethodResult.state_est``) and fuse an aiding source.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results.

    Returns
    -------
    tuple[str, ...]
        The methods, in the order of ``results``. INS carries the states of a run with current
        states but fuses nothing: its estimate stays at the prior (0, the prior's 1-sigma), and
        is left out.
    """
    return tuple(m for m, r in results.items() if r.state_est is not None and r.updates and len(r.t_s))


def source_states_figure(
    results: Mapping[str, MethodResult],
    run: int = 0,
    height_px: int | None = None,
    validate: bool = False,
) -> go.Figure:
    """What every method estimated of the states its aiding sources add, in run ``run`` (0-based):
    one panel per state (``MethodResult.state_labels``; with the DVL's current states, the current
    north and east [m/s] at the vehicle), each method's estimate a line of its colour over its
    +-1-sigma band (the filter's own covariance), the truth a dashed black line (where known: a
    simulation's current at the vehicle; a log knows none).

    A consistent filter keeps the truth inside its 1-sigma band about 68 % of the time; the band
    narrows where the water-track beams observe the current (turns make both axes observable).

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results; the methods of :func:`state_methods` are drawn.
    run : int
        The Monte Carlo run drawn, clipped to the runs there are.
    height_px : int or None
        The figure's height (None: :data:`PANEL_HEIGHT_PX` and a half per panel).
    validate : bool
        Let plotly check the figure (slow; for tests).

    Returns
    -------
    plotly.graph_objects.Figure
        Stacked panels on one time axis, each named with its unit and the methods' colours.
    """
    methods = state_methods(results)
    labels = list(dict.fromkeys(label for m in methods for label in (results[m].state_labels or ())))
    colors = [method_color(m) for m in methods]
    data: list[dict[str, Any]] = []
    truths: list[dict[str, Any]] = []  # drawn last, over the bands
    panels: list[dict[str, Any]] = []
    estimates = [results[m].state_est for m in methods]
    runs = max((e.shape[1] for e in estimates if e is not None), default=1)
    i = min(max(int(run), 0), runs - 1)
    for k, label in enumerate(labels):
        name, unit = state_name_unit(label)
        truth_drawn = False
        for method, color in zip(methods, colors):
            r = results[method]
            if label not in (r.state_labels or ()):
                continue
            assert r.state_est is not None and r.state_sigma is not None and r.state_true is not None
            j = (r.state_labels or ()).index(label)
            keep = decimate(len(r.t_s), MAX_POINTS)
            t, est, sigma = r.t_s[keep], r.state_est[keep, i, j], r.state_sigma[keep, i, j]
            band = {"hoverinfo": "skip", "line": {"width": 0, "color": color}}
            data.append({**_line(t, est + sigma, f"{method.upper()} +1 sigma", color, k), **band})
            data.append(
                {**_line(t, est - sigma, f"{method.upper()} -1 sigma", color, k), **band}
                | {"fill": "tonexty", "fillcolor": hex_to_rgba(color, band_alpha(len(methods)))}
            )
            data.append(_line(t, est, f"{method.upper()} {name.lower()}", color, k))
            true = r.state_true[keep, i, j]
            if not truth_drawn and np.isfinite(true).any():  # the same truth for every method
                truths.append(_line(t, true, f"true {name.lower()}", TRUTH_COLOR, k, TRUTH_DASH))
                truth_drawn = True
        truth_key = f', <span style="color:{TRUTH_COLOR}">dashed: true</span>' if truth_drawn else ""
        key = _key([m.upper() for m in methods], colors)
        panels.append({"label": f"<b>{name}</b> {key}{truth_key}", "unit": unit})
    what = (
        "Current at the vehicle"
        if labels and all(x.startswith("current_") for x in labels)
        else "Sources' states"
    )
    run_note = f", run {i + 1} of {runs}" if runs > 1 else ""
    title = f"{what}{run_note} <span style='font-size:11px'>(line: estimate, band: &plusmn;1 sigma)</span>"
    height = height_px or int(1.5 * PANEL_HEIGHT_PX) * max(1, len(panels)) + 70
    return make_figure(data + truths, _stack(title, panels, height), validate)
