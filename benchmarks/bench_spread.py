"""The Spread tab of a Monte Carlo: how soon after "Run complete" its figures are drawn, for 10 and
100 runs of three methods on the figure eight, in headless Chromium with software WebGL at 1600x1000;
and what building those figures costs the server, in Python, for 100 runs.

    python benchmarks/bench_spread.py [--runs 10 100] [--repeats 3] [--duration 250] [--throttle]

The page is opened at an address that sets the mission (app.dashboard.links: ``traj``, ``m``, ``runs``).
Two ways of looking, each a fresh tab and a run of its own per repeat:

- the Spread tab open while the Monte Carlo runs: from the moment "Run complete" shows to the
  moment the tab's three plots hold this run's figures (negative: drawn before the status said so;
  the server sends them first);
- the Spread tab clicked once "Run complete" shows: from the click to the three plots drawn.

Times are taken in the page (``performance.now()``, a poll every 10 ms), not by the driver. The
3-D view draws at its own pace (60 frames/s) unless ``--throttle`` slows it as the tests do. The
Python timing builds the three figures (app.figures.spread_figures) and their JSON (what viser
sends) from a 100-run Monte Carlo computed in this process. Writes docs/results/spread_timing.md
(benchmarks/fragment.py), which docs/dashboard.md includes.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tests.browser.conftest import CHROMIUM_ARGS, THROTTLE_FRAMES, chromium_path, dashboard_server

METHODS = ("ins", "lc", "tc")
"""Three methods: 100 runs of five exceed the dashboard's memory budget (docs/dashboard.md, Run size)."""
TARGET_S = 1.0
WATCH = """
(() => {
  window.__spread = {};
  const drawn = () => {
    // the three plots of the spread (app.figures.spread_figures), found by their titles, with data
    const titles = Array.from(document.querySelectorAll('.js-plotly-plot'))
      .filter(p => (p._fullData || []).some(t => (t.x || []).length > 1))
      .map(p => ((p.layout || {}).title || {}).text || '');
    return ['spread of', 'Final errors', 'NEES/dim per block'].every(w => titles.some(t => t.includes(w)));
  };
  setInterval(() => {
    const w = window.__spread, now = performance.now();
    const text = document.body ? document.body.textContent : '';
    if (w.complete === undefined && text.includes('Run complete')) w.complete = now;
    if (w.refused === undefined && text.includes('Cannot run')) w.refused = now;
    if (w.drawn === undefined && drawn()) w.drawn = now;
  }, 10);
})();
"""


def page_times(url: str, repeats: int, throttle: bool) -> tuple[list[float], list[float], list[float]]:
    """Per repeat [s]: Run -> "Run complete"; "Run complete" -> the spread drawn with its tab open
    during the run; the tab's click after "Run complete" -> the spread drawn."""
    complete, open_during, clicked_after = [], [], []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
        try:
            for _ in range(repeats):
                for tab_open in (True, False):
                    context = browser.new_context(viewport={"width": 1600, "height": 1000})
                    if throttle:
                        context.add_init_script(THROTTLE_FRAMES)
                    page = context.new_page()
                    page.goto(url)
                    run = page.get_by_role("button", name="Run", exact=True)
                    run.wait_for(timeout=60000)
                    page.wait_for_function("location.search.includes('runs=')", timeout=120000)
                    page.wait_for_timeout(1500)  # the address applied, the tab settled
                    spread = page.get_by_role("tab", name="Spread")
                    if tab_open:
                        spread.click()
                    page.evaluate(WATCH)
                    t0 = page.evaluate("performance.now()")
                    run.click()
                    page.wait_for_function(
                        "window.__spread.complete !== undefined || window.__spread.refused !== undefined",
                        timeout=900000,
                        polling=50,
                    )
                    marks = page.evaluate("window.__spread")
                    if "complete" not in marks:
                        raise SystemExit(f"the dashboard refused the run at {url}: see its notification")
                    complete.append((marks["complete"] - t0) / 1e3)
                    if tab_open:
                        page.wait_for_function("window.__spread.drawn !== undefined", timeout=60000, polling=50)
                        marks = page.evaluate("window.__spread")
                        open_during.append((marks["drawn"] - marks["complete"]) / 1e3)
                    else:
                        page.wait_for_timeout(500)
                        clicked = page.evaluate("performance.now()")
                        spread.click()
                        page.wait_for_function("window.__spread.drawn !== undefined", timeout=60000, polling=50)
                        clicked_after.append((page.evaluate("window.__spread.drawn") - clicked) / 1e3)
                    context.close()
        finally:
            browser.close()
    return complete, open_during, clicked_after


def python_times(runs: int, duration_s: float, repeats: int = 5) -> tuple[list[float], list[int]]:
    """The three spread figures of a ``runs``-run Monte Carlo of ``duration_s`` built and turned to
    JSON, each repeat [s] (after one warm-up), and the JSON's sizes [bytes]."""
    import numpy as np

    from app.figures.spread_figures import final_errors_figure, nees_blocks_figure, runs_figure
    from tauvcore.config import Config
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate

    config = Config().replace("trajectory", name="figure8", duration_s=duration_s).replace("run", methods=METHODS)
    results = run(config, simulate(config, np.random.default_rng(0), runs), np.random.default_rng(1))

    def build() -> list[str]:
        figures = (runs_figure("lc", results["lc"]), final_errors_figure(results), nees_blocks_figure(results))
        return [figure.to_json() for figure in figures]

    sizes = [len(text) for text in build()]
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        build()
        times.append(time.perf_counter() - t0)
    return times, sizes


def _row(label: str, values: list[float]) -> str:
    return f"| {label} | {statistics.median(values):.2f} | {min(values):.2f}-{max(values):.2f} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, nargs="+", default=[10, 100])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--duration", type=float, default=250.0, help="mission [s]; above 60 s every trace is cut to 600 points"
    )
    parser.add_argument("--throttle", action="store_true", help="the 3-D view at 5 frames/s, as in the tests")
    args = parser.parse_args()
    rows = [
        f"| Spread tab, {', '.join(m.upper() for m in METHODS)}, figure eight, {args.duration:g} s, 1600x1000 "
        f"(median of {args.repeats}) | seconds | min-max |",
        "|---|---|---|",
    ]
    with dashboard_server(timeout_s=120.0) as base:
        for runs in args.runs:
            url = f"{base}/?traj=figure8&dur={args.duration:g}&m={','.join(METHODS)}&runs={runs}"
            complete, open_during, clicked_after = page_times(url, args.repeats, args.throttle)
            rows += [
                _row(f"{runs} runs: Run -> \"Run complete\"", complete),
                _row(f"{runs} runs, tab open: \"Run complete\" -> spread drawn", open_during),
                _row(f"{runs} runs, tab clicked after \"Run complete\" -> spread drawn", clicked_after),
            ]
            print("\n".join(rows[-3:]), flush=True)
    built, sizes = python_times(100, args.duration)
    rows.append(
        _row(f"server: the three figures of 100 runs built and sent as JSON ({sum(sizes) / 1e6:.1f} MB)", built)
    )
    table = "\n".join(rows) + (
        f"\n\nTarget: at most {TARGET_S:g} s from \"Run complete\" to the spread drawn. Headless Chromium "
        "(Debian's package) with software WebGL" + (", frames throttled as in the tests." if args.throttle else ".")
    )
    print(table)
    print(f"written to {fragment.write('spread_timing', table)}")


if __name__ == "__main__":
    main()
