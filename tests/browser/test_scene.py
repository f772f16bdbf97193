"""The 3-D scene and playback in a real browser: beams drawn as the
boxes say before any run, the time slider kept where the user put it and spanning what was run
after Stop, and the playback speed setting the pace of the time."""

from __future__ import annotations

import base64
import re

import pytest

from app.figures.scene import BEAM_COLORS, BEAM_RETURNING, BEAM_SWITCHED_OFF
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
RUNNING = re.compile(r"^Running \w+, ")
# pixels of a screenshot within 40 of each given colour (per channel), counted in the page
COUNT_COLOURS_JS = """async ([png, colours]) => {
  const img = new Image();
  img.src = 'data:image/png;base64,' + png;
  await img.decode();
  const canvas = document.createElement('canvas');
  canvas.width = img.width; canvas.height = img.height;
  const ctx = canvas.getContext('2d');
  ctx.drawImage(img, 0, 0);
  const px = ctx.getImageData(0, 0, img.width, img.height).data;
  const counts = colours.map(() => 0);
  for (let i = 0; i < px.length; i += 4)
    colours.forEach((c, k) => {
      if (Math.abs(px[i] - c[0]) < 40 && Math.abs(px[i + 1] - c[1]) < 40 && Math.abs(px[i + 2] - c[2]) < 40) counts[k]++;
    });
  return counts;
}"""


def beam_pixels(tab) -> tuple[int, int]:
    """(returning, switched off) beam pixels in the 3-D view as drawn now (the legend, which floats
    over the view, hidden for the count)."""
    tab.page.wait_for_timeout(1500)        # frames at 5/s under test (conftest.THROTTLE_FRAMES)
    tab.page.evaluate("() => { const l = document.getElementById('tauv-legend'); if (l) l.style.visibility = 'hidden'; }")
    png = base64.b64encode(tab.page.locator("canvas").first.screenshot()).decode()
    return tuple(tab.page.evaluate(COUNT_COLOURS_JS, [png, [BEAM_COLORS[BEAM_RETURNING],
                                                            BEAM_COLORS[BEAM_SWITCHED_OFF]]]))


def slider(tab) -> dict[str, float]:
    thumb = tab.page.get_by_role("slider").first
    return {k: float(thumb.get_attribute(f"aria-value{k}")) for k in ("now", "max")}



def test_a_switched_off_beam_is_drawn_off_before_any_run(new_tab) -> None:
    """Given a fresh tab, when Beam 2 is unticked, then its beam is drawn switched off at once."""
    tab = new_tab()
    returning, off = beam_pixels(tab)
    assert returning > 30 and off < 10, (returning, off)
    tab.set_checkbox("Beam 2", False)
    returning2, off2 = beam_pixels(tab)
    assert off2 > 10 and returning2 < returning, (returning, off, returning2, off2)


def test_the_slider_stays_where_the_user_put_it_and_spans_what_was_run(new_tab) -> None:
    """Given a long run, when the user puts the slider at 0 while it runs, then the slider stays
    there, and after Stop it spans what was run. (It snapped back under load: a value the run set
    just before the move reached the server arrived after it, and viser echoes no value to the tab
    that moved it; app.dashboard.session_playback.Playback._echo_slider sends it back once.)"""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"LC"})
    tab.type_into("Duration [s]", "36000")    # the longest mission: still running when Stop is pressed
    page.get_by_role("button", name="Run", exact=True).click()
    page.get_by_text(RUNNING).wait_for(timeout=15000)
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') > 5",
                           timeout=60000)
    thumb = page.get_by_role("slider").first
    thumb.focus()                            # the thumb moves with the run: no waiting for it to hold still
    thumb.press("Home")                      # the user puts the slider at 0 s
    page.wait_for_timeout(3000)              # results keep arriving meanwhile
    page.get_by_role("button", name="Stop", exact=True).evaluate("b => b.click()")
    tab.notification("Run stopped").wait_for(timeout=20000)
    page.wait_for_timeout(500)
    span = slider(tab)
    assert span["now"] == 0.0 and 20.0 < span["max"] < 36000.0, span


def test_the_playback_speed_sets_the_pace_of_the_time(new_tab) -> None:
    """Given a 250 s run, played back at 1x and at 10x, the time advances about ten times as fast
    at 10x, at about the wall clock's pace at 1x."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"LC"})
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    thumb = page.get_by_role("slider").first
    rates = {}
    for speed in ("1x", "10x"):
        tab.choose("Speed", speed)
        thumb.focus()
        thumb.press("Home")
        page.get_by_role("button", name="Play", exact=True).click()
        page.wait_for_timeout(1000)
        t0, w0 = slider(tab)["now"], page.evaluate("performance.now()")
        page.wait_for_timeout(2000)
        t1, w1 = slider(tab)["now"], page.evaluate("performance.now()")
        page.get_by_role("button", name="Pause", exact=True).click()
        rates[speed] = (t1 - t0) / ((w1 - w0) / 1000.0)
    assert 0.4 < rates["1x"] < 2.0, rates
    assert rates["10x"] > 5.0 * rates["1x"], rates
    page.get_by_role("button", name="Fit mission", exact=True).click()
    page.wait_for_timeout(1500)
    page.screenshot(path=str(ARTIFACTS / "scene.png"))
    assert tab.external_requests == []


def test_a_click_on_a_plot_moves_the_playback_there(new_tab) -> None:
    """Given a finished run with the slider at 0, when the user clicks three quarters of the way
    along the velocity plot, then the slider (and so the scene and every plot's cursor) moves to
    the time under the click; a time typed into "Go to [s]" does the same, and text that is no
    time is refused in a notification naming the field and the value."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"LC"})
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    thumb = page.get_by_role("slider").first
    thumb.focus()
    thumb.press("Home")
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 0",
                           timeout=10000)
    plot = page.locator(".js-plotly-plot").first
    plot.scroll_into_view_if_needed()
    area = plot.locator(".nsewdrag").first.bounding_box()
    x_range = plot.evaluate("gd => gd._fullLayout.xaxis.range")
    wanted_s = x_range[0] + 0.75 * (x_range[1] - x_range[0])
    page.mouse.click(area["x"] + 0.75 * area["width"], area["y"] + 0.5 * area["height"])
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') > 0",
                           timeout=15000)
    page.wait_for_timeout(500)
    now = slider(tab)["now"]
    assert abs(now - wanted_s) < 0.02 * (x_range[1] - x_range[0]), (now, wanted_s)   # the nearest sample
    assert float(tab.field("Go to [s]").input_value()) == pytest.approx(now, abs=0.06)
    thumb.focus()
    thumb.press("Home")                                      # away, then the same point again
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 0",
                           timeout=10000)
    # the same place clicked again moves the playback again; to about the same time, not always the
    # same sample: the plot's autorange may have dropped the first figure's padding meanwhile
    # (0-250.4 s, then 0-250 s on a quiet machine, which moves the place by 0.3 s)
    page.mouse.click(area["x"] + 0.75 * area["width"], area["y"] + 0.5 * area["height"])
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') > 0",
                           timeout=15000)
    page.wait_for_timeout(500)
    assert abs(slider(tab)["now"] - now) < 0.02 * (x_range[1] - x_range[0]), (slider(tab)["now"], now)
    tab.type_into("Go to [s]", "42")
    page.wait_for_function("() => +document.querySelector('[role=slider]').getAttribute('aria-valuenow') === 42",
                           timeout=15000)
    tab.type_into("Go to [s]", "soon")                       # key by key: refused once, when the typing stops
    tab.notification("Go to: not moved").wait_for(timeout=10000)
    page.wait_for_timeout(1500)
    assert tab.notification("Go to: not moved").count() == 1     # a CI run showed two ("soo", "soon")
    assert page.get_by_text("Go to [s]: 'soon' is not a number of seconds").count() == 1
    assert slider(tab)["now"] == 42.0
