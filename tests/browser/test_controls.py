"""The run uses exactly what the page shows, in a real browser.

viser's page sends control changes through one sender throttled to a message per 50 ms that
keeps only the latest, whatever control it is for: of three changes within 50 ms the middle one
never reached the server (app.dashboard.session_controls.ControlPanel.confirm_page_state). The configuration a run used
is shown in the Results tab ("Configuration run"), which is what these tests read.
"""

from __future__ import annotations

import pytest

from app.dashboard.inputs import (
    DVL_MAX_ALTITUDE,
    RPM_NOISE,
    SEABED_DEPTH,
    SEABED_FOLDER,
    SWITCH_ALTITUDE,
)
from app.figures.vehicle_figures import FIN_NAMES
from tauvcore.config import Config
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser

# three checkbox clicks in one task, by their input ids: all three within one 50 ms window of
# viser's sender whatever the page is doing (clicks 10 ms apart by setTimeout took 40-79 ms on a
# loaded machine, the page's first frames under software WebGL delaying the timers)
THREE_CLICKS_JS = """(names) => {
  const box = (name) => document.getElementById(
      [...document.querySelectorAll('label')].find(l => l.textContent === name).htmlFor);
  const t0 = performance.now();
  for (const name of names) box(name).click();
  return performance.now() - t0;
}"""


def run_and_wait(tab) -> None:
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)


def test_three_changes_within_20_ms_all_reach_the_run(new_tab) -> None:
    """Given VB and PLCF off and beam 4 on, when the three are toggled at once (one script, well
    within viser's 50 ms window) and Run is pressed, then the run used VB and PLCF and not beam 4
    (before: PLCF, the middle change, was lost while its box showed ticked)."""
    tab = new_tab()
    tab.type_into("Duration [s]", "20")
    spread_ms = tab.page.evaluate(THREE_CLICKS_JS, ["VB", "PLCF", "Beam 4"])
    assert spread_ms < 50.0, spread_ms       # within one window of viser's sender
    tab.page.wait_for_timeout(500)
    assert tab.checkbox("VB").is_checked() and tab.checkbox("PLCF").is_checked()
    assert not tab.checkbox("Beam 4").is_checked()
    run_and_wait(tab)
    used = tab.run_config()
    assert used["Methods"] == "INS, LC, TC, VB, NSV, PLCF, ELC"
    assert used["DVL beams"] == "1, 2, 3"
    assert used["Duration [s]"] == "20"


def test_typed_scientific_notation_reaches_the_server_as_typed(new_tab) -> None:
    """ "1e1" typed key by key is 10 s (the browser's number field dropped the "e": 11 s)."""
    tab = new_tab()
    tab.set_methods({"INS", "TC"})
    tab.type_into("Duration [s]", "1e1")
    tab.type_into("Seed", "42")
    run_and_wait(tab)
    used = tab.run_config()
    assert used["Duration [s]"] == "10" and used["Seed"] == "42" and used["Methods"] == "INS, TC"
    # the untouched partial-beam assumptions: n_f's default, epsilon derived from the vehicle
    assert used["VB n_f"] == "20"
    assert used["NSV epsilon [m^2/s^2]"] == f"auto ({Config().nsv_epsilon_value_m2_per_s2():.3g})"


def test_typed_n_f_and_epsilon_reach_the_run(new_tab) -> None:
    """Given n_f 7 and epsilon 0.5 typed into the partial-beam fields, when NSV and VB run, then
    the "Configuration run" table shows both as typed."""
    tab = new_tab()
    tab.set_methods({"NSV", "VB"})
    tab.set_checkbox("Beam 3", False)
    tab.set_checkbox("Beam 4", False)
    tab.type_into("Duration [s]", "10")
    tab.type_into("VB n_f", "7")
    tab.type_into("NSV epsilon [m^2/s^2]", "0.5")
    run_and_wait(tab)
    used = tab.run_config()
    assert used["NSV epsilon [m^2/s^2]"] == "0.5" and used["VB n_f"] == "7"
    assert used["Methods"] == "VB, NSV" and used["DVL beams"] == "1, 2"


@pytest.mark.parametrize("folder, label, typed, message", [
    (None, "Duration [s]", "abc", "Duration [s]: 'abc' is not a number"),
    (None, "Duration [s]", "0.5", "Duration [s]: '0.5' is out of range"),
    (None, "Seed", "2.5", "Seed: '2.5' is not a whole number"),
    ("Sensors (Table 2)", "Gyro noise [deg/sqrt(h)]", "1e6", "Gyro noise [deg/sqrt(h)]: '1e6' is out of range"),
    (None, "Runs", "1000", "GB of memory"),
    (None, "VB n_f", "0", "VB n_f: '0' is out of range: partial.vb_nf"),
    (None, "VB n_f", "nan", "VB n_f: 'nan' is not a number"),
    (None, "NSV epsilon [m^2/s^2]", "-1", "NSV epsilon [m^2/s^2]: '-1' is out of range"),
])
def test_a_bad_typed_value_is_refused_by_name_and_nothing_runs(new_tab, folder, label, typed, message) -> None:
    tab = new_tab()
    page = tab.page
    if folder is not None:
        tab.open_folder(folder)
    tab.type_into(label, typed)
    page.get_by_role("button", name="Run", exact=True).click()
    note = tab.refusal(message)
    note.wait_for(timeout=15000)
    text = note.inner_text()
    assert "Error" not in text and "Singular" not in text          # a clean message, no exception names
    assert page.get_by_text("Cannot run", exact=True).is_visible()
    assert page.get_by_text("Ready. Choose a mission", exact=False).is_visible()   # no run started
    assert page.get_by_role("button", name="Run", exact=True).is_enabled()


def test_bad_seabed_and_rpm_values_are_refused_by_name_then_a_good_run_uses_them(new_tab) -> None:
    """Given Switch altitude -5 and RPM noise -1 typed, when Run is pressed, then a notification
    names the switch altitude and its value (and the RPM noise with it) and nothing runs; with it
    corrected, the RPM noise;
    then DVL max altitude 0, then Seabed depth 12000 (deeper than the deepest ocean). Corrected,
    the same tab runs and the run used the values as typed: the server kept serving."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"INS", "TC"})
    tab.type_into("Duration [s]", "10")
    tab.open_folder(SEABED_FOLDER)
    tab.type_into(SWITCH_ALTITUDE, "-5")
    tab.type_into(RPM_NOISE, "-1")
    steps = (  # the message a Run shows, then what is typed before the next Run
        (f"{SWITCH_ALTITUDE}: '-5' is out of range: vkf.switch_altitude_m", ((SWITCH_ALTITUDE, "40"),)),
        (f"{RPM_NOISE}: '-1' is out of range: rpm.noise_rpm", ((RPM_NOISE, "0"), (DVL_MAX_ALTITUDE, "0"))),
        (f"{DVL_MAX_ALTITUDE}: '0' is out of range: dvl.max_altitude_m", ((DVL_MAX_ALTITUDE, "50"),
                                                                           (SEABED_DEPTH, "12000"))),
        (f"{SEABED_DEPTH}: '12000' is out of range: trajectory.seabed_depth_m", ((SEABED_DEPTH, "80"),)),
    )
    refusals = page.get_by_text("Cannot run", exact=True)
    for message, typed in steps:
        before = refusals.count()
        page.get_by_role("button", name="Run", exact=True).click()
        page.wait_for_function(                  # this press's own notification (they stay), not an earlier one
            "n => Array.from(document.querySelectorAll('.mantine-Notification-title'))"
            ".filter(e => e.textContent === 'Cannot run').length > n", arg=before, timeout=15000)
        note = tab.refusal(message)
        note.wait_for(timeout=15000)
        assert "Error" not in note.inner_text() and "Traceback" not in note.inner_text()
        assert page.get_by_text("Ready. Choose a mission", exact=False).is_visible()   # no run started
        assert page.get_by_role("button", name="Run", exact=True).is_enabled()
        for label, text in typed:
            tab.type_into(label, text)
    run_and_wait(tab)
    used = tab.run_config()
    assert used[SWITCH_ALTITUDE] == "40" and used[RPM_NOISE] == "0" and used[DVL_MAX_ALTITUDE] == "50"
    assert used["Duration [s]"] == "10" and used["Seabed"] == "flat, 80 m"


def test_truth_dynamic_reaches_the_run_and_shows_its_fins_and_propeller(new_tab) -> None:
    """Given Truth: dynamic on the figure eight, when a 10 s run completes, then the run used the
    dynamic truth and the Vehicle tab plots the four fins and the propeller; given Truth back to
    kinematic, the next run's Vehicle tab has no figure and says why."""
    tab = new_tab()
    page = tab.page
    tab.choose_trajectory("figure8")
    tab.choose("Truth", "dynamic")
    tab.set_methods({"INS", "TC"})
    tab.type_into("Duration [s]", "10")
    run_and_wait(tab)
    used = tab.run_config()
    assert used["Truth"] == "dynamic" and used["Trajectory"] == "figure8"
    page.get_by_role("tab", name="Vehicle").click()
    page.wait_for_timeout(1000)
    fins = [dict(f) for f in tab.plot_traces() if any(name == "propeller" for name, _ in f)]
    assert len(fins) == 1, tab.plot_traces()
    assert set(fins[0]) == {*FIN_NAMES, "propeller"}
    assert all(n == 101 for n in fins[0].values())          # 10 s at the 10 Hz output rate
    page.screenshot(path=str(ARTIFACTS / "dashboard_vehicle.png"))
    page.get_by_role("tab", name="Mission").click()
    tab.choose("Truth", "kinematic")
    page.get_by_text("Run complete", exact=True).first.wait_for(state="hidden", timeout=15000)
    run_and_wait(tab)
    assert tab.run_config()["Truth"] == "kinematic"
    page.get_by_role("tab", name="Vehicle").click()
    page.get_by_text("the kinematic truth is closed-form motion", exact=False).wait_for(timeout=10000)
    assert not [f for f in tab.plot_traces() if any(name == "propeller" for name, _ in f)]
