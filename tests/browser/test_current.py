"""The ocean current in a real browser: typed into its folder, it reaches the run, the address and
the Vehicle tab; a current the configuration refuses is a notification naming its control, and the
server goes on serving."""

from __future__ import annotations

import pytest

from app.dashboard.inputs import CURRENT_FOLDER, CURRENT_SPEED, CURRENT_TOWARD, CURRENT_VARIATION
from app.figures.vehicle_figures import (
    CURRENT_EAST_NAME,
    CURRENT_NORTH_NAME,
    GROUND_SPEED_NAME,
    WATER_SPEED_NAME,
)
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
CURRENT_TRACES = {CURRENT_NORTH_NAME, CURRENT_EAST_NAME, WATER_SPEED_NAME, GROUND_SPEED_NAME}


def run_and_wait(tab) -> None:
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").last.wait_for(timeout=120000)


def current_figures(tab) -> list[dict[str, int]]:
    return [dict(f) for f in tab.plot_traces() if any(name == CURRENT_NORTH_NAME for name, _ in f)]


def test_a_typed_current_reaches_the_run_the_address_and_the_vehicle_tab(new_tab) -> None:
    """Given 0.5 m/s toward 90 deg typed into the current's folder, when a 10 s run completes,
    then the run flew it (the Results tab's "Current"), the address carries it, and the Vehicle
    tab of the kinematic truth plots the current and both speeds under its note; back in still
    water, the next run's Vehicle tab has no current figure."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"INS", "TC"})
    tab.type_into("Duration [s]", "10")
    tab.open_folder(CURRENT_FOLDER, reveals=CURRENT_SPEED)
    tab.type_into(CURRENT_SPEED, "0.5")
    tab.type_into(CURRENT_TOWARD, "90")
    tab.type_into(CURRENT_VARIATION, "0.05")
    run_and_wait(tab)
    used = tab.run_config()
    assert used["Current"] == "0.5 m/s toward 90 deg, variation 0.05 m/s RMS (600 s, seed 0)"
    assert "cur=0.5&cto=90&csh=0&cvar=0.05" in page.url
    page.get_by_role("tab", name="Vehicle").click()
    page.get_by_text("speed through the water", exact=False).wait_for(timeout=10000)
    figures = current_figures(tab)
    assert len(figures) == 1 and set(figures[0]) == CURRENT_TRACES, tab.plot_traces()
    assert all(n == 101 for n in figures[0].values())  # 10 s at the 10 Hz output rate
    assert page.get_by_text("the kinematic truth is closed-form motion", exact=False).is_visible()
    page.screenshot(path=str(ARTIFACTS / "dashboard_current.png"))
    page.get_by_role("tab", name="Mission").click()
    tab.type_into(CURRENT_SPEED, "0")
    tab.type_into(CURRENT_VARIATION, "0")
    page.get_by_text("Run complete", exact=True).first.wait_for(state="hidden", timeout=15000)
    run_and_wait(tab)
    assert tab.run_config()["Current"] == "still water"
    page.get_by_role("tab", name="Vehicle").click()
    page.get_by_text("the kinematic truth is closed-form motion", exact=False).wait_for(timeout=10000)
    assert not current_figures(tab)


def test_a_current_the_configuration_refuses_is_named_by_its_control_and_the_server_goes_on(new_tab) -> None:
    """Given 2.5 m/s against the vehicle's 2 m/s, then 1.5 m/s across the figure eight (a crab
    beyond 45 deg for the kinematic truth), when Run is pressed, then each is one notification
    naming Current [m/s], its value as typed and the configuration's reason, and nothing runs;
    with 1 m/s the same tab runs."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"INS", "TC"})
    tab.type_into("Duration [s]", "10")
    tab.open_folder(CURRENT_FOLDER, reveals=CURRENT_SPEED)
    tab.type_into(CURRENT_SPEED, "2.5")
    steps = (  # the message a Run shows, what it must hold, then what is done before the next Run
        (
            f"{CURRENT_SPEED}: '2.5' is out of range: trajectory.current_n_mps",
            "not below the vehicle's speed trajectory.speed_mps 2.0 m/s",
            lambda: (tab.choose_trajectory("figure8"), tab.type_into(CURRENT_SPEED, "1.5")),
        ),
        (
            f"{CURRENT_SPEED}: '1.5' is out of range: trajectory.current_n_mps",
            "would crab",
            lambda: tab.type_into(CURRENT_SPEED, "1"),
        ),
    )
    refusals = page.get_by_text("Cannot run", exact=True)
    for message, reason, then in steps:
        before = refusals.count()
        page.get_by_role("button", name="Run", exact=True).click()
        page.wait_for_function(
            "n => Array.from(document.querySelectorAll('.mantine-Notification-title'))"
            ".filter(e => e.textContent === 'Cannot run').length > n",
            arg=before,
            timeout=15000,
        )
        note = tab.refusal(message)
        note.wait_for(timeout=15000)
        text = note.inner_text()
        assert reason in text and "Error" not in text and "Traceback" not in text
        assert page.get_by_text("Ready. Choose a mission", exact=False).is_visible()  # no run started
        assert page.get_by_role("button", name="Run", exact=True).is_enabled()
        then()
    run_and_wait(tab)
    used = tab.run_config()
    assert used["Current"] == "1 m/s toward 0 deg" and used["Trajectory"] == "figure8"
