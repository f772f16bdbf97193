"""Plotly figures of run results: pure functions, results in, ``go.Figure`` out.

Each method has one colour everywhere (plots, 3-D trajectories, legend). With one run the
curves are that run's errors; with several Monte Carlo runs they are the RMS over runs (as in
the paper's figures) and the sigma band is the RMS of the filter's own 1-sigma. Attitude error is
shown as tilt (roll, pitch: levelling) and heading apart, and as their norm: with DVL aiding alone
heading is unobservable, so the norm is almost all heading and hides how well tilt is estimated.
The consistency figure shows whether each method knows its own error: its NEES divided by the
block's dimension (1 for a consistent filter) against the two-sided 99 % band. The actuator figure
shows what the dynamic truth's vehicle did: its four fins and its propeller; the altitude figure
how high it flew above the seabed, against the DVL's range and the velocity filter's switch to RPM;
the VKF figure what that velocity filter learned of the propeller (Yoo 2014's ``vkf`` method).

Yoo 2014's methods (``ins-dvl``, ``vkf``) run a 12-state filter with no position state: their
position 1-sigma and NEES are NaN (no band, no curve) and their NEES is divided by their own
block dimensions (``MethodResult.block_dims``), not the 20-state filter's.

Figures are plain dicts wrapped without plotly's per-property validation (:func:`_figure`; validating
costs most of a redraw); the tests check that each validates and equals its validated construction.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from typing import Any, TypedDict

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio

from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import REGISTERED_METHODS, Config, to_dict
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.eval.consistency import CONFIDENCE, method_consistency, nees_band, nees_series
from tauvcore.eval.metrics import rms
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, wrap_angle

METHOD_COLORS = {
    "ins": "#7f7f7f",
    "lc": "#1f77b4",
    "tc": "#ff7f0e",
    "vb": "#2ca02c",
    "nsv": "#d62728",
    "plcf": "#9467bd",
    "vhv": "#8c564b",
    "elc": "#e377c2",
    "ins-dvl": "#bcbd22",
    "vkf": "#17becf",  # Yoo 2014's 12-state filter (tauvcore.config.YOO_METHODS)
}
# Methods added as one file each (tauvcore.aiding.registry), coloured in registration order from
# tab20's paler and darker companions of the colours above; each keeps the beams' distance
# (app.scene.BEAM_MIN_DELTA_E, tests/unit/test_scene.py) like the papers' methods.
REGISTERED_COLORS = ("#637939", "#e7969c", "#ffbb78", "#aec7e8", "#c5b0d5", "#8c6d31")
METHOD_COLORS.update(
    {m: REGISTERED_COLORS[i % len(REGISTERED_COLORS)] for i, m in enumerate(REGISTERED_METHODS)}
)
TRUTH_COLOR = "#111111"
QUANTITIES = {
    "vel": ("vel_err_mps", "vel_sigma_mps", "Velocity error", "m/s"),
    "att": ("att_err_deg", "att_sigma_deg", "Attitude error (norm)", "deg"),
    "tilt": ("tilt_err_deg", "tilt_sigma_deg", "Tilt error (roll, pitch)", "deg"),
    "heading": ("heading_err_deg", "heading_sigma_deg", "Heading error", "deg"),
    "pos": ("pos_err_m", "pos_sigma_m", "Position error", "m"),
}
AUTO = "auto"
LOG_SPAN = 10.0
"""``log_y="auto"`` draws a log axis only when the drawn values span more than this factor: over a
narrower range (heading error 1.0-1.2 deg) a log axis has no ticks and flattens the curves."""
NEES_BLOCK_NAMES = {
    "full": "full state",
    "pos": "position",
    "vel": "velocity",
    "tilt": "tilt",
    "heading": "heading",
    "sensor": "sensor errors",
}
"""Consistency blocks (tauvcore.engine.results.BLOCK_DIMS) as the figure names them."""
BAND_COLOR = "rgba(120,120,120,0.18)"
FIN_NAMES = ("fin 1 lower stbd", "fin 2 lower port", "fin 3 upper port", "fin 4 upper stbd")
"""Fins 1-4 of tauvcore.truth.vehicle (FIN_POSITION_ANGLES_RAD: 45, 135, 225, 315 deg from starboard
towards down)."""
FIN_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a")
"""One colour per fin, in the actuator figure and on the fins of the 3-D view."""
PROPELLER_COLOR = "#444444"


def method_color(method: str) -> str:
    return METHOD_COLORS.get(method, "#393b79")


def _hex_to_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i : i + 2], 16) for i in (1, 3, 5))
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
    # "x unified": hovering anywhere reads every curve at that time, and a click anywhere in a plot
    # names a time (app.plot_click moves the playback there)
    layout = {
        "hovermode": "x unified",
        **layout,
        "template": _template(layout.get("template", "plotly_white")),
    }
    if validate:
        return go.Figure(data=data, layout=layout)
    return go.Figure(data=data, layout=layout, _validate=False)


def _spans_decades(curves: list[np.ndarray]) -> bool:
    """True if the positive finite values of ``curves`` span more than LOG_SPAN."""
    values = np.concatenate([np.ravel(c) for c in curves]) if curves else np.empty(0)
    values = values[np.isfinite(values) & (values > 0)]
    return values.size > 0 and float(values.max()) > LOG_SPAN * float(values.min())


def error_figure(
    results: Mapping[str, MethodResult],
    quantity: str = "vel",
    show_sigma: bool = False,
    log_y: bool | str = False,
    height_px: int = 300,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Error norm against time for every method; one trace per method named by its short name.

    ``quantity``: "vel", "tilt", "heading", "att" (the attitude norm) or "pos". ``show_sigma``
    adds the filter's 1-sigma as a shaded band under each curve (a trace named "<NAME> 1-sigma"),
    where the method has one (not for the position of Yoo 2014's methods: NaN, no position state).
    ``log_y``: True, False, or "auto" (log only where the drawn values span more than LOG_SPAN).
    At most about ``max_points`` points are drawn per trace (evenly strided, the last epoch
    always included): a plot panel is a few hundred pixels wide, and every point drawn is data
    sent to the browser on each live update.
    """
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    if log_y not in (True, False, AUTO):
        raise ValueError(f"log_y must be True, False or {AUTO!r}, got {log_y!r}")
    err_field, sigma_field, title, unit = QUANTITIES[quantity]
    data: list[dict[str, Any]] = []
    drawn: list[np.ndarray] = []
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
            if np.isfinite(band).any():  # Yoo 2014's filter has no position state: no position band
                drawn.append(band)
                data.append(
                    {
                        "type": "scatter",
                        "x": t,
                        "y": band,
                        "name": f"{method.upper()} 1-sigma",
                        "mode": "lines",
                        "line": {"width": 0},
                        "fill": "tozeroy",
                        "fillcolor": _hex_to_rgba(color, 0.15),
                        "hoverinfo": "skip",
                        "showlegend": False,
                        "legendgroup": method,
                    }
                )
        drawn.append(curve)
        data.append(
            {
                "type": "scatter",
                "x": t,
                "y": curve,
                "name": method.upper(),
                "mode": "lines",
                "line": {"color": color, "width": 2},
                "legendgroup": method,
            }
        )
    log = _spans_decades(drawn) if log_y == AUTO else bool(log_y)
    label = f"{title} [{unit}]" + (f" (RMS of {runs} runs)" if runs > 1 else "")
    layout = {
        "title": {"text": label, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 50, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.2},
        "xaxis": {"title": {"text": "time [s]"}},
        "template": "plotly_white",
        "yaxis": {"type": "log" if log else "linear", "exponentformat": "power"},
    }
    return _figure(data, layout, validate)


def block_dims(result: MethodResult) -> dict[str, int]:
    """NEES dimension of each block of ``result``: the 20-state filter's (BLOCK_DIMS), or the
    method's own (Yoo 2014's 12-state filter: ``MethodResult.block_dims``)."""
    return result.block_dims or BLOCK_DIMS


def nees_figure(
    results: Mapping[str, MethodResult],
    block: str = "full",
    height_px: int = 300,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Does each method know its own error? Its NEES of ``block`` divided by the block's
    dimension n, averaged over the Monte Carlo runs, against time; one trace per method.

    ``block``: "full" (all error states) or "pos", "vel", "tilt", "heading", "sensor"
    (tauvcore.engine.results.BLOCK_DIMS). n is each method's own (:func:`block_dims`: the full
    state is 20 for the first paper's methods, 12 for Yoo 2014's, whose position NEES is NaN: no
    curve). A consistent filter's curve lies near 1 (a dotted line, trace "1 = consistent") and
    inside the two-sided 99 % band of the run-averaged NEES (:func:`tauvcore.eval.consistency.nees_band`;
    a grey shaded trace "99 % band", which narrows as runs are added; when the methods drawn have
    different n, one band per n, "99 % band (dim n)", the first dashed, the others dotted); above
    it the filter is over-confident, below it cautious. NEES spans decades (VB at a small n_f
    reached thousands), so the y-axis is logarithmic. Epochs where a run's NEES is not finite (a
    diverged filter) are gaps.
    """
    if block not in BLOCK_DIMS:
        raise ValueError(f"block must be one of {', '.join(BLOCK_DIMS)}, got {block!r}")
    data: list[dict[str, Any]] = []
    by_dim: dict[int, list[str]] = {}  # block dimension -> the methods drawn with it, in order
    runs, t_first, t_last = 1, np.inf, -np.inf
    for method, res in results.items():
        if len(res.t_s) == 0:
            continue
        dim = block_dims(res)[block]
        by_dim.setdefault(dim, []).append(method.upper())
        keep = decimate(len(res.t_s), max_points)
        series = nees_series(res, block)[keep]
        runs = series.shape[1]
        with np.errstate(invalid="ignore", over="ignore"):
            curve = series.mean(axis=1) / dim
        curve = np.where(np.isfinite(curve), curve, np.nan)
        t = res.t_s[keep]
        t_first, t_last = min(t_first, float(t[0])), max(t_last, float(t[-1]))
        data.append(
            {
                "type": "scatter",
                "x": t,
                "y": curve,
                "name": method.upper(),
                "mode": "lines",
                "line": {"color": method_color(method), "width": 2},
                "legendgroup": method,
            }
        )
    band_name = f"{CONFIDENCE:.0%} band".replace("%", " %")
    if data:
        reference = []
        for k, dim in enumerate(by_dim):
            lo, hi = nees_band(dim, runs)
            reference.append(
                {
                    "type": "scatter",
                    "x": [t_first, t_last, t_last, t_first],
                    "y": [lo, lo, hi, hi],
                    "name": band_name if len(by_dim) == 1 else f"{band_name} (dim {dim})",
                    "mode": "lines",
                    "fill": "toself",
                    "fillcolor": BAND_COLOR,
                    "line": {
                        "color": "rgba(120,120,120,0.6)",
                        "width": 1,
                        "dash": "dash" if k == 0 else "dot",
                    },
                    "hoverinfo": "skip",
                }
            )
        reference.append(
            {
                "type": "scatter",
                "x": [t_first, t_last],
                "y": [1.0, 1.0],
                "name": "1 = consistent",
                "mode": "lines",
                "line": {"color": TRUTH_COLOR, "width": 1, "dash": "dot"},
                "hoverinfo": "skip",
            }
        )
        data = reference + data
    groups = list(by_dim.items()) or [(BLOCK_DIMS[block], [])]
    dims_text = "; ".join(
        f"dim {dim}" if k == 0 else f"{', '.join(names)} dim {dim}" for k, (dim, names) in enumerate(groups)
    )
    runs_text = f", mean of {runs} runs" if runs > 1 else ", 1 run"
    title = f"NEES/dim, {NEES_BLOCK_NAMES[block]} ({dims_text}){runs_text}"
    layout = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 55, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.2},
        "xaxis": {"title": {"text": "time [s]"}},
        "template": "plotly_white",
        "yaxis": {
            "type": "log",
            "exponentformat": "power",
            "title": {"text": "NEES/dim (1 = consistent, >1 over-confident)", "font": {"size": 11}},
        },
    }
    return _figure(data, layout, validate)


def elc_choice_figure(result: MethodResult, height_px: int = 220, validate: bool = False) -> go.Figure:
    """Which construction the ELC selector took for each body axis at every DVL epoch (run 0)."""
    data: list[dict[str, Any]] = []
    dvl = result.updates.get("dvl")

    def markers(t: np.ndarray, axis_name: str, color: str, name: str, group: str) -> dict[str, Any]:
        return {
            "type": "scatter",
            "x": t,
            "y": [axis_name] * len(t),
            "mode": "markers",
            "marker": {"color": color, "size": 6, "symbol": "square"},
            "name": name,
            "legendgroup": group,
            "showlegend": not any(d["name"] == name for d in data),
        }

    if dvl is not None and dvl.elc_choice is not None:
        assert dvl.mode is not None  # the DVL record that carries the ELC's choices carries its modes
        choice = dvl.elc_choice[:, 0, :]  # (U, 3)
        mode = dvl.mode[:, 0]
        for axis, axis_name in enumerate(("surge", "sway", "heave")):
            for code, name in enumerate(CANDIDATES):
                hit = (choice[:, axis] == code) & (mode == 2)
                if hit.any():
                    data.append(markers(dvl.t_s[hit], axis_name, method_color(name), name.upper(), name))
            lc_hit = mode == 1
            if lc_hit.any():
                data.append(markers(dvl.t_s[lc_hit], axis_name, method_color("lc"), "LC (3-4 beams)", "lc"))
    layout = {
        "title": {"text": "ELC selector: method per axis", "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 60, "r": 10, "t": 35, "b": 35},
        "xaxis": {"title": {"text": "time [s]"}},
        "template": "plotly_white",
        "legend": {"orientation": "h", "y": -0.35},
        "yaxis": {"categoryorder": "array", "categoryarray": ["heave", "sway", "surge"]},
    }
    return _figure(data, layout, validate)


def actuator_figure(
    t_s: np.ndarray,
    fin_angles_rad: np.ndarray,
    propeller_rpm: np.ndarray,
    height_px: int = 380,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """The dynamic truth's actuators against time: the four fin deflections [deg] (top panel,
    one trace per fin named by FIN_NAMES; positive pushes along the fin's normal, see
    tauvcore.truth.vehicle) and the propeller speed [rev/min] (bottom panel, trace "propeller"),
    on one shared time axis.

    Parameters
    ----------
    t_s : (T,) time [s].
    fin_angles_rad : (T, 4) fin deflections [rad], fins 1-4.
    propeller_rpm : (T,) propeller speed [rev/min].

    At most about ``max_points`` points per trace (:func:`decimate`, the last sample kept).
    """
    t_s, fins, rpm = (
        np.asarray(t_s, float),
        np.asarray(fin_angles_rad, float),
        np.asarray(propeller_rpm, float),
    )
    if fins.shape != (t_s.size, 4) or rpm.shape != t_s.shape:
        raise ValueError(
            f"actuator_figure needs t_s (T,), fin_angles_rad (T, 4) and propeller_rpm (T,), got "
            f"{t_s.shape}, {fins.shape} and {rpm.shape}"
        )
    keep = decimate(t_s.size, max_points)
    t, fins_deg = t_s[keep], np.degrees(fins[keep])
    data: list[dict[str, Any]] = [
        {
            "type": "scatter",
            "x": t,
            "y": fins_deg[:, k],
            "name": name,
            "mode": "lines",
            "line": {"color": color, "width": 1.5},
            "xaxis": "x",
            "yaxis": "y",
        }
        for k, (name, color) in enumerate(zip(FIN_NAMES, FIN_COLORS))
    ]
    data.append(
        {
            "type": "scatter",
            "x": t,
            "y": rpm[keep],
            "name": "propeller",
            "mode": "lines",
            "line": {"color": PROPELLER_COLOR, "width": 1.5},
            "xaxis": "x2",
            "yaxis": "y2",
        }
    )
    layout = {
        "title": {"text": "Dynamic truth: fins and propeller", "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 55, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.15},
        "template": "plotly_white",
        "xaxis": {"anchor": "y", "matches": "x2", "showticklabels": False},
        "yaxis": {"domain": [0.4, 1.0], "title": {"text": "fin deflection [deg]", "font": {"size": 11}}},
        "xaxis2": {"anchor": "y2", "title": {"text": "time [s]"}},
        "yaxis2": {"domain": [0.0, 0.3], "title": {"text": "propeller [rpm]", "font": {"size": 11}}},
    }
    return _figure(data, layout, validate)


def intervals_above(t_s: np.ndarray, x: np.ndarray, threshold: float) -> np.ndarray:
    """(K, 2) start and end times of the stretches where ``x`` > ``threshold``, each crossing
    placed by linear interpolation between the samples either side (a stretch open at either end
    of the series starts or ends there). NaN counts as not above."""
    t_s, x = np.asarray(t_s, float), np.asarray(x, float)
    above = np.zeros(x.size + 2, dtype=bool)
    with np.errstate(invalid="ignore"):
        above[1:-1] = x > threshold
    edges = np.diff(above.astype(np.int8))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1  # first and last sample above

    def crossing(i: int, j: int) -> float:
        # between sample i (one side of the threshold) and j (the other); NaN neighbour: at the sample above
        if not np.isfinite(x[i]) or x[j] == x[i]:
            return float(t_s[j])
        return float(t_s[i] + (threshold - x[i]) / (x[j] - x[i]) * (t_s[j] - t_s[i]))

    starts = [float(t_s[k]) if k == 0 else crossing(k - 1, k) for k in first.tolist()]
    ends = [float(t_s[k]) if k == x.size - 1 else crossing(k, k + 1) for k in last.tolist()]
    return np.array([starts, ends], dtype=float).T.reshape(-1, 2)


ALTITUDE_NAME = "altitude"
DVL_LIMIT_NAME = "DVL range limit"
SWITCH_NAME = "VKF switch (RPM above)"
RPM_NAME = "RPM in use"
"""The altitude figure's traces (:func:`altitude_figure`)."""
ALTITUDE_COLOR = "#8c6d31"
DVL_LIMIT_COLOR = "#d62728"
SWITCH_COLOR = "#1f77b4"
RPM_FILL = "rgba(255,150,30,0.2)"
"""The "lost" beams' orange of the 3-D view (app.scene.BEAM_COLORS), light: where the DVL is out of reach."""


def altitude_figure(
    t_s: np.ndarray,
    altitude_m: np.ndarray,
    dvl_max_altitude_m: float,
    switch_altitude_m: float,
    height_px: int = 320,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """The vehicle's true altitude above the seabed against time (Yoo 2014 section 3),
    with the DVL's range limit (``dvl.max_altitude_m``: higher, the beams of a level DVL find no
    bottom) and the velocity filter's switch (``vkf.switch_altitude_m``: higher, it uses the
    propeller RPM instead of the DVL) as horizontal lines, and the stretches above the switch
    shaded as one trace named RPM_NAME (present only if there are any).

    Parameters
    ----------
    t_s : (T,) time [s].
    altitude_m : (T,) height above the seabed straight below [m] (NaN: none).

    The curve is drawn with at most about ``max_points`` points (:func:`decimate`); the shaded
    stretches are found on every sample (:func:`intervals_above`).
    """
    t_s, alt = np.asarray(t_s, float), np.asarray(altitude_m, float)
    if alt.shape != t_s.shape or t_s.ndim != 1:
        raise ValueError(
            f"altitude_figure needs t_s (T,) and altitude_m (T,), got {t_s.shape} and {alt.shape}"
        )
    finite = alt[np.isfinite(alt)]
    top = 1.1 * max(dvl_max_altitude_m, switch_altitude_m, float(finite.max()) if finite.size else 0.0)
    bottom = min(0.0, float(finite.min()) if finite.size else 0.0)
    t0, t1 = (float(t_s[0]), float(t_s[-1])) if t_s.size else (0.0, 0.0)
    data: list[dict[str, Any]] = []
    spans = intervals_above(t_s, alt, switch_altitude_m)
    if len(spans):
        x: list[float | None] = []
        y: list[float | None] = []
        for a, b in spans:
            x += [a, a, b, b, a, None]
            y += [bottom, top, top, bottom, bottom, None]
        data.append(
            {
                "type": "scatter",
                "x": x,
                "y": y,
                "name": RPM_NAME,
                "mode": "lines",
                "fill": "toself",
                "fillcolor": RPM_FILL,
                "line": {"width": 0},
                "hoverinfo": "skip",
            }
        )
    data.append(
        {
            "type": "scatter",
            "x": [t0, t1],
            "y": [dvl_max_altitude_m] * 2,
            "name": DVL_LIMIT_NAME,
            "mode": "lines",
            "line": {"color": DVL_LIMIT_COLOR, "width": 1.5, "dash": "dash"},
        }
    )
    data.append(
        {
            "type": "scatter",
            "x": [t0, t1],
            "y": [switch_altitude_m] * 2,
            "name": SWITCH_NAME,
            "mode": "lines",
            "line": {"color": SWITCH_COLOR, "width": 1.5, "dash": "dot"},
        }
    )
    keep = decimate(t_s.size, max_points)
    data.append(
        {
            "type": "scatter",
            "x": t_s[keep],
            "y": alt[keep],
            "name": ALTITUDE_NAME,
            "mode": "lines",
            "line": {"color": ALTITUDE_COLOR, "width": 2},
        }
    )
    title = f"Altitude (DVL limit {dvl_max_altitude_m:g} m, RPM above {switch_altitude_m:g} m)"
    layout = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 55, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.2},
        "template": "plotly_white",
        "xaxis": {"title": {"text": "time [s]"}},
        "yaxis": {"range": [bottom, top], "title": {"text": "altitude [m]", "font": {"size": 11}}},
    }
    return _figure(data, layout, validate)


VKF_SF_NAME = "scale factor"
VKF_B_NAME = "bias"
TRUE_SUFFIX = " (true)"
SIGMA_SUFFIX = " 1-sigma"
"""The VKF figure's traces (:func:`vkf_figure`): each estimate, its band "<name> 1-sigma" (in the
legend with its estimate) and the RPM model's truth "<name> (true)"; the shading RPM_NAME (the bias
panel's copy, "RPM in use (bias)", in the legend with it)."""
MM_PER_M = 1e3
"""The scale factor is drawn in mm/s per rpm: 2.35, not 0.00235."""


def vkf_figure(
    trace: Mapping[str, np.ndarray],
    run: int = 0,
    height_px: int = 420,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """What Yoo 2014's velocity Kalman filter learned of the propeller (method ``vkf``; eq. 20,
    ``V_rpm = rpm sf - b``): its scale factor sf [mm/s per rpm] (top panel) and bias b [m/s]
    (bottom panel) against time, each with its 1-sigma band and, where finite, the RPM model's
    true value (dashed; NaN on the dynamic truth, whose propeller has no such model), and the
    pings where eq. 29 aids with the RPM instead of the DVL shaded (trace RPM_NAME): there the
    VKF only predicts, so its estimates hold still.

    Parameters
    ----------
    trace : ``MethodResult.vkf_trace`` (tauvcore.engine.yoo_bank): ``t_s`` (U,) [s], ``x`` and
        ``sigma`` (U, R, 3) = V [m/s], sf [m/s per rpm], b [m/s], ``sf_true``, ``b_true`` (U, R),
        ``rpm_in_use`` (U, R) bool.
    run : which of the R runs is drawn (the title names it when there are several).

    The curves are drawn with at most about ``max_points`` points (:func:`decimate`); the shaded
    stretches are found on every ping (:func:`intervals_above`).
    """
    t_s, x, sigma = (np.asarray(trace[k], float) for k in ("t_s", "x", "sigma"))
    sf_true, b_true = np.asarray(trace["sf_true"], float), np.asarray(trace["b_true"], float)
    in_use = np.asarray(trace["rpm_in_use"], bool)
    U = t_s.size
    if (
        t_s.ndim != 1
        or x.ndim != 3
        or x.shape[::2] != (U, 3)
        or sigma.shape != x.shape
        or not sf_true.shape == b_true.shape == in_use.shape == x.shape[:2]
    ):
        raise ValueError(
            f"vkf_figure needs t_s (U,), x and sigma (U, R, 3), sf_true, b_true and rpm_in_use (U, R), "
            f"got {t_s.shape}, {x.shape}, {sigma.shape}, {sf_true.shape}, {b_true.shape} and "
            f"{in_use.shape}"
        )
    runs = x.shape[1]
    if not 0 <= run < runs:
        raise ValueError(f"run must be within [0, {runs - 1}], got {run}")
    color = method_color("vkf")
    keep = decimate(U, max_points)
    t = t_s[keep]
    spans = intervals_above(t_s, in_use[:, run].astype(float), 0.5)
    data: list[dict[str, Any]] = []
    panels = ((VKF_SF_NAME, 1, MM_PER_M, sf_true, "x", "y"), (VKF_B_NAME, 2, 1.0, b_true, "x2", "y2"))
    ranges = []
    for name, k, scale, truth, xaxis, yaxis in panels:
        est, sig = scale * x[keep, run, k], scale * sigma[keep, run, k]
        true = scale * truth[keep, run]
        drawn = np.concatenate([est - sig, est + sig, true])
        drawn = drawn[np.isfinite(drawn)]
        lo, hi = (float(drawn.min()), float(drawn.max())) if drawn.size else (0.0, 1.0)
        pad = 0.05 * (hi - lo) or 0.05 * abs(hi) or 1.0
        lo, hi = lo - pad, hi + pad
        ranges.append([lo, hi])
        if len(spans):
            xs: list[float | None] = []
            ys: list[float | None] = []
            for a, b in spans:
                xs += [a, a, b, b, a, None]
                ys += [lo, hi, hi, lo, lo, None]
            data.append(
                {
                    "type": "scatter",
                    "x": xs,
                    "y": ys,
                    "name": RPM_NAME if k == 1 else f"{RPM_NAME} (bias)",
                    "mode": "lines",
                    "fill": "toself",
                    "fillcolor": RPM_FILL,
                    "line": {"width": 0},
                    "hoverinfo": "skip",
                    "legendgroup": "rpm",
                    "showlegend": k == 1,
                    "xaxis": xaxis,
                    "yaxis": yaxis,
                }
            )
        data.append(
            {
                "type": "scatter",
                "x": np.r_[t, t[::-1]],
                "y": np.r_[est + sig, (est - sig)[::-1]],
                "name": name + SIGMA_SUFFIX,
                "mode": "lines",
                "fill": "toself",
                "fillcolor": _hex_to_rgba(color, 0.2),
                "line": {"width": 0},
                "hoverinfo": "skip",
                "legendgroup": name,
                "showlegend": False,
                "xaxis": xaxis,
                "yaxis": yaxis,
            }
        )
        if np.isfinite(true).any():
            data.append(
                {
                    "type": "scatter",
                    "x": t,
                    "y": true,
                    "name": name + TRUE_SUFFIX,
                    "mode": "lines",
                    "line": {"color": TRUTH_COLOR, "width": 1.5, "dash": "dash"},
                    "xaxis": xaxis,
                    "yaxis": yaxis,
                }
            )
        data.append(
            {
                "type": "scatter",
                "x": t,
                "y": est,
                "name": name,
                "mode": "lines",
                "line": {"color": color, "width": 2},
                "legendgroup": name,
                "xaxis": xaxis,
                "yaxis": yaxis,
            }
        )
    title = "VKF: propeller scale factor and bias" + (f" (run {run + 1} of {runs})" if runs > 1 else "")
    layout = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 60, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.2},
        "template": "plotly_white",
        "xaxis": {"anchor": "y", "matches": "x2", "showticklabels": False},
        "yaxis": {
            "domain": [0.55, 1.0],
            "range": ranges[0],
            "title": {"text": "sf [mm/s per rpm]", "font": {"size": 11}},
        },
        "xaxis2": {"anchor": "y2", "title": {"text": "time [s]"}},
        "yaxis2": {
            "domain": [0.0, 0.45],
            "range": ranges[1],
            "title": {"text": "b [m/s]", "font": {"size": 11}},
        },
    }
    return _figure(data, layout, validate)


class DvlCounts(TypedDict):
    """:func:`dvl_counts`: the DVL updates summed over the runs; None each without DVL updates."""

    dvl_fused: int | None
    dvl_rejected: int | None
    dvl_coast: int | None


class SummaryRow(DvlCounts):
    """One method's line of :func:`summary_rows`."""

    method: str  # upper case
    vel_final_mps: float
    vel_rms_mps: float
    att_final_deg: float
    att_rms_deg: float
    tilt_rms_deg: float
    heading_rms_deg: float
    pos_final_m: float
    pos_rms_m: float
    nees_dim: int
    nees_per_dim: float
    nees_in_band: float
    vel_nees_per_dim: float
    dvl_nis_per_dof: float
    runs: int
    diverged_runs: int
    diverged_first_s: float
    p_floor_count: int


def summary_rows(results: Mapping[str, MethodResult]) -> list[SummaryRow]:
    """Per method: final and RMS-over-time errors (RMS over runs first when there are several),
    tilt and heading apart; consistency (tauvcore.eval.consistency.method_consistency, each
    method with its own NEES dimensions): the full state's dimension, its mean
    NEES/dim and the fraction of epochs inside its 99 % band, velocity
    NEES/dim, DVL NIS per degree of freedom (NaN without DVL updates); and the filter's health:
    how many runs the divergence monitor flagged, the earliest flag [s] (NaN if none) and the P
    eigenvalue-floor repairs summed over runs."""
    rows: list[SummaryRow] = []
    for method, res in results.items():

        def curve(x: np.ndarray) -> np.ndarray:
            return x[:, 0] if x.shape[1] == 1 else rms(x, axis=1)

        vel, att, pos = curve(res.vel_err_mps), curve(res.att_err_deg), curve(res.pos_err_m)
        consistency = method_consistency(res)
        dvl_nis = consistency.nis.get("dvl")
        rows.append(
            {
                "method": method.upper(),
                "vel_final_mps": float(vel[-1]),
                "vel_rms_mps": float(rms(vel)),
                "att_final_deg": float(att[-1]),
                "att_rms_deg": float(rms(att)),
                "tilt_rms_deg": float(rms(curve(res.tilt_err_deg))),
                "heading_rms_deg": float(rms(curve(res.heading_err_deg))),
                "pos_final_m": float(pos[-1]),
                "pos_rms_m": float(rms(pos)),
                "nees_dim": consistency.nees["full"].dim,
                "nees_per_dim": consistency.nees["full"].per_dim,
                "nees_in_band": consistency.nees["full"].in_band,
                "vel_nees_per_dim": consistency.nees["vel"].per_dim,
                "dvl_nis_per_dof": dvl_nis.per_dof if dvl_nis is not None else float("nan"),
                "runs": int(res.diverged.size),
                "diverged_runs": int(np.count_nonzero(res.diverged)),
                "diverged_first_s": float(np.nanmin(res.diverged_at_s))
                if res.diverged.any()
                else float("nan"),
                "p_floor_count": int(np.sum(res.p_floor_count)),
                **dvl_counts(res),
            }
        )
    return rows


def dvl_counts(result: MethodResult) -> DvlCounts:
    """The DVL updates of ``result`` summed over its runs, as the CLI counts them (app.cli
    summary_table): ``dvl_fused``, ``dvl_rejected`` (failed the gate) and ``dvl_coast`` (pings
    with no measurement); None each for a method without DVL updates (INS)."""
    dvl = result.updates.get("dvl")
    if dvl is None:
        return {"dvl_fused": None, "dvl_rejected": None, "dvl_coast": None}
    return {
        "dvl_fused": int(np.sum(dvl.fused)),
        "dvl_rejected": int(np.sum(dvl.rejected)),
        "dvl_coast": int(np.sum(~dvl.valid)),
    }


def _health_cell(row: SummaryRow) -> str:
    """ "ok", or when the divergence monitor flagged runs, when (and how many of the runs)."""
    if not row["diverged_runs"]:
        return "ok"
    at = f"diverged at {row['diverged_first_s']:.1f} s"
    if row["runs"] == 1:
        return at
    return f"{row['diverged_runs']} of {row['runs']} runs, first {at}"


def _fixed(x: float, decimals: int) -> str:
    """``x`` with ``decimals`` decimals, "-" if it is not finite."""
    return f"{x:.{decimals}f}" if np.isfinite(x) else "-"


def _ratio(x: float) -> str:
    """A NEES or NIS ratio (1 = consistent, up to thousands): two decimals near 1, "-" if not finite."""
    if not np.isfinite(x):
        return "-"
    if x >= 100.0:
        return f"{x:.0f}"
    return f"{x:.2f}" if x >= 0.1 else f"{x:.2g}"


def _in_band_cell(per_dim: float, in_band: float) -> str:
    if not np.isfinite(per_dim):
        return "-"
    return _ratio(per_dim) + (f" ({in_band:.0%})".replace("%", " %") if np.isfinite(in_band) else "")


ERROR_COLUMNS = (
    "method",
    "vel final [m/s]",
    "vel RMS [m/s]",
    "att final [deg]",
    "pos final [m]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
)
CONSISTENCY_COLUMNS = (
    "method",
    "states",
    "NEES/dim (in 99 % band)",
    "vel NEES/dim",
    "DVL NIS/dof",
    "monitor",
)
"""The results' two tables (a "P floors" column ends the second when some method needed a repair):
one table of eleven columns is wider than the dashboard's panel, which cut off its right end."""
CONSISTENCY_HEADING = "**Consistency** (1 = the method knows its error; above 1 it is over-confident)"
RMS_COLUMNS = (
    "method",
    "vel RMS [m/s]",
    "att RMS [deg]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
    "pos RMS [m]",
    "DVL fused",
    "DVL rejected",
    "DVL coast",
)
RMS_HEADING = (
    "**RMS over time and DVL updates** (fused; rejected by the gate; coast: pings without a "
    "measurement; summed over the runs)"
)
"""The results' third table: every RMS figure the CLI prints and its DVL counts."""


def _table(columns: tuple[str, ...], rows: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)] + [
        "| " + " | ".join(cells) + " |" for cells in rows
    ]


def summary_markdown(results: Mapping[str, MethodResult]) -> str:
    """The results as two Markdown tables (the dashboard shows them as text a person and a test
    can read): errors, then consistency below the line CONSISTENCY_HEADING.

    Errors: final and RMS velocity, the attitude norm, position, and tilt and heading RMS apart.
    Consistency: the number of error states (the full NEES's dimension: 20, Yoo 2014's 12), the
    NEES/dim of the full state with the fraction of epochs inside its two-sided 99 %
    band, velocity NEES/dim and DVL NIS per degree of freedom (1 = the method knows its error; "-"
    where there is nothing to measure, as for DVL NIS without DVL updates, or a value is NaN).
    The "monitor" column is the divergence monitor's verdict (tauvcore.engine: state or P
    not finite, an estimated sensor error far beyond its prior, innovations inconsistent, or the
    gate locked out). It sees only what the measurements reveal: "ok" is not a proof of
    consistency (VB at n_f = 2 on beams 1-2 was "ok" with a velocity error of 50 sigma); the
    NEES columns beside it are. A "P floors" column (repairs of P summed over runs) appears
    only when some method needed one. The RMS figures and DVL counts are :func:`rms_markdown`.
    """
    rows = summary_rows(results)
    floors = any(r["p_floor_count"] for r in rows)
    errors = [
        [
            str(r["method"]),
            _fixed(r["vel_final_mps"], 4),
            _fixed(r["vel_rms_mps"], 4),
            _fixed(r["att_final_deg"], 3),
            _fixed(r["pos_final_m"], 2),
            _fixed(r["tilt_rms_deg"], 3),
            _fixed(r["heading_rms_deg"], 3),
        ]
        for r in rows
    ]
    consistency = [
        [
            str(r["method"]),
            str(r["nees_dim"]),
            _in_band_cell(r["nees_per_dim"], r["nees_in_band"]),
            _ratio(r["vel_nees_per_dim"]),
            _ratio(r["dvl_nis_per_dof"]),
            _health_cell(r),
        ]
        + ([str(r["p_floor_count"])] if floors else [])
        for r in rows
    ]
    columns = CONSISTENCY_COLUMNS + (("P floors",) if floors else ())
    return "\n".join(
        _table(ERROR_COLUMNS, errors) + ["", CONSISTENCY_HEADING, ""] + _table(columns, consistency)
    )


def rms_markdown(results: Mapping[str, MethodResult]) -> str:
    """The Results tab's third table, below RMS_HEADING: every RMS over time the CLI prints
    (velocity, attitude norm, tilt, heading, position) and the DVL's fused, rejected and coast
    counts (:func:`dvl_counts`; "-" for a method without DVL updates)."""

    def count(x: int | None) -> str:
        return "-" if x is None else str(x)

    rows = [
        [
            str(r["method"]),
            _fixed(r["vel_rms_mps"], 4),
            _fixed(r["att_rms_deg"], 3),
            _fixed(r["tilt_rms_deg"], 3),
            _fixed(r["heading_rms_deg"], 3),
            _fixed(r["pos_rms_m"], 2),
            count(r["dvl_fused"]),
            count(r["dvl_rejected"]),
            count(r["dvl_coast"]),
        ]
        for r in summary_rows(results)
    ]
    return "\n".join([RMS_HEADING, ""] + _table(RMS_COLUMNS, rows))


# ------------------------------------------------------------------ the workbench
CURSOR_NAME = "time cursor"
CURSOR_COLOR = "rgba(40,40,40,0.7)"


def cursor_shape(t_s: float) -> dict[str, Any]:
    """The shared time cursor: a vertical line at ``t_s`` [s] across the whole plot (a plotly
    layout shape named CURSOR_NAME; the dashboard moves it in the page with the time slider)."""
    return {
        "type": "line",
        "name": CURSOR_NAME,
        "xref": "x",
        "yref": "paper",
        "x0": float(t_s),
        "x1": float(t_s),
        "y0": 0.0,
        "y1": 1.0,
        "line": {"color": CURSOR_COLOR, "width": 1.5, "dash": "dot"},
    }


def with_cursor(figure: go.Figure, t_s: float | None) -> go.Figure:
    """``figure`` with the time cursor at ``t_s`` (None: none), in place; returned for chaining."""
    figure.layout.shapes = [] if t_s is None else [cursor_shape(t_s)]
    return figure


COMPONENTS = {
    "pos": (("north", "east", "down"), "Position error", "m"),
    "vel": (("surge", "sway", "heave"), "Body velocity error", "m/s"),
    "att": (("roll", "pitch", "heading"), "Attitude error (Euler angles)", "deg"),
}
"""Signed error components (:func:`error_components`): names of the three axes, title, unit."""


def _nearest(t_from: np.ndarray, t_to: np.ndarray) -> np.ndarray:
    """Index into ``t_from`` (sorted) of the sample nearest each of ``t_to``."""
    i = np.clip(np.searchsorted(t_from, t_to), 1, max(len(t_from) - 1, 1))
    before = np.abs(t_to - t_from[i - 1]) <= np.abs(t_from[np.minimum(i, len(t_from) - 1)] - t_to)
    return np.where(before, i - 1, i).clip(0, len(t_from) - 1)


def error_components(
    result: MethodResult,
    truth_t_s: np.ndarray,
    truth_pos_n: np.ndarray,
    truth_C_nb: np.ndarray,
    truth_vel_n: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Signed errors (estimate minus truth) of ``result`` at its output epochs, per axis.

    ``pos`` (T, R, 3): north, east, down [m], ``est_pos_n - pos_n``. ``vel`` (T, R, 3): surge,
    sway, heave [m/s], the body-frame velocity error ``C_nb_est.T v_est_n - C_nb.T v_n`` (the
    norm of it is ``MethodResult.vel_err_mps``). ``att`` (T, R, 3): roll, pitch, heading [deg],
    the difference of the estimated and true ZYX Euler angles, heading wrapped to (-180, 180].
    ``vel`` needs ``est_vel_n`` and ``est_euler_rad``, ``att`` the latter: missing, the key is absent.

    Parameters
    ----------
    truth_t_s : (N,) epochs of the truth [s]; each output epoch takes the nearest (the dashboard's
        truth view is sampled at the output epochs, so they coincide).
    truth_pos_n, truth_C_nb : (N, 3), (N, 3, 3) true position [m] and attitude.
    truth_vel_n : (N, 3) true NED velocity [m/s]; None: the central difference of ``truth_pos_n``
        (``np.gradient``, second order: error ~ dt^2/6 |d3r/dt3|, 2e-5 m/s at 10 Hz for a jerk of 0.01 m/s^3).
    """
    truth_t_s = np.asarray(truth_t_s, float)
    if len(truth_t_s) == 0 or len(result.t_s) == 0:
        raise ValueError(
            f"error_components needs epochs, got {len(truth_t_s)} of truth and {len(result.t_s)} of results"
        )
    k = _nearest(truth_t_s, np.asarray(result.t_s, float))
    pos, C = np.asarray(truth_pos_n, float)[k], np.asarray(truth_C_nb, float)[k]
    out = {"pos": result.est_pos_n - pos[:, None, :]}
    if result.est_euler_rad is not None:
        euler_true = euler_from_C_nb(C)
        d = result.est_euler_rad - euler_true[:, None, :]
        d[..., 2] = wrap_angle(d[..., 2])
        out["att"] = np.degrees(d)
        if result.est_vel_n is not None:
            if truth_vel_n is None:
                vel_all = (
                    np.gradient(np.asarray(truth_pos_n, float), truth_t_s, axis=0)
                    if len(truth_t_s) > 1
                    else np.zeros((1, 3))
                )
            else:
                vel_all = np.asarray(truth_vel_n, float)
            v_true_b = np.einsum("tji,tj->ti", C, vel_all[k])  # C_nb.T v_n
            v_est_b = np.einsum("trji,trj->tri", C_nb_from_euler(result.est_euler_rad), result.est_vel_n)
            out["vel"] = v_est_b - v_true_b[:, None, :]
    return out


def identical_methods(results: Mapping[str, MethodResult]) -> dict[str, str]:
    """Methods whose results equal an earlier method's, each mapped to that method (the first
    in ``results``' order): every error series, its sigma and NEES equal element for element (NaN
    equal to NaN). ELC, NSV, VB, ... with all four beams returning are LC: the same numbers."""
    fields = ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "pos_sigma_m", "nees")
    same: dict[str, str] = {}
    seen: list[str] = []
    for method, res in results.items():
        for other in seen:
            ref = results[other]
            if ref.t_s.shape == res.t_s.shape and all(
                getattr(ref, f).shape == getattr(res, f).shape
                and np.array_equal(getattr(ref, f), getattr(res, f), equal_nan=True)
                for f in fields
            ):
                same[method] = other
                break
        else:
            seen.append(method)
    return same


def identical_note(same: Mapping[str, str]) -> str:
    """One sentence per group of identical methods (:func:`identical_methods`), "" if none."""
    groups: dict[str, list[str]] = {}
    for method, ref in same.items():
        groups.setdefault(ref, []).append(method.upper())
    parts = [
        f"{' and '.join(names)} {'give' if len(names) > 1 else 'gives'} exactly the results of {ref.upper()}"
        for ref, names in groups.items()
    ]
    if not parts:
        return ""
    return (
        "**Identical methods:** " + "; ".join(parts) + " (with 3-4 beams returning, the partial-beam methods "
        "fuse as LC). Their curves lie on one another: the one drawn last hides the others."
    )


def _panels(n: int, gap: float = 0.06) -> list[tuple[float, float]]:
    """y domains of ``n`` stacked panels, the first on top."""
    h = (1.0 - gap * (n - 1)) / n
    return [
        (max(0.0, round(1.0 - k * (h + gap) - h, 6)), min(1.0, round(1.0 - k * (h + gap), 6)))
        for k in range(n)
    ]


def _stacked_layout(title: str, names: list[str], height_px: int) -> dict[str, Any]:
    """Layout of len(``names``) panels sharing the time axis, each y-axis titled by its name."""
    layout: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 60, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.12},
        "template": "plotly_white",
    }
    n = len(names)
    for k, ((lo, hi), name) in enumerate(zip(_panels(n), names)):
        suffix = "" if k == 0 else str(k + 1)
        layout[f"xaxis{suffix}"] = (
            {"anchor": f"y{suffix}", "title": {"text": "time [s]"}}
            if k == n - 1
            else {"anchor": f"y{suffix}", "matches": f"x{n if n > 1 else ''}", "showticklabels": False}
        )
        layout[f"yaxis{suffix}"] = {
            "domain": [lo, hi],
            "title": {"text": name, "font": {"size": 11}},
            "zeroline": True,
        }
    return layout


def components_figure(
    results: Mapping[str, MethodResult],
    components: Mapping[str, Mapping[str, np.ndarray]],
    quantity: str = "vel",
    height_px: int = 480,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Signed error components of ``quantity`` ("pos", "vel", "att": COMPONENTS) against time,
    one panel per axis (north/east/down, surge/sway/heave, roll/pitch/heading), one trace per
    method and panel named by the method (in the legend once, its panels grouped with it).

    ``components``: method -> :func:`error_components` of it (a method absent, or without
    ``quantity``, is not drawn). With several Monte Carlo runs the curves are the RMS over runs
    (unsigned). At most about ``max_points`` points per trace (:func:`decimate`).
    """
    if quantity not in COMPONENTS:
        raise ValueError(f"quantity must be one of {', '.join(COMPONENTS)}, got {quantity!r}")
    axes, title, unit = COMPONENTS[quantity]
    data: list[dict[str, Any]] = []
    runs = 1
    for method, res in results.items():
        comp = components.get(method, {}).get(quantity)
        if comp is None or len(res.t_s) == 0:
            continue
        keep = decimate(len(res.t_s), max_points)
        runs = comp.shape[1]
        curves = comp[keep, 0, :] if runs == 1 else rms(comp[keep], axis=1)
        for k in range(3):
            suffix = "" if k == 0 else str(k + 1)
            data.append(
                {
                    "type": "scatter",
                    "x": res.t_s[keep],
                    "y": curves[:, k],
                    "name": method.upper(),
                    "mode": "lines",
                    "line": {"color": method_color(method), "width": 1.5},
                    "legendgroup": method,
                    "showlegend": k == 0,
                    "xaxis": f"x{suffix}",
                    "yaxis": f"y{suffix}",
                }
            )
    label = f"{title} [{unit}]" + (f" (RMS of {runs} runs)" if runs > 1 else ", estimate - truth")
    return _figure(data, _stacked_layout(label, [f"{a} [{unit}]" for a in axes], height_px), validate)


INNOVATION_ROWS = {"dvl": {3: ("surge", "sway", "heave"), 4: ("beam 1", "beam 2", "beam 3", "beam 4")}}
INNOVATION_ROWS.update({name: {len(s.row_labels): s.row_labels} for name, s in SOURCES.items()})
"""What a source's innovation rows are, by their number (DVL: body axes, TC: beams; a plug-in: its own)."""
BAND_SUFFIX = " 3-sigma"
REJECTED_SUFFIX = " rejected"


def innovation_sources(results: Mapping[str, MethodResult]) -> tuple[str, ...]:
    """The aiding sources any method of ``results`` updated with, in order of appearance."""
    return tuple(dict.fromkeys(s for res in results.values() for s in res.updates))


def innovation_figure(
    results: Mapping[str, MethodResult],
    source: str = "dvl",
    run: int = 0,
    height_px: int = 520,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Innovations of aiding ``source`` against time for run ``run`` of each method that has such
    updates, one panel per measurement row (the DVL's body axes, or TC's beams), with the
    filter's 3-sigma envelope ``+-3 sqrt(S_ii)`` (``UpdateRecord.innovation_var``) as a shaded
    band (trace "<METHOD> 3-sigma") and the rows the gate rejected marked with a cross (trace
    "<METHOD> rejected", at every rejected row, never decimated). Epochs where the source gave
    no measurement are gaps. A consistent filter keeps about 99.7 % of its innovations in its band.
    Each panel holds one quantity: methods whose rows mean different things (LC's body axes, TC's
    beams) get panels of their own, one per row name (:data:`INNOVATION_ROWS`), never a shared one.
    """
    records = {
        m: r.updates[source] for m, r in results.items() if source in r.updates and len(r.updates[source].t_s)
    }
    named = INNOVATION_ROWS.get(source, {})
    row_names = {
        m: named.get(d, tuple(f"row {k + 1}" for k in range(d)))
        for m, d in ((m, rec.innovation.shape[2]) for m, rec in records.items())
    }
    names = list(dict.fromkeys(name for labels in row_names.values() for name in labels)) or ["row 1"]
    data: list[dict[str, Any]] = []
    for method, rec in records.items():
        if not 0 <= run < rec.innovation.shape[1]:
            raise ValueError(f"run must be within [0, {rec.innovation.shape[1] - 1}], got {run}")
        color = method_color(method)
        keep = decimate(len(rec.t_s), max_points)
        t = rec.t_s[keep]
        valid = rec.valid[:, run]
        for k in range(rec.innovation.shape[2]):
            panel = names.index(row_names[method][k])
            suffix = "" if panel == 0 else str(panel + 1)
            axes = {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}
            nu = np.where(valid, rec.innovation[:, run, k], np.nan)
            with np.errstate(invalid="ignore"):
                env = np.where(valid, 3.0 * np.sqrt(rec.innovation_var[:, run, k]), np.nan)
            e = env[keep]
            data.append(
                {
                    "type": "scatter",
                    "x": np.r_[t, t[::-1]],
                    "y": np.r_[e, -e[::-1]],
                    "name": method.upper() + BAND_SUFFIX,
                    "mode": "lines",
                    "fill": "toself",
                    "fillcolor": _hex_to_rgba(color, 0.12),
                    "line": {"width": 0},
                    "hoverinfo": "skip",
                    "legendgroup": method,
                    "showlegend": False,
                    **axes,
                }
            )
            data.append(
                {
                    "type": "scatter",
                    "x": t,
                    "y": nu[keep],
                    "name": method.upper(),
                    "mode": "lines+markers",
                    "marker": {"size": 3},
                    "line": {"color": color, "width": 1},
                    "legendgroup": method,
                    "showlegend": k == 0,
                    **axes,
                }
            )
            hit = rec.rejected_rows[:, run, k] & valid
            if hit.any():
                data.append(
                    {
                        "type": "scatter",
                        "x": rec.t_s[hit],
                        "y": rec.innovation[hit, run, k],
                        "name": method.upper() + REJECTED_SUFFIX,
                        "mode": "markers",
                        "marker": {"color": color, "size": 8, "symbol": "x"},
                        "legendgroup": method,
                        "showlegend": not any(d["name"] == method.upper() + REJECTED_SUFFIX for d in data),
                        **axes,
                    }
                )
    runs_text = f", run {run + 1}" if any(rec.innovation.shape[1] > 1 for rec in records.values()) else ""
    title = f"{source.upper()} innovations with their 3-sigma (x: rejected){runs_text}"
    return _figure(data, _stacked_layout(title, names, height_px), validate)


RUN_DASHES = ("solid", "dash", "dot", "dashdot", "longdash")
"""Line style of each overlaid run (:func:`compare_figure`), the method colours kept."""


def compare_figure(
    runs: Sequence[tuple[str, Mapping[str, MethodResult]]],
    quantity: str = "vel",
    log_y: bool | str = False,
    height_px: int = 300,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """:func:`error_figure` of several runs overlaid: ``runs`` is (label, results) per run, each
    run's curves in its method's colour and the run's line style (RUN_DASHES, in order: the first
    solid), each trace named "<METHOD> (<label>)"."""
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    if log_y not in (True, False, AUTO):
        raise ValueError(f"log_y must be True, False or {AUTO!r}, got {log_y!r}")
    err_field, _, title, unit = QUANTITIES[quantity]
    data: list[dict[str, Any]] = []
    drawn: list[np.ndarray] = []
    for n, (label, results) in enumerate(runs):
        for method, res in results.items():
            if len(res.t_s) == 0:
                continue
            keep = decimate(len(res.t_s), max_points)
            err = getattr(res, err_field)[keep]
            curve = err[:, 0] if err.shape[1] == 1 else rms(err, axis=1)
            drawn.append(curve)
            data.append(
                {
                    "type": "scatter",
                    "x": res.t_s[keep],
                    "y": curve,
                    "name": f"{method.upper()} ({label})",
                    "mode": "lines",
                    "legendgroup": f"{label}/{method}",
                    "line": {
                        "color": method_color(method),
                        "width": 2,
                        "dash": RUN_DASHES[n % len(RUN_DASHES)],
                    },
                }
            )
    log = _spans_decades(drawn) if log_y == AUTO else bool(log_y)
    labels = ", ".join(f"{label} {RUN_DASHES[n % len(RUN_DASHES)]}" for n, (label, _) in enumerate(runs))
    layout = {
        "title": {"text": f"{title} [{unit}]: {labels}", "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 50, "r": 10, "t": 35, "b": 35},
        "legend": {"orientation": "h", "y": -0.2},
        "xaxis": {"title": {"text": "time [s]"}},
        "template": "plotly_white",
        "yaxis": {"type": "log" if log else "linear", "exponentformat": "power"},
    }
    return _figure(data, layout, validate)


def overlay_figure(runs: Sequence[tuple[str, go.Figure]]) -> go.Figure:
    """Figures of one kind, one per run (``runs``: (label, figure)), overlaid: every method's curve
    of every run in its method's colour and the run's line style (RUN_DASHES, the first solid),
    named "<METHOD> (<label>)"; what is not a method's curve (a 99 % band, the "1 = consistent"
    line, 1-sigma bands) is drawn once, from the first run's figure. The first figure's layout is
    kept, its title followed by the runs' line styles. Used for the NEES plots of runs kept side by
    side (:func:`nees_figure`), as :func:`compare_figure` is for the errors."""
    if not runs:
        raise ValueError("overlay_figure needs at least one run")
    methods = {m.upper() for m in METHOD_COLORS}
    out = go.Figure(layout=runs[0][1].layout)
    for n, (label, figure) in enumerate(runs):
        dash = RUN_DASHES[n % len(RUN_DASHES)]
        for trace in figure.data:
            name = getattr(trace, "name", None)
            if name in methods:
                copy = type(trace)(trace)  # a trace copies from its own kind
                copy.update(name=f"{name} ({label})", legendgroup=f"{label}/{name}", line={"dash": dash})
                out.add_trace(copy)
            elif n == 0:
                out.add_trace(trace)
    styles = ", ".join(f"{label} {RUN_DASHES[n % len(RUN_DASHES)]}" for n, (label, _) in enumerate(runs))
    title = runs[0][1].to_dict()["layout"].get("title", {}).get("text", "")
    out.update_layout(title_text=f"{title}: {styles}")
    return out


COMPARE_COLUMNS = (
    "method",
    "run",
    "vel RMS [m/s]",
    "att RMS [deg]",
    "tilt RMS [deg]",
    "heading RMS [deg]",
    "pos RMS [m]",
    "pos final [m]",
    "NEES/dim",
)


def compare_markdown(runs: Sequence[tuple[str, Mapping[str, MethodResult]]]) -> str:
    """The runs' results side by side: one Markdown table, a line per method and run, the runs
    of one method together (methods in order of first appearance; :func:`summary_rows`' numbers)."""
    rows: dict[str, list[list[str]]] = {}
    for label, results in runs:
        for r in summary_rows(results):
            rows.setdefault(str(r["method"]), []).append(
                [
                    str(r["method"]),
                    label,
                    _fixed(r["vel_rms_mps"], 4),
                    _fixed(r["att_rms_deg"], 3),
                    _fixed(r["tilt_rms_deg"], 3),
                    _fixed(r["heading_rms_deg"], 3),
                    _fixed(r["pos_rms_m"], 2),
                    _fixed(r["pos_final_m"], 2),
                    _ratio(r["nees_per_dim"]),
                ]
            )
    return "\n".join(_table(COMPARE_COLUMNS, [line for lines in rows.values() for line in lines]))


def flat_config(config: Config, runs: int | None = None) -> dict[str, Any]:
    """``config`` (tauvcore.config.to_dict) as "section.field" -> value (nested records joined by
    dots, lists as they are); ``runs``: also the Monte Carlo run count, as "runs"."""
    out: dict[str, Any] = {}

    def walk(prefix: str, value: Any) -> None:
        if isinstance(value, dict):
            for key, v in value.items():
                walk(f"{prefix}.{key}" if prefix else key, v)
        else:
            out[prefix] = value

    walk("", to_dict(config))
    if runs is not None:
        out["runs"] = runs
    return out


def config_differences(configs: Sequence[Mapping[str, Any]]) -> dict[str, list[Any]]:
    """The settings (keys of :func:`flat_config`) whose values are not all equal across
    ``configs``, each with its value in every config (None where one lacks it), in key order."""
    keys = sorted(set().union(*configs)) if configs else []
    out = {}
    for key in keys:
        values = [c.get(key) for c in configs]
        if any(v != values[0] for v in values[1:]):
            out[key] = values
    return out


def _cell(value: Any) -> str:
    if isinstance(value, list):
        return ", ".join(_cell(v) for v in value) or "(none)"
    if isinstance(value, float):
        return f"{value:g}"
    return "-" if value is None else str(value).replace("|", "/")


def config_diff_markdown(labels: Sequence[str], configs: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of the settings that differ between the runs (:func:`config_differences`),
    one column per run; a sentence when they all ran the same configuration."""
    diff = config_differences(configs)
    if not diff:
        return "**Configuration:** the same for " + ", ".join(labels) + "."
    return "\n".join(
        ["**Configuration differences**", ""]
        + _table(("setting", *labels), [[key, *(_cell(v) for v in values)] for key, values in diff.items()])
    )
