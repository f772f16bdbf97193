"""Fixtures for the dashboard tests: a `tauv serve` process and Debian's headless Chromium.

Chromium comes from Debian's package (scripts/test.sh installs it); Playwright only drives it
through ``executable_path``: never ``playwright install``, which downloads a browser. Background
networking is off, and every test page records any request that leaves this machine.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts"
CHROMIUM_ARGS = [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--disable-default-apps", "--disable-extensions",
    "--enable-unsafe-swiftshader",
]
# Software WebGL (SwiftShader) on a 2-core machine: a viser page redrawing at 60 frames/s takes a
# whole core, and two tabs starve the server and the test driver. Pages under test draw at most
# 5 frames/s; the 3-D scene is the same, it is only redrawn less often.
THROTTLE_FRAMES = """
(() => {
  const raf = window.requestAnimationFrame.bind(window);
  window.requestAnimationFrame = (cb) => setTimeout(() => raf(cb), 200);
})();
"""
LOCAL_PREFIXES = ("http://127.0.0.1", "http://localhost", "ws://127.0.0.1", "ws://localhost", "data:", "blob:",
                  "about:")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def chromium_path() -> str:
    path = shutil.which("chromium") or shutil.which("chromium-browser")
    if path is None:
        pytest.fail("Debian's chromium is not installed: run the tests with `bash scripts/test.sh`")
    return path


@contextlib.contextmanager
def dashboard_server(log: Any = subprocess.DEVNULL, timeout_s: float = 60.0, extra: tuple[str, ...] = ()) -> Iterator[str]:
    """``tauv serve`` on a free port with the flags ``extra``, its output to ``log``: yields its
    address once GET / answers (RuntimeError if it exits or does not answer within ``timeout_s``),
    stops it afterwards."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--port", str(port), *extra],
                            stdout=log, stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                urllib.request.urlopen(url, timeout=1).read(100)
                break
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"tauv serve did not start (exit status {proc.poll()})") from None
                time.sleep(0.2)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()


@pytest.fixture(scope="session")
def server_url() -> Iterator[str]:
    ARTIFACTS.mkdir(exist_ok=True)
    with open(ARTIFACTS / "server.log", "w") as log, contextlib.ExitStack() as stack:
        try:
            url = stack.enter_context(dashboard_server(log))
        except RuntimeError:
            pytest.fail(f"tauv serve did not start; see {ARTIFACTS / 'server.log'}")
        yield url


@pytest.fixture(scope="session")
def browser():
    from playwright.sync_api import sync_playwright
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


class Tab:
    """One dashboard tab, with the controls the tests use."""

    def __init__(self, page, url: str) -> None:
        self.page = page
        self.external_requests: list[str] = []
        page.on("request", lambda r: None if r.url.startswith(LOCAL_PREFIXES) else self.external_requests.append(r.url))
        page.goto(url)
        page.get_by_role("button", name="Run", exact=True).wait_for(timeout=30000)

    def checkbox(self, label: str):
        return self.page.get_by_role("checkbox", name=label, exact=True)

    def field(self, label: str):
        """The text input of the control labelled ``label`` (viser's label[for] names the row,
        not the Mantine text input, so get_by_label does not reach it)."""
        return self.page.locator(f'xpath=//label[normalize-space()="{label}"]/../../following-sibling::*[1]'
                                 '//input[not(@type="hidden")]')

    def open_folder(self, label: str, reveals: str | None = None) -> None:
        """Expand the GUI folder titled ``label``. The title is scrolled into view and clicked
        by the element's own click (``el.click()`` in the page), without waiting for the panel to
        hold still: under software WebGL on a loaded machine the panel's layout can keep moving
        for longer than a mouse click's actionability wait (a CI run timed out after 30 s), and a
        mouse click at where the title was drawn can land on the checkbox that moved there (the
        magnetometer's was ticked so, and the run aided with it). With ``reveals`` (the label of
        a field inside), the folder is clicked again, twice at most, until that field shows: a
        folder that appeared a moment before (its source just ticked) may not be ready for the
        first click."""
        from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

        for attempt in range(3):
            title = self.page.get_by_text(label, exact=False).first
            title.scroll_into_view_if_needed(timeout=15000)
            title.evaluate("el => el.click()")
            self.page.wait_for_timeout(300)
            if reveals is None:
                return
            try:
                self.field(reveals).wait_for(state="visible", timeout=5000)
                return
            except PlaywrightTimeoutError:
                if attempt == 2:
                    raise

    def type_into(self, label: str, text: str) -> None:
        """Clear the field and type ``text`` key by key, as a person does."""
        box = self.field(label)
        box.fill("")
        box.press_sequentially(text)
        self.page.wait_for_timeout(300)

    def run_config(self) -> dict[str, str]:
        """The "Configuration run" table of the Results tab: setting -> value as shown."""
        self.page.get_by_role("tab", name="Results").click()
        table = self.page.locator("table", has=self.page.get_by_text("Setting", exact=True))
        table.wait_for(timeout=10000)
        rows = table.locator("tr").all_inner_texts()
        return dict(tuple(c.strip() for c in row.split("\t"))[:2] for row in rows[1:])

    def set_checkbox(self, label: str, checked: bool) -> None:
        """Tick or untick the checkbox ``label`` and wait until the page shows it so. The click is
        the element's own (``el.click()`` in the page), not a mouse click at where the box was
        drawn: while the panel settles after a folder opens, a click at a position can land on the
        box above and tick that one instead (the run would then aid with a source it was not
        asked for). A click that does not change the box is tried again, twice at most,
        half a second apart."""
        from playwright.sync_api import expect

        box = self.checkbox(label)
        for attempt in range(3):
            box.scroll_into_view_if_needed(timeout=15000)
            if box.is_checked() != checked:
                box.evaluate("el => el.click()")
            try:
                expect(box).to_be_checked(checked=checked, timeout=5000)
                return
            except AssertionError:
                if attempt == 2:
                    raise
                self.page.wait_for_timeout(500)

    def set_methods(self, wanted: set[str]) -> None:
        for m in ("INS", "LC", "TC", "VB", "NSV", "PLCF", "VHV", "ELC", "INS-DVL", "VKF"):
            self.set_checkbox(m, m in wanted)

    def choose(self, label: str, option: str, exact: bool = True) -> None:
        """Pick ``option`` in the dropdown labelled ``label`` and wait until the page shows it.
        The dropdown is scrolled into view and clicked without waiting for the panel to hold
        still (as ``open_folder`` does); a click that opens no list, or a list without the option
        (the panel moved under the pointer: a CI run waited 30 s for "always"), is tried again,
        twice at most, after Escape closes whatever opened."""
        from playwright.sync_api import TimeoutError as PlaywrightTimeoutError

        wanted = self.page.get_by_role("option", name=option, exact=True)
        for attempt in range(3):
            box = self.page.get_by_label(label, exact=exact).first
            box.scroll_into_view_if_needed(timeout=15000)
            box.click(force=True, timeout=15000)
            try:
                wanted.wait_for(state="visible", timeout=5000)
                break
            except PlaywrightTimeoutError:
                if attempt == 2:
                    raise
                self.page.keyboard.press("Escape")
                self.page.wait_for_timeout(500)
        wanted.click(timeout=15000)
        self.page.wait_for_timeout(300)

    def choose_trajectory(self, name: str) -> None:
        self.choose("Trajectory", name, exact=False)

    def notification(self, title: str):
        return self.page.get_by_text(title, exact=True)

    def refusal(self, message: str):
        """The latest notification whose text holds ``message`` (a refused Run names every bad
        control in one; the note under the status line says the same, and is not this)."""
        return self.page.locator(".mantine-Notification-description", has_text=message).last

    def plot_traces(self) -> list[list[tuple[str, int]]]:
        """(name, number of points) of every trace of every plotly figure on the page."""
        return self.page.evaluate(
            "Array.from(document.querySelectorAll('.js-plotly-plot')).map(p => "
            "(p._fullData || []).filter(t => t.visible !== false && t.showlegend !== false)"
            ".map(t => [t.name, (t.y || []).length]))")

    def results_table(self) -> dict[str, list[float]]:
        """The four error columns of the results table (vel final, vel RMS, att final, pos final)."""
        rows = self.page.locator("table").first.locator("tr").all_inner_texts()
        out = {}
        for row in rows[1:]:
            cells = [c.strip() for c in row.split("\t")]
            out[cells[0]] = [float(c) for c in cells[1:5]]
        return out


@pytest.fixture
def new_tab(browser, server_url):
    contexts = []

    def make(query: str = "") -> Tab:
        """A new tab (its own browser context) at the dashboard's address followed by ``query``."""
        ctx = browser.new_context(viewport={"width": 1500, "height": 950})
        ctx.add_init_script(THROTTLE_FRAMES)
        contexts.append(ctx)
        return Tab(ctx.new_page(), server_url + query)

    yield make
    for ctx in contexts:
        ctx.close()
