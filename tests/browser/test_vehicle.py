"""The "Your vehicle" folder in a real browser, on a simulated log the server lists with ``--logs``:
Calibrate shows its table and Apply says the calibration applies at Run; Tune runs with its
progress, Stop ends it with the best point so far and its before/after table, and Apply fills the
noise controls it names; the next Run replays the log with them."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator

import pytest
from playwright.sync_api import expect

from tests.browser.conftest import ARTIFACTS, THROTTLE_FRAMES, Tab, dashboard_server

pytestmark = pytest.mark.browser

FOLDER = "Your vehicle: calibrate and tune"


@pytest.fixture(scope="module")
def logs_url(tmp_path_factory) -> Iterator[str]:
    """``tauv serve --logs DIR`` where DIR holds ``dive``: 400 s of the figure eight (long enough
    that a tuning is still searching when Stop is pressed), saved by ``tauv run --save-log`` (its
    reference the truth)."""
    logs = tmp_path_factory.mktemp("logs")
    subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--trajectory", "figure8", "--duration", "400", "--method", "lc",
         "--seed", "1", "--save-log", str(logs / "dive")],
        check=True, capture_output=True, timeout=300,
    )
    ARTIFACTS.mkdir(exist_ok=True)
    with open(ARTIFACTS / "server_vehicle.log", "w") as log, dashboard_server(log, extra=("--logs", str(logs))) as url:
        yield url


@pytest.fixture
def tab(browser, logs_url) -> Iterator[Tab]:
    ctx = browser.new_context(viewport={"width": 1500, "height": 950})
    ctx.add_init_script(THROTTLE_FRAMES)
    try:
        yield Tab(ctx.new_page(), logs_url)
    finally:
        ctx.close()


def _choose_dive(tab: Tab) -> None:
    tab.choose("Source", "dive", exact=False)
    tab.page.get_by_text("dive", exact=False).first.wait_for(timeout=30000)


def test_calibrate_then_apply_on_a_log(tab: Tab) -> None:
    """Given the log chosen as Source, Calibrate shows "Calibration of dive" with the
    command's table, and Apply says the calibration applies at Run."""
    _choose_dive(tab)
    tab.open_folder(FOLDER)
    tab.page.get_by_role("button", name="Calibrate", exact=True).click()
    tab.page.locator("strong", has_text="Calibration of dive").wait_for(timeout=180000)
    expect(tab.page.get_by_text("calibration from 1 log", exact=False).first).to_be_visible(timeout=10000)
    tab.page.locator("strong", has_text="Calibration of dive").scroll_into_view_if_needed()
    tab.page.screenshot(path=str(ARTIFACTS / "vehicle_calibrate.png"))
    apply = tab.page.get_by_role("button", name="Apply", exact=True)
    expect(apply).to_be_enabled(timeout=10000)
    apply.click()
    tab.notification("Applied to log dive").wait_for(timeout=30000)
    expect(tab.page.locator(".mantine-Notification-description", has_text="apply at Run").last).to_be_visible(
        timeout=10000
    )


def test_tune_stopped_keeps_its_best_point_and_apply_fills_the_controls(tab: Tab) -> None:
    """Given the log chosen as Source, Tune starts on a worker (Calibrate and Tune disabled
    while it runs); Stop ends it with "Stopped: the best point so far" and the before/after
    table; Apply fills in the DVL noise control, and Run replays the log with it."""
    _choose_dive(tab)
    tab.open_folder(FOLDER)
    tune = tab.page.get_by_role("button", name="Tune", exact=True)
    tune.click()
    expect(tune).to_be_disabled(timeout=30000)
    stop = tab.page.get_by_role("button", name="Stop", exact=True)
    expect(stop).to_be_enabled(timeout=30000)
    tab.page.wait_for_timeout(2000)
    stop.click()
    tab.page.locator("strong", has_text="Tuning of dive").wait_for(timeout=180000)
    expect(tab.page.get_by_text("Stopped: the best point so far", exact=False)).to_be_visible(timeout=10000)
    expect(tab.page.get_by_text("NIS/dof", exact=False).first).to_be_visible(timeout=10000)
    expect(tune).to_be_enabled(timeout=30000)
    tab.page.locator("strong", has_text="Tuning of dive").scroll_into_view_if_needed()
    tab.page.screenshot(path=str(ARTIFACTS / "vehicle_tune.png"))
    tab.page.get_by_role("button", name="Apply", exact=True).click()
    tab.notification("Applied to log dive").wait_for(timeout=30000)
    expect(tab.page.locator(".mantine-Notification-description", has_text="filled in").last).to_be_visible(
        timeout=10000
    )
    tab.page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=180000)
    assert tab.run_config()["Source"] == "log dive"
