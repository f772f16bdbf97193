"""The plots keep their data, in a real browser at 1600 x 1000 and 1280 x 800: with twelve methods and
their 1-sigma bands every plot card keeps a plot area of at least PLOT_MIN_PX and shows its time axis's
tick labels above its legend (Plots and Components tabs), the 1-sigma bands stay translucent where all
twelve overlap, "Attitude norm" scrolls its new plot into view, and a replayed log, whose errors start at
exactly zero on its reference, gets linear error axes.

Each plot is read from plotly's own state in the page (``_fullLayout._size``: the plot area) and the DOM
(bounding boxes of the tick labels, the legend, the axis titles; the computed fill of each band).
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator

import pytest

from tests.browser.conftest import ARTIFACTS, THROTTLE_FRAMES, Tab, dashboard_server

pytestmark = pytest.mark.browser

TWELVE = "ins,lc,tc,vb,nsv,plcf,vhv,elc,iekf,ins-dvl,vkf,cv"
PLOT_MIN_PX = 150  # the plot area every card keeps, whatever its legend holds
STACK_MAX_ALPHA = 0.5  # the opacity where every 1-sigma band overlaps: translucent, not a solid colour
SIZES = [(1600, 1000), (1280, 800)]

# every plot drawn in the shown tab: its title, plot area, and whether its x tick labels and axis titles
# lie inside the card and above the legend
LAYOUT_JS = """() => Array.from(document.querySelectorAll('.js-plotly-plot'))
  .filter(p => p._fullLayout && p.offsetParent !== null && (p._fullData || []).length)
  .map(p => {
    const card = p.getBoundingClientRect();
    const legend = p.querySelector('.legend');
    const legendTop = legend ? legend.getBoundingClientRect().top : Infinity;
    const boxes = sel => Array.from(p.querySelectorAll(sel)).map(e => e.getBoundingClientRect())
      .filter(b => b.width > 0);
    const ticks = Array.from(p.querySelectorAll('g[class] > text'))  // every x axis's: xtick, x2tick, x3tick
      .filter(e => /^x[0-9]*tick$/.test(e.parentElement.getAttribute('class')))
      .map(e => e.getBoundingClientRect()).filter(b => b.width > 0);
    const titles = boxes('.g-xtitle text, .g-x2title text, .g-x3title text');
    return {
      title: (p._fullLayout.title || {}).text || '',
      plot_px: p._fullLayout._size.h,
      ticks: ticks.length,
      ticks_inside: ticks.every(b => b.bottom <= card.bottom + 0.5 && b.bottom <= legendTop + 0.5),
      titles_clear: titles.every(b => b.bottom <= legendTop + 0.5),
    };
  })"""
# the alpha of every filled 1-sigma band of the plot titled like __TITLE__, as the page paints it
FILLS_JS = """title => {
  const p = Array.from(document.querySelectorAll('.js-plotly-plot'))
    .find(q => q._fullLayout && ((q._fullLayout.title || {}).text || '').startsWith(title));
  if (!p) return null;
  return Array.from(p.querySelectorAll('.scatterlayer .trace'))
    .filter((g, k) => (p._fullData[k] || {}).name && p._fullData[k].name.endsWith('1-sigma'))
    .map(g => { const f = g.querySelector('path.js-fill');
                return f ? [getComputedStyle(f).fill, getComputedStyle(f).fillOpacity] : null; })
    .filter(x => x);
}"""
IN_VIEW_JS = """title => {
  const p = Array.from(document.querySelectorAll('.js-plotly-plot'))
    .find(q => q._fullLayout && ((q._fullLayout.title || {}).text || '').startsWith(title) && q.offsetParent);
  if (!p) return null;
  const r = p.getBoundingClientRect();
  return {top: r.top, bottom: r.bottom, height: window.innerHeight};
}"""


def _open(browser, url: str, width: int, height: int):
    ctx = browser.new_context(viewport={"width": width, "height": height})
    ctx.add_init_script(THROTTLE_FRAMES)
    return ctx, Tab(ctx.new_page(), url)


def _run(tab: Tab) -> None:
    tab.page.wait_for_timeout(2000)  # the address's controls are applied
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").last.wait_for(timeout=600000)


def _layouts(tab: Tab, count: int) -> list[dict]:
    """The shown tab's plots, once ``count`` of them are drawn with data."""
    tab.page.wait_for_function(f"({LAYOUT_JS})().length >= {count}", timeout=120000)
    tab.page.wait_for_timeout(1500)  # the last redraw settles
    return tab.page.evaluate(f"({LAYOUT_JS})()")


def _alpha(fill: str, opacity: str) -> float:
    match = re.fullmatch(r"rgba?\((\d+),\s*(\d+),\s*(\d+)(?:,\s*([0-9.]+))?\)", fill)
    assert match is not None, fill
    return float(match.group(4) or 1.0) * float(opacity)


def _kept(plot: dict) -> str | None:
    """What is wrong with a plot card of LAYOUT_JS, or None."""
    if plot["plot_px"] < PLOT_MIN_PX:
        return f"{plot['title']!r}: plot area {plot['plot_px']:.0f} px < {PLOT_MIN_PX}"
    if not (plot["ticks"] > 0 and plot["ticks_inside"] and plot["titles_clear"]):
        return f"{plot['title']!r}: x tick labels or axis title cut or on the legend {plot}"
    return None


@pytest.mark.parametrize("width, height", SIZES)
def test_twelve_methods_keep_every_plot_and_its_time_axis(browser, server_url, width, height) -> None:
    """Given twelve methods on a 20 s run and Show 1-sigma ticked, every plot of the Plots and
    Components tabs keeps a plot area of at least PLOT_MIN_PX with its x tick labels inside the
    card and above the legend (no axis title on the legend); the heading plot's twelve 1-sigma
    bands together stay translucent; ticking Attitude norm brings its plot into view. Every check
    is made and the failures are named together."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

    ctx, tab = _open(browser, server_url + f"?dur=20&m={TWELVE}", width, height)
    problems: list[str] = []
    try:
        _run(tab)
        tab.page.get_by_role("tab", name="Plots").click()
        tab.set_checkbox("Show 1-sigma", True)
        tab.page.wait_for_function(f"(({FILLS_JS})('Heading error') || []).length >= 12", timeout=120000)
        plots = _layouts(tab, 4)
        tab.page.screenshot(path=str(ARTIFACTS / f"plot_layout_plots_{width}.png"))
        problems += [p for p in map(_kept, plots) if p]
        fills = tab.page.evaluate(FILLS_JS, "Heading error")
        clear = 1.0
        for fill, opacity in fills:
            clear *= 1.0 - _alpha(fill, opacity)
        if 1.0 - clear > STACK_MAX_ALPHA:
            problems.append(f"the heading plot's 1-sigma bands stack to opacity {1.0 - clear:.2f}: {fills}")

        tab.page.evaluate("document.querySelector('.js-plotly-plot').scrollIntoView({block: 'start'})")
        tab.set_checkbox("Attitude norm", True)
        try:
            tab.page.wait_for_function(
                f"(() => {{ const r = ({IN_VIEW_JS})('Attitude error (norm)');"
                " return r !== null && r.top >= 0 && r.bottom <= r.height; })()",
                timeout=60000,
            )
        except PlaywrightTimeoutError:
            where = tab.page.evaluate(IN_VIEW_JS, "Attitude error (norm)")
            problems.append(f"the Attitude norm plot is not in view after ticking it: {where}")

        tab.page.get_by_role("tab", name="Components").click()
        components = _layouts(tab, 3)
        tab.page.screenshot(path=str(ARTIFACTS / f"plot_layout_components_{width}.png"))
        problems += [p for p in map(_kept, components) if p]
    finally:
        ctx.close()
    assert not problems, "\n".join(problems)


@pytest.fixture(scope="module")
def logs_url(tmp_path_factory) -> Iterator[str]:
    """``tauv serve --logs DIR`` where DIR holds ``dive``: 30 s of the figure eight saved by
    ``tauv run --save-log`` (its reference the truth)."""
    logs = tmp_path_factory.mktemp("logs")
    subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--trajectory", "figure8", "--duration", "30", "--method", "lc",
         "--seed", "1", "--save-log", str(logs / "dive")],
        check=True, capture_output=True, timeout=600,
    )
    ARTIFACTS.mkdir(exist_ok=True)
    with open(ARTIFACTS / "server_plot_layout.log", "w") as log, dashboard_server(log, extra=("--logs", str(logs))) as url:
        yield url


def test_a_replay_s_errors_start_at_zero_on_linear_axes(browser, logs_url) -> None:
    """Given the log replayed (its errors exactly 0 at the first epoch, where the filter starts on
    its reference), the error plots' y axes are linear by default (a log axis stretched to 1e-16);
    Error axes "log" draws them logarithmic with no value at or below zero."""
    ctx, tab = _open(browser, logs_url + "?m=ins,lc", 1600, 1000)
    try:
        tab.choose("Source", "dive", exact=False)
        _run(tab)
        tab.page.get_by_role("tab", name="Plots").click()
        _layouts(tab, 4)
        axes = tab.page.evaluate("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                                 ".filter(p => p._fullLayout && p.offsetParent && (p._fullData || []).length)"
                                 ".map(p => [p._fullLayout.title.text, p._fullLayout.yaxis.type])")
        errors = [a for a in axes if a[0].startswith(("Velocity", "Position", "Tilt", "Heading"))]
        assert len(errors) == 4 and all(kind == "linear" for _, kind in errors), axes
        tab.choose("Error axes", "log")
        tab.page.wait_for_function(
            "(() => { const p = Array.from(document.querySelectorAll('.js-plotly-plot')).find(q => q._fullLayout"
            " && (q._fullLayout.title.text || '').startsWith('Velocity')); return p && p._fullLayout.yaxis.type === 'log'"
            " && p._fullLayout.yaxis.range[0] > -9; })()",
            timeout=60000,
        )
    finally:
        ctx.close()
