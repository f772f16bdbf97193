"""Runs and files named for what they are, and a replay's controls honest, in a real browser.

One server for the module, with a short simulated log (``dive``) offered as a Source. In one tab a
refused Run leaves a red "Cannot run" notice; a run with a current, water-track "both", the
current states and the smoother clears it, draws the lime water-track beams in the Sensors beam
panel and names its download for all of that; a plain run after it unticks Smoothed and has
another label and file name; the Runs tab's difference table reads in words at both window
sizes. In another tab the log as Source disables Trajectory and Duration with the reason, and
the replay's status names the DVL noise carried into it.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator

import pytest
from playwright.sync_api import expect

from app.dashboard.inputs import (
    CURRENT_FOLDER,
    CURRENT_SPEED,
    DURATION,
    DVL_CURRENT_STATES,
    DVL_MAX_ALTITUDE,
    DVL_NOISE,
    DVL_WATER_TRACK,
    SEABED_FOLDER,
    TRAJECTORY,
)
from tests.browser.conftest import ARTIFACTS, THROTTLE_FRAMES, Tab, dashboard_server

pytestmark = pytest.mark.browser
CURRENT_RUN = "?traj=straight&dur=20&m=lc&seed=1&wt=both&cst=random-walk&cur=0.3&cto=45&sm=1"
"""A 20 s straight run of LC with a current of 0.3 m/s towards 45°, water-track "both", the
current as states and the smoother."""
LIME = "rgb(0, 255, 0)"
FIGURES_JS = (
    "Array.from(document.querySelectorAll('.js-plotly-plot')).map(p => (p._fullData || [])"
    ".map(t => ({name: t.name, color: (t.marker && t.marker.color) || '', n: (t.y || []).length})))"
)
SIZES = ((1600, 1000), (1280, 800))


@pytest.fixture(scope="module")
def logs_url(tmp_path_factory) -> Iterator[str]:
    """``tauv serve --logs DIR`` where DIR holds ``dive``: 30 s of the straight mission saved by
    ``tauv run --save-log``."""
    logs = tmp_path_factory.mktemp("logs")
    subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--trajectory", "straight", "--duration", "30", "--method", "lc",
         "--seed", "1", "--save-log", str(logs / "dive")],
        check=True, capture_output=True, timeout=300,
    )
    ARTIFACTS.mkdir(exist_ok=True)
    with open(ARTIFACTS / "server_names.log", "w") as log, dashboard_server(log, extra=("--logs", str(logs))) as url:
        yield url


@pytest.fixture
def tabs(browser, logs_url) -> Iterator:
    contexts = []

    def make(query: str = "") -> Tab:
        ctx = browser.new_context(viewport={"width": 1600, "height": 1000})
        ctx.add_init_script(THROTTLE_FRAMES)
        contexts.append(ctx)
        return Tab(ctx.new_page(), logs_url + query)

    yield make
    for ctx in contexts:
        ctx.close()


def _run(tab: Tab, count: int) -> None:
    """Press Run and wait for its "Run complete" notification (the tab's ``count``-th run; the
    previous one's notification, which closes after 6 s, gone first)."""
    complete = tab.page.locator(".mantine-Notification-title", has_text="Run complete")
    expect(complete).to_have_count(0, timeout=30000)
    tab.page.get_by_role("tab", name="Mission").click()
    tab.page.get_by_role("button", name="Run", exact=True).click()
    try:
        complete.first.wait_for(timeout=180000)
    except Exception:
        tab.page.screenshot(path=str(ARTIFACTS / f"names_run_{count}_failed.png"))
        raise


def _download_name(tab: Tab) -> str:
    page = tab.page
    page.get_by_role("tab", name="Results").click()
    button = page.get_by_role("button", name="JSON", exact=True)
    expect(button).to_be_enabled(timeout=30000)
    with page.expect_download(timeout=60000) as info:
        button.click()
    return info.value.suggested_filename


def _choose(tab: Tab, label: str, option: str) -> None:
    """Tab.choose, once more after a pause if the page was too busy to take the click (a run's
    figures being drawn under software WebGL); the dropdown then shows ``option``."""
    for attempt in range(2):
        tab.page.wait_for_timeout(2000)
        try:
            tab.choose(label, option)
            break
        except Exception:
            if attempt == 1:
                raise
            tab.page.keyboard.press("Escape")
    expect(tab.page.get_by_label(label, exact=True).first).to_have_value(option, timeout=15000)


def test_runs_are_named_for_their_settings_and_the_page_keeps_no_stale_notice_or_tick(tabs) -> None:
    """Given LC with a current, water-track "both", current states and the smoother, after a Run
    refused for its Duration: the successful run removes the red "Cannot run"; the Sensors beam
    panel has lime water-track markers; its JSON is named for the current, water-track and
    smoother. Then a plain run of the same mission: Smoothed, ticked before, is unticked and
    disabled; its file name and its Runs label differ; the difference table has no Python
    reprs, at 1600x1000 and 1280x800."""
    tab = tabs(CURRENT_RUN)
    page = tab.page
    tab.type_into(DURATION, "twenty")
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Cannot run").wait_for(timeout=15000)
    tab.type_into(DURATION, "20")
    _run(tab, 1)
    try:
        expect(page.get_by_text("Cannot run", exact=True)).to_have_count(0, timeout=15000)
    except AssertionError:
        page.screenshot(path=str(ARTIFACTS / "names_notice_kept.png"))
        raise AssertionError(page.evaluate(
            "Array.from(document.querySelectorAll('.mantine-Notification-root')).map(e => e.innerText)")) from None

    page.get_by_role("tab", name="Sensors").click()
    page.wait_for_function(f"{FIGURES_JS}.flat().some(t => t.color === {LIME!r} && t.n > 0)", timeout=60000)
    lime = [t for f in page.evaluate(FIGURES_JS) for t in f if t["color"] == LIME and t["n"] > 0]
    assert lime and all("water-track" in t["name"] for t in lime), lime

    page.get_by_role("tab", name="Plots").click()
    tab.set_checkbox("Smoothed", True)
    current_name = _download_name(tab)
    for token in ("current0.3mps_to45deg", "wt_both", "smoothed"):
        assert token in current_name, current_name

    page.get_by_role("tab", name="Mission").click()
    tab.open_folder(SEABED_FOLDER, reveals=DVL_MAX_ALTITUDE)
    _choose(tab, DVL_CURRENT_STATES, "off")  # first: current states without water-track would be refused
    _choose(tab, DVL_WATER_TRACK, "off")
    tab.open_folder(CURRENT_FOLDER, reveals=CURRENT_SPEED)
    tab.type_into(CURRENT_SPEED, "0")
    tab.set_checkbox("Smoother", False)
    _run(tab, 2)
    page.get_by_role("tab", name="Plots").click()
    smoothed = tab.checkbox("Smoothed")
    expect(smoothed).not_to_be_checked(timeout=30000)
    expect(smoothed).to_be_disabled()
    plain_name = _download_name(tab)
    assert plain_name == "tauv-straight-20s-seed1-lc.json" != current_name

    page.get_by_role("tab", name="Runs").click()
    first = page.get_by_text("current 0.3 m/s towards 45°", exact=False).first
    first.wait_for(timeout=60000)
    labels = [page.get_by_text(re.compile(r"^straight, 20 s, seed 1, LC.*")).nth(k).inner_text() for k in (0, 1)]
    assert labels[0] != labels[1], labels
    assert "water-track both" in labels[0] and "smoother" in labels[0] and labels[1] == "straight, 20 s, seed 1, LC"
    for n in (1, 2):
        tab.set_checkbox(f"Overlay run {n}", True)
    table = page.locator("table", has=page.get_by_text("setting", exact=True))
    table.wait_for(timeout=30000)
    for width, height in SIZES:
        page.set_viewport_size({"width": width, "height": height})
        table.scroll_into_view_if_needed()
        text = table.inner_text()
        assert "current" in text and "0.3 m/s towards 45°" in text and "both" in text, text
        assert "{" not in text and "[" not in text, text
        box = table.bounding_box()
        assert box is not None and box["width"] > 0 and box["x"] + box["width"] <= width + 1, (width, box)
        page.screenshot(path=str(ARTIFACTS / f"names_runs_{width}x{height}.png"))


def test_a_replay_disables_what_the_log_sets_and_names_what_it_carries(tabs) -> None:
    """Given the log ``dive`` as Source: Trajectory and Duration are disabled and say "set by the
    log"; with DVL noise 0.05 typed, the replay's status names it, and once the log's own
    configuration arrives Duration says the log's length."""
    tab = tabs("?m=lc")
    page = tab.page
    tab.choose("Source", "dive", exact=False)
    duration = tab.field(DURATION)
    expect(duration).to_be_disabled(timeout=15000)
    expect(page.get_by_label(TRAJECTORY, exact=False).first).to_be_disabled()
    duration.locator("xpath=..").hover(force=True)
    expect(page.get_by_text("set by the log", exact=False).first).to_be_visible(timeout=15000)
    tab.open_folder("Sensors (Table 2)", reveals=DVL_NOISE)
    tab.type_into(DVL_NOISE, "0.05")
    _run(tab, 1)
    status = page.get_by_text("Run complete: log dive", exact=False).first
    status.wait_for(timeout=30000)
    assert "DVL noise 0.05 m/s" in status.inner_text(), status.inner_text()
    page.mouse.move(0, 0)
    duration.locator("xpath=..").hover(force=True)
    expect(page.get_by_text("set by the log: 30 s", exact=True)).to_be_visible(timeout=15000)
