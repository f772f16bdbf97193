"""The Spread tab in a real browser: a 10-run Monte Carlo's runs one by one, their median and 5-95 %
band, the histograms of every method's final errors and the NEES of every block against its 95 %
and 99 % bands, legends outside the plots at both window sizes; a single run shows a hint."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
SIZES = ((1600, 1000), (1280, 800))
SPREAD_PLOTS_JS = """
() => Array.from(document.querySelectorAll('.js-plotly-plot'))
  .map((p, index) => [p, index])
  .filter(([p]) => (p._fullData || []).length)
  .map(([p, index]) => {
    const box = (el) => { const b = el.getBoundingClientRect(); return [b.left, b.top, b.right, b.bottom]; };
    const legend = p.querySelector('.legend');
    return {
      index,
      title: String((p.layout && p.layout.title && p.layout.title.text) || ''),
      traces: p._fullData.map(t => ({name: t.name, xaxis: t.xaxis, yaxis: t.yaxis, points: (t.y || []).length,
                                    total: Array.from(t.y || []).reduce((a, b) => a + (Number(b) || 0), 0)})),
      legend: legend ? box(legend) : null,
      areas: Array.from(p.querySelectorAll('.nsewdrag')).map(box),
    };
  })
"""
HINT = "Run a Monte Carlo (Runs > 1) to see the spread"


def _spread_plots(tab) -> dict[str, dict]:
    """The Spread tab's three plots as drawn: "runs" (holds a median), "final" (titled "Final
    errors"), "nees" (holds the 95 % band); absent ones left out."""
    plots = {}
    for plot in tab.page.evaluate(SPREAD_PLOTS_JS):
        names = {t["name"] for t in plot["traces"]}
        if "median" in names:
            plots["runs"] = plot
        elif any(name.startswith("95 % band") for name in names):
            plots["nees"] = plot
        elif plot["title"].startswith("Final errors"):
            plots["final"] = plot
    return plots


def _overlaps(a: list[float], b: list[float]) -> bool:
    return a[0] < b[2] - 1 and b[0] < a[2] - 1 and a[1] < b[3] - 1 and b[1] < a[3] - 1


def test_a_ten_run_monte_carlo_shows_its_spread(new_tab) -> None:
    """Given a 10-run Monte Carlo of LC and TC (20 s), when it completes and the Spread tab opens,
    then LC's velocity and position panels hold its 10 runs one by one, their median and the 5-95 %
    band; the histograms count 10 final errors per method in each panel; the NEES plot has a panel
    per block, each method's mean over runs in each, against the 95 % and 99 % bands; and at
    1600x1000 and 1280x800 no legend lies on a plot's area."""
    tab = new_tab("?traj=figure8&dur=20&m=lc,tc&runs=10")
    tab.page.set_viewport_size({"width": SIZES[0][0], "height": SIZES[0][1]})
    tab.page.wait_for_function("location.search.includes('runs=10')", timeout=30000)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=180000)
    tab.page.get_by_role("tab", name="Spread").click()
    tab.page.wait_for_function(
        f"(() => {{ const p = ({SPREAD_PLOTS_JS})(); return p.length >= 3; }})()", timeout=30000)
    plots = _spread_plots(tab)
    assert set(plots) == {"runs", "final", "nees"}, plots.keys()

    runs = plots["runs"]["traces"]
    for yaxis in ("y", "y2"):   # velocity, position
        panel = [t for t in runs if t["yaxis"] == yaxis]
        names = [t["name"] for t in panel]
        assert sorted(n for n in names if n.startswith("run ")) == sorted(f"run {r}" for r in range(1, 11)), names
        assert {"median", "5–95 %", "5–95 % low"} <= set(names), names
        drawn = [t for t in panel if t["name"] != "one line per run"]   # the runs' legend entry: no data
        assert all(t["points"] == 201 for t in drawn), drawn   # 20 s at 10 Hz, every epoch
    expect(tab.page.get_by_text("Spread of", exact=True)).to_be_visible()

    final = [t for t in plots["final"]["traces"] if t["points"]]
    for xaxis in ("x", "x2"):  # final velocity, final position error
        counted = {t["name"]: t["total"] for t in final if t["xaxis"] == xaxis}
        assert counted == {"LC": 10, "TC": 10}, counted

    nees = plots["nees"]["traces"]
    panels = sorted({t["yaxis"] for t in nees})
    assert len(panels) >= 6, panels  # full, position, velocity, tilt, heading, sensor errors
    for yaxis in panels:
        names = {t["name"] for t in nees if t["yaxis"] == yaxis}
        assert {"LC", "TC", "95 % band", "99 % band"} <= names, (yaxis, names)
    tab.page.screenshot(path=str(ARTIFACTS / "spread.png"))
    for name, plot in plots.items():   # each plot scrolled into view, marked by its place among the page's plots
        tab.page.evaluate(f"document.querySelectorAll('.js-plotly-plot')[{plot['index']}].scrollIntoView()")
        tab.page.wait_for_timeout(500)
        tab.page.screenshot(path=str(ARTIFACTS / f"spread_{name}.png"))

    for width, height in SIZES:
        tab.page.set_viewport_size({"width": width, "height": height})
        tab.page.wait_for_timeout(1500)
        for name, plot in _spread_plots(tab).items():
            assert plot["legend"] is not None, name
            assert not any(_overlaps(plot["legend"], area) for area in plot["areas"]), (name, width, plot)
    assert tab.external_requests == []


def test_a_single_run_shows_the_hint_not_empty_plots(new_tab) -> None:
    """Given one run (10 s), when it completes and the Spread tab opens, then the tab says to run
    a Monte Carlo and draws no spread plot."""
    tab = new_tab("?dur=10&m=lc")
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    tab.page.get_by_role("tab", name="Spread").click()
    expect(tab.page.get_by_text(HINT, exact=False)).to_be_visible(timeout=10000)
    tab.page.wait_for_timeout(1000)
    assert _spread_plots(tab) == {}
