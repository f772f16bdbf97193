"""Screenshots of every tab of the dashboard after two runs, for docs/dashboard.md's tour.

    python scripts/dashboard_tour.py [--out docs/tour]

Starts ``tauv serve`` on a free port, opens it in Debian's headless Chromium at 1600 x 1000, runs
the figure eight on the dynamic truth (INS, TC, NSV, ELC) once with four beams, then a 10-run
Monte Carlo with beams 3 and 4 out from 100 s to 150 s, and writes one PNG per tab: the
workbench's Plots (the outage shaded), Components, Consistency, Innovations, Sensors, Series (TC's
velocity error and DVL NIS against time, its track as an XY plot), Map (ellipses at the cursor),
Spread, Results and Runs, and the control panel's Mission, Vehicle and Seabed. Look at them
before committing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from tests.browser.conftest import CHROMIUM_ARGS, THROTTLE_FRAMES, Tab, chromium_path, dashboard_server  # noqa: E402

WORKBENCH_TABS = (
    "Plots", "Components", "Consistency", "Innovations", "Sensors", "Series", "Map", "Spread", "Results", "Runs",
)  # fmt: skip
PANEL_TABS = ("Mission", "Vehicle", "Seabed")
CURSOR_S = 125.0  # inside the outage: the map's ellipses grow there
SERIES = "tc/vel_err_mps, tc/dvl/nis"
XY = "tc/est_east_m; tc/est_north_m, truth/north_m"


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
            page.get_by_role("button", name="Run", exact=True).click()  # run 1: four beams
            page.get_by_text("Run complete", exact=True).last.wait_for(timeout=180000)
            tab.open_folder("Outages [s]", reveals="Beam 3 outage start")
            for beam in (3, 4):
                tab.type_into(f"Beam {beam} outage start", "100")
                tab.type_into(f"Beam {beam} outage end", "150")
            tab.type_into("Runs", "10")
            page.get_by_role("button", name="Run", exact=True).click()  # run 2: the outage, 10 runs
            # the first run's notification may have closed by now: the status line says when it ends
            page.wait_for_function("document.body.innerText.includes('10 run(s)')", timeout=60000)
            page.wait_for_function("document.body.innerText.includes('Run complete: figure8')", timeout=300000)
            page.wait_for_timeout(2000)
            tab.type_into("Go to [s]", f"{CURSOR_S:g}")
            page.get_by_role("tab", name="Series", exact=True).first.click()
            tab.type_into("Time plot", SERIES)
            tab.field("Time plot").press("Enter")
            tab.type_into("XY plot", XY)
            tab.field("XY plot").press("Enter")
            for name in WORKBENCH_TABS:
                page.get_by_role("tab", name=name, exact=True).first.click()
                page.wait_for_timeout(2500)
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
