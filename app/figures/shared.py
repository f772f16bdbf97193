"""The figures' common ground: each method's colour, the plain-dict figure, the stride that keeps
a trace small, stacked panels on one time axis, and the shared time cursor.

Each method has one colour everywhere (plots, 3-D trajectories, legend). The figures are pure
functions, results in, ``go.Figure`` out, one module per kind: app.figures.error_figures (the errors, the
consistency figure, the ELC selector's choices, runs overlaid), app.figures.innovation_figures (each aiding
source's innovations) and app.figures.vehicle_figures (what the dynamic truth's vehicle did, its altitude,
what the velocity filter learned of the propeller); the Results tab's tables are
app.reports.markdown_tables. Every plot has the mission time in seconds on its x axis, so one cursor
(:func:`cursor_shape`) marks the same time on all of them.

Figures are plain dicts wrapped without plotly's per-property validation (:func:`make_figure`;
validating costs most of a redraw); the tests check that each validates and equals its validated
construction.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
import plotly.graph_objects as go
import plotly.io as pio

from tauvcore.config import ALL_METHODS, REGISTERED_METHODS

METHOD_COLORS = {
    "ins": "#7f7f7f",
    "lc": "#1f77b4",
    "tc": "#ff7f0e",
    "vb": "#2ca02c",
    "nsv": "#d62728",
    "plcf": "#9467bd",
    "vhv": "#8c564b",
    "elc": "#e377c2",
    "iekf": "#e7ba52",
    "ins-dvl": "#bcbd22",
    "vkf": "#17becf",  # Yoo 2014's 12-state filter (tauvcore.config.YOO_METHODS)
}
# Methods added as one file each (tauvcore.aiding.registry), then the methods of the filter families
# added in their own folders (tauvcore.filter.families), coloured in that order from tab20's paler and
# darker companions of the colours above; each keeps the beams' distance (app.figures.scene.BEAM_MIN_DELTA_E,
# tests/unit/app/figures/test_scene.py) like the papers' methods.
REGISTERED_COLORS = ("#637939", "#e7969c", "#ffbb78", "#aec7e8", "#c5b0d5", "#8c6d31")
METHOD_COLORS.update(
    {
        m: REGISTERED_COLORS[i % len(REGISTERED_COLORS)]
        for i, m in enumerate((*REGISTERED_METHODS, *(m for m in ALL_METHODS if m not in METHOD_COLORS)))
    }
)
TRUTH_COLOR = "#111111"


def method_color(method: str) -> str:
    return METHOD_COLORS.get(method, "#393b79")


def hex_to_rgba(color: str, alpha: float) -> str:
    r, g, b = (int(color[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def decimate(n: int, max_points: int | None) -> slice:
    """A stride that keeps at most about ``max_points`` of ``n`` samples, always the last one."""
    if max_points is None or n <= max_points:
        return slice(None)
    step = int(np.ceil(n / max_points))
    return slice((n - 1) % step, None, step)


def merge_bins(n: int, max_points: int | None) -> tuple[slice, np.ndarray | None]:
    """How a reduced run's ``n`` bins (tauvcore.eval.envelope) are drawn with at most about
    ``max_points`` points: the stride of :func:`decimate` picks each group's last bin (its
    representative and time), and the groups start at the returned indices (None: one bin per
    point) for ``np.fmin.reduceat`` / ``np.fmax.reduceat`` of the bins' minima and maxima."""
    keep = decimate(n, max_points)
    if keep == slice(None):
        return keep, None
    picked = np.arange(n)[keep]
    return keep, np.r_[0, picked[:-1] + 1]


def merged_envelope(
    low: np.ndarray, high: np.ndarray, starts: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The minima and maxima ``low``, ``high`` (bins first) of the groups of bins starting at
    ``starts`` (:func:`merge_bins`; None: as they are); NaN only where a group has no value."""
    low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
    if starts is None:
        return low, high
    return np.fmin.reduceat(low, starts, axis=0), np.fmax.reduceat(high, starts, axis=0)


ENVELOPE_ALPHA = 0.25
BAND_STACK_ALPHA = 0.3
"""The opacity where every method's band (1-sigma, 3-sigma) overlaps: each band's alpha is chosen
so that all of them stacked reach this (:func:`band_alpha`), and the plot behind stays readable."""
BAND_ALPHA_MAX = 0.15  # one band alone


def band_alpha(bands: int) -> float:
    """Each band's fill alpha when ``bands`` of them overlap: ``1 - (1 - a)^n = BAND_STACK_ALPHA``,
    at most BAND_ALPHA_MAX (one band alone).

    Parameters
    ----------
    bands : int
        How many bands are drawn on one panel (one per method).

    Returns
    -------
    float
        The alpha of each, to four decimals.
    """
    each = 1.0 - (1.0 - BAND_STACK_ALPHA) ** (1.0 / max(bands, 1))
    return round(min(BAND_ALPHA_MAX, each), 4)


def bin_label(bin_s: float) -> str:
    """How a plot names a reduced run's band: the curve's own range within each screen bin,
    "curve's min–max within each 9.1 s bin" (a decimation band: with several runs it is the range
    of the RMS over runs inside the bin, not the spread of the runs)."""
    return f"curve's min–max within each {bin_s:.3g} s bin"


def envelope_traces(
    t: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    name: str,
    color: str,
    bin_s: float,
    group: str,
    **axes: str,
) -> list[dict[str, Any]]:
    """A reduced run's envelope as a band: the minimum per bin (an invisible line) and the maximum
    filled down to it (``fill="tonexty"``), in ``color`` pale, grouped with the curve ``group``;
    hover reads "<name> curve min in 9.1 s bin" and "... max ...": the drawn curve's own extremes
    within each bin (a decimation band, not the runs' spread). Drawn before the representative
    line, so the line lies on top of its band."""
    label = f"{name} curve {{}} in {bin_s:.3g} s bin"
    common = {"type": "scatter", "x": t, "mode": "lines", "legendgroup": group, "showlegend": False, **axes}
    return [
        {**common, "y": low, "name": label.format("min"), "line": {"width": 0, "color": color}},
        {
            **common,
            "y": high,
            "name": label.format("max"),
            "line": {"width": 0, "color": color},
            "fill": "tonexty",
            "fillcolor": hex_to_rgba(color, ENVELOPE_ALPHA),
        },
    ]


@functools.cache
def _template(name: str) -> dict[str, Any]:
    """A named plotly template as the dict plotly.js reads (validation would resolve the name)."""
    return pio.templates[name].to_plotly_json()


def make_figure(data: list[dict[str, Any]], layout: dict[str, Any], validate: bool = False) -> go.Figure:
    """``go.Figure`` of plain trace and layout dicts; ``validate`` False skips plotly's property
    checks (the same figure, several times faster to build)."""
    # "x unified": hovering anywhere reads every curve at that time, and a click anywhere in a plot
    # names a time (app.dashboard.plot_click moves the playback there)
    layout = {
        "hovermode": "x unified",
        **layout,
        "template": _template(layout.get("template", "plotly_white")),
    }
    if validate:
        return go.Figure(data=data, layout=layout)
    return go.Figure(data=data, layout=layout, _validate=False)


def panel_domains(n: int, gap: float = 0.06) -> list[tuple[float, float]]:
    """y domains of ``n`` stacked panels, the first on top."""
    h = (1.0 - gap * (n - 1)) / n
    return [
        (max(0.0, round(1.0 - k * (h + gap) - h, 6)), min(1.0, round(1.0 - k * (h + gap), 6)))
        for k in range(n)
    ]


LEGEND_BELOW = {"orientation": "h", "yanchor": "top", "y": -0.15}
"""The legend under the time axis, hanging from its top so that more rows (runs overlaid, eight
methods) grow downward into the margin plotly makes for it (figures of fixed height; the
workbench's time plots reserve their legend's rows instead: :func:`legend_bottom`)."""
TIME_AXIS = {"ticksuffix": " s"}
"""The time axis of a plot with its legend below: the unit on the ticks ("5 s"), no axis title for
a second row of the legend to land on (a title sits where plotly's first legend row does)."""
CARD_WIDTH_PX = 480
"""The plot card's width the legend's rows are counted for [px]: the workbench's cards are 480 px
wide at 1280 x 800 and at 1600 x 1000. viser scales a card's height with its width, so a wider card
(the panel dragged wider) has fewer rows and more room; a narrower one keeps the same proportions."""
LEGEND_ROW_PX = 21  # one row of a horizontal legend at plotly's 12 px font
LEGEND_CHAR_PX = 7.0  # a legend name's character at 12 px (Open Sans, capitals and digits)
LEGEND_ITEM_PX = 46  # a legend item's symbol and gaps: plotly's itemwidth 30, 2 x 5 px gap and the next gap
TICK_LABELS_PX = 26  # the x tick labels and their gap under the plot
TITLE_PX = 35  # the title's band above the plot


def legend_names(data: list[dict[str, Any]]) -> list[str]:
    """The names a figure's legend lists: each trace's whose ``showlegend`` is not False.

    Parameters
    ----------
    data : list[dict[str, Any]]
        Plain trace dicts (:func:`make_figure`).

    Returns
    -------
    list[str]
        The legend's names, in the order plotly draws them (``traceorder="normal"``).
    """
    return [str(trace.get("name", "")) for trace in data if trace.get("showlegend", True) is not False]


def legend_rows(names: list[str], width_px: float) -> int:
    """How many rows a horizontal legend of ``names`` takes under a plot area ``width_px`` wide:
    plotly draws one row when every item fits at its own width, else columns as wide as the
    widest item, as many as fit in a row.

    Parameters
    ----------
    names : list[str]
        The legend's names (:func:`legend_names`).
    width_px : float
        The plot area's width [px].

    Returns
    -------
    int
        The number of rows (0 for no names).
    """
    if not names:
        return 0
    items_px = [LEGEND_ITEM_PX + LEGEND_CHAR_PX * len(name) for name in names]
    if sum(items_px) <= width_px:
        return 1
    per_row = max(1, int(width_px // max(items_px)))
    return -(-len(names) // per_row)


def legend_bottom(
    layout: dict[str, Any], data: list[dict[str, Any]], plot_px: int, card_px: int = CARD_WIDTH_PX
) -> dict[str, Any]:
    """``layout`` with its legend in a band of its own under the x tick labels, and its height
    grown by that band, so that the plot area keeps ``plot_px`` whatever the legend holds (twelve
    methods, their smoothed curves, kept runs overlaid): the legend's rows are counted at a card
    ``card_px`` wide (:func:`legend_rows`), and the legend hangs from the bottom of the figure
    (``yref="container"``), clear of the tick labels and of any axis title.

    Parameters
    ----------
    layout : dict[str, Any]
        A plain layout with ``margin`` (``l``, ``r``, ``t``) and no ``height`` needed.
    data : list[dict[str, Any]]
        The figure's traces (their legend names).
    plot_px : int
        The plot area's height [px] at a card ``card_px`` wide.
    card_px : int
        The card's width [px] the rows are counted for.

    Returns
    -------
    dict[str, Any]
        A new layout: ``height`` (the card's aspect is height / ``card_px``), ``margin.b``, ``legend``.
    """
    margin = {"l": 50, "r": 10, "t": TITLE_PX, **layout.get("margin", {})}
    rows = legend_rows(legend_names(data), card_px - margin["l"] - margin["r"])
    bottom_px = TICK_LABELS_PX + rows * LEGEND_ROW_PX + (6 if rows else 0)
    return {
        **layout,
        "height": int(margin["t"] + plot_px + bottom_px),
        "margin": {**margin, "b": bottom_px},
        "legend": {
            "orientation": "h",
            "traceorder": "normal",
            "x": 0.0,
            "xanchor": "left",
            "yref": "container",
            "y": 0.0,
            "yanchor": "bottom",
        },
    }


def card_aspect(figure: go.Figure, card_px: int = CARD_WIDTH_PX) -> float:
    """The aspect (height / width) a viser plot card needs for ``figure``, whose ``layout.height``
    was reckoned for a card ``card_px`` wide (:func:`legend_bottom`).

    Parameters
    ----------
    figure : go.Figure
        The figure; without a height, 400 px.
    card_px : int
        The card's width the height was reckoned for [px].

    Returns
    -------
    float
        Its aspect, to two decimals.
    """
    height_px: Any = figure.layout["height"]  # plotly's stubs type an item as a figure
    return round(float(height_px or 400) / card_px, 2)


def time_layout(title: str, height_px: int, yaxis: dict[str, Any], left_px: int = 50) -> dict[str, Any]:
    """The layout of one plot against time with its legend below it (LEGEND_BELOW, TIME_AXIS).

    Parameters
    ----------
    title : str
        The plot's title.
    height_px : int
        Its height [px].
    yaxis : dict[str, Any]
        Its y-axis.
    left_px : int
        Its left margin [px], room for the y-axis' tick labels.

    Returns
    -------
    dict[str, Any]
        The plain layout dict (:func:`make_figure`).
    """
    return {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": left_px, "r": 10, "t": 35, "b": 35},
        "legend": LEGEND_BELOW,
        "xaxis": TIME_AXIS,
        "template": "plotly_white",
        "yaxis": yaxis,
    }


PLACEHOLDER_TEXT = "No run yet: press Run"


@functools.lru_cache(maxsize=128)
def placeholder_figure(title: str, text: str = PLACEHOLDER_TEXT) -> go.Figure:
    """What a plot shows before its first run: its title and one line of text, no empty axes.

    One figure per (title, text), shared by every tab that shows it: read, never modified (a
    plotly figure costs 30 ms to build, and a new tab shows some 30 of them)."""
    return go.Figure(
        layout={
            "title": {"text": title, "font": {"size": 13}},
            "xaxis": {"visible": False},
            "yaxis": {"visible": False},
            "annotations": [
                {
                    "text": text,
                    "showarrow": False,
                    "xref": "paper",
                    "yref": "paper",
                    "x": 0.5,
                    "y": 0.5,
                    "font": {"size": 13, "color": "#888"},
                }
            ],
            "margin": {"l": 20, "r": 20, "t": 40, "b": 20},
            "template": "plotly_white",
        }
    )


def stacked_layout(
    title: str, names: list[str], height_px: int, data: list[dict[str, Any]] | None = None
) -> dict[str, Any]:
    """Layout of len(``names``) panels sharing the time axis, each y-axis titled by its name; the
    bottom axis carries the unit on its ticks ("5 s", TIME_AXIS), no title for the legend to land
    on. With ``data`` (the figure's traces) the legend has a band of its own below the panels and
    the figure grows by it (:func:`legend_bottom`): the panels keep ``height_px`` less the title
    and the tick labels whatever the legend holds."""
    layout: dict[str, Any] = {
        "title": {"text": title, "font": {"size": 13}},
        "height": height_px,
        "margin": {"l": 60, "r": 10, "t": TITLE_PX, "b": 35},
        "legend": {"orientation": "h", "y": -0.12},
        "template": "plotly_white",
    }
    n = len(names)
    for k, ((lo, hi), name) in enumerate(zip(panel_domains(n), names)):
        suffix = "" if k == 0 else str(k + 1)
        layout[f"xaxis{suffix}"] = (
            {"anchor": f"y{suffix}", **TIME_AXIS}
            if k == n - 1
            else {"anchor": f"y{suffix}", "matches": f"x{n if n > 1 else ''}", "showticklabels": False}
        )
        layout[f"yaxis{suffix}"] = {
            "domain": [lo, hi],
            "title": {"text": name, "font": {"size": 11}},
            "zeroline": True,
        }
    if data is None:
        return layout
    return legend_bottom(layout, data, max(height_px - TITLE_PX - TICK_LABELS_PX, 1))


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


SENT_CURSOR_S = 0.0
"""Where a figure's time cursor is when sent: the page draws it at the slider's time
(app/assets/view_sync.js, TIME_META), so the figure's JSON does not depend on the time and viser sends a figure
again only when its data change (it skips a JSON equal to the one the page has)."""

TIME_META = {"tauv_time_axis": True}
"""``layout.meta`` of a plot against the mission time: the page's one time axis (the cursor and the
zoomed range, app/assets/view_sync.js) applies to every plot carrying it, and to no other."""


def with_cursor(figure: go.Figure, t_s: float | None) -> go.Figure:
    """``figure`` tagged a time plot (TIME_META) with the time cursor at ``t_s`` (None: none), in
    place; returned for chaining. The page moves the cursor to the slider's time whenever the plot
    is drawn (app/assets/view_sync.js, app.dashboard.page_scripts.view_sync), so a figure is sent with it anywhere."""
    figure.layout.meta = TIME_META
    figure.layout.shapes = [] if t_s is None else [cursor_shape(t_s)]
    return figure
