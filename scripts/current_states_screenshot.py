"""The Sensors tab's figure of the current's estimate, for docs/dashboard.md: docs/current_states.png.

    python scripts/current_states_screenshot.py [--out docs/current_states.png]

Runs LC on a 120 s figure eight in a current of 0.2 m/s north and 0.3 m/s east, every beam
water-tracking (``dvl.water_track = "always"``) and the current as random-walk states of the
filter, draws the figure the dashboard's Sensors tab draws of that run
(app.figures.sensor_figures.source_states_figure), and photographs it in Debian's headless Chromium (the
page holds plotly.js itself: nothing is fetched). The run is set by configuration, not through
the dashboard: this branch's dashboard has no controls for the current the truth flies in. Look at
the picture before committing.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from app.figures.sensor_figures import source_states_figure  # noqa: E402
from tauvcore.config import from_dict  # noqa: E402
from tauvcore.engine.mission import run_streaming  # noqa: E402
from tests.browser.conftest import CHROMIUM_ARGS, chromium_path  # noqa: E402

MISSION = {
    "trajectory": {"name": "figure8", "duration_s": 120.0, "current_n_mps": [0.2, 0.3, 0.0]},
    "dvl": {"water_track": "always", "current_states": "random-walk"},
    "run": {"methods": ["ins", "lc"], "seed": 0},
}
WIDTH_PX, HEIGHT_PX = 900, 480


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "current_states.png"))
    args = parser.parse_args()
    config = from_dict(MISSION)
    results = run_streaming(config, np.random.default_rng(config.run.seed), 1)
    figure = source_states_figure(results, height_px=HEIGHT_PX)
    figure.update_layout(width=WIDTH_PX)
    with tempfile.TemporaryDirectory() as tmp:
        page_path = Path(tmp) / "current.html"
        figure.write_html(page_path, include_plotlyjs=True, full_html=True)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": WIDTH_PX + 20, "height": HEIGHT_PX + 20})
            page.goto(page_path.as_uri())
            page.locator(".js-plotly-plot").wait_for(timeout=30000)
            page.wait_for_timeout(500)
            page.locator(".js-plotly-plot").screenshot(path=args.out)
            browser.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
