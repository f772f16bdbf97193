"""One time axis across the dashboard: every time plot of every workbench tab shows the slider's
time and the same zoomed range, a hidden tab catching up when shown, and the page's address keeps
the time, the range and the 3-D camera for a new tab to open at.

One 10-run Monte Carlo (80 s, LC) in one tab serves the whole module; the checks build on each
other in order (the address test opens its own tab at the address the others left)."""

from __future__ import annotations

import re
from urllib.parse import parse_qs, urlparse

import pytest

from tests.browser.conftest import THROTTLE_FRAMES, Tab

pytestmark = pytest.mark.browser
WINDOW = {"width": 1600, "height": 1000}  # the last test shrinks the window to 1280x800
SHOWN_PLOTS_JS = ("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                  ".filter(p => p.data && p.data.length && p.offsetParent !== null)")
CURSORS_JS = (f"{SHOWN_PLOTS_JS}.map(p => ((p.layout.shapes || [])"
              ".find(s => s.name === 'time cursor') || {}).x0 ?? null)")
RANGES_JS = (f"{SHOWN_PLOTS_JS}.map(p => Object.keys(p._fullLayout).filter(k => /^xaxis\\d*$/.test(k))"
             ".map(k => p._fullLayout[k].range))")
TABS = ("Plots", "Components", "Consistency", "Innovations", "Sensors")


def slider_s(tab: Tab) -> float:
    return float(tab.page.get_by_role("slider").first.get_attribute("aria-valuenow"))


def shown_cursors(tab: Tab, workbench_tab: str) -> list[float | None]:
    tab.page.get_by_role("tab", name=workbench_tab, exact=True).click()
    tab.page.wait_for_function(f"{SHOWN_PLOTS_JS}.length > 0", timeout=60000)
    tab.page.wait_for_timeout(1500)   # the tab's plots drawn (5 frames/s) and settled
    return tab.page.evaluate(CURSORS_JS)


def shown_ranges(tab: Tab, workbench_tab: str) -> list[list[list[float]]]:
    tab.page.get_by_role("tab", name=workbench_tab, exact=True).click()
    tab.page.wait_for_function(f"{SHOWN_PLOTS_JS}.length > 0", timeout=60000)
    tab.page.wait_for_timeout(1500)
    return tab.page.evaluate(RANGES_JS)


def query(tab: Tab) -> dict[str, str]:
    return {k: v[0] for k, v in parse_qs(urlparse(tab.page.url).query).items()}


def open_tab(browser, url: str) -> Tab:
    ctx = browser.new_context(viewport=WINDOW)
    ctx.add_init_script(THROTTLE_FRAMES)
    return Tab(ctx.new_page(), url)


@pytest.fixture(scope="module")
def finished(browser, server_url):
    """A tab at 1600x1000 after a 10-run Monte Carlo of 80 s with LC, every workbench tab drawn."""
    tab = open_tab(browser, server_url)
    tab.page.set_default_timeout(120000)   # a loaded 2-core machine answers late; no timing is asserted
    tab.checkbox("VKF").wait_for(timeout=60000)   # every control of a loaded page
    tab.set_methods({"LC"})
    tab.type_into("Duration [s]", "80")
    tab.type_into("Runs", "10")
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=180000)
    tab.page.wait_for_timeout(3000)   # the deferred plots (components, innovations, sensors) sent
    yield tab
    tab.page.context.close()


def test_a_monte_carlo_ends_with_every_cursor_at_the_slider(finished) -> None:
    """Given a 10-run Monte Carlo just finished, then on every workbench tab every plot's time
    cursor stands at the slider's time (the run's end)."""
    tab = finished
    t_s = slider_s(tab)
    assert t_s > 70.0, t_s
    for name in TABS:
        cursors = shown_cursors(tab, name)
        assert cursors and all(c is not None and abs(c - t_s) < 0.06 for c in cursors), (name, t_s, cursors)


def test_go_to_moves_the_cursor_of_every_tab(finished) -> None:
    """Given the finished run with the Plots tab open, when the user goes to 60 s, then the slider
    says 60 and every plot of Plots, Sensors, Consistency and Components (hidden when the time
    moved) has its cursor at 60 s, and Plots still does when opened again."""
    tab = finished
    tab.page.get_by_role("tab", name="Plots", exact=True).click()
    tab.page.wait_for_timeout(1000)
    tab.type_into("Go to [s]", "60")
    tab.page.wait_for_function("+document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 60",
                               timeout=60000)
    for name in ("Plots", "Sensors", "Consistency", "Components", "Plots"):
        cursors = shown_cursors(tab, name)
        assert cursors and all(c is not None and abs(c - 60.0) < 1e-6 for c in cursors), (name, cursors)


def test_a_zoom_applies_to_every_time_plot_of_every_tab(finished) -> None:
    """Given the finished run, when the user drags across a quarter of the velocity plot (a zoom
    in time), then every time plot of every tab, each panel of the multi-panel figures too, shows
    that range (the tabs hidden at the zoom when opened); a double-click on a plot of another tab
    gives every plot its whole time back."""
    tab = finished
    page = tab.page
    page.get_by_role("tab", name="Plots", exact=True).click()
    plot = page.locator(".js-plotly-plot").first
    plot.scroll_into_view_if_needed()
    page.wait_for_timeout(1000)
    area = plot.locator(".nsewdrag").first.bounding_box()
    y = area["y"] + 0.5 * area["height"]
    page.mouse.move(area["x"] + 0.25 * area["width"], y)
    page.mouse.down()
    page.mouse.move(area["x"] + 0.40 * area["width"], y, steps=5)
    page.mouse.move(area["x"] + 0.50 * area["width"], y, steps=5)
    page.mouse.up()
    page.wait_for_timeout(1000)
    zoomed = plot.evaluate("gd => gd._fullLayout.xaxis.range")
    assert 5.0 < zoomed[1] - zoomed[0] < 40.0, zoomed
    for name in TABS:
        ranges = [r for plot_ranges in shown_ranges(tab, name) for r in plot_ranges]
        assert ranges and all(abs(r[0] - zoomed[0]) < 1e-6 and abs(r[1] - zoomed[1]) < 1e-6
                              for r in ranges), (name, zoomed, ranges)
    # a reset on another tab's plot: every plot back to its whole time
    page.get_by_role("tab", name="Sensors", exact=True).click()
    page.wait_for_timeout(1000)
    other = page.locator(".js-plotly-plot >> visible=true").first
    box = other.locator(".nsewdrag").first.bounding_box()
    page.mouse.dblclick(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
    page.wait_for_timeout(1500)
    for name in ("Sensors", "Plots"):
        ranges = [r for plot_ranges in shown_ranges(tab, name) for r in plot_ranges]
        assert ranges and all(r[1] - r[0] > 60.0 for r in ranges), (name, ranges)


def test_the_address_keeps_time_zoom_and_camera_for_a_new_tab(finished, browser, server_url) -> None:
    """Given the finished run at 60 s with a zoom on the velocity plot, then the page's address
    carries t=60, the zoomed range x and the camera cam; a new tab opened at that address shows
    the slider at 60 s, the camera there, and after its own run every time plot zoomed to x with
    its cursor at 60 s."""
    tab = finished
    page = tab.page
    page.get_by_role("tab", name="Plots", exact=True).click()
    tab.type_into("Go to [s]", "60")   # (the previous test's double-click moved the playback too)
    page.wait_for_function("+document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 60",
                           timeout=60000)
    page.evaluate("() => window.__tauv.setRange([30, 50])")  # what a drag does (the previous test)
    page.wait_for_function("/[?&]x=30:50(&|$)/.test(location.search) && /[?&]t=60(&|$)/.test(location.search)"
                           " && /[?&]cam=/.test(location.search)", timeout=60000)
    link = query(tab)
    cam = [float(v) for v in link["cam"].split(",")]
    other = open_tab(browser, server_url + "/?" + urlparse(page.url).query)
    other.page.set_default_timeout(120000)
    try:
        other.page.wait_for_function("+document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 60",
                                     timeout=30000)
        # the new tab's camera, as its page reports it back into its address
        other.page.wait_for_timeout(2500)
        got = [float(v) for v in query(other)["cam"].split(",")]
        assert max(abs(a - b) for a, b in zip(got, cam)) < 0.05, (got, cam)
        other.page.get_by_role("button", name="Run", exact=True).click()
        other.notification("Run complete").wait_for(timeout=180000)
        assert slider_s(other) == 60.0
        for name in ("Plots", "Consistency"):
            ranges = [r for plot_ranges in shown_ranges(other, name) for r in plot_ranges]
            assert ranges and all(abs(r[0] - 30) < 1e-6 and abs(r[1] - 50) < 1e-6 for r in ranges), (name, ranges)
            cursors = other.page.evaluate(CURSORS_JS)
            assert all(c is not None and abs(c - 60.0) < 1e-6 for c in cursors), (name, cursors)
        assert re.search(r"[?&]x=30:50(&|$)", urlparse(other.page.url).query or "") is not None
    finally:
        other.page.context.close()


def test_at_1280x800_a_plot_click_moves_every_cursor_and_a_zoom_every_range(finished) -> None:
    """Given the finished run in a window of 1280x800, when the user clicks the velocity plot a
    third of the way along, then the slider moves to the clicked time and every plot of every tab
    has its cursor there; a zoom set from one plot is every plot's range, and resetting it gives
    each its whole time back."""
    tab = finished
    page = tab.page
    page.set_viewport_size({"width": 1280, "height": 800})
    page.evaluate("() => window.__tauv.setRange(null)")
    page.get_by_role("tab", name="Plots", exact=True).click()
    plot = page.locator(".js-plotly-plot").first
    plot.scroll_into_view_if_needed()
    page.wait_for_timeout(1500)
    area = plot.locator(".nsewdrag").first.bounding_box()
    page.mouse.click(area["x"] + area["width"] / 3, area["y"] + 0.5 * area["height"])
    page.wait_for_function("+document.querySelector('[role=slider]').getAttribute('aria-valuenow') < 50",
                           timeout=60000)
    t_s = slider_s(tab)
    assert 15.0 < t_s < 40.0, t_s
    for name in TABS:
        cursors = shown_cursors(tab, name)
        assert cursors and all(c is not None and abs(c - t_s) < 0.06 for c in cursors), (name, t_s, cursors)
    page.evaluate("() => window.__tauv.setRange([10, 20])")
    for name in ("Sensors", "Plots"):
        ranges = [r for plot_ranges in shown_ranges(tab, name) for r in plot_ranges]
        assert ranges and all(abs(r[0] - 10) < 1e-6 and abs(r[1] - 20) < 1e-6 for r in ranges), (name, ranges)
    page.evaluate("() => window.__tauv.setRange(null)")
    for name in ("Components", "Plots"):
        ranges = [r for plot_ranges in shown_ranges(tab, name) for r in plot_ranges]
        assert ranges and all(r[1] - r[0] > 60.0 for r in ranges), (name, ranges)
