"""A Monte Carlo in the dashboard against the same study on the command line: 10 runs of five
methods on the figure eight, Run pressed to "Run complete" in headless Chromium, beside the
whole ``tauv mc`` process.

    python benchmarks/bench_mc_page.py [--repeats 5] [--runs 10]

The page is timed on the server as it starts (two workers: the Monte Carlo split across both,
app.dashboard.split_run) and on ``tauv serve --workers 1`` (one worker: no split). The page is
opened at an address that sets the mission (app.dashboard.links: ``traj``, ``m``, ``runs``), so
every repeat presses Run on the same controls; the time to the first plot update is kept too.
``tauv mc --trajectory figure8 --runs 10 --method ins,lc,tc,nsv,elc --workers 1 --out DIR`` is
timed as a whole command (report and files included), the worker's own computation alone
(app.dashboard.worker.run_worker in this process, after a warm-up), and the workers' part as the
server runs it: on one worker of its pool, and split across both (app.dashboard.split_run, which
the dashboard uses when both workers are idle). The last repeat records a Chrome
trace: the 3-D view's frames (WebGL in software, SwiftShader, on a machine without a GPU) and
the time the page's main thread waited for them. Writes docs/results/mc_page.md
(benchmarks/fragment.py), which docs/dashboard.md includes.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import fragment  # noqa: E402  (benchmarks/, this script's own directory)

from tests.browser.conftest import CHROMIUM_ARGS, THROTTLE_FRAMES, chromium_path, dashboard_server

METHODS = ("ins", "lc", "tc", "nsv", "elc")


def frames(trace_path: Path) -> tuple[list[float], float]:
    """The WebGL frames of a Chrome trace (their durations in the GPU process [s], each over
    20 ms) and the time the page's main thread waited to read them back [s]."""
    events = json.loads(trace_path.read_text())
    events = events["traceEvents"] if isinstance(events, dict) else events
    done = [e for e in events if e.get("ph") == "X" and "dur" in e]
    webgl = [e["dur"] / 1e6 for e in done if e["name"] == "WebGL" and e["dur"] > 20000]
    waited = sum(e["dur"] for e in done if e["name"] == "GLES2::ReadPixels") / 1e6
    return webgl, waited


def page_times(url: str, repeats: int, trace_path: Path) -> tuple[list[float], list[float]]:
    """(Run -> first plot update, Run -> "Run complete") per repeat [s], a fresh tab each; the
    last repeat traced into ``trace_path``."""
    first_plot, complete = [], []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
        try:
            for _ in range(repeats):
                context = browser.new_context(viewport={"width": 1600, "height": 1000})
                context.add_init_script(THROTTLE_FRAMES)
                page = context.new_page()
                page.goto(url)
                run = page.get_by_role("button", name="Run", exact=True)
                run.wait_for(timeout=60000)
                page.wait_for_function("location.search.includes('runs=')", timeout=30000)
                page.wait_for_timeout(1500)                  # the address applied, the tab settled
                last = len(complete) == repeats - 1
                if last:
                    browser.start_tracing(page=page, path=str(trace_path), categories=["devtools.timeline", "gpu"])
                t0 = time.perf_counter()
                run.click()
                page.wait_for_function(
                    "() => Array.from(document.querySelectorAll('.js-plotly-plot'))"
                    ".some(p => (p._fullData || []).some(t => t.name === 'LC'))",
                    timeout=120000,
                )
                first_plot.append(time.perf_counter() - t0)
                page.get_by_text("Run complete", exact=True).wait_for(timeout=180000)
                complete.append(time.perf_counter() - t0)
                if last:
                    browser.stop_tracing()
                context.close()
        finally:
            browser.close()
    return first_plot, complete


def cli_time(runs: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "app.cli", "mc", "--trajectory", "figure8", "--runs", str(runs),
                        "--method", ",".join(METHODS), "--workers", "1", "--out", str(Path(tmp) / "mc")],
                       check=True, stdout=subprocess.DEVNULL)
        return time.perf_counter() - t0


def worker_time(runs: int) -> float:
    """The worker's own computation of the Monte Carlo, in this process [s]."""
    from app.dashboard.worker import run_worker
    from tauvcore.config import Config, to_dict

    config = to_dict(Config().replace("trajectory", name="figure8").replace("run", methods=METHODS))

    class Sink:
        def put(self, message: tuple) -> None:
            pass

    class Never:
        def is_set(self) -> bool:
            return False

    t0 = time.perf_counter()
    run_worker(config, runs, Sink(), Never())
    return time.perf_counter() - t0


def pool_times(runs: int, repeats: int = 3) -> tuple[list[float], list[float]]:
    """The workers' part as the dashboard runs it, Run's submission to the final message [s]: on
    one worker of the server's pool (app.dashboard.worker.RunPool), and split in two batches
    across both (app.dashboard.split_run.SplitRun); a warm-up of each first."""
    from app.dashboard.split_run import SplitRun
    from app.dashboard.worker import RunPool
    from tauvcore.config import Config, to_dict

    config = to_dict(Config().replace("trajectory", name="figure8").replace("run", methods=METHODS))
    pool = RunPool(workers=2)

    def timed(start) -> float:
        t0 = time.perf_counter()
        handle = start()
        while handle.queue.get(timeout=300.0)[0] not in ("done", "error"):
            pass
        return time.perf_counter() - t0

    try:
        one_worker = lambda: pool.start(config, runs)  # noqa: E731
        both = lambda: SplitRun(pool, config, runs)  # noqa: E731
        timed(one_worker), timed(both)  # warm-up: both workers' kernels loaded
        return [timed(one_worker) for _ in range(repeats)], [timed(both) for _ in range(repeats)]
    finally:
        pool.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=10)
    args = parser.parse_args()
    query = f"/?traj=figure8&m={','.join(METHODS)}&runs={args.runs}"
    with dashboard_server(timeout_s=120.0) as base, tempfile.TemporaryDirectory() as tmp:
        first_plot, complete = page_times(base + query, args.repeats, Path(tmp) / "trace.json")
        webgl, waited = frames(Path(tmp) / "trace.json")
    with dashboard_server(timeout_s=120.0, extra=("--workers", "1")) as base, tempfile.TemporaryDirectory() as tmp:
        first_one, complete_one = page_times(base + query, args.repeats, Path(tmp) / "trace.json")
    cli = [cli_time(args.runs) for _ in range(3)]
    worker_time(args.runs)  # warm-up: imports, compiled kernels loaded
    alone = [worker_time(args.runs) for _ in range(3)]
    one_worker, both = pool_times(args.runs)
    rows = [
        f"| {args.runs}-run Monte Carlo, five methods, figure eight (median of {args.repeats}) | seconds | min-max |",
        "|---|---|---|",
        f"| dashboard: Run -> first plot update | {statistics.median(first_plot):.2f} "
        f"| {min(first_plot):.2f}-{max(first_plot):.2f} |",
        f"| dashboard: Run -> \"Run complete\" | {statistics.median(complete):.2f} "
        f"| {min(complete):.2f}-{max(complete):.2f} |",
        f"| the same with `tauv serve --workers 1` (the runs on one worker): Run -> first plot update "
        f"| {statistics.median(first_one):.2f} | {min(first_one):.2f}-{max(first_one):.2f} |",
        f"| the same with `tauv serve --workers 1`: Run -> \"Run complete\" | {statistics.median(complete_one):.2f} "
        f"| {min(complete_one):.2f}-{max(complete_one):.2f} |",
        f"| `tauv mc --workers 1`, the whole command (median of 3) | {statistics.median(cli):.2f} "
        f"| {min(cli):.2f}-{max(cli):.2f} |",
        f"| the worker's computation alone, in one process (median of 3) | {statistics.median(alone):.2f} "
        f"| {min(alone):.2f}-{max(alone):.2f} |",
        f"| the workers' part on the server's pool, one worker, Run -> final results (median of 3) "
        f"| {statistics.median(one_worker):.2f} | {min(one_worker):.2f}-{max(one_worker):.2f} |",
        f"| the same on both workers, the runs in two batches (the dashboard's way; median of 3) "
        f"| {statistics.median(both):.2f} | {min(both):.2f}-{max(both):.2f} |",
        f"| last repeat: the page's main thread waiting for the 3-D view's {len(webgl)} frames "
        f"(software WebGL; median {1e3 * statistics.median(webgl or [0.0]):.0f} ms, longest "
        f"{1e3 * max(webgl or [0.0]):.0f} ms) | {waited:.2f} | |",
    ]
    table = "\n".join(rows) + "\n\nHeadless Chromium (Debian's package) with software WebGL, frames throttled as in the tests."
    print(table)
    print(f"written to {fragment.write('mc_page', table)}")


if __name__ == "__main__":
    main()
