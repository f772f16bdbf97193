"""Plotly figures of the Sensors tab: a run's raw measurements (the IMU's rates and specific force,
every aiding source's columns, the DVL beams' states), and what a method estimated of the sensors'
errors (IMU biases, DVL beam biases and scale factor) with its 3-sigma against their truth.

Both are stacked panels on one time axis, each panel named in its top-left corner with its unit
and its curves' colours (no legend: a shared one would list the same x, y, z in every panel).
Angles are drawn in degrees, the IMU's biases in mg and deg/h, the DVL's in mm/s and percent:
the units a data sheet gives them in.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures import (
    TIME_AXIS,
    bin_label,
    decimate,
    envelope_traces,
    hex_to_rgba,
    make_figure,
    merge_bins,
    merged_envelope,
    panel_domains,
)
from app.scene import BEAM_COLORS
from app.sensor_view import BEAM_STATE_CODES, SensorView
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
    view : app.sensor_view.SensorView of one run.
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
        for i, axis in enumerate("xyz"):
            data.append(
                _line(
                    t[keep],
                    np.asarray(arr)[keep, i] * factor,
                    f"{quantity.lower()} {axis}",
                    AXIS_COLORS[i],
                    k,
                )
            )
    for source in view["sources"].values():
        ts = np.asarray(source["t_s"], float)
        sel = decimate(ts.size, MAX_POINTS)
        columns = list(source["columns"])
        units = {source["units"].get(c, "") for c in columns}
        unit = units.pop() if len(units) == 1 else ""
        factor, shown = DISPLAY_UNITS.get(unit, (1.0, unit))
        k = len(panels)
        # a truth column is drawn beside the column it is the truth of ("true_altitude_m" beside
        # "altitude_m"); the others (the DVL's true beam biases) are the sensor-error figure's
        truths = {c: source["truth"][f"true_{c}"] for c in columns if f"true_{c}" in source["truth"]}
        truth_note = " (dashed: true)" if truths else ""
        names = [_pretty(c) for c in columns]
        panels.append(
            {
                "label": f"<b>{source['label']}</b> {_key(names, AXIS_COLORS)}{truth_note}",
                "unit": shown,
            }
        )
        mode = "lines+markers" if ts.size <= 400 else "lines"
        for i, column in enumerate(columns):
            color = AXIS_COLORS[i % len(AXIS_COLORS)]
            values = np.asarray(source["columns"][column], float)[sel] * factor
            trace = _line(ts[sel], values, names[i], color, k)
            trace["mode"] = mode
            trace["marker"] = {"size": 3}
            data.append(trace)
            if column in truths:
                true = np.asarray(truths[column], float)[sel] * factor
                data.append(_line(ts[sel], true, f"{names[i]} (true)", color, k, TRUTH_DASH))
        states = source.get("beam_state")
        if states is not None and len(states):
            k = len(panels)
            names = [BEAM_STATE_CODES[c] for c in range(len(BEAM_STATE_CODES))]
            colors = [f"rgb{BEAM_COLORS[s]}" for s in names]
            panels.append({"label": f"<b>DVL beams</b> {_key(names, colors)}", "unit": "beam"})
            states = np.asarray(states)[sel]
            for code, (state, color) in enumerate(zip(names, colors)):
                ping, beam = np.nonzero(states == code)
                if ping.size == 0:
                    continue
                suffix = "" if k == 0 else str(k + 1)
                data.append(
                    {
                        "type": "scatter",
                        "x": ts[sel][ping],
                        "y": beam + 1,
                        "name": state,
                        "mode": "markers",
                        "marker": {"color": color, "size": 4, "symbol": "square"},
                        "xaxis": f"x{suffix}",
                        "yaxis": f"y{suffix}",
                    }
                )
    run_note = f", run {view['run'] + 1} of {view['runs']}" if view["runs"] > 1 else ""
    layout = _stack(f"Raw sensors{run_note}", panels, height_px)
    beam_axis = next((k for k, p in enumerate(panels) if p["unit"] == "beam"), None)
    if beam_axis is not None:
        suffix = "" if beam_axis == 0 else str(beam_axis + 1)
        layout[f"yaxis{suffix}"].update({"range": [0.5, 4.5], "tickvals": [1, 2, 3, 4], "zeroline": False})
    return make_figure(data, layout, validate)


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
    key = "line: estimate, band: &plusmn;3&sigma;" + (", dashed: true" if any_truth else "")
    if binned:
        key += ", dark band: " + bin_label(result.bin_s)
    title = f"{result.method.upper()}: sensor errors{run_note} <span style='font-size:11px'>({key})</span>"
    return make_figure(data, _stack(title, panels, height_px), validate)
