"""The Series tab's two figures of any recorded series (app.figures.series_catalog): a time plot,
one panel per unit on the shared time axis, and an XY plot of one series against another.

Each series is drawn with at most :data:`MAX_POINTS` points (every k-th, the last kept: the view
of a plot, not its data). In the XY plot each Y series is read at the X series' epochs (linear
interpolation within the epochs both cover, none outside), so series of different rates pair up;
when both axes are lengths (metres), one metre is as long on both.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import plotly.graph_objects as go

from app.figures.series_catalog import Series
from app.figures.shared import LEGEND_BELOW, decimate, make_figure, panel_domains, placeholder_figure

MAX_POINTS = 2000
"""Points drawn of each series (the screen has fewer columns)."""
PANEL_HEIGHT_PX = 190  # each unit's panel of the time plot
PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
    "#17becf",
)  # fmt: skip
"""The picked series' colours, in the order they were picked."""
TIME_HINT = "Pick a series above and press **Add to time plot**"
XY_HINT = "Pick a series and press **X axis**, then another and **Add to Y**"


def _units(series: Sequence[Series]) -> list[str]:
    """The units of ``series``, each once, in the order they first appear."""
    return list(dict.fromkeys(s.unit for s in series))


def _unit_label(unit: str) -> str:
    return "" if unit == "-" else f" [{unit}]"


def series_time_figure(series: Sequence[Series], title: str = "Series against time") -> go.Figure:
    """The picked ``series`` against time: one panel per unit (top to bottom in the order the
    units were first picked), sharing the time axis.

    Parameters
    ----------
    series : Sequence[Series]
        The picked series (app.figures.series_catalog.Catalog.series).
    title : str
        The figure's title.

    Returns
    -------
    go.Figure
        The figure, its height growing with the panels; a placeholder when nothing is picked.
    """
    if not series:
        return placeholder_figure(title, TIME_HINT.replace("**", ""))
    units = _units(series)
    n = len(units)
    data: list[dict[str, Any]] = []
    for k, s in enumerate(series):
        panel = units.index(s.unit)
        keep = decimate(len(s.t_s), MAX_POINTS)
        suffix = "" if panel == 0 else str(panel + 1)
        data.append(
            {
                "type": "scattergl" if len(s.t_s[keep]) > MAX_POINTS // 2 else "scatter",
                "x": s.t_s[keep],
                "y": s.value[keep],
                "name": s.name,
                "mode": "lines+markers" if len(s.t_s) < 60 else "lines",
                "line": {"color": PALETTE[k % len(PALETTE)], "width": 1.5},
                "xaxis": f"x{suffix}",
                "yaxis": f"y{suffix}",
                "hovertemplate": f"%{{y:.4g}}{_unit_label(s.unit)}",
            }
        )
    layout: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 13}},
        "height": PANEL_HEIGHT_PX * n + 60 + 18 * len(series),
        "margin": {"l": 60, "r": 10, "t": 35, "b": 35},
        "legend": LEGEND_BELOW,
        "template": "plotly_white",
    }
    for k, ((lo, hi), unit) in enumerate(zip(panel_domains(n), units)):
        suffix = "" if k == 0 else str(k + 1)
        layout[f"xaxis{suffix}"] = {"anchor": f"y{suffix}", "ticksuffix": " s", "showticklabels": k == n - 1}
        if k > 0:
            layout[f"xaxis{suffix}"]["matches"] = "x"
        layout[f"yaxis{suffix}"] = {"domain": [lo, hi], "title": {"text": unit if unit != "-" else ""}}
    return make_figure(data, layout)


def paired(x: Series, y: Series) -> tuple[np.ndarray, np.ndarray]:
    """``y`` read at ``x``'s epochs: the two value arrays of the XY plot, over the epochs of ``x``
    within ``y``'s first and last (linear interpolation; ``y``'s NaN stay NaN near them).

    Parameters
    ----------
    x, y : Series
        The X and one Y series.

    Returns
    -------
    tuple[numpy.ndarray, numpy.ndarray]
        X's values and Y's at the same epochs, shape (E',) each.
    """
    if x.t_s.shape == y.t_s.shape and np.array_equal(x.t_s, y.t_s):
        return x.value, y.value
    inside = (x.t_s >= y.t_s[0]) & (x.t_s <= y.t_s[-1]) if len(y.t_s) else np.zeros(len(x.t_s), bool)
    order = np.argsort(y.t_s, kind="stable")
    return x.value[inside], np.interp(x.t_s[inside], y.t_s[order], y.value[order])


def series_xy_figure(
    x: Series | None, ys: Sequence[Series], title: str = "Series against series"
) -> go.Figure:
    """Each of ``ys`` against ``x`` (see :func:`paired`), with equal scales when both are lengths.

    Parameters
    ----------
    x : Series or None
        The X series (None: not picked yet).
    ys : Sequence[Series]
        The Y series.
    title : str
        The figure's title.

    Returns
    -------
    go.Figure
        The figure; a placeholder until X and one Y are picked.
    """
    if x is None or not ys:
        return placeholder_figure(title, XY_HINT.replace("**", ""))
    data = []
    for k, y in enumerate(ys):
        xv, yv = paired(x, y)
        keep = decimate(len(xv), MAX_POINTS)
        data.append(
            {
                "type": "scatter",
                "x": xv[keep],
                "y": yv[keep],
                "name": y.name,
                "mode": "lines",
                "line": {"color": PALETTE[k % len(PALETTE)], "width": 1.5},
                "hovertemplate": f"x %{{x:.4g}}{_unit_label(x.unit)}<br>y %{{y:.4g}}{_unit_label(y.unit)}",
            }
        )
    y_units = _units(ys)
    yaxis: dict[str, Any] = {"title": {"text": ", ".join(u for u in y_units if u != "-")}}
    if x.unit == "m" and y_units == ["m"]:
        yaxis.update(scaleanchor="x", scaleratio=1)
    layout = {
        "title": {"text": title, "font": {"size": 13}},
        "height": 420 + 18 * len(ys),
        "margin": {"l": 60, "r": 10, "t": 35, "b": 45},
        "legend": LEGEND_BELOW,
        "hovermode": "closest",
        "xaxis": {"title": {"text": f"{x.name}{_unit_label(x.unit)}"}},
        "yaxis": yaxis,
        "template": "plotly_white",
    }
    return make_figure(data, layout)
