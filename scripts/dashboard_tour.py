"""Screenshots of every tab of the dashboard after a run, for docs/dashboard.md's tour.

    python scripts/dashboard_tour.py [--out docs/tour]

Starts ``tauv serve`` on a free port, opens it in Debian's headless Chromium at 1600 x 1000, runs
the figure eight with beams 3 and 4 off (INS, TC, NSV, ELC, dynamic truth, 3 runs), keeps a
second run with all four beams for the Runs tab, and writes one PNG per tab: the workbench's
Plots, Components, Consistency, Innovations, Results and Runs, and the control panel's Mission,
Vehicle and Seabed. Look at them before committing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from tests.browser.conftest import CHROMIUM_ARGS, THROTTLE_FRAMES, Tab, chromium_path, dashboard_server  # noqa: E402

WORKBENCH_TABS = ("Plots", "Components", "Consistency", "Innovations", "Sensors", "Results", "Runs")
PANEL_TABS = ("Mission", "Vehicle", "Seabed")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "tour"))
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with dashboard_server(timeout_s=120.0) as base:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            context = browser.new_context(viewport={"width": 1600, "height": 1000})
            context.add_init_script(THROTTLE_FRAMES)
            tab = Tab(context.new_page(), f"{base}/?traj=figure8&truth=dynamic&m=ins,tc,nsv,elc&runs=1")
            page = tab.page
            page.wait_for_timeout(1500)
            page.get_by_role("button", name="Run", exact=True).click()        # run 1: four beams
            page.get_by_text("Run complete", exact=True).last.wait_for(timeout=180000)
            tab.set_checkbox("Beam 3", False)
            tab.set_checkbox("Beam 4", False)
            tab.type_into("Runs", "3")
            page.get_by_role("button", name="Run", exact=True).click()        # run 2: two beams, 3 runs
            # the first run's notification may have closed by now: the status line says when it ends
            page.wait_for_function("document.body.innerText.includes('3 run(s)')", timeout=60000)
            page.wait_for_function("document.body.innerText.includes('Run complete: figure8')", timeout=180000)
            page.wait_for_timeout(2000)
            for name in WORKBENCH_TABS:
                page.get_by_role("tab", name=name, exact=True).first.click()
                page.wait_for_timeout(1500)
                page.screenshot(path=str(out / f"{name.lower()}.png"))
                print(f"wrote {out / (name.lower() + '.png')}")
            page.get_by_role("tab", name="Plots", exact=True).first.click()
            for name in PANEL_TABS:
                page.get_by_role("tab", name=name, exact=True).first.click()
                page.wait_for_timeout(1500)
                page.screenshot(path=str(out / f"panel_{name.lower()}.png"))
                print(f"wrote {out / ('panel_' + name.lower() + '.png')}")
            browser.close()


if __name__ == "__main__":
    main()
