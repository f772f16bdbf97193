"""A run's events on the dashboard's time axes (app.figures.event_traces), in a real browser: one
160 s straight run with beams 3 and 4 lost 100-150 s, shared by the module, shows the outage as a
band on every time axis of the Plots, Innovations and Sensors tabs with a hover text naming the
beams and the window, kept when the time cursor moves and gone with the Events box unticked; the
gate's rejections are marked where the innovations show them; a replay of A-KIT's segment 1 (when
the data is here) marks the divergence the Results table reports."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.browser.conftest import ARTIFACTS, THROTTLE_FRAMES, Tab, dashboard_server

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
AKIT_SEGMENT = Path(os.environ.get("TAUV_AKIT", ROOT.parent / "shared" / "data" / "akit")) / "Trajectory1"
"""A-KIT's segment 1: in the directory ``TAUV_AKIT`` names, or ../shared/data/akit (as
scripts/json_snapshot.py reads it)."""
OUTAGE_QUERY = "?traj=straight&dur=160&m=lc,tc&o3=100:150&o4=100:150"
OUTAGE_NAME = "scheduled DVL outage"  # tauvcore.eval.events.EVENT_KINDS["outage"], the legend's entry
OUTAGE_TEXT = "scheduled DVL outage: beams 3,4 lost 100-150 s"

EVENTS_JS = """
() => Array.from(document.querySelectorAll('.js-plotly-plot'))
  .filter(p => p.offsetParent !== null && p.data && p.data.length && p._fullLayout)
  .map(p => ({
    title: (p._fullLayout.title && p._fullLayout.title.text) || '',
    xaxes: [...new Set(p._fullData.filter(t => !/^y5\\d$/.test(t.yaxis)).map(t => t.xaxis))].sort(),
    bands: (p.layout.shapes || []).filter(s => s.name === 'event outage').map(s => [s.xref, s.x0, s.x1]),
    cursor: (p.layout.shapes || []).filter(s => s.name === 'time cursor').map(s => s.x0),
    markers: Object.fromEntries(p.data.filter(t => /^y5\\d$/.test(t.yaxis || ''))
      .map(t => [t.name + ' ' + t.xaxis, {x: Array.from(t.x), text: Array.from(t.hovertext || [])}])),
    rejected: p._fullData.filter(t => / rejected$/.test(t.name || '')).flatMap(t => Array.from(t.x)),
  }))
"""
"""Every plotly figure shown: its title, the x axes its data use, the outage bands, the cursor and
the event markers (on the invisible axes y51, y52, ...), the innovations' rejected crosses."""
HOVER_JS = """
([title, name]) => {
  const p = Array.from(document.querySelectorAll('.js-plotly-plot'))
    .find(q => q.offsetParent !== null && q._fullLayout && q._fullLayout.title.text === title);
  const k = p.data.findIndex(t => t.name === name);
  const trace = p._fullData[k];
  window.Plotly.Fx.hover(p, [{curveNumber: k, pointNumber: 1}], trace.xaxis + trace.yaxis);
  return p.querySelector('.hoverlayer') ? p.querySelector('.hoverlayer').textContent : '';
}
"""
"""Hover the second point of trace ``name`` of the shown figure titled ``title`` (plotly's own
hover, as the mouse does) and read the hover label."""


def _open_tab(tab: Tab, name: str) -> None:
    tab.page.get_by_role("tab", name=name, exact=True).click()
    tab.page.wait_for_timeout(500)


def _figures_with_bands(tab: Tab, timeout_ms: float = 90000) -> list[dict]:
    """The shown figures once each has its data and its outage bands (the deferred tabs draw a
    moment after the run, once the tab is still)."""
    tab.page.wait_for_function(
        f"(() => {{ const f = ({EVENTS_JS})(); return f.length > 0 && f.every(p => p.bands.length > 0); }})()",
        timeout=timeout_ms,
    )
    return tab.page.evaluate(EVENTS_JS)


@pytest.fixture(scope="module")
def outage_tab(browser, server_url) -> Iterator[Tab]:
    """One run of LC and TC on the straight line, 160 s, beams 3 and 4 lost 100-150 s."""
    ctx = browser.new_context(viewport={"width": 1600, "height": 1000})
    ctx.add_init_script(THROTTLE_FRAMES)
    try:
        tab = Tab(ctx.new_page(), server_url + OUTAGE_QUERY)
        tab.page.get_by_role("button", name="Run", exact=True).click(timeout=120000)  # a loaded page is slow
        tab.notification("Run complete").wait_for(timeout=240000)
        yield tab
    finally:
        ctx.close()


def _assert_outage_on_every_axis(figures: list[dict]) -> None:
    for figure in figures:
        assert sorted(b[0] for b in figure["bands"]) == figure["xaxes"], figure["title"]
        assert all(b[1:] == [100, 150] for b in figure["bands"]), figure["title"]
        outage = [v for k, v in figure["markers"].items() if k.startswith(OUTAGE_NAME)]
        assert outage and all(set(m["text"]) == {OUTAGE_TEXT} for m in outage), figure["title"]
        assert all(m["x"] == [100, 125, 150] for m in outage), figure["title"]


@pytest.mark.parametrize("workbench_tab", ["Plots", "Innovations", "Sensors"])
def test_the_outage_is_shaded_on_every_time_axis_of_the_tab(outage_tab: Tab, workbench_tab: str) -> None:
    """Given the run, when a tab shows, then each of its figures has a band 100-150 s on each of
    its x axes (the Sensors tab's stacked panels, the Innovations' beams) and markers whose hover
    text names beams 3,4 and 100-150 s; plotly's own hover label says so."""
    _open_tab(outage_tab, workbench_tab)
    figures = _figures_with_bands(outage_tab)
    assert len(figures) >= (4 if workbench_tab == "Plots" else 1)
    _assert_outage_on_every_axis(figures)
    label = outage_tab.page.evaluate(HOVER_JS, [figures[0]["title"], OUTAGE_NAME])
    assert "beams 3,4" in label and "100-150 s" in label


def test_the_bands_stay_when_the_cursor_moves_and_go_with_the_events_box(outage_tab: Tab) -> None:
    """Given the Plots tab, when Go to moves the cursor to 60 s, then the bands are still drawn
    beside the cursor; unticking Events removes bands and markers, ticking it brings them back."""
    page = outage_tab.page
    _open_tab(outage_tab, "Plots")
    _figures_with_bands(outage_tab)
    outage_tab.type_into("Go to [s]", "60")
    page.wait_for_function(
        f"(() => {{ const f = ({EVENTS_JS})(); return f.length && f.every(p => p.cursor[0] === 60); }})()",
        timeout=30000,
    )
    _assert_outage_on_every_axis(page.evaluate(EVENTS_JS))
    outage_tab.set_checkbox("Events", False)
    page.wait_for_function(
        f"(() => {{ const f = ({EVENTS_JS})(); return f.length && f.every(p => !p.bands.length "
        "&& !Object.keys(p.markers).length); })()",
        timeout=30000,
    )
    outage_tab.set_checkbox("Events", True)
    _assert_outage_on_every_axis(_figures_with_bands(outage_tab, 30000))


def test_gate_rejections_are_marked_where_the_innovations_show_them(outage_tab: Tab) -> None:
    """Given the run's DVL updates the gate refused whole (LC at 84 and 86 s, TC's beam 3 at 86 s
    with seed 0), the Innovations tab marks each with a "gate rejection" marker at its time, at a
    cross of the rejected innovations, its hover naming the method, the DVL and the time; resets,
    when there are any, are marked as such."""
    _open_tab(outage_tab, "Innovations")
    (figure,) = _figures_with_bands(outage_tab)
    markers = [(x, t) for k, v in figure["markers"].items() if k.startswith("gate rejection")
               for x, t in zip(v["x"], v["text"], strict=True)]
    dvl = {x for x, t in markers if ": DVL update rejected by the gate at " in t}
    assert dvl, "no DVL rejection marked"
    assert dvl <= set(figure["rejected"])  # each at a cross of the innovations
    assert all(re.match(r"(LC|TC): [A-Z]+ update rejected by the gate at [\d.]+ s", t) for _, t in markers)
    resets = [t for k, v in figure["markers"].items() if k.startswith("lock-out reset") for t in v["text"]]
    assert all("velocity reset to the DVL after a lock-out" in t for t in resets)


@pytest.mark.parametrize(("width", "height"), [(1600, 1000), (1280, 800)])
def test_the_band_and_its_legend_entry_are_drawn_inside_the_plot(outage_tab: Tab, width: int, height: int) -> None:
    """At both window sizes the velocity plot draws its outage band from 100 to 150 s on its time
    axis, inside the plotting area, and names its colour in a legend entry inside the figure."""
    page = outage_tab.page
    page.set_viewport_size({"width": width, "height": height})
    _open_tab(outage_tab, "Plots")
    _figures_with_bands(outage_tab)
    page.wait_for_timeout(1000)
    box = page.evaluate(
        """() => {
      const p = Array.from(document.querySelectorAll('.js-plotly-plot')).find(q => q.offsetParent !== null
        && q.layout.shapes && q.layout.shapes.some(s => s.name === 'event outage'));
      const xa = p._fullLayout.xaxis, ya = p._fullLayout.yaxis;
      const band = Array.from(p.querySelectorAll('.shapelayer path'))
        .map(e => e.getBoundingClientRect()).filter(r => r.width > 5)[0];
      const plot = p.getBoundingClientRect();
      const entry = Array.from(p.querySelectorAll('.legendtext'))
        .find(e => e.textContent === 'scheduled DVL outage');
      const legend = entry ? entry.getBoundingClientRect() : null;
      return {x100: plot.left + xa._offset + xa.l2p(100), x150: plot.left + xa._offset + xa.l2p(150),
              top: plot.top + ya._offset, bottom: plot.top + ya._offset + ya._length,
              band: [band.left, band.right, band.top, band.bottom], plot: [plot.left, plot.right, plot.bottom],
              legend: legend && [legend.left, legend.right, legend.bottom]};
    }"""
    )
    left, right, top, bottom = box["band"]
    assert left == pytest.approx(box["x100"], abs=2) and right == pytest.approx(box["x150"], abs=2)
    assert top == pytest.approx(box["top"], abs=2) and bottom == pytest.approx(box["bottom"], abs=2)
    assert box["legend"] is not None, "no legend entry names the outage's colour"
    assert box["plot"][0] <= box["legend"][0] and box["legend"][1] <= box["plot"][1]
    assert box["legend"][2] <= box["plot"][2]
    page.set_viewport_size({"width": 1600, "height": 1000})


@pytest.fixture(scope="module")
def akit_url(tmp_path_factory) -> Iterator[str]:
    """``tauv serve --logs DIR`` with A-KIT's segment 1 converted to ``akit1`` (skipped without
    the data: it is not part of the repository)."""
    if not (AKIT_SEGMENT / "IMU.csv").exists():
        pytest.skip("A-KIT data not present (TAUV_AKIT or ../shared/data/akit)")
    logs = tmp_path_factory.mktemp("akit_logs")
    subprocess.run([sys.executable, str(ROOT / "scripts" / "akit_to_log.py"), str(AKIT_SEGMENT), str(logs / "akit1")],
                   check=True, capture_output=True, timeout=300)
    ARTIFACTS.mkdir(exist_ok=True)
    with open(ARTIFACTS / "server_events.log", "w") as log, dashboard_server(log, extra=("--logs", str(logs))) as url:
        yield url


def test_a_replay_of_akit_marks_its_divergence(browser, akit_url: str) -> None:
    """Given A-KIT's segment 1 replayed with INS and LC, the Results table reports LC's divergence
    "diverged at T s" (343.45 s); the Plots tab's figures mark it with a "divergence flagged"
    marker at T s naming LC and a dashed line on the time axis, and mark LC's gate rejections
    (35 pings of the log)."""
    ctx = browser.new_context(viewport={"width": 1600, "height": 1000})
    ctx.add_init_script(THROTTLE_FRAMES)
    try:
        tab = Tab(ctx.new_page(), akit_url + "?src=akit1&m=ins,lc")
        tab.page.get_by_role("button", name="Run", exact=True).click(timeout=120000)  # a loaded page is slow
        tab.notification("Run complete").wait_for(timeout=400000)
        tab.page.get_by_role("tab", name="Results", exact=True).click()
        flagged = tab.page.get_by_text(re.compile(r"diverged at [\d.]+ s")).first
        flagged.wait_for(timeout=30000)
        t_text = re.search(r"diverged at ([\d.]+) s", flagged.inner_text()).group(1)
        _open_tab(tab, "Plots")
        tab.page.wait_for_function(
            f"(() => {{ const f = ({EVENTS_JS})(); return f.length && f.every(p => "
            "Object.keys(p.markers).some(k => k.startsWith('divergence flagged'))); })()",
            timeout=60000,
        )
        figure = tab.page.evaluate(EVENTS_JS)[0]
        marker = next(v for k, v in figure["markers"].items() if k.startswith("divergence flagged"))
        assert any(abs(x - float(t_text)) < 0.1 for x in marker["x"])
        assert any(re.match(rf"LC: divergence flagged at {re.escape(t_text)}", t) for t in marker["text"])
        rejections = [t for k, v in figure["markers"].items() if k.startswith("gate rejection") for t in v["text"]]
        assert rejections and all(t.startswith("LC: DVL update rejected by the gate at ") for t in rejections)
        lines = tab.page.evaluate(
            "() => Array.from(document.querySelectorAll('.js-plotly-plot')).filter(p => p.offsetParent !== null"
            " && p.layout && p.layout.shapes).flatMap(p => p.layout.shapes.filter(s => s.name === 'event diverged')"
            ".map(s => s.x0))"
        )
        assert any(abs(x - float(t_text)) < 0.1 for x in lines)
    finally:
        ctx.close()
