"""Dashboard timings in headless Chromium (Debian's package, software WebGL), and the screenshot
at the top of the README.

    python benchmarks/bench_dashboard.py [--repeats 3] [--clicks 5] [--screenshot docs/dashboard.png]
                                         [--root DIR] [--out FILE]

writes docs/results/dashboard_timing.md (benchmarks/fragment.py), which docs/dashboard.md includes
(``--out``: that file instead; ``--root``: serve the code of another checkout, e.g. to compare).

Measures, at 1600x1000, for a single 250 s run with all eight methods:
- page open -> first 3-D picture: navigation start until the WebGL canvas is on the page and
  has drawn two animation frames;
- Run pressed -> first plot update: until the velocity plot (its tab opened right after Run)
  holds its first traces;
- after the run, a workbench tab switch (Plots <-> Components), Go to (a time typed into
  "Go to [s]") and a click on the velocity plot: each from the click to the last frame drawn, that
  is the animation frame after the last change to a plot, a tab panel or the slider, once nothing
  has changed for QUIET_MS (median of ``--clicks``).
The numbers are for this machine's software renderer; a browser with a GPU draws faster.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tests.browser.conftest import CHROMIUM_ARGS, chromium_path, free_port

METHODS = ("INS", "LC", "TC", "VB", "NSV", "PLCF", "VHV", "ELC")
WINDOW = {"width": 1600, "height": 1000}
QUIET_MS = 1500  # an answer is over once the page has not changed for this long
WATCH_JS = """() => {
  // the time of the animation frame after the latest change to a plot, a tab or the slider
  window.__benchLast = performance.now();
  const watched = (n) => n && n.closest && n.closest('.js-plotly-plot, [role=tabpanel], [role=tab], [role=slider]');
  new MutationObserver((list) => {
    if (list.some((m) => watched(m.target.nodeType === 1 ? m.target : m.target.parentElement)))
      requestAnimationFrame(() => { window.__benchLast = performance.now(); });
  }).observe(document.body, {subtree: true, childList: true, attributes: true, characterData: true});
}"""
ANSWERED_JS = f"""(t0) => new Promise((done) => {{
  // [ms] from t0 to the last frame drawn, once the page changed and then held still; NaN: no change in 60 s
  const check = () => {{
    const now = performance.now(), changed = window.__benchLast > t0;
    if (changed && now - window.__benchLast > {QUIET_MS}) done(window.__benchLast - t0);
    else if (now - t0 > 60000) done(NaN);
    else setTimeout(check, 100);
  }};
  check();
}})"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--clicks", type=int, default=5, help="tab switches, Go tos and plot clicks measured")
    parser.add_argument("--screenshot", help="save a screenshot of a finished run here")
    parser.add_argument("--root", help="serve the dashboard of this checkout (default: this one)")
    parser.add_argument("--out", help="write the table here instead of docs/results/dashboard_timing.md")
    args = parser.parse_args()
    port = free_port()
    root = Path(args.root).resolve() if args.root else Path(__file__).resolve().parents[1]
    server = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--port", str(port)], cwd=root,
                              env={**os.environ, "PYTHONPATH": str(root)},
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    first_picture, first_plot = [], []
    clicks: dict[str, list[float]] = {}
    try:
        time.sleep(1.0)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            for repeat in range(args.repeats):
                page = browser.new_context(viewport=WINDOW).new_page()
                for _ in range(100):
                    try:
                        t0 = time.perf_counter()
                        page.goto(url)
                        break
                    except Exception:  # server still starting
                        time.sleep(0.2)
                page.locator("canvas").first.wait_for(timeout=240000)
                page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
                first_picture.append(time.perf_counter() - t0)
                page.get_by_role("button", name="Run", exact=True).wait_for()
                for m in METHODS:
                    box = page.get_by_role("checkbox", name=m, exact=True)
                    if not box.is_checked():
                        box.click()
                t0 = time.perf_counter()
                page.get_by_role("button", name="Run", exact=True).click()
                page.get_by_role("tab", name="Plots").click()   # plots draw only while their tab shows
                page.wait_for_function("() => { const p = document.querySelector('.js-plotly-plot');"
                                       " return p && p._fullData && p._fullData.length > 0; }", timeout=120000)
                first_plot.append(time.perf_counter() - t0)
                page.get_by_text("Run complete", exact=True).wait_for(timeout=180000)
                if repeat == 0:
                    clicks = measure_clicks(page, args.clicks)
                page.context.close()
            if args.screenshot:
                shoot(browser, url, args.screenshot)
            browser.close()
    finally:
        server.terminate()
    rows = [("page open -> first 3-D picture", first_picture),
            ("Run pressed -> first plot update (250 s, 8 methods)", first_plot)]
    for name, values in clicks.items():
        answered = [v for v in values if math.isfinite(v)]
        late = f", {len(values) - len(answered)} unanswered in 60 s" if len(answered) < len(values) else ""
        rows.append((f"{name} -> last frame drawn (target 0.5 s{late})", answered or [math.nan]))
    table = "\n".join(
        [f"| measurement (median of {args.repeats} runs; clicks: of {args.clicks}) | seconds | min-max |", "|---|---|---|"]
        + [f"| {name} | {statistics.median(v):.2f} | {min(v):.2f}-{max(v):.2f} |" for name, v in rows]
    ) + ("\n\nHeadless Chromium (Debian's package) with software WebGL at 1600x1000; a browser with a GPU "
         "draws faster.")
    print(table)
    if args.out:
        Path(args.out).write_text(table + "\n", encoding="utf-8")
        print(f"written to {args.out}")
    else:
        print(f"written to {fragment.write('dashboard_timing', table)}")


def measure_clicks(page, n: int) -> dict[str, list[float]]:
    """After a finished run: ``n`` workbench tab switches, Go tos and clicks on the velocity plot,
    each timed from the click to the last frame drawn (WATCH_JS, ANSWERED_JS) [s]."""
    page.wait_for_timeout(8000)   # the deferred plots drawn and sent
    page.evaluate(WATCH_JS)
    out: dict[str, list[float]] = {"workbench tab switch": [], "Go to": [], "plot click": []}

    def timed(action) -> float:
        t0 = page.evaluate("performance.now()")
        action()
        return page.evaluate(ANSWERED_JS, t0) / 1000.0

    go_to = page.locator('xpath=//label[normalize-space()="Go to [s]"]/../../following-sibling::*[1]'
                         '//input[not(@type="hidden")]')
    for k in range(n):
        tab = ("Components", "Plots")[k % 2]
        out["workbench tab switch"].append(timed(lambda: page.get_by_role("tab", name=tab, exact=True).click()))
    page.get_by_role("tab", name="Plots", exact=True).click()
    page.wait_for_timeout(2000)
    for k in range(n):
        out["Go to"].append(timed(lambda: go_to.fill(f"{60 + 40 * (k % 2)}")))
    plot = page.locator(".js-plotly-plot").first
    plot.scroll_into_view_if_needed()
    area = plot.locator(".nsewdrag").first.bounding_box()
    for k in range(n):
        x = area["x"] + (0.3 + 0.4 * (k % 2)) * area["width"]
        out["plot click"].append(timed(lambda: page.mouse.click(x, area["y"] + 0.5 * area["height"])))
    return out


def shoot(browser, url: str, path: str) -> None:
    """Figure eight, beams 3 and 4 lost, four methods; the 3-D view with the Plots tab open."""
    page = browser.new_context(viewport={"width": 1600, "height": 900}).new_page()
    page.goto(url)
    page.get_by_role("button", name="Run", exact=True).wait_for(timeout=60000)
    page.get_by_label("Trajectory").click()
    page.get_by_role("option", name="figure8", exact=True).click()
    for k in (3, 4):
        page.get_by_role("checkbox", name=f"Beam {k}", exact=True).uncheck()
    for m in METHODS:
        box = page.get_by_role("checkbox", name=m, exact=True)
        if box.is_checked() != (m in ("INS", "TC", "NSV", "ELC")):
            box.click()
    page.get_by_role("button", name="Run", exact=True).click()
    page.get_by_text("Run complete", exact=True).wait_for(timeout=180000)
    page.evaluate("() => document.querySelectorAll('.mantine-Notification-root button').forEach(b => b.click())")
    page.get_by_role("tab", name="Plots").click()
    page.wait_for_timeout(2500)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=path)
    page.context.close()


if __name__ == "__main__":
    main()
