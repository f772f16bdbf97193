"""Plotly figures of the vehicle: what the dynamic truth's vehicle did, the ocean current it flew
in, how high it flew, and what Yoo 2014's velocity filter learned of its propeller.

The actuator figure shows the four fins and the propeller of the dynamic truth (tauvcore.truth.vehicle);
the altitude figure how high the vehicle flew above the seabed, against the DVL's range and the
velocity filter's switch to RPM; the VKF figure what that velocity filter learned of the propeller
(Yoo 2014's ``vkf`` method); the current figure the current at the vehicle (tauvcore.truth.current)
and its speed through the water against over ground. They draw arrays, not a MethodResult: the
truth's series and the VKF's trace.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.shared import (
    LEGEND_BELOW,
    TIME_AXIS,
    TRUTH_COLOR,
    decimate,
    hex_to_rgba,
    make_figure,
    method_color,
    time_layout,
)

FIN_NAMES = ("fin 1 lower stbd", "fin 2 lower port", "fin 3 upper port", "fin 4 upper stbd")
"""Fins 1-4 of tauvcore.truth.vehicle (FIN_POSITION_ANGLES_RAD: 45, 135, 225, 315 deg from starboard
towards down)."""
FIN_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a")
"""One colour per fin, in the actuator figure and on the fins of the 3-D view."""
PROPELLER_COLOR = "#444444"


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

    At most about ``max_points`` points per trace (:func:`app.figures.shared.decimate`, the last sample kept).
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
    top, bottom = _y_axis([0.4, 1.0], "fin deflection [deg]"), _y_axis([0.0, 0.3], "propeller [rpm]")
    layout = _two_panels("Dynamic truth: fins and propeller", height_px, 55, top, bottom)
    return make_figure(data, layout, validate)


def _two_panels(
    title: str, height_px: int, left_px: int, yaxis: dict[str, Any], yaxis2: dict[str, Any]
) -> dict[str, Any]:
    """The layout of two panels on one time axis, ``yaxis`` the top one's and ``yaxis2`` the
    bottom one's, with the legend below them."""
    return {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": left_px, "r": 10, "t": 35, "b": 35},
        "legend": LEGEND_BELOW,
        "template": "plotly_white",
        "xaxis": {"anchor": "y", "matches": "x2", "showticklabels": False},
        "yaxis": yaxis,
        "xaxis2": {"anchor": "y2", **TIME_AXIS},
        "yaxis2": yaxis2,
    }


def _y_axis(domain: list[float], title: str, **extra: Any) -> dict[str, Any]:
    """A panel's y-axis: its ``domain`` (bottom and top, a fraction of the plot), ``extra`` keys and
    its ``title``."""
    return {"domain": domain, **extra, "title": {"text": title, "font": {"size": 11}}}


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
"""The "lost" beams' orange of the 3-D view (app.figures.scene.BEAM_COLORS), light: where the DVL is out of reach."""


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

    The curve is drawn with at most about ``max_points`` points (:func:`app.figures.shared.decimate`); the shaded
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
        data.append(_rpm_shading(spans, bottom, top))
    for level_m, name, color, dash in (
        (dvl_max_altitude_m, DVL_LIMIT_NAME, DVL_LIMIT_COLOR, "dash"),
        (switch_altitude_m, SWITCH_NAME, SWITCH_COLOR, "dot"),
    ):
        data.append(
            {
                "type": "scatter",
                "x": [t0, t1],
                "y": [level_m] * 2,
                "name": name,
                "mode": "lines",
                "line": {"color": color, "width": 1.5, "dash": dash},
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
    yaxis = {"range": [bottom, top], "title": {"text": "altitude [m]", "font": {"size": 11}}}
    return make_figure(data, time_layout(title, height_px, yaxis, left_px=55), validate)


def _rpm_shading(spans: np.ndarray, lo: float, hi: float, **extra: Any) -> dict[str, Any]:
    """The trace RPM_NAME: each of ``spans`` ((K, 2) start and end [s]) shaded from ``lo`` to
    ``hi``, one closed outline per span, the outlines apart by None; ``extra`` keys added."""
    x: list[float | None] = []
    y: list[float | None] = []
    for a, b in spans:
        x += [a, a, b, b, a, None]
        y += [lo, hi, hi, lo, lo, None]
    return {
        "type": "scatter",
        "x": x,
        "y": y,
        "name": RPM_NAME,
        "mode": "lines",
        "fill": "toself",
        "fillcolor": RPM_FILL,
        "line": {"width": 0},
        "hoverinfo": "skip",
        **extra,
    }


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

    The curves are drawn with at most about ``max_points`` points (:func:`app.figures.shared.decimate`); the shaded
    stretches are found on every ping (:func:`intervals_above`).
    """
    t_s, x, sigma, sf_true, b_true, in_use = _vkf_arrays(trace)
    runs = x.shape[1]
    if not 0 <= run < runs:
        raise ValueError(f"run must be within [0, {runs - 1}], got {run}")
    keep = decimate(t_s.size, max_points)
    spans = intervals_above(t_s, in_use[:, run].astype(float), 0.5)
    data: list[dict[str, Any]] = []
    ranges = []
    for name, k, scale, truth in ((VKF_SF_NAME, 1, MM_PER_M, sf_true), (VKF_B_NAME, 2, 1.0, b_true)):
        est, sig = scale * x[keep, run, k], scale * sigma[keep, run, k]
        traces, y_range = _vkf_panel(name, k, t_s[keep], est, sig, scale * truth[keep, run], spans)
        data += traces
        ranges.append(y_range)
    title = "VKF: propeller scale factor and bias" + (f" (run {run + 1} of {runs})" if runs > 1 else "")
    top = _y_axis([0.55, 1.0], "sf [mm/s per rpm]", range=ranges[0])
    layout = _two_panels(title, height_px, 60, top, _y_axis([0.0, 0.45], "b [m/s]", range=ranges[1]))
    return make_figure(data, layout, validate)


def _vkf_arrays(trace: Mapping[str, np.ndarray]) -> tuple[np.ndarray, ...]:
    """``t_s`` (U,), ``x`` and ``sigma`` (U, R, 3), ``sf_true``, ``b_true`` and ``rpm_in_use``
    (U, R) of a VKF trace (:func:`vkf_figure`), as arrays; ValueError naming their shapes if
    these do not agree."""
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
    return t_s, x, sigma, sf_true, b_true, in_use


def _vkf_panel(
    name: str, k: int, t: np.ndarray, est: np.ndarray, sig: np.ndarray, true: np.ndarray, spans: np.ndarray
) -> tuple[list[dict[str, Any]], list[float]]:
    """Panel ``k`` of :func:`vkf_figure` (1: the scale factor, on top; 2: the bias) of the
    estimate ``est`` of ``name``, its 1-sigma ``sig`` and its truth ``true`` at times ``t`` [s]:
    the RPM's ``spans`` shaded, the band, the truth where finite and the estimate; and the
    panel's y range, padded by 5 %."""
    axes = {"xaxis": "x", "yaxis": "y"} if k == 1 else {"xaxis": "x2", "yaxis": "y2"}
    color = method_color("vkf")
    drawn = np.concatenate([est - sig, est + sig, true])
    drawn = drawn[np.isfinite(drawn)]
    lo, hi = (float(drawn.min()), float(drawn.max())) if drawn.size else (0.0, 1.0)
    pad = 0.05 * (hi - lo) or 0.05 * abs(hi) or 1.0
    lo, hi = lo - pad, hi + pad
    data: list[dict[str, Any]] = []
    if len(spans):
        name_rpm = RPM_NAME if k == 1 else f"{RPM_NAME} (bias)"
        data.append(_rpm_shading(spans, lo, hi, name=name_rpm, legendgroup="rpm", showlegend=k == 1, **axes))
    data.append(
        {
            "type": "scatter",
            "x": np.r_[t, t[::-1]],
            "y": np.r_[est + sig, (est - sig)[::-1]],
            "name": name + SIGMA_SUFFIX,
            "mode": "lines",
            "fill": "toself",
            "fillcolor": hex_to_rgba(color, 0.2),
            "line": {"width": 0},
            "hoverinfo": "skip",
            "legendgroup": name,
            "showlegend": False,
            **axes,
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
                **axes,
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
            **axes,
        }
    )
    return data, [lo, hi]


CURRENT_NORTH_NAME = "current north"
CURRENT_EAST_NAME = "current east"
WATER_SPEED_NAME = "through the water"
GROUND_SPEED_NAME = "over ground"
"""The current figure's traces (:func:`current_figure`)."""
CURRENT_NORTH_COLOR = "#2166ac"
CURRENT_EAST_COLOR = "#b2182b"
WATER_SPEED_COLOR = "#1a9850"
GROUND_SPEED_COLOR = TRUTH_COLOR


def water_and_ground_speed_mps(
    C_nb: np.ndarray, vel_water_b: np.ndarray, current_n_mps: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The vehicle's speed through the water and over ground.

    Parameters
    ----------
    C_nb : numpy.ndarray
        Attitude, body to NED, shape (T, 3, 3).
    vel_water_b : numpy.ndarray
        Velocity through the water, body frame, shape (T, 3) [m/s].
    current_n_mps : numpy.ndarray
        The current at the vehicle, NED, shape (T, 3) [m/s].

    Returns
    -------
    speed_water_mps : numpy.ndarray
        ``|vel_water_b|``, shape (T,) [m/s].
    speed_ground_mps : numpy.ndarray
        ``|C_nb vel_water_b + c_n|``, shape (T,) [m/s].
    """
    C, w, c = (np.asarray(a, float) for a in (C_nb, vel_water_b, current_n_mps))
    ground_n = np.einsum("kij,kj->ki", C, w) + c
    return np.linalg.norm(w, axis=1), np.linalg.norm(ground_n, axis=1)


def current_figure(
    t_s: np.ndarray,
    current_n_mps: np.ndarray,
    speed_water_mps: np.ndarray,
    speed_ground_mps: np.ndarray,
    height_px: int = 380,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """The ocean current at the vehicle and what it does to the vehicle's speed, against time: the
    current's north and east parts [m/s] (top panel, traces CURRENT_NORTH_NAME and
    CURRENT_EAST_NAME) and the speed through the water against the speed over ground [m/s]
    (bottom panel, WATER_SPEED_NAME and GROUND_SPEED_NAME), on one shared time axis. The title
    gives the current's mean speed and the direction it flows toward (clockwise from north).

    Parameters
    ----------
    t_s : numpy.ndarray
        Time, shape (T,) [s].
    current_n_mps : numpy.ndarray
        The current at the vehicle, NED, shape (T, 3) [m/s] (its down part is not drawn).
    speed_water_mps : numpy.ndarray
        Speed through the water, shape (T,) [m/s] (what the propeller's RPM measures).
    speed_ground_mps : numpy.ndarray
        Speed over ground, shape (T,) [m/s] (what the DVL's bottom lock measures).
    height_px : int
        The figure's height [px].
    max_points : int or None
        At most about this many points per trace (:func:`app.figures.shared.decimate`, the last kept).
    validate : bool
        Let plotly check the figure's properties.

    Returns
    -------
    plotly.graph_objects.Figure
        The two-panel figure.
    """
    t_s, c = np.asarray(t_s, float), np.asarray(current_n_mps, float)
    water, ground = np.asarray(speed_water_mps, float), np.asarray(speed_ground_mps, float)
    if t_s.ndim != 1 or c.shape != (t_s.size, 3) or water.shape != t_s.shape or ground.shape != t_s.shape:
        raise ValueError(
            f"current_figure needs t_s (T,), current_n_mps (T, 3), speed_water_mps and speed_ground_mps "
            f"(T,), got {t_s.shape}, {c.shape}, {water.shape} and {ground.shape}"
        )
    keep = decimate(t_s.size, max_points)
    t = t_s[keep]
    panels = (
        (CURRENT_NORTH_NAME, c[keep, 0], CURRENT_NORTH_COLOR, "x", "y"),
        (CURRENT_EAST_NAME, c[keep, 1], CURRENT_EAST_COLOR, "x", "y"),
        (WATER_SPEED_NAME, water[keep], WATER_SPEED_COLOR, "x2", "y2"),
        (GROUND_SPEED_NAME, ground[keep], GROUND_SPEED_COLOR, "x2", "y2"),
    )
    data: list[dict[str, Any]] = [
        {
            "type": "scatter",
            "x": t,
            "y": y,
            "name": name,
            "mode": "lines",
            "line": {"color": color, "width": 1.8 if name != GROUND_SPEED_NAME else 1.5},
            "xaxis": xaxis,
            "yaxis": yaxis,
        }
        for name, y, color, xaxis, yaxis in panels
    ]
    mean_n, mean_e = (float(np.mean(c[:, k])) if t_s.size else 0.0 for k in (0, 1))
    speed = float(np.hypot(mean_n, mean_e))
    toward = float(np.degrees(np.arctan2(mean_e, mean_n)) % 360.0)
    title = f"Current: mean {speed:.2f} m/s toward {toward:.0f} deg"
    top, bottom = _y_axis([0.55, 1.0], "current [m/s]"), _y_axis([0.0, 0.45], "speed [m/s]")
    return make_figure(data, _two_panels(title, height_px, 55, top, bottom), validate)
