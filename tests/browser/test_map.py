"""The workbench's Map tab: the truth and every method's track from above with the position
ellipses, following the time slider, coloured by error on request, at one scale in both windows."""

from __future__ import annotations

import pytest

from tests.browser.conftest import ARTIFACTS, THROTTLE_FRAMES, Tab

pytestmark = pytest.mark.browser
MAP_JS = "Array.from(document.querySelectorAll('.js-plotly-plot')).find(p => p.layout && p.layout.meta && p.layout.meta.tauv === 'map' && p.data)"
STATE_JS = f"""(() => {{
  const p = {MAP_JS};
  if (!p || !p._fullLayout || !p._fullLayout.xaxis) return null;
  const first = p.layout.meta.cursor;
  const data = p._fullData;  // plotly's own copy: numpy arrays arrive base64-coded in p.data
  return {{
    key: p.layout.meta.key,
    names: data.slice(0, first).filter(t => t.showlegend !== false).map(t => t.name),
    tracks: Object.fromEntries(data.slice(0, first).filter(t => t.customdata)
      .map(t => [t.name, {{x: Array.from(t.x), y: Array.from(t.y), color: t.marker && t.marker.color ? Array.from(t.marker.color) : null,
                         scale: !!(t.marker && t.marker.showscale)}}])),
    along: Object.fromEntries(data.slice(0, first).filter(t => t.hoverinfo === 'skip').map(t => [t.name, t.x.length])),
    cursor: data.slice(first).map(t => ({{name: t.name, x: Array.from(t.x || []), y: Array.from(t.y || [])}})),
    px_per_m: [p._fullLayout.xaxis._m, p._fullLayout.yaxis._m],
    width: p.getBoundingClientRect().width,
  }};
}})()"""


def _map(tab: Tab) -> dict:
    state = tab.page.evaluate(STATE_JS)
    assert state is not None
    return state


def _cursor(state: dict, name: str) -> dict:
    return next(c for c in state["cursor"] if c["name"] == name)


@pytest.mark.parametrize("width, height", [(1600, 1000), (1280, 800)])
def test_the_map_shows_tracks_and_ellipses_follows_the_slider_and_colours_by_error(
    browser, server_url, width, height
) -> None:
    """Given a 20 s figure-eight run of LC, TC and VKF, when the Map tab is opened, then it shows
    the truth and the three tracks, LC's and TC's 1- and 3-sigma ellipses at the cursor and along
    the track (VKF has no position state: none), at one scale north and east; when the slider goes
    to 0 and to the end, the cursor's marks move to the tracks' first and last points without the
    figure being sent again; Colour by error marks each track point with a colour scale."""
    from playwright.sync_api import expect

    ctx = browser.new_context(viewport={"width": width, "height": height})
    ctx.add_init_script(THROTTLE_FRAMES)
    try:
        tab = Tab(ctx.new_page(), server_url + "?traj=figure8&dur=20&m=lc,tc,vkf")
        expect(tab.checkbox("VKF")).to_be_checked(timeout=30000)  # the address is applied
        tab.page.get_by_role("button", name="Run", exact=True).click()
        tab.page.get_by_role("tab", name="Runs").click()
        tab.checkbox("Overlay run 1").wait_for(timeout=120000)
        tab.page.get_by_role("tab", name="Map").click()
        tab.page.wait_for_function(f"(() => {{ const p = {MAP_JS}; return p && p.data.some(t => t.name === 'VKF'); }})()",
                                   timeout=30000)
        state = _map(tab)
        assert {"truth", "LC", "TC", "VKF"} <= set(state["names"]), state["names"]
        for method in ("LC", "TC"):
            assert len(state["tracks"][method]["x"]) > 150, method  # 10 Hz over 20 s
            for k in ("1σ", "3σ"):
                assert len(_cursor(state, f"{method} {k} at the cursor")["x"]) > 20, (method, k)
            assert state["along"][f"{method} 1σ, 3σ every 20 s"] > 40, state["along"]
        assert _cursor(state, "VKF 1σ at the cursor")["x"] == []
        x_px, y_px = state["px_per_m"]
        assert abs(abs(x_px / y_px) - 1.0) < 1e-3, state["px_per_m"]  # one scale: a circle stays a circle
        tab.page.screenshot(path=str(ARTIFACTS / f"map-{width}x{height}.png"))

        # the slider: Home, then End; the cursor's marks follow, the figure stays the one sent
        tab.page.get_by_role("tab", name="Mission").click()
        slider = tab.page.locator('xpath=//label[normalize-space()="Time [s]"]/../../following-sibling::*[1]'
                                  '//*[@role="slider"]')
        slider.focus()
        for key, index in (("Home", 0), ("End", -1)):
            slider.press(key)
            lc = state["tracks"]["LC"]
            x, y = lc["x"][index], lc["y"][index]
            tab.page.wait_for_function(
                f"(() => {{ const p = {MAP_JS}; const c = p._fullData.find(t => t.name === 'LC at the cursor');"
                f" return Math.abs(c.x[0] - {x!r}) < 1e-9 && Math.abs(c.y[0] - {y!r}) < 1e-9; }})()", timeout=20000)
            moved = _map(tab)
            assert moved["key"] == state["key"], "the map was sent again for a cursor move"
            ellipse = _cursor(moved, "LC 3σ at the cursor")
            centre_x = (max(ellipse["x"]) + min(ellipse["x"])) / 2
            assert abs(centre_x - lc["x"][index]) < 1e-6, (centre_x, lc["x"][index])

        # colour by error: a marker colour per track point, one colour scale
        tab.choose("Colour by", "error")
        tab.page.wait_for_function(f"(() => {{ const p = {MAP_JS}; const t = p._fullData.find(t => t.name === 'LC');"
                                   " return t && t.marker && t.marker.color && t.marker.color.length > 0; })()", timeout=30000)
        coloured = _map(tab)
        lc = coloured["tracks"]["LC"]
        assert lc["color"] is not None and len(lc["color"]) == len(lc["x"]), lc["color"]
        assert all(isinstance(v, (int, float)) and v >= 0 for v in lc["color"]) and max(lc["color"]) > 0
        assert sum(t["scale"] for t in coloured["tracks"].values()) == 1  # one colour bar
        x_px, y_px = coloured["px_per_m"]
        assert abs(abs(x_px / y_px) - 1.0) < 1e-3, coloured["px_per_m"]
        assert tab.external_requests == []
    finally:
        ctx.close()
