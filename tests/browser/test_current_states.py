"""Water-track and the current states in a real browser: chosen in the Seabed folder, they reach
the run, the address, the Consistency tab's NEES of the block "current", the Innovations' source
"water" and the Sensors tab's figure of the current's estimate; a combination the configuration
refuses is a notification naming a control, and the server goes on serving.

The dashboard of this branch flies still water (the current's own controls are another branch's):
the truth drawn is a zero current, which the filter must find from a prior of 0.5 m/s.
"""

from __future__ import annotations

import pytest

from app.dashboard.inputs import DVL_CURRENT_STATES, DVL_MAX_ALTITUDE, DVL_WATER_TRACK, SEABED_FOLDER
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
FIGURES_JS = (
    "Array.from(document.querySelectorAll('.js-plotly-plot'))"
    ".map(p => ({title: (p.layout.title && p.layout.title.text) || '', traces: (p._fullData || [])"
    ".map(t => ({name: t.name, y: Array.from(t.y || [])}))}))"
)



def figure(tab, title_start: str, timeout_ms: float = 30000) -> dict:
    """The plotly figure of the page whose title starts with ``title_start``, once it shows."""
    tab.page.wait_for_function(f"{FIGURES_JS}.some(f => f.title.startsWith({title_start!r}))", timeout=timeout_ms)
    return next(f for f in tab.page.evaluate(FIGURES_JS) if f["title"].startswith(title_start))


def refused_with(tab, message: str) -> None:
    """Press Run and wait for this press's "Cannot run" holding ``message``; nothing runs."""
    page = tab.page
    before = page.get_by_text("Cannot run", exact=True).count()
    page.get_by_role("button", name="Run", exact=True).click()
    page.wait_for_function(
        "n => Array.from(document.querySelectorAll('.mantine-Notification-title'))"
        ".filter(e => e.textContent === 'Cannot run').length > n", arg=before, timeout=15000)
    note = tab.refusal(message)
    note.wait_for(timeout=15000)
    assert "Error" not in note.inner_text() and "Traceback" not in note.inner_text()
    assert page.get_by_text("Ready. The page's address set", exact=False).is_visible()   # no run started
    assert page.get_by_role("button", name="Run", exact=True).is_enabled()


def test_water_track_and_current_states_reach_the_run_the_nees_and_the_current_s_figure(new_tab) -> None:
    """Given LC on a 30 s figure eight with Water-track "always" and Current states "random-walk"
    chosen in the Seabed folder, when the DVL's range is typed below the water-track layer, then
    Run names DVL max altitude and the water-track; put right, with the Smoother ticked, the run
    completes: the Results tab and the address carry both choices, the
    Consistency tab offers the block "current" and draws LC's NEES of it, the Innovations offer
    the water-track source, and the Sensors tab draws LC's current north and east against the truth."""
    tab = new_tab("?traj=figure8&dur=30&m=lc")
    page = tab.page
    tab.open_folder(SEABED_FOLDER, reveals=DVL_MAX_ALTITUDE)
    tab.choose(DVL_WATER_TRACK, "always")
    tab.choose(DVL_CURRENT_STATES, "random-walk")
    tab.type_into(DVL_MAX_ALTITUDE, "5")
    refused_with(tab, f"{DVL_MAX_ALTITUDE}: '5' is out of range with {DVL_WATER_TRACK} 'always'")
    tab.type_into(DVL_MAX_ALTITUDE, "100")
    tab.set_checkbox("Smoother", True)  # the smoother takes the current states too
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").last.wait_for(timeout=120000)

    used = tab.run_config()
    assert used[DVL_WATER_TRACK].startswith("always, layer 10 m"), used
    assert used[DVL_CURRENT_STATES].startswith("random-walk, 1-sigma 0.5 m/s"), used
    assert "&wt=always&cst=random-walk&" in page.url

    page.get_by_role("tab", name="Consistency").click()
    tab.choose("NEES block", "current")
    nees = figure(tab, "NEES/dim, current (north, east) (dim 2)")
    lc = next(t for t in nees["traces"] if t["name"] == "LC")
    assert len(lc["y"]) == 301 and sum(v is not None for v in lc["y"]) > 250          # 30 s at 10 Hz

    page.get_by_role("tab", name="Innovations").click()
    page.get_by_label("Aiding source", exact=True).click()
    page.get_by_role("option", name="water", exact=True).wait_for(timeout=15000)
    page.keyboard.press("Escape")

    page.get_by_role("tab", name="Sensors").click()
    current = figure(tab, "Current at the vehicle")
    traces = {t["name"]: t["y"] for t in current["traces"]}
    assert {"LC current north", "LC current east", "true current north", "true current east"} <= set(traces)
    assert len(traces["LC current east"]) == 301 and set(traces["true current east"]) == {0}      # still water
    assert abs(traces["LC current east"][-1]) < 0.2            # found from a prior of 0.5 m/s
    page.get_by_text("Current at the vehicle", exact=False).first.scroll_into_view_if_needed()
    page.screenshot(path=str(ARTIFACTS / "dashboard_current_states.png"))
    assert tab.external_requests == []
