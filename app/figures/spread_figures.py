"""Plotly figures of a Monte Carlo's spread over its R runs: pure functions, results in,
``go.Figure`` out.

The error and consistency figures (app.figures.error_figures) draw one curve per method, the RMS
of the errors and the mean NEES over the runs; these show how the runs spread around it:

- :func:`runs_figure`: one method's velocity and position error norms of each run against time
  (at most :data:`MAX_RUNS_DRAWN` runs drawn, :func:`runs_drawn`), their median over the runs and
  the band from the 5th to the 95th percentile over the runs at each epoch (:func:`percentiles`,
  over every run, not only those drawn);
- :func:`final_errors_figure`: histograms of each method's velocity and position error at the
  last epoch, one value per run (:func:`histogram_edges`, :func:`histogram_counts`);
- :func:`nees_blocks_figure`: each NEES block's mean over the runs divided by the block's
  dimension against time, for every method, against the two-sided 95 % and 99 % bands of the
  mean of R chi-square variables of the block's dimension (:func:`mean_nees_band`).

A long run reduced to time bins (tauvcore.eval.envelope) keeps each run's value at every bin's
last epoch: the percentiles and the runs drawn are those values. The time figures are laid out by
app.figures.shared's time layouts and tagged time plots (the page's cursor and zoom apply); the
histograms are not.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.error_figures import NEES_BLOCK_NAMES, band_trace, block_dims, nees_blocks
from app.figures.log_axes import LOG_SPAN
from app.figures.shared import (
    LEGEND_BELOW,
    TIME_AXIS,
    TRUTH_COLOR,
    decimate,
    hex_to_rgba,
    make_figure,
    method_color,
    stacked_layout,
)
from tauvcore.engine.results import MethodResult
from tauvcore.eval.envelope import nees_curve
from tauvcore.eval.metrics import average_nees_bounds

MAX_RUNS_DRAWN = 20
"""At most this many runs are drawn one by one: more lines only fill the band in."""
PERCENTILES = (5.0, 50.0, 95.0)
"""The band's lower edge, the median and the band's upper edge [%] over the runs at each epoch."""
BAND_CONFIDENCES = (0.95, 0.99)
"""The two-sided confidences of the NEES bands, the narrower first."""
SPREAD_QUANTITIES = {
    "vel": ("vel_err_mps", "Velocity error", "m/s"),
    "pos": ("pos_err_m", "Position error", "m"),
}
"""The error norms whose spread is drawn: MethodResult field, name, unit."""
RUN_ALPHA = 0.35  # a run's line: the method's colour, pale, so the median and band read through it
BAND_ALPHA = 0.2  # the 5-95 % band
NEES_BAND_COLORS = {0.95: "rgba(120,120,120,0.28)", 0.99: "rgba(120,120,120,0.12)"}
PANEL_PX = 150  # each stacked panel's height
MARGIN_PX = 110  # title, the time axis' ticks and one row of legend
TICKS_PX = 30  # from the lowest plot area's bottom edge to the legend: the time axis' tick labels
BAND_NAME = "5–95 %"
MEDIAN_NAME = "median"
RUNS_NAME = "one line per run"


def runs_drawn(num_runs: int, limit: int = MAX_RUNS_DRAWN) -> np.ndarray:
    """The runs drawn one by one out of ``num_runs``: all of them up to ``limit``, else ``limit``
    evenly spaced run indices, the first and the last included (the same runs every time).

    Parameters
    ----------
    num_runs : int
        Runs R of the Monte Carlo.
    limit : int
        The most runs drawn (at least 1).

    Returns
    -------
    numpy.ndarray
        Increasing run indices (0-based), at most ``limit`` of them, int.
    """
    if limit < 1:
        raise ValueError(f"limit must be >= 1, got {limit}")
    if num_runs <= limit:
        return np.arange(max(int(num_runs), 0))
    return np.unique(np.round(np.linspace(0, num_runs - 1, limit)).astype(int))


def percentiles(series: np.ndarray, q: tuple[float, ...] = PERCENTILES) -> np.ndarray:
    """The percentiles ``q`` over the runs at each epoch of a (T, R) series, by linear
    interpolation between the sorted runs (as ``numpy.nanpercentile``: a run's NaN, a diverged
    filter's, is left out; an epoch with no value is NaN).

    Parameters
    ----------
    series : numpy.ndarray
        Values over T epochs and R runs, shape (T, R), in any unit.
    q : tuple of float
        Percentiles [%] in [0, 100].

    Returns
    -------
    numpy.ndarray
        Shape (len(q), T), in the series' unit.
    """
    series = np.asarray(series, dtype=float)
    if series.ndim != 2:
        raise ValueError(f"series must be (T, R), got shape {series.shape}")
    # numpy.nanpercentile's method, vectorised over the epochs (it loops over them in Python): the
    # sorted finite runs (NaN sorts last), the virtual index (n - 1) q / 100 between two of them
    ordered = np.sort(series, axis=1)
    n = np.sum(~np.isnan(ordered), axis=1)  # (T,)
    index = np.maximum(n - 1, 0)[None, :] * (np.asarray(q, dtype=float)[:, None] / 100.0)  # (Q, T)
    below = np.floor(index).astype(int)
    above = np.minimum(below + 1, np.maximum(n - 1, 0)[None, :])
    low = np.take_along_axis(ordered, below.T, axis=1).T
    high = np.take_along_axis(ordered, above.T, axis=1).T
    fraction = index - below
    with np.errstate(invalid="ignore"):
        values = np.where(fraction > 0.0, low + fraction * (high - low), low)
    values[:, n == 0] = np.nan
    return values


def mean_nees_band(dim: int, num_runs: int, confidence: float) -> tuple[float, float]:
    """Two-sided band of the mean NEES over ``num_runs`` runs of a consistent filter's
    ``dim``-dimensional block, divided by ``dim``: ``R * mean(NEES)`` is chi-square with ``R dim``
    degrees of freedom (tauvcore.eval.metrics.average_nees_bounds), so the band is its
    ``(1 - confidence) / 2`` and ``(1 + confidence) / 2`` quantiles over ``R dim``.

    Parameters
    ----------
    dim : int
        The block's dimension (its degrees of freedom).
    num_runs : int
        Runs R averaged over.
    confidence : float
        Probability inside the band, in (0, 1).

    Returns
    -------
    tuple[float, float]
        Lower and upper edge of the mean NEES / dim, dimensionless.
    """
    lo, hi = average_nees_bounds(int(dim), max(int(num_runs), 1), confidence)
    return lo / dim, hi / dim


def histogram_edges(values: np.ndarray, bins: int) -> tuple[np.ndarray, bool]:
    """``bins + 1`` bin edges spanning the finite ``values``: evenly spaced in the logarithm when
    the values are all positive and span more than LOG_SPAN (app.figures.log_axes: INS's final
    position error against an aided method's), else evenly spaced; a single value gets a bin of
    its own around it.

    Parameters
    ----------
    values : numpy.ndarray
        The values to bin, any shape, in any unit (NaN left out).
    bins : int
        Bins (at least 1).

    Returns
    -------
    tuple of (numpy.ndarray, bool)
        The edges, increasing, in the values' unit; and whether they are logarithmic.
    """
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins}")
    finite = np.asarray(values, dtype=float).ravel()
    finite = finite[np.isfinite(finite)]
    if finite.size == 0:
        return np.linspace(0.0, 1.0, bins + 1), False
    low, high = float(finite.min()), float(finite.max())
    if low > 0.0 and high > LOG_SPAN * low:
        return np.geomspace(low, high, bins + 1), True
    if high == low:
        half = 0.5 * abs(low) if low != 0.0 else 0.5
        low, high = low - half, high + half
    return np.linspace(low, high, bins + 1), False


def histogram_counts(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """How many of the finite ``values`` fall in each bin of ``edges`` (``numpy.histogram``: each
    bin holds its left edge, the last also its right edge; values a rounding outside the outer
    edges counted in the outer bins).

    Parameters
    ----------
    values : numpy.ndarray
        The values, any shape (NaN not counted).
    edges : numpy.ndarray
        Bin edges, increasing, shape (B + 1,).

    Returns
    -------
    numpy.ndarray
        Counts per bin, shape (B,), int.
    """
    finite = np.asarray(values, dtype=float).ravel()
    finite = np.clip(finite[np.isfinite(finite)], edges[0], edges[-1])
    return np.histogram(finite, bins=edges)[0]


def histogram_bins(num_runs: int) -> int:
    """Bins of a histogram of ``num_runs`` values: Rice's rule ``2 R^(1/3)``, 5 to 30 (10 runs:
    5 bins; 100 runs: 10)."""
    return int(np.clip(np.ceil(2.0 * np.cbrt(max(num_runs, 1))), 5, 30))


def _stacked_time_layout(title: str, names: list[str], height_px: int) -> dict[str, Any]:
    """app.figures.shared.stacked_layout with its legend below the time axis' tick labels, outside
    the panels, and the time axis' unit on its ticks (no axis title for the legend to land on)."""
    layout = stacked_layout(title, names, height_px)
    last = f"xaxis{len(names) if len(names) > 1 else ''}"
    layout[last] = {**{k: v for k, v in layout[last].items() if k != "title"}, **TIME_AXIS}
    layout["margin"] = {**layout["margin"], "b": MARGIN_PX - layout["margin"]["t"]}
    plot_px = height_px - layout["margin"]["t"] - layout["margin"]["b"]
    layout["legend"] = {**LEGEND_BELOW, "y": -TICKS_PX / max(plot_px, 1)}
    return layout


def _panel_axes(k: int) -> dict[str, str]:
    """The axes of the ``k``-th stacked panel (0: the top one)."""
    suffix = "" if k == 0 else str(k + 1)
    return {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}


def _spread_traces(
    t: np.ndarray, series: np.ndarray, runs: np.ndarray, color: str, first: bool, axes: dict[str, str]
) -> list[dict[str, Any]]:
    """One panel of :func:`runs_figure`: the 5-95 % band over every run of ``series`` (T, R), the
    runs ``runs`` one by one and the median, on the panel's ``axes``; in the legend once
    (``first``)."""
    low, median, high = percentiles(series)
    common = {"type": "scatter", "x": t, "mode": "lines", **axes}
    data: list[dict[str, Any]] = [
        {
            **common,
            "y": low,
            "name": f"{BAND_NAME} low",
            "legendgroup": "band",
            "showlegend": False,
            "line": {"width": 0, "color": color},
            "hoverinfo": "skip",
        },
        {
            **common,
            "y": high,
            "name": BAND_NAME,
            "legendgroup": "band",
            "showlegend": first,
            "line": {"width": 0, "color": color},
            "fill": "tonexty",
            "fillcolor": hex_to_rgba(color, BAND_ALPHA),
        },
    ]
    run_line = {"width": 1, "color": hex_to_rgba(color, RUN_ALPHA)}
    if first:  # the runs' one legend entry, a line of no point (each run's own is named on hover)
        data.append(
            {**common, "x": [None], "y": [None], "name": RUNS_NAME, "legendgroup": "runs", "line": run_line}
        )
    for r in runs:
        data.append(
            {
                **common,
                "y": series[:, r],
                "name": f"run {r + 1}",
                "legendgroup": "runs",
                "showlegend": False,
                "line": run_line,
            }
        )
    data.append(
        {
            **common,
            "y": median,
            "name": MEDIAN_NAME,
            "legendgroup": "median",
            "showlegend": first,
            "line": {"width": 2.5, "color": TRUTH_COLOR},
        }
    )
    return data


def runs_figure(
    method: str,
    result: MethodResult,
    max_points: int | None = 600,
    max_runs: int = MAX_RUNS_DRAWN,
    validate: bool = False,
) -> go.Figure:
    """How ``method``'s runs spread: its velocity and position error norms (two stacked panels on
    one time axis) of at most ``max_runs`` runs (:func:`runs_drawn`; the legend's "run k" names the
    first, hover each), in its colour, pale, over the band from the 5th to the 95th percentile over
    all the runs at each epoch (``"5–95 %"``) and under their median (``"median"``, black). At
    most about ``max_points`` epochs per trace (app.figures.shared.decimate; the last included).

    Parameters
    ----------
    method : str
        The method's name.
    result : MethodResult
        Its results over T epochs and R runs.
    max_points : int or None
        At most about this many points per trace (None: every epoch).
    max_runs : int
        At most this many runs drawn one by one.
    validate : bool
        Build the figure with plotly's property checks.

    Returns
    -------
    go.Figure
        The figure; hovering a line names its run.
    """
    num_runs = result.vel_err_mps.shape[1]
    keep = decimate(len(result.t_s), max_points)
    t = result.t_s[keep]
    runs = runs_drawn(num_runs, max_runs)
    color = method_color(method)
    data: list[dict[str, Any]] = []
    names = []
    for k, (field, name, unit) in enumerate(SPREAD_QUANTITIES.values()):
        series = np.asarray(getattr(result, field), dtype=float)[keep]
        data += _spread_traces(t, series, runs, color, k == 0, _panel_axes(k))
        names.append(f"{name} [{unit}]")
    drawn = f"{len(runs)} of {num_runs} runs drawn" if len(runs) < num_runs else f"{num_runs} runs"
    title = f"{method.upper()}: spread of {drawn}, median and {BAND_NAME} over all"
    layout = _stacked_time_layout(title, names, PANEL_PX * len(names) + MARGIN_PX + 60)
    layout["hovermode"] = "closest"  # a run's line names its run; "x unified" would list them all
    return make_figure(data, layout, validate)


def final_values(result: MethodResult, field: str) -> np.ndarray:
    """Each run's value of ``field`` (a (T, R) series of MethodResult) at the last epoch, (R,)."""
    series = np.asarray(getattr(result, field), dtype=float)
    return series[-1] if len(series) else np.empty(0)


def _histogram_trace(
    method: str, counts: np.ndarray, edges: np.ndarray, axes: dict[str, str], first: bool
) -> dict[str, Any]:
    """One method's histogram as a stepped outline filled down to zero: ``x`` the edges (the first
    twice), ``y`` 0, the counts, 0, so that ``sum(y)`` is the number of runs counted."""
    color = method_color(method)
    return {
        "type": "scatter",
        "x": np.r_[edges[0], edges],
        "y": np.r_[0, counts, 0],
        "name": method.upper(),
        "mode": "lines",
        "line": {"shape": "hv", "color": color, "width": 1.5},
        "fill": "tozeroy",
        "fillcolor": hex_to_rgba(color, 0.2),
        "legendgroup": method,
        "showlegend": first,
        "hovertemplate": "%{y} runs<extra>" + method.upper() + "</extra>",
        **axes,
    }


def final_errors_figure(results: Mapping[str, MethodResult], validate: bool = False) -> go.Figure:
    """Histograms of the final errors: each method's velocity (top) and position (bottom) error
    norm at the last epoch, one value per run, counted in bins shared by the methods
    (:func:`histogram_edges` of every method's values, :func:`histogram_bins` of the runs; a
    logarithmic axis where the edges are), each method a stepped outline in its colour. The
    panels are on axes ``x``/``y`` and ``x2``/``y2``; no time axis, so no time cursor (the page
    draws it on time plots only: app.figures.shared.TIME_META) and a click names no time.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results over R runs.
    validate : bool
        Build the figure with plotly's property checks.

    Returns
    -------
    go.Figure
        The figure; trace k of a panel is the k-th method's, ``sum(y)`` its finite final values.
    """
    data: list[dict[str, Any]] = []
    num_runs = max((r.vel_err_mps.shape[1] for r in results.values()), default=1)
    t_end = max((float(r.t_s[-1]) for r in results.values() if len(r.t_s)), default=0.0)
    layout: dict[str, Any] = {
        "title": {"text": f"Final errors at {t_end:g} s, {num_runs} runs", "font": {"size": 13}},
        "height": 2 * PANEL_PX + 170,
        "margin": {"l": 50, "r": 10, "t": 35, "b": 40},
        "legend": {**LEGEND_BELOW, "y": -0.22},
        "hovermode": "closest",
        "template": "plotly_white",
    }
    for k, (field, name, unit) in enumerate(SPREAD_QUANTITIES.values()):
        finals = {m: final_values(r, field) for m, r in results.items()}
        edges, log = histogram_edges(
            np.concatenate([*finals.values(), np.empty(0)]), histogram_bins(num_runs)
        )
        suffix = "" if k == 0 else str(k + 1)
        axes = {"xaxis": f"x{suffix}", "yaxis": f"y{suffix}"}
        for m, values in finals.items():
            data.append(_histogram_trace(m, histogram_counts(values, edges), edges, axes, k == 0))
        top = 1.0 - k * 0.58
        layout[f"xaxis{suffix}"] = {
            "anchor": f"y{suffix}",
            "type": "log" if log else "linear",
            "exponentformat": "power",
            "title": {"text": f"final {name.lower()} [{unit}]", "font": {"size": 11}},
        }
        layout[f"yaxis{suffix}"] = {
            "anchor": f"x{suffix}",
            "domain": [round(top - 0.42, 6), top],
            "title": {"text": "runs", "font": {"size": 11}},
            "rangemode": "tozero",
        }
    return make_figure(data, layout, validate)


def _band_traces(
    dims: list[int], num_runs: int, t_first: float, t_last: float, first: bool, axes: dict[str, str]
) -> list[dict[str, Any]]:
    """The 99 % and 95 % bands (BAND_CONFIDENCES, the wider drawn first) of the mean NEES / dim of
    ``num_runs`` runs for each block dimension of ``dims``, from ``t_first`` to ``t_last`` [s], on
    ``axes``; in the legend once (``first``)."""
    data = []
    for confidence in sorted(BAND_CONFIDENCES, reverse=True):
        name = f"{confidence:.0%} band".replace("%", " %")
        for j, dim in enumerate(dims):
            lo, hi = mean_nees_band(dim, num_runs, confidence)
            line = {"width": 0.5, "color": "rgba(120,120,120,0.5)", "dash": "dash" if j == 0 else "dot"}
            label = name if len(dims) == 1 else f"{name} (dim {dim})"
            extra = {"legendgroup": f"band {confidence}", "showlegend": first, **axes}
            data.append(
                band_trace((t_first, t_last), (lo, hi), label, NEES_BAND_COLORS[confidence], line, **extra)
            )
    return data


def nees_blocks_figure(
    results: Mapping[str, MethodResult], max_points: int | None = 600, validate: bool = False
) -> go.Figure:
    """Does each method know its error, block by block? One panel per NEES block the results hold
    (app.figures.error_figures.nees_blocks: the whole state, position, velocity, tilt, heading, the
    sensor errors, the current...), each method's NEES of the block averaged over the R runs and
    divided by the block's dimension (:func:`tauvcore.eval.envelope.nees_curve`) against time, over
    the two-sided 95 % and 99 % bands of that mean for R runs (:func:`mean_nees_band`; one pair per
    dimension where methods differ in it); logarithmic y axes. A method without the block (Yoo
    2014's filter has no position state) has no curve in its panel.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results over R runs.
    max_points : int or None
        At most about this many points per trace.
    validate : bool
        Build the figure with plotly's property checks.

    Returns
    -------
    go.Figure
        The figure, a panel per block, the top one the whole state's.
    """
    blocks = nees_blocks(results)
    num_runs = max((r.vel_err_mps.shape[1] for r in results.values()), default=1)
    drawn = {m: r for m, r in results.items() if len(r.t_s)}
    t_first = min((float(r.t_s[0]) for r in drawn.values()), default=0.0)
    t_last = max((float(r.t_s[-1]) for r in drawn.values()), default=0.0)
    data: list[dict[str, Any]] = []
    names = []
    for k, block in enumerate(blocks):
        axes = _panel_axes(k)
        dims = list(dict.fromkeys(block_dims(r)[block] for r in drawn.values() if block in block_dims(r)))
        data += _band_traces(dims, num_runs, t_first, t_last, k == 0, axes)
        for m, r in drawn.items():
            if block not in block_dims(r):
                continue
            keep = decimate(len(r.t_s), max_points)
            data.append(
                {
                    "type": "scatter",
                    "x": r.t_s[keep],
                    "y": nees_curve(r, block)[keep] / block_dims(r)[block],
                    "name": m.upper(),
                    "mode": "lines",
                    "connectgaps": True,
                    "legendgroup": m,
                    "showlegend": k == 0,
                    "line": {"color": method_color(m), "width": 1.5},
                    **axes,
                }
            )
        names.append(NEES_BLOCK_NAMES.get(block, block))
    title = f"NEES/dim per block, mean of {num_runs} runs, against its 95 % and 99 % bands"
    layout = _stacked_time_layout(title, names, PANEL_PX * len(names) + MARGIN_PX)
    for k in range(len(names)):
        key = f"yaxis{'' if k == 0 else k + 1}"
        layout[key] = {**layout[key], "type": "log", "exponentformat": "power"}
    return make_figure(data, layout, validate)
