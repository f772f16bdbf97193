"""Dashboard timings in headless Chromium (Debian's package, software WebGL), and the screenshot
at the top of the README.

    python benchmarks/bench_dashboard.py [--repeats 3] [--screenshot docs/dashboard.png]

writes docs/results/dashboard_timing.md (benchmarks/fragment.py), which docs/dashboard.md includes.

Measures, for a single 250 s run with all eight methods:
- page open -> first 3-D picture: navigation start until the WebGL canvas is on the page and
  has drawn two animation frames;
- Run pressed -> first plot update: until the velocity plot (its tab opened right after Run)
  holds its first traces.
The numbers are for this machine's software renderer; a browser with a GPU draws faster.
"""

from __future__ import annotations

import argparse
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--screenshot", help="save a screenshot of a finished run here")
    args = parser.parse_args()
    port = free_port()
    server = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--port", str(port)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    first_picture, first_plot = [], []
    try:
        time.sleep(1.0)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            for _ in range(args.repeats):
                page = browser.new_context(viewport={"width": 1600, "height": 950}).new_page()
                for _ in range(100):
                    try:
                        t0 = time.perf_counter()
                        page.goto(url)
                        break
                    except Exception:  # server still starting
                        time.sleep(0.2)
                page.locator("canvas").first.wait_for(timeout=60000)
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
                page.context.close()
            if args.screenshot:
                shoot(browser, url, args.screenshot)
            browser.close()
    finally:
        server.terminate()
    table = "\n".join(
        [
            f"| measurement (median of {args.repeats}) | seconds | min-max |",
            "|---|---|---|",
            f"| page open -> first 3-D picture | {statistics.median(first_picture):.2f} "
            f"| {min(first_picture):.2f}-{max(first_picture):.2f} |",
            f"| Run pressed -> first plot update (250 s, 8 methods) | {statistics.median(first_plot):.2f} "
            f"| {min(first_plot):.2f}-{max(first_plot):.2f} |",
        ]
    ) + "\n\nHeadless Chromium (Debian's package) with software WebGL; a browser with a GPU draws faster."
    print(table)
    print(f"written to {fragment.write('dashboard_timing', table)}")


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
