"""The smoother in a real browser: ticked before Run, its Smoothed boxes become usable when the
run ends and draw each 20-state method's smoothed curve; a bad memory is a notification."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser


def test_smoothed_toggles_the_smoothed_traces_after_a_short_run(new_tab) -> None:
    """Given the Smoother ticked and LC, TC and VKF on a 40 s mission, when the run ends and
    Smoothed is ticked, then the velocity plot holds "LC smoothed", "TC smoothed" and "VKF
    smoothed"; unticked, it holds none; Smoothed NEES does the same."""
    tab = new_tab("?dur=40&m=lc,tc,vkf")
    smoothed = tab.checkbox("Smoothed")
    expect(smoothed).to_be_disabled(timeout=10000)  # no smoothed results before a run
    tab.set_checkbox("Smoother", True)
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    tab.page.get_by_role("tab", name="Plots").click()
    expect(smoothed).to_be_enabled(timeout=10000)

    def velocity() -> set[str]:
        return {name for name, _ in tab.plot_traces()[0]}

    assert velocity() == {"LC", "TC", "VKF"}
    tab.set_checkbox("Smoothed", True)
    for _ in range(50):
        if "LC smoothed" in velocity():
            break
        tab.page.wait_for_timeout(200)
    assert velocity() == {"LC", "TC", "VKF", "LC smoothed", "TC smoothed", "VKF smoothed"}
    tab.page.screenshot(path=str(ARTIFACTS / "smoothed_plots.png"))
    tab.set_checkbox("Smoothed", False)
    for _ in range(50):
        if "LC smoothed" not in velocity():
            break
        tab.page.wait_for_timeout(200)
    assert velocity() == {"LC", "TC", "VKF"}
    tab.page.get_by_role("tab", name="Consistency").click()
    tab.set_checkbox("Smoothed NEES", True)

    def nees() -> set[str]:
        figures = [f for f in tab.plot_traces() if any(name == "99 % band" or name.startswith("99 % band") for name, _ in f)]
        return {name for name, _ in figures[0]} if figures else set()

    for _ in range(50):
        if "TC smoothed" in nees():
            break
        tab.page.wait_for_timeout(200)
    assert {"LC smoothed", "TC smoothed", "VKF smoothed"} <= nees()
    tab.page.get_by_role("tab", name="Results").click()
    expect(tab.page.get_by_text("the fixed-interval smoother over the whole run")).to_be_visible(timeout=10000)


def test_a_bad_smoother_memory_gets_a_notification(new_tab) -> None:
    tab = new_tab("?dur=10")
    tab.set_checkbox("Smoother", True)
    tab.type_into("Smoother memory [MB]", "lots")
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.page.get_by_text("Cannot run", exact=True).wait_for(timeout=10000)
    tab.refusal("Smoother memory [MB]: 'lots' is not a number").wait_for(timeout=10000)
