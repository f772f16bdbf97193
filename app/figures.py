"""Plotly figures of run results: pure functions, results in, ``go.Figure`` out.

Each method has one colour everywhere (plots, 3-D trajectories, legend). With one run the
curves are that run's errors; with several Monte Carlo runs they are the RMS over runs (as in
the paper's figures) and the sigma band is the RMS of the filter's own 1-sigma.

Figures are assembled as plain dicts and wrapped without plotly's per-property validation
(:func:`_figure`): validation took 45 of the 56 ms that the four live plots cost per redraw, and
redraws run on the server's threads while other tabs wait for their controls. The tests check
that every figure validates and equals its validated construction.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio

from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.eval.metrics import rms
from tauvcore.eval.runner import MethodResult

METHOD_COLORS = {
    "ins": "#7f7f7f", "lc": "#1f77b4", "tc": "#ff7f0e", "vb": "#2ca02c",
    "nsv": "#d62728", "plcf": "#9467bd", "vhv": "#8c564b", "elc": "#e377c2",
}
TRUTH_COLOR = "#111111"
QUANTITIES = {
    "vel": ("vel_err_mps", "vel_sigma_mps", "Velocity error", "m/s"),
    "att": ("att_err_deg", "att_sigma_deg", "Attitude error", "deg"),
    "pos": ("pos_err_m", "pos_sigma_m", "Position error", "m"),
}


def method_color(method: str) -> str:
    return METHOD_COLORS.get(method, "#17becf")


def _hex_to_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def decimate(n: int, max_points: int | None) -> slice:
    """A stride that keeps at most about ``max_points`` of ``n`` samples, always the last one."""
    if max_points is None or n <= max_points:
        return slice(None)
    step = int(np.ceil(n / max_points))
    return slice((n - 1) % step, None, step)


@functools.cache
def _template(name: str) -> dict[str, Any]:
    """A named plotly template as the dict plotly.js reads (validation would resolve the name)."""
    return pio.templates[name].to_plotly_json()


def _figure(data: list[dict[str, Any]], layout: dict[str, Any], validate: bool = False) -> go.Figure:
    """``go.Figure`` of plain trace and layout dicts; ``validate`` False skips plotly's property
    checks (the same figure, several times faster to build)."""
    layout = {**layout, "template": _template(layout.get("template", "plotly_white"))}
    if validate:
        return go.Figure(data=data, layout=layout)
    return go.Figure(data=data, layout=layout, _validate=False)


def error_figure(results: Mapping[str, MethodResult], quantity: str = "vel", show_sigma: bool = False,
                 log_y: bool = False, height_px: int = 300, max_points: int | None = 600,
                 validate: bool = False) -> go.Figure:
    """Error norm against time for every method; one trace per method named by its short name.

    ``quantity``: "vel", "att" or "pos". ``show_sigma`` adds the filter's 1-sigma as a shaded
    band under each curve (a trace named "<NAME> 1-sigma"). At most about ``max_points`` points
    are drawn per trace (evenly strided, the last epoch always included): a plot panel is a few
    hundred pixels wide, and every point drawn is data sent to the browser on each live update.
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    err_field, sigma_field, title, unit = QUANTITIES[quantity]
    data: list[dict[str, Any]] = []
    runs = 1
    for method, res in results.items():
        keep = decimate(len(res.t_s), max_points)
        err = getattr(res, err_field)[keep]
        t = res.t_s[keep]
        runs = err.shape[1]
        curve = err[:, 0] if runs == 1 else rms(err, axis=1)
        color = method_color(method)
        if show_sigma:
            sigma = getattr(res, sigma_field)[keep]
            band = sigma[:, 0] if runs == 1 else rms(sigma, axis=1)
            data.append({"type": "scatter", "x": t, "y": band, "name": f"{method.upper()} 1-sigma", "mode": "lines",
                         "line": {"width": 0}, "fill": "tozeroy", "fillcolor": _hex_to_rgba(color, 0.15),
                         "hoverinfo": "skip", "showlegend": False, "legendgroup": method})
        data.append({"type": "scatter", "x": t, "y": curve, "name": method.upper(), "mode": "lines",
                     "line": {"color": color, "width": 2}, "legendgroup": method})
    label = f"{title} [{unit}]" + (f" (RMS of {runs} runs)" if runs > 1 else "")
    layout = {"title": {"text": label, "font": {"size": 13}}, "height": height_px,
              "margin": {"l": 50, "r": 10, "t": 35, "b": 35}, "legend": {"orientation": "h", "y": -0.2},
              "xaxis": {"title": {"text": "time [s]"}}, "template": "plotly_white",
              "yaxis": {"type": "log" if log_y else "linear", "exponentformat": "power"}}
    return _figure(data, layout, validate)


def elc_choice_figure(result: MethodResult, height_px: int = 220, validate: bool = False) -> go.Figure:
    """Which construction the ELC selector took for each body axis at every DVL epoch (run 0)."""
    data: list[dict[str, Any]] = []
    dvl = result.updates.get("dvl")

    def markers(t: np.ndarray, axis_name: str, color: str, name: str, group: str) -> dict[str, Any]:
        return {"type": "scatter", "x": t, "y": [axis_name] * len(t), "mode": "markers",
                "marker": {"color": color, "size": 6, "symbol": "square"}, "name": name, "legendgroup": group,
                "showlegend": not any(d["name"] == name for d in data)}

    if dvl is not None and dvl.elc_choice is not None:
        choice = dvl.elc_choice[:, 0, :]                      # (U, 3)
        mode = dvl.mode[:, 0]
        for axis, axis_name in enumerate(("surge", "sway", "heave")):
            for code, name in enumerate(CANDIDATES):
                hit = (choice[:, axis] == code) & (mode == 2)
                if hit.any():
                    data.append(markers(dvl.t_s[hit], axis_name, method_color(name), name.upper(), name))
            lc_hit = mode == 1
            if lc_hit.any():
                data.append(markers(dvl.t_s[lc_hit], axis_name, method_color("lc"), "LC (3-4 beams)", "lc"))
    layout = {"title": {"text": "ELC selector: method per axis", "font": {"size": 13}}, "height": height_px,
              "margin": {"l": 60, "r": 10, "t": 35, "b": 35}, "xaxis": {"title": {"text": "time [s]"}},
              "template": "plotly_white", "legend": {"orientation": "h", "y": -0.35},
              "yaxis": {"categoryorder": "array", "categoryarray": ["heave", "sway", "surge"]}}
    return _figure(data, layout, validate)


def summary_rows(results: Mapping[str, MethodResult]) -> list[dict[str, float | str]]:
    """Final and RMS-over-time errors per method (RMS over runs first when there are several),
    and the filter's health: how many runs the divergence monitor flagged, the earliest flag
    [s] (NaN if none) and the P eigenvalue-floor repairs summed over runs."""
    rows = []
    for method, res in results.items():
        def curve(x: np.ndarray) -> np.ndarray:
            return x[:, 0] if x.shape[1] == 1 else rms(x, axis=1)
        vel, att, pos = curve(res.vel_err_mps), curve(res.att_err_deg), curve(res.pos_err_m)
        rows.append({"method": method.upper(), "vel_final_mps": float(vel[-1]), "vel_rms_mps": float(rms(vel)),
                     "att_final_deg": float(att[-1]), "att_rms_deg": float(rms(att)),
                     "pos_final_m": float(pos[-1]), "pos_rms_m": float(rms(pos)),
                     "runs": int(res.diverged.size), "diverged_runs": int(np.count_nonzero(res.diverged)),
                     "diverged_first_s": float(np.nanmin(res.diverged_at_s)) if res.diverged.any() else float("nan"),
                     "p_floor_count": int(np.sum(res.p_floor_count))})
    return rows


def _health_cell(row: Mapping[str, float | str]) -> str:
    """"ok", or when the divergence monitor flagged runs, when (and how many of the runs)."""
    if not row["diverged_runs"]:
        return "ok"
    at = f"diverged at {row['diverged_first_s']:.1f} s"
    if row["runs"] == 1:
        return at
    return f"{row['diverged_runs']} of {row['runs']} runs, first {at}"


def summary_markdown(results: Mapping[str, MethodResult]) -> str:
    """The results table as Markdown (the dashboard shows it as text a person and a test can read).

    The "monitor" column is the divergence monitor's verdict (tauvcore.eval.runner: state or P
    not finite, an estimated sensor error far beyond its prior, innovations inconsistent, or the
    gate locked out). It sees only what the measurements reveal: "ok" is not a proof of
    consistency (VB at n_f = 2 on beams 1-2 was "ok" with a velocity error of 50 sigma). A
    "P floors" column (repairs of P summed over runs) appears only when some method needed one.
    """
    rows = summary_rows(results)
    floors = any(r["p_floor_count"] for r in rows)
    lines = ["| method | vel final [m/s] | vel RMS [m/s] | att final [deg] | pos final [m] | monitor |"
             + (" P floors |" if floors else ""),
             "|---|---|---|---|---|---|" + ("---|" if floors else "")]
    for r in rows:
        lines.append(f"| {r['method']} | {r['vel_final_mps']:.4f} | {r['vel_rms_mps']:.4f} | "
                     f"{r['att_final_deg']:.3f} | {r['pos_final_m']:.2f} | {_health_cell(r)} |"
                     + (f" {r['p_floor_count']} |" if floors else ""))
    return "\n".join(lines)
