"""The workbench: runs kept and overlaid, the shared time cursor, diagnostics per method."""

from __future__ import annotations

import pytest

from app.dashboard.inputs import DVL_NOISE
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
CURSORS_JS = ("Array.from(document.querySelectorAll('.js-plotly-plot'))"
              ".filter(p => p.data && p.data.length)"
              ".map(p => ((p.layout.shapes || []).find(s => s.name === 'time cursor') || {}).x0)")


def _run(tab, number: int) -> None:
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.page.get_by_role("tab", name="Runs").click()
    tab.checkbox(f"Overlay run {number}").wait_for(timeout=120000)


def test_two_runs_overlaid_compared_cursor_and_diagnostics(new_tab) -> None:
    """Given two 10 s straight runs (LC; then LC and TC with a quieter DVL), when both are ticked
    in the Runs tab, then the plots overlay both runs' traces and the configuration differences
    name the changed fields, and the NEES plot overlays both runs too; moving the time slider moves
    the cursor on every plot; the innovation plot holds a curve with data for every selected method."""
    tab = new_tab()
    tab.type_into("Duration [s]", "10")
    tab.set_methods({"LC"})
    _run(tab, 1)
    tab.page.get_by_role("tab", name="Mission").click()
    tab.set_methods({"LC", "TC"})
    tab.open_folder("Sensors (Table 2)")
    tab.type_into(DVL_NOISE, "0.02")
    _run(tab, 2)
    for n in (1, 2):
        tab.set_checkbox(f"Overlay run {n}", True)
    diff = tab.page.locator("table", has=tab.page.get_by_text("setting", exact=True))
    diff.wait_for(timeout=20000)
    rows = diff.locator("tr").all_inner_texts()
    assert any(r.startswith("DVL noise") and "0.02 m/s" in r for r in rows), rows
    assert any(r.startswith("methods") for r in rows), rows
    side = tab.page.locator("table", has=tab.page.get_by_text("run 2", exact=True)).last.locator("tr").all_inner_texts()
    assert any(r.startswith("TC\trun 2") for r in side), side
    tab.page.get_by_role("tab", name="Plots").click()
    tab.page.wait_for_function("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                               ".some(p => (p.data || []).some(t => t.name === 'TC (run 2)'))", timeout=20000)
    velocity = dict(tab.plot_traces()[0])
    assert {"LC (run 1)", "LC (run 2)", "TC (run 2)"} <= set(velocity) and min(velocity.values()) > 50, velocity
    tab.page.screenshot(path=str(ARTIFACTS / "workbench.png"))

    # the shared cursor: the run left the slider at its end; Home takes it to 0 on every plot
    tab.page.get_by_role("tab", name="Mission").click()
    slider = tab.page.locator('xpath=//label[normalize-space()="Time [s]"]/../../following-sibling::*[1]'
                              '//*[@role="slider"]')
    slider.focus()
    slider.press("End")
    tab.page.wait_for_function(f"(() => {{ const c = {CURSORS_JS}; return c.length > 3 && c.every(x => x > 9); }})()",
                               timeout=20000)
    slider.press("Home")
    tab.page.wait_for_function(f"(() => {{ const c = {CURSORS_JS}; return c.length > 3 && c.every(x => x === 0); }})()",
                               timeout=20000)

    # diagnostics: the NEES of both runs overlaid (as the errors), the innovations of the current
    # run (LC, TC), with data for each
    tab.page.get_by_role("tab", name="Consistency").click()
    nees = [dict(f) for f in tab.plot_traces() if any(name == "99 % band" for name, _ in f)]
    assert len(nees) == 1, nees
    assert all(nees[0].get(name, 0) > 50 for name in ("LC (run 1)", "LC (run 2)", "TC (run 2)")), nees
    tab.page.get_by_role("tab", name="Innovations").click()
    innovations = [dict(f) for f in tab.plot_traces() if "TC" in dict(f) and "LC" in dict(f) and "LC (run 1)" not in dict(f)]
    assert any(f["LC"] >= 9 and f["TC"] >= 9 for f in innovations), innovations   # 10 s of 1 Hz DVL
    assert tab.external_requests == []


def test_a_new_run_clears_the_overlay_and_each_kept_run_says_what_tells_it_apart(new_tab) -> None:
    """Given two kept 10 s runs, four beams and then beams 1-2, ticked for overlay, when Run is
    pressed again, then the boxes are unticked and the plots show the new run, not the kept
    pair; each entry names its beams and seed, so the two look different."""
    tab = new_tab()
    tab.type_into("Duration [s]", "10")
    tab.set_methods({"LC", "TC"})
    _run(tab, 1)
    tab.page.get_by_role("tab", name="Mission").click()
    tab.set_checkbox("Beam 3", False)
    tab.set_checkbox("Beam 4", False)
    _run(tab, 2)
    entries = {n: tab.page.get_by_text(text, exact=False)
               for n, text in ((1, "straight, 10 s, seed 0, LC TC"), (2, "straight, 10 s, seed 0, LC TC, beams 1,2"))}
    for n, entry in entries.items():
        entry.first.wait_for(timeout=20000)
    for n in (1, 2):
        tab.set_checkbox(f"Overlay run {n}", True)
    tab.page.get_by_role("tab", name="Plots").click()
    tab.page.wait_for_function("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                               ".some(p => (p.data || []).some(t => t.name === 'TC (run 2)'))", timeout=20000)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").last.wait_for(timeout=120000)
    tab.page.wait_for_function("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                               ".some(p => (p.data || []).some(t => t.name === 'TC'))", timeout=20000)
    velocity = dict(tab.plot_traces()[0])
    assert not any("(run " in name for name in velocity), velocity
    assert {"LC", "TC"} <= set(velocity), velocity
    tab.page.get_by_role("tab", name="Runs").click()
    for n in (1, 2):
        assert not tab.checkbox(f"Overlay run {n}").is_checked()
    assert tab.external_requests == []


def test_a_registered_method_runs_from_the_dashboard(new_tab) -> None:
    """Given the registered method CV (tauvcore/aiding/cv.py) ticked beside LC, when a 10 s run
    ends, then the error plots hold a CV curve with data, in CV's own colour, and the Innovations
    tab offers CV's updates as a source of their own."""
    from app.figures.shared import METHOD_COLORS
    from tauvcore.aiding.registry import REGISTRY

    tab = new_tab()
    tab.type_into("Duration [s]", "10")
    tab.set_methods({"LC"})
    tab.set_checkbox("CV", True)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    velocity = dict(tab.plot_traces()[0])
    assert velocity.get("CV", 0) > 50 and velocity.get("LC", 0) > 50, velocity
    colour = tab.page.evaluate("Array.from(document.querySelectorAll('.js-plotly-plot'))[0]"
                               "._fullData.find(t => t.name === 'CV').line.color")
    assert colour == METHOD_COLORS["cv"]
    tab.page.get_by_role("tab", name="Innovations").click()
    source = REGISTRY["cv"].source
    tab.page.wait_for_function("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                               ".some(p => (p.layout.title && p.layout.title.text || '').includes('innovation'))",
                               timeout=30000)   # the diagnostics are drawn once the tab is still (QUIET_S)
    tab.page.get_by_label("Aiding source", exact=True).click()
    tab.page.get_by_role("option", name=source, exact=True).wait_for(timeout=10000)


def test_a_monte_carlo_run_s_innovations_are_chosen_by_its_number(new_tab) -> None:
    """Given a Monte Carlo of 3 runs, the Innovations tab shows run 1's and offers a Run field;
    when it is set to 2, then the plot shows run 2's innovations (its title says so)."""
    tab = new_tab()
    tab.type_into("Duration [s]", "10")
    tab.type_into("Runs", "3")
    tab.set_methods({"LC", "TC"})
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    tab.page.get_by_role("tab", name="Innovations").click()
    titles_js = ("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                 ".map(p => (p.layout.title && p.layout.title.text) || '').filter(t => t.includes('innovations'))")
    tab.page.wait_for_function(f"{titles_js}.some(t => t.endsWith('run 1'))", timeout=30000)
    box = tab.field("Run")
    box.fill("2")
    box.press("Enter")
    tab.page.wait_for_function(f"{titles_js}.some(t => t.endsWith('run 2'))", timeout=30000)
    # LC's body axes and TC's beams in panels of their own: 3 + 4
    panels = tab.page.evaluate("Array.from(document.querySelectorAll('.js-plotly-plot'))"
                               ".filter(p => ((p.layout.title && p.layout.title.text) || '').includes('innovations'))"
                               ".map(p => Object.keys(p.layout).filter(k => k.startsWith('yaxis')).length)")
    assert panels == [7], panels


SENSOR_FIGURES_JS = (
    "Array.from(document.querySelectorAll('.js-plotly-plot'))"
    ".filter(p => /^(Raw sensors|[A-Z-]+: sensor errors)/.test((p.layout.title && p.layout.title.text) || ''))"
    ".map(p => ({title: p.layout.title.text, traces: (p._fullData || []).map(t => ({name: t.name, y: Array.from(t.y || []),"
    " x: Array.from(t.x || [])}))}))"
)


def test_the_sensors_tab_shows_the_raw_channels_and_each_method_s_sensor_errors(new_tab) -> None:
    """Given a 20 s figure eight with beams 1 and 2 (LC and TC), the Sensors tab draws the gyro,
    the accelerometer and the DVL's four beams, beams 3 and 4 as gaps (no value at any ping) and
    switched off in the beam-state panel, depth and the magnetometer's attitude; below, LC's sensor
    errors (estimate, 3-sigma and truth); choosing TC draws TC's."""
    tab = new_tab("?traj=figure8")
    tab.type_into("Duration [s]", "20")
    tab.set_methods({"LC", "TC"})
    tab.set_checkbox("Beam 3", False)
    tab.set_checkbox("Beam 4", False)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    tab.page.get_by_role("tab", name="Sensors").click()
    tab.page.wait_for_function(f"{SENSOR_FIGURES_JS}.length === 2", timeout=30000)
    raw, errors = sorted(tab.page.evaluate(SENSOR_FIGURES_JS), key=lambda f: f["title"] != "Raw sensors")
    traces = {t["name"]: t for t in raw["traces"]}
    for name in ("gyro x", "gyro z", "accelerometer z", "beam1", "beam2", "beam3", "beam4", "depth", "yaw"):
        assert name in traces, sorted(traces)
    assert len(traces["gyro x"]["y"]) >= 150                                  # 10 Hz over 20 s
    assert all(v is None or v != v for v in traces["beam3"]["y"] + traces["beam4"]["y"])  # gaps, not zeros
    assert sum(v is not None and v == v for v in traces["beam1"]["y"]) >= 15    # 1 Hz DVL
    off = traces["switched off"]
    assert set(off["y"]) == {3, 4} and len(off["x"]) == 2 * len(traces["beam1"]["x"])
    assert errors["title"].startswith("LC: sensor errors"), errors["title"]
    names = {t["name"] for t in errors["traces"]}
    assert {"gyro bias z (body) estimate", "gyro bias z (body) +3 sigma", "gyro bias z (body) true",
            "DVL scale factor error estimate"} <= names, sorted(names)
    tab.choose("Sensor errors of", "tc")
    tab.page.wait_for_function(f"{SENSOR_FIGURES_JS}.some(f => f.title.startsWith('TC: sensor errors'))",
                               timeout=30000)
    tab.page.screenshot(path=str(ARTIFACTS / "sensors_tab.png"))
    assert tab.external_requests == []
