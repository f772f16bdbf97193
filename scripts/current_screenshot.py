"""The screenshot of the dashboard in an ocean current, for docs/dashboard.md: docs/current.png.

    python scripts/current_screenshot.py [--out docs/current.png]

Starts ``tauv serve`` on a free port, opens it in Debian's headless Chromium at 1600 x 1000 with
the figure eight in 0.5 m/s flowing toward 45 deg with a 0.1 m/s varying part (the link's
``cur``, ``cto`` and ``cvar``), runs INS, TC and NSV for 120 s, goes to 40 s with the camera above the
vehicle and shows the Vehicle tab beside the 3-D view: the current's arrow over the vehicle and the current figure. Look at it
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

QUERY = "?traj=figure8&truth=kinematic&dur=120&m=ins,tc,nsv&cur=0.5&cto=45&cvar=0.1"
SHOWN_AT_S = "40"
CAMERA = "chase: above"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "current.png"))
    args = parser.parse_args()
    with dashboard_server(timeout_s=120.0) as base:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            context = browser.new_context(viewport={"width": 1600, "height": 1000})
            context.add_init_script(THROTTLE_FRAMES)
            tab = Tab(context.new_page(), base + QUERY)
            page = tab.page
            page.wait_for_timeout(1500)
            page.get_by_role("button", name="Run", exact=True).click()
            page.get_by_text("Run complete", exact=True).last.wait_for(timeout=180000)
            page.get_by_label("Camera", exact=True).click()  # from above: the arrow at its full length
            page.get_by_role("option", name=CAMERA, exact=True).click()
            tab.type_into("Go to [s]", SHOWN_AT_S)
            page.keyboard.press("Enter")
            for close in page.locator(".mantine-Notification-root button").all():  # the notifications
                close.click()
            page.get_by_role("tab", name="Vehicle", exact=True).first.click()
            page.wait_for_timeout(3000)
            page.screenshot(path=args.out)
            print(f"wrote {args.out}")
            browser.close()


if __name__ == "__main__":
    main()
