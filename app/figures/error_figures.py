"""Plotly figures of the errors and the consistency of run results: pure functions, results in,
``go.Figure`` out.

With one run the curves are that run's errors; with several Monte Carlo runs they are the RMS over
runs (as in the paper's figures) and the sigma band is the RMS of the filter's own 1-sigma.
Attitude error is shown as tilt (roll, pitch: levelling) and heading apart, and as their norm: with
DVL aiding alone heading is unobservable, so the norm is almost all heading and hides how well tilt
is estimated. The signed components (:func:`components_figure`) show each axis apart. The
consistency figure shows whether each method knows its own error: its NEES divided by the block's
dimension (1 for a consistent filter) against the two-sided 99 % band. Runs kept side by side are
overlaid, each in its own line style (:func:`compare_figure`, :func:`overlay_figure`).

Yoo 2014's methods (``ins-dvl``, ``vkf``) run a 12-state filter with no position state: their
position 1-sigma and NEES are NaN (no band, no curve) and their NEES is divided by their own
block dimensions (``MethodResult.block_dims``), not the 20-state filter's.

With ``smoothed`` the fixed-interval smoother's results of each method that has them
(``MethodResult.smoothed``: every method of a run that asked for the smoother) are drawn
beside the filter's: a dashed line of the method's colour named "<METHOD> smoothed", and with the
1-sigma its smoothed 1-sigma as a dotted line (:func:`smoothed_traces`).

A long run reduced to time bins (tauvcore.eval.envelope.DecimatedResult) is drawn as each curve's
value at every bin's last epoch over a shaded band from its minimum to its maximum within the bin
(:func:`app.figures.shared.envelope_traces`), the bins merged further where a trace would hold more than
``max_points``; the title names the bin width.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.log_axes import AUTO, drop_for_log, error_axis, log_axis
from app.figures.shared import (
    BAND_ALPHA_MAX,
    METHOD_COLORS,
    TICK_LABELS_PX,
    TIME_AXIS,
    TITLE_PX,
    TRUTH_COLOR,
    band_alpha,
    bin_label,
    decimate,
    envelope_traces,
    hex_to_rgba,
    legend_bottom,
    make_figure,
    merge_bins,
    merged_envelope,
    method_color,
    stacked_layout,
    time_layout,
)
from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.eval.consistency import CONFIDENCE, nees_band
from tauvcore.eval.envelope import curve_key, is_decimated, nees_curve, run_curve
from tauvcore.eval.metrics import rms
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, wrap_angle

QUANTITIES = {
    "vel": ("vel_err_mps", "vel_sigma_mps", "Velocity error", "m/s"),
    "att": ("att_err_deg", "att_sigma_deg", "Attitude error (norm)", "deg"),
    "tilt": ("tilt_err_deg", "tilt_sigma_deg", "Tilt error (roll, pitch)", "deg"),
    "heading": ("heading_err_deg", "heading_sigma_deg", "Heading error", "deg"),
    "pos": ("pos_err_m", "pos_sigma_m", "Position error", "m"),
}
PLOT_PX = 160
"""The plot area's height of an error or consistency plot on a card CARD_WIDTH_PX wide [px]; its
legend's rows are added below it (app.figures.shared.legend_bottom)."""
NEES_BLOCK_NAMES = {
    "full": "full state",
    "pos": "position",
    "vel": "velocity",
    "tilt": "tilt",
    "heading": "heading",
    "sensor": "sensor errors",
    "current": "current (north, east)",
}
"""Consistency blocks (tauvcore.engine.results.BLOCK_DIMS, and the states the aiding sources add:
the DVL's current, tauvcore.aiding.dvl_water) as the figure names them; another block by its name."""
BAND_COLOR = "rgba(120,120,120,0.18)"


def _points(res: MethodResult, max_points: int | None) -> tuple[slice, np.ndarray | None]:
    """The epochs drawn of ``res`` (a stride) and, for a run reduced to bins, where the merged
    groups of bins start (app.figures.shared.merge_bins)."""
    if is_decimated(res):
        return merge_bins(len(res.t_s), max_points)
    return decimate(len(res.t_s), max_points), None


def _envelope_note(results: Mapping[str, MethodResult]) -> str:
    """ ", shaded: curve's min–max within each 9.1 s bin" when a run of ``results`` is reduced to bins, else ""."""
    widths = sorted({float(r.bin_s) for r in results.values() if is_decimated(r)})
    return f", shaded: {bin_label(widths[-1])}" if widths else ""


SMOOTHED_DASH = "dash"
"""The line style of a method's smoothed curves (the filter's are solid)."""


def smoothed_name(method: str) -> str:
    """The legend's name of ``method``'s smoothed curve: "LC smoothed".

    Parameters
    ----------
    method : str
        The method's name.

    Returns
    -------
    str
        Its smoothed curve's name.
    """
    return f"{method.upper()} smoothed"


def smoothed_traces(
    method: str,
    res: MethodResult,
    fields: tuple[str, str | None],
    max_points: int | None,
    scale: float = 1.0,
    curve_of: Any = None,
) -> list[dict[str, Any]]:
    """The traces of ``res``'s smoothed results (none when it has none, or no epoch): the curve
    (the single run's value, the RMS over runs; or ``curve_of(smoothed)`` (T,)) as a dashed line
    of the method's colour named :func:`smoothed_name`, over its min-max band when the run is in
    bins, and with ``fields[1]`` its 1-sigma as a dotted line.

    Parameters
    ----------
    method : str
        The method's name.
    res : MethodResult
        Its results; ``res.smoothed`` is drawn.
    fields : tuple of (str, str or None)
        The error series' field and the 1-sigma's (None: no 1-sigma), or the ``low``/``high`` key
        of a reduced run's band when ``curve_of`` is given.
    max_points : int or None
        At most about this many points per trace (the filter's curves' stride).
    scale : float
        Every value drawn is multiplied by it (NEES: 1 / the block's dimension).
    curve_of : Callable[[MethodResult], numpy.ndarray] or None
        The curve of the smoothed results; None: the run curve of ``fields[0]``.

    Returns
    -------
    list[dict[str, Any]]
        Plain trace dicts, the band's before the line.
    """
    sm = res.smoothed
    if sm is None or len(sm.t_s) == 0:
        return []
    keep, starts = _points(sm, max_points)
    t = sm.t_s[keep]
    color = method_color(method)
    name = smoothed_name(method)

    curve = (run_curve(getattr(sm, fields[0])) if curve_of is None else curve_of(sm))[keep] * scale
    data: list[dict[str, Any]] = []
    if is_decimated(sm):
        lo, hi = merged_envelope(sm.low[fields[0]], sm.high[fields[0]], starts)
        data += envelope_traces(t, lo * scale, hi * scale, name, color, sm.bin_s, method)
    data.append(
        {
            "type": "scatter",
            "x": t,
            "y": curve,
            "name": name,
            "mode": "lines",
            "line": {"color": color, "width": 2, "dash": SMOOTHED_DASH},
            "connectgaps": True,  # a replay's NEES is known at its reference's epochs only (tauvcore.eval.judging)
            "legendgroup": method,
        }
    )
    if fields[1] is not None:
        band = run_curve(getattr(sm, fields[1])[keep])
        if np.isfinite(band).any():
            data.append(
                {
                    "type": "scatter",
                    "x": t,
                    "y": band,
                    "name": f"{name} 1-sigma",
                    "mode": "lines",
                    "line": {"color": color, "width": 1, "dash": "dot"},
                    "showlegend": False,
                    "legendgroup": method,
                }
            )
    return data


def _error_curve(
    res: MethodResult,
    err_field: str,
    keep: slice,
    starts: np.ndarray | None,
    name: str,
    group: str,
    line: dict[str, Any],
) -> tuple[list[dict[str, Any]], list[np.ndarray]]:
    """The traces of ``res``'s error ``err_field`` at the epochs ``keep`` (:func:`_points`): its
    curve (:func:`tauvcore.eval.envelope.run_curve`) named ``name`` in the legend group ``group``,
    drawn with ``line``, over its min-max band when the run is in bins; and the values drawn (for
    :func:`_spans_decades`)."""
    t = res.t_s[keep]
    curve = run_curve(getattr(res, err_field)[keep])
    data: list[dict[str, Any]] = []
    drawn: list[np.ndarray] = []
    if is_decimated(res):
        lo, hi = merged_envelope(res.low[err_field], res.high[err_field], starts)
        drawn += [lo, hi]
        data += envelope_traces(t, lo, hi, name, line["color"], res.bin_s, group)
    drawn.append(curve)
    data.append(
        {
            "type": "scatter",
            "x": t,
            "y": curve,
            "name": name,
            "mode": "lines",
            "line": line,
            "legendgroup": group,
        }
    )
    return data, drawn


def _check_quantity(quantity: str, log_y: bool | str) -> None:
    """ValueError naming ``quantity`` unless it is one of QUANTITIES, or ``log_y`` unless it is
    True, False or AUTO (:func:`error_figure`, :func:`compare_figure`)."""
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    if log_y not in (True, False, AUTO):
        raise ValueError(f"log_y must be True, False or {AUTO!r}, got {log_y!r}")


def _sigma_band(method: str, t: np.ndarray, band: np.ndarray) -> dict[str, Any]:
    """``method``'s 1-sigma as one band: a thin dotted line of its colour, filled down to zero
    (its alpha set by :func:`error_figure` once every band is known)."""
    color = method_color(method)
    return {
        "type": "scatter",
        "x": t,
        "y": band,
        "name": f"{method.upper()} 1-sigma",
        "mode": "lines",
        "line": {"width": 1, "color": color, "dash": "dot"},
        "fill": "tozeroy",
        "fillcolor": hex_to_rgba(color, BAND_ALPHA_MAX),
        "hoverinfo": "skip",
        "showlegend": False,
        "legendgroup": method,
    }


def _error_layout(
    title: str, height_px: int | None, yaxis: dict[str, Any], data: list[dict[str, Any]], left_px: int = 50
) -> dict[str, Any]:
    """The layout of an error or consistency plot: :func:`app.figures.shared.time_layout` with its
    legend in a band of its own below (app.figures.shared.legend_bottom); the plot area PLOT_PX
    high, or ``height_px`` less the title and the tick labels, whatever the legend holds."""
    plot_px = PLOT_PX if height_px is None else max(height_px - TITLE_PX - TICK_LABELS_PX, 1)
    return legend_bottom(time_layout(title, plot_px, yaxis, left_px), data, plot_px)


def error_figure(
    results: Mapping[str, MethodResult],
    quantity: str = "vel",
    show_sigma: bool = False,
    log_y: bool | str = False,
    height_px: int | None = None,
    max_points: int | None = 600,
    validate: bool = False,
    smoothed: bool = False,
) -> go.Figure:
    """Error norm against time for every method; one trace per method named by its short name.

    ``quantity``: "vel", "tilt", "heading", "att" (the attitude norm) or "pos". ``show_sigma``
    adds the filter's 1-sigma as one band per method under its curve (a trace named "<NAME>
    1-sigma": a dotted line filled down to zero, translucent however many overlap:
    :func:`app.figures.shared.band_alpha`), where the method has one (not for the position of Yoo 2014's methods:
    NaN, no position state). ``log_y``: True, False, or "auto" (:func:`log_axis`: log where the
    drawn values span more than app.figures.log_axes.LOG_SPAN and no error starts at zero); on a log axis the zeros
    are gaps (:func:`drop_for_log`). At most about ``max_points`` points are drawn per trace
    (evenly strided, the last epoch always included): a plot panel is a few hundred pixels
    wide, and every point drawn is data sent to the browser on each live update. ``smoothed``:
    each method's smoothed error beside its filtered one, and with ``show_sigma`` its smoothed
    1-sigma (:func:`smoothed_traces`). ``height_px``: the figure's height without its legend
    (None: a plot area of PLOT_PX); the legend's rows are added below (:func:`_error_layout`).
    """
    _check_quantity(quantity, log_y)
    err_field, sigma_field, title, unit = QUANTITIES[quantity]
    data: list[dict[str, Any]] = []
    drawn: list[np.ndarray] = []
    bands: list[dict[str, Any]] = []
    runs = 1
    for method, res in results.items():
        keep, starts = _points(res, max_points)
        runs = getattr(res, err_field).shape[1]
        if show_sigma:
            band = run_curve(getattr(res, sigma_field)[keep])
            if np.isfinite(band).any():  # Yoo 2014's filter has no position state: no position band
                drawn.append(band)
                bands.append(_sigma_band(method, res.t_s[keep], band))
                data.append(bands[-1])
        line = {"color": method_color(method), "width": 2}
        traces, values = _error_curve(res, err_field, keep, starts, method.upper(), method, line)
        data += traces
        drawn += values
        if smoothed:
            traces = smoothed_traces(
                method, res, (err_field, sigma_field if show_sigma else None), max_points
            )
            drawn += [np.asarray(trace["y"], dtype=float) for trace in traces]
            data += traces
    for band in bands:
        band["fillcolor"] = hex_to_rgba(band["line"]["color"], band_alpha(len(bands)))
    log = log_axis(drawn, log_y)
    if log:
        data = drop_for_log(data, drawn)
    label = f"{title} [{unit}]" + (f" (RMS of {runs} runs)" if runs > 1 else "") + _envelope_note(results)
    return make_figure(data, _error_layout(label, height_px, error_axis(log), data), validate)


def block_dims(result: MethodResult) -> dict[str, int]:
    """NEES dimension of each block of ``result``: the 20-state filter's (BLOCK_DIMS), or the
    method's own (``MethodResult.block_dims``: Yoo 2014's 12-state filter, or the 20-state filter
    with the states its sources add, e.g. ``current``)."""
    return result.block_dims or BLOCK_DIMS


def nees_blocks(results: Mapping[str, MethodResult]) -> tuple[str, ...]:
    """The NEES blocks a consistency plot of ``results`` can draw.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results.

    Returns
    -------
    tuple[str, ...]
        The 20-state filter's blocks (tauvcore.engine.results.BLOCK_DIMS, "full" first), then
        those a method's own ``block_dims`` adds (the DVL's ``current``), in order of appearance.
    """
    return tuple(dict.fromkeys([*BLOCK_DIMS, *(b for r in results.values() for b in block_dims(r))]))


def nees_figure(
    results: Mapping[str, MethodResult],
    block: str = "full",
    height_px: int | None = None,
    max_points: int | None = 600,
    validate: bool = False,
    smoothed: bool = False,
) -> go.Figure:
    """Does each method know its own error? Its NEES of ``block`` divided by the block's
    dimension n, averaged over the Monte Carlo runs, against time; one trace per method.

    ``block``: "full" (all error states) or "pos", "vel", "tilt", "heading", "sensor"
    (tauvcore.engine.results.BLOCK_DIMS), or a block the sources add ("current": the DVL's current
    states; :func:`nees_blocks`). A method whose ``block_dims`` lacks ``block`` is not drawn, and
    the title names it ("no current: VKF"). n is each method's own (:func:`block_dims`: the full
    state is 20 for the first paper's methods, 12 for Yoo 2014's, whose position NEES is NaN: no
    curve, and 2 more with the current states). A consistent filter's curve lies near 1 (a dotted line, trace
    "1 = consistent") and inside the two-sided 99 % band of the run-averaged NEES
    (:func:`tauvcore.eval.consistency.nees_band`; a grey shaded trace "99 % band", which narrows as
    runs are added; when the methods drawn have different n, one band per n, "99 % band (dim n)",
    the first dashed, the others dotted); above it the filter is over-confident, below it cautious.
    NEES spans decades (VB at a small n_f reached thousands), so the y-axis is logarithmic. Epochs
    where the NEES is not finite are bridged by the line: a replayed log's NEES is known at its
    reference's own epochs only (tauvcore.eval.judging), a 1 Hz reference's every tenth epoch. ``smoothed``: each method's
    smoothed NEES of the block, against the same truth and band, as a dashed line beside its
    filtered one (:func:`smoothed_traces`).
    """
    known = dict.fromkeys([*nees_blocks(results), *NEES_BLOCK_NAMES])
    if block not in known:
        raise ValueError(f"block must be one of {', '.join(known)}, got {block!r}")
    data: list[dict[str, Any]] = []
    by_dim: dict[int, list[str]] = {}  # block dimension -> the methods drawn with it, in order
    without: list[str] = []  # the methods whose filter has no such block
    runs, t_first, t_last = 1, np.inf, -np.inf
    for method, res in results.items():
        if block not in block_dims(res):
            without.append(method.upper())
            continue
        if len(res.t_s) == 0:
            continue
        dim = block_dims(res)[block]
        by_dim.setdefault(dim, []).append(method.upper())
        traces, t, runs = _nees_traces(method, res, block, dim, max_points, smoothed)
        data += traces
        t_first, t_last = min(t_first, float(t[0])), max(t_last, float(t[-1]))
    if data:
        data = _nees_references(list(by_dim), runs, t_first, t_last) + data
    title = _nees_title(block, by_dim, without, runs, _envelope_note(results))
    yaxis = {
        **error_axis(True),
        "title": {"text": "NEES/dim (1 = consistent, >1 over-confident)", "font": {"size": 11}},
    }
    return make_figure(data, _error_layout(title, height_px, yaxis, data, left_px=55), validate)


def _nees_traces(
    method: str, res: MethodResult, block: str, dim: int, max_points: int | None, smoothed: bool
) -> tuple[list[dict[str, Any]], np.ndarray, int]:
    """``method``'s curve of :func:`nees_figure`: its NEES of ``block`` over ``dim`` (the block's
    dimension), averaged over the runs, over its min-max band when the run is in bins, and with
    ``smoothed`` its smoothed curve beside it; with the times drawn [s] and the number of runs."""
    keep, starts = _points(res, max_points)
    curve = nees_curve(res, block)[keep] / dim
    t = res.t_s[keep]
    data: list[dict[str, Any]] = []
    if is_decimated(res):
        key = curve_key(block)
        lo, hi = merged_envelope(res.low[key], res.high[key], starts)
        data += envelope_traces(
            t, lo / dim, hi / dim, method.upper(), method_color(method), res.bin_s, method
        )
    data.append(
        {
            "type": "scatter",
            "x": t,
            "y": curve,
            "name": method.upper(),
            "mode": "lines",
            "line": {"color": method_color(method), "width": 2},
            "connectgaps": True,  # a replay's NEES is known at its reference's epochs only (tauvcore.eval.judging)
            "legendgroup": method,
        }
    )
    if smoothed:
        data += smoothed_traces(
            method, res, (curve_key(block), None), max_points, 1.0 / dim, lambda sm: nees_curve(sm, block)
        )
    return data, t, res.vel_err_mps.shape[1]


def band_trace(
    t_s: tuple[float, float],
    band: tuple[float, float],
    name: str,
    fillcolor: str,
    line: dict[str, Any],
    **extra: Any,
) -> dict[str, Any]:
    """A consistency band: the rectangle from ``band`` (low, high) over the times ``t_s`` (first,
    last) [s], filled with ``fillcolor`` and outlined with ``line``, named ``name``, no hover;
    ``extra`` (axes, legend group) as given."""
    (t_first, t_last), (lo, hi) = t_s, band
    return {
        "type": "scatter",
        "x": [t_first, t_last, t_last, t_first],
        "y": [lo, lo, hi, hi],
        "name": name,
        "mode": "lines",
        "fill": "toself",
        "fillcolor": fillcolor,
        "line": line,
        "hoverinfo": "skip",
        **extra,
    }


def _nees_references(dims: list[int], runs: int, t_first: float, t_last: float) -> list[dict[str, Any]]:
    """The reference traces of :func:`nees_figure` from ``t_first`` to ``t_last`` [s]: the 99 %
    band of the mean NEES/dim of ``runs`` runs for each block dimension of ``dims`` (the first
    dashed, the others dotted), and the line "1 = consistent"."""
    band_name = f"{CONFIDENCE:.0%} band".replace("%", " %")
    reference = []
    for k, dim in enumerate(dims):
        lo, hi = nees_band(dim, runs)
        name = band_name if len(dims) == 1 else f"{band_name} (dim {dim})"
        line = {"color": "rgba(120,120,120,0.6)", "width": 1, "dash": "dash" if k == 0 else "dot"}
        reference.append(band_trace((t_first, t_last), (lo, hi), name, BAND_COLOR, line))
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
    return reference


def _nees_title(block: str, by_dim: dict[int, list[str]], without: list[str], runs: int, note: str) -> str:
    """The title of :func:`nees_figure`: the block, its dimension per method (``by_dim``), the
    methods ``without`` it, the runs averaged and the ``note`` on the bins of runs in bins."""
    groups = list(by_dim.items()) or ([(BLOCK_DIMS[block], [])] if block in BLOCK_DIMS else [])
    dims_text = "; ".join(
        f"dim {dim}" if k == 0 else f"{', '.join(names)} dim {dim}" for k, (dim, names) in enumerate(groups)
    )
    runs_text = f", mean of {runs} runs" if runs > 1 else ", 1 run"
    name = NEES_BLOCK_NAMES.get(block, block)
    missing = f"; no {block}: {', '.join(without)}" if without else ""
    if groups:
        return f"NEES/dim, {name} ({dims_text}{missing}){runs_text}{note}"
    # a run without such states (one of the kept runs overlaid, say)
    return f"NEES/dim, {name}: no method of this run has it" + (f" ({', '.join(without)})" if without else "")


def elc_choice_figure(result: MethodResult, height_px: int = 220, validate: bool = False) -> go.Figure:
    """Which construction the ELC selector took for each body axis at every DVL epoch (run 0);
    ``height_px`` without the legend, whose rows are added below (app.figures.shared.legend_bottom)."""
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
        "margin": {"l": 60, "r": 10, "t": TITLE_PX},
        "xaxis": TIME_AXIS,
        "template": "plotly_white",
        "yaxis": {"categoryorder": "array", "categoryarray": ["heave", "sway", "surge"]},
    }
    layout = legend_bottom(layout, data, max(height_px - TITLE_PX - TICK_LABELS_PX, 1))
    return make_figure(data, layout, validate)


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


def components_figure(
    results: Mapping[str, MethodResult],
    components: Mapping[str, Mapping[str, np.ndarray]],
    quantity: str = "vel",
    height_px: int = 360,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """Signed error components of ``quantity`` ("pos", "vel", "att": COMPONENTS) against time,
    one panel per axis (north/east/down, surge/sway/heave, roll/pitch/heading), one trace per
    method and panel named by the method (in the legend once, its panels grouped with it).

    ``components``: method -> :func:`error_components` of it (a method absent, or without
    ``quantity``, is not drawn). With several Monte Carlo runs the curves are the RMS over runs
    (unsigned). At most about ``max_points`` points per trace (:func:`app.figures.shared.decimate`).
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
    layout = stacked_layout(label, [f"{a} [{unit}]" for a in axes], height_px, data)
    return make_figure(data, layout, validate)


RUN_DASHES = ("solid", "dash", "dot", "dashdot", "longdash")
"""Line style of each overlaid run (:func:`compare_figure`), the method colours kept."""


def compare_figure(
    runs: Sequence[tuple[str, Mapping[str, MethodResult]]],
    quantity: str = "vel",
    log_y: bool | str = False,
    height_px: int | None = None,
    max_points: int | None = 600,
    validate: bool = False,
) -> go.Figure:
    """:func:`error_figure` of several runs overlaid: ``runs`` is (label, results) per run, each
    run's curves in its method's colour and the run's line style (RUN_DASHES, in order: the first
    solid), each trace named "<METHOD> (<label>)"."""
    _check_quantity(quantity, log_y)
    err_field, _, title, unit = QUANTITIES[quantity]
    data: list[dict[str, Any]] = []
    drawn: list[np.ndarray] = []
    for n, (label, results) in enumerate(runs):
        for method, res in results.items():
            if len(res.t_s) == 0:
                continue
            keep, starts = _points(res, max_points)
            line = {"color": method_color(method), "width": 2, "dash": RUN_DASHES[n % len(RUN_DASHES)]}
            name, group = f"{method.upper()} ({label})", f"{label}/{method}"
            traces, values = _error_curve(res, err_field, keep, starts, name, group, line)
            data += traces
            drawn += values
    log = log_axis(drawn, log_y)
    if log:
        data = drop_for_log(data, drawn)
    labels = ", ".join(f"{label} {RUN_DASHES[n % len(RUN_DASHES)]}" for n, (label, _) in enumerate(runs))
    note = _envelope_note({str(n): r for n, (_, rs) in enumerate(runs) for r in rs.values()})
    layout = _error_layout(f"{title} [{unit}]: {labels}{note}", height_px, error_axis(log), data)
    return make_figure(data, layout, validate)


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
                copy: Any = type(trace)(trace)  # a trace copies from its own kind
                copy.update(name=f"{name} ({label})", legendgroup=f"{label}/{name}", line={"dash": dash})
                out.add_trace(copy)
            elif n == 0:
                out.add_trace(trace)
    styles = ", ".join(f"{label} {RUN_DASHES[n % len(RUN_DASHES)]}" for n, (label, _) in enumerate(runs))
    first = runs[0][1].to_dict()["layout"]
    margin = first.get("margin", {})
    plot_px = int(first.get("height") or PLOT_PX + TITLE_PX) - margin.get("t", TITLE_PX) - margin.get("b", 0)
    layout = legend_bottom(first, out.to_dict()["data"], max(plot_px, 1))
    out.update_layout(
        title_text=f"{first.get('title', {}).get('text', '')}: {styles}",
        height=layout["height"],
        margin=layout["margin"],
        legend=layout["legend"],
    )
    return out
