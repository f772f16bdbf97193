"""How the time plots keep their data (app/figures/shared.py's layout helpers, app/figures/error_figures.py,
app/figures/innovation_figures.py): the legend in a band of its own below the plot and the figure grown by its
rows, one translucent 1-sigma band per method, a linear axis for errors that start at zero and zeros left out
of a log axis (app/figures/log_axes.py), no minor labels on a log axis, and the reduced run's band named for what it is.

One seeded 20 s run of three methods; twelve methods are those three results under twelve names (the
layout depends on the names and the number of traces, not on the numbers).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from app.dashboard import page_scripts
from app.figures.error_figures import (
    PLOT_PX,
    compare_figure,
    components_figure,
    error_components,
    error_figure,
    nees_figure,
    overlay_figure,
)
from app.figures.innovation_figures import BAND_SUFFIX, innovation_figure
from app.figures.log_axes import ZERO_FRACTION, log_axis
from app.figures.shared import (
    BAND_STACK_ALPHA,
    CARD_WIDTH_PX,
    LEGEND_ROW_PX,
    TICK_LABELS_PX,
    band_alpha,
    bin_label,
    card_aspect,
    legend_bottom,
    legend_rows,
)
from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import simulate

TWELVE = ("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc", "iekf", "ins-dvl", "vkf", "ukf")


@pytest.fixture(scope="module")
def three() -> dict[str, MethodResult]:
    config = Config().replace("trajectory", duration_s=20.0).replace("run", methods=("ins", "lc", "tc"))
    return run(config, simulate(config, np.random.default_rng(3), 1), np.random.default_rng(4))


@pytest.fixture(scope="module")
def twelve(three) -> dict[str, MethodResult]:
    picks = list(three.values())
    return {m: picks[k % 3] for k, m in enumerate(TWELVE)}


def _plot_px(figure) -> float:
    layout = figure.layout
    return layout.height - layout.margin.t - layout.margin.b


def _alpha(fillcolor: str) -> float:
    match = re.fullmatch(r"rgba\((\d+),(\d+),(\d+),([0-9.]+)\)", fillcolor.replace(" ", ""))
    assert match is not None, fillcolor
    return float(match.group(4))


# ------------------------------------------------------------------------------------------ legend rows

def test_legend_rows_one_row_or_columns_as_wide_as_the_widest_name() -> None:
    assert legend_rows([], 300) == 0
    assert legend_rows(["LC"], 300) == 1
    one = legend_rows(["LC"], 10_000)
    assert one == 1 and legend_rows(["LC"] * 40, 10_000) == 1
    # 10 names of 3 characters (46 + 3 x 7 = 67 px each): all in one row from 670 px; else columns
    # 67 px wide, 5 per row in 335 px, 4 in 334 px
    assert legend_rows(["ABC"] * 10, 670) == 1 and legend_rows(["ABC"] * 10, 669) == 2
    assert legend_rows(["ABC"] * 10, 335) == 2 and legend_rows(["ABC"] * 10, 334) == 3
    # the columns are as wide as the widest name: one long name makes every column wide
    assert legend_rows(["ABC"] * 9 + ["ABCDEFGHIJ"], 335) == 5  # 116 px columns, 2 per row


def test_the_legend_has_a_band_of_its_own_and_the_plot_keeps_its_height() -> None:
    """Whatever the legend holds, the plot area keeps plot_px: the figure grows by one row's height
    per row, and the legend hangs from the figure's bottom edge, under the tick labels."""
    heights = []
    for n in (1, 6, 24):
        data = [{"type": "scatter", "name": f"M{k} smoothed"} for k in range(n)]
        layout = legend_bottom({"margin": {"l": 50, "r": 10, "t": 35}}, data, 160)
        rows = legend_rows([d["name"] for d in data], CARD_WIDTH_PX - 60)
        assert layout["height"] - layout["margin"]["t"] - layout["margin"]["b"] == 160
        assert layout["margin"]["b"] >= TICK_LABELS_PX + rows * LEGEND_ROW_PX
        assert layout["legend"]["yref"] == "container" and layout["legend"]["y"] == 0.0
        assert layout["legend"]["yanchor"] == "bottom" and layout["legend"]["orientation"] == "h"
        heights.append(layout["height"])
    assert heights[0] < heights[1] < heights[2]


@pytest.mark.parametrize("smoothed_or_sigma", [False, True])
def test_twelve_methods_keep_the_error_plot_s_height(three, twelve, smoothed_or_sigma) -> None:
    """The plot area is PLOT_PX with three methods and with twelve; the twelve's card is taller by
    their legend's extra rows, and its aspect (viser: height / width) follows the height."""
    small = error_figure(three, "vel", show_sigma=smoothed_or_sigma, log_y="auto")
    large = error_figure(twelve, "vel", show_sigma=smoothed_or_sigma, log_y="auto")
    assert _plot_px(small) == PLOT_PX and _plot_px(large) == PLOT_PX
    assert large.layout.height > small.layout.height
    assert large.layout.margin.b >= TICK_LABELS_PX + 2 * LEGEND_ROW_PX  # twelve names: two rows or more
    assert card_aspect(large) == round(large.layout.height / CARD_WIDTH_PX, 2)
    assert large.layout.xaxis.title.text is None  # no axis title for the legend to land on


def test_nees_compare_and_overlay_keep_their_plot_height(three, twelve) -> None:
    assert _plot_px(nees_figure(twelve, "full")) == PLOT_PX
    compare = compare_figure([("run 1", twelve), ("run 2", twelve)], "vel")
    assert _plot_px(compare) == PLOT_PX
    overlay = overlay_figure([("run 1", nees_figure(twelve)), ("run 2", nees_figure(twelve))])
    alone = nees_figure(twelve)
    assert _plot_px(overlay) == pytest.approx(_plot_px(alone))
    assert overlay.layout.height > alone.layout.height  # twice the names, more rows


def test_components_time_axis_has_no_title_on_the_legend(three, twelve) -> None:
    """The bottom panel's axis carries the unit on its ticks ("5 s") and no "time [s]" title where
    the legend's first row would sit; the panels keep their height with twelve methods."""
    truth_t = three["lc"].t_s
    result = three["lc"]
    pos = result.est_pos_n[:, 0, :]
    assert result.est_euler_rad is not None
    from tauvcore.geo.rotations import C_nb_from_euler

    components = {
        m: error_components(r, truth_t, pos, C_nb_from_euler(result.est_euler_rad[:, 0, :])) for m, r in twelve.items()
    }
    small = components_figure({"lc": result}, {"lc": components["lc"]}, "pos")
    large = components_figure(twelve, components, "pos")
    assert _plot_px(small) == pytest.approx(_plot_px(large))
    assert large.layout.height > small.layout.height
    bottom = large.layout.xaxis3
    assert bottom.title.text is None and bottom.ticksuffix == " s"
    assert large.layout.legend.yref == "container"


# ------------------------------------------------------------------------------------------ bands

def test_band_alpha_keeps_the_stack_translucent() -> None:
    for n in (1, 2, 5, 12, 30):
        a = band_alpha(n)
        assert 0.0 < a <= 0.15
        assert 1.0 - (1.0 - a) ** n <= BAND_STACK_ALPHA + 1e-3


def test_one_translucent_sigma_band_per_method(twelve) -> None:
    """Twelve methods: twelve 1-sigma traces, one per method, each a dotted line of its colour with
    a fill whose alpha keeps all twelve stacked at most BAND_STACK_ALPHA (the heading plot was solid)."""
    figure = error_figure(twelve, "heading", show_sigma=True)
    bands = [t for t in figure.data if t.name.endswith("1-sigma")]
    assert sorted(t.name for t in bands) == sorted(f"{m.upper()} 1-sigma" for m in TWELVE)
    for trace in bands:
        alpha = _alpha(trace.fillcolor)
        assert alpha == band_alpha(12)
        assert trace.line.dash == "dot" and trace.line.width == 1
    stacked = 1.0 - np.prod([1.0 - _alpha(t.fillcolor) for t in bands])
    assert stacked <= BAND_STACK_ALPHA + 1e-3


def test_innovation_bands_are_translucent_when_stacked(three) -> None:
    figure = innovation_figure(three, "dvl")
    bands = [t for t in figure.data if t.name.endswith(BAND_SUFFIX)]
    methods = {t.name for t in bands}
    assert methods == {"LC" + BAND_SUFFIX, "TC" + BAND_SUFFIX}
    assert all(_alpha(t.fillcolor) == band_alpha(2) for t in bands)
    assert _plot_px(figure) == pytest.approx(figure.layout.height - figure.layout.margin.t - figure.layout.margin.b)


# ------------------------------------------------------------------------------------------ log and linear

def _starting_at_zero(results: dict[str, MethodResult]) -> dict[str, MethodResult]:
    """``results`` with every error starting at an exact zero, as a replay's does on its reference,
    and the next epoch at the rounding of a zero (1e-16)."""
    out = {}
    for m, r in results.items():
        vel = r.vel_err_mps.copy()
        vel[0], vel[1] = 0.0, 1e-16
        out[m] = dataclasses.replace(r, vel_err_mps=vel)
    return out


def test_errors_that_start_at_zero_get_a_linear_axis(three) -> None:
    wide = error_figure(three, "vel", log_y="auto")
    assert wide.layout.yaxis.type == "log"  # the INS error spans decades: log where nothing starts at zero
    zero = _starting_at_zero(three)
    assert error_figure(zero, "vel", log_y="auto").layout.yaxis.type == "linear"
    assert not log_axis([np.array([0.0, 1e-3, 1.0])], "auto") and log_axis([np.array([1e-3, 1.0])], "auto")


def test_a_log_axis_leaves_the_zeros_out(three) -> None:
    """log_y True on errors that start at zero: the zero and its 1e-16 rounding are gaps, so the
    axis does not reach down to 1e-16; every value drawn is above ZERO_FRACTION of the largest."""
    figure = error_figure(_starting_at_zero(three), "vel", log_y=True, show_sigma=True)
    assert figure.layout.yaxis.type == "log"
    top = max(np.nanmax(np.asarray(t.y, dtype=float)) for t in figure.data)
    for trace in figure.data:
        y = np.asarray(trace.y, dtype=float)
        finite = y[np.isfinite(y)]
        assert finite.size and finite.min() > ZERO_FRACTION * top, trace.name
        if not trace.name.endswith("1-sigma"):
            assert np.isnan(y[0]) and np.isnan(y[1])


def test_log_axes_label_the_powers_of_ten_only(three) -> None:
    for figure in (error_figure(three, "vel", log_y=True), nees_figure(three)):
        axis = figure.layout.yaxis
        assert axis.type == "log" and axis.minorloglabels == "none" and axis.exponentformat == "power"


# ------------------------------------------------------------------------------------------ names

def test_the_reduced_run_s_band_is_named_for_what_it_is() -> None:
    assert bin_label(9.1) == "curve's min\u2013max within each 9.1 s bin"
    assert "spread" not in bin_label(0.2) and "per 0.2 s bin" not in bin_label(0.2)


def test_the_scroll_script_names_the_plot_and_waits_for_it() -> None:
    script = page_scripts.scroll_to_plot("Attitude error (norm) [deg]")
    assert '"Attitude error (norm) [deg]"' in script and "scrollIntoView" in script
    assert "__" not in script
