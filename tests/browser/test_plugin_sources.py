"""A plug-in aiding source from the page (app.dashboard.controls): the Aiding folder offers the USBL with its
section's controls; ticked, a run fuses it and the Innovations tab shows its panels."""

from __future__ import annotations

import os

import pytest

from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser

SCREENSHOT = os.environ.get("TAUV_USBL_SCREENSHOT", str(ARTIFACTS / "usbl_aiding.png"))
TITLES_JS = ("Array.from(document.querySelectorAll('.js-plotly-plot'))"
             ".map(p => (p.layout.title && p.layout.title.text) || '')")


def test_usbl_ticked_in_the_aiding_folder_runs_and_shows_its_innovations(new_tab) -> None:
    """Given a 30 s straight run with LC, when USBL is ticked in the Aiding folder with a fix every
    2 s, then the run completes, its configuration names the USBL, and the Innovations tab offers
    "usbl", whose plot has one panel per row of the fix (north, east, down) with LC's fixes."""
    tab = new_tab()
    tab.type_into("Duration [s]", "30")
    tab.set_methods({"LC"})
    tab.open_folder("Aiding")
    tab.checkbox("USBL").wait_for(state="visible", timeout=15000)
    tab.set_checkbox("USBL", True)
    tab.open_folder("USBL settings", reveals="USBL fix interval [s]")
    tab.type_into("USBL fix interval [s]", "2")
    tab.field("USBL latency [s]").scroll_into_view_if_needed(timeout=15000)
    tab.page.screenshot(path=SCREENSHOT)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    config = tab.run_config()
    assert config["Aiding"] == "dvl, usbl" and config["USBL fix interval [s]"] == "2", config
    tab.page.get_by_role("tab", name="Innovations").click()
    tab.page.wait_for_function(f"{TITLES_JS}.some(t => t.includes('innovations'))", timeout=30000)
    tab.choose("Aiding source", "usbl")
    tab.page.wait_for_function(f"{TITLES_JS}.some(t => t.startsWith('USBL innovations'))", timeout=30000)
    panels = tab.page.evaluate(
        "Array.from(document.querySelectorAll('.js-plotly-plot'))"
        ".filter(p => ((p.layout.title && p.layout.title.text) || '').startsWith('USBL innovations'))"
        ".map(p => Object.keys(p.layout).filter(k => k.startsWith('yaxis'))"
        ".map(k => (p.layout[k].title && p.layout[k].title.text) || ''))")
    assert len(panels) == 1 and len(panels[0]) == 3, panels
    assert [any(row in t for t in panels[0]) for row in ("north", "east", "down")] == [True] * 3, panels
    lc = [n for f in tab.plot_traces() for name, n in f if name == "LC"]
    assert lc and max(lc) >= 10, lc   # 30 s of fixes every 2 s, a few lost
    assert tab.external_requests == []
