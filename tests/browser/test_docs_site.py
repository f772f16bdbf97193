"""The documentation site in the browser: built as `bash scripts/docs.sh` builds it, opened from
the disk; its home page, the tutorial (with the dashboard screenshot the browser tests take) and
an API reference page show, the navigation reaches the API, and no page asks for anything beyond
the site's own files. Screenshots go to artifacts/."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser

REPO = Path(__file__).resolve().parents[2]
TUTORIAL_TITLE = "Tutorial: from install to a partial-beam comparison"


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    subprocess.run(
        [str(Path(sys.executable).with_name("mkdocs")), "build", "--strict", "--site-dir", str(out)],
        cwd=REPO, check=True, capture_output=True, timeout=300, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    return out


def test_the_home_page_the_tutorial_and_the_api_reference_show_and_fetch_nothing(browser, site: Path) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    asked: list[str] = []
    page.on("request", lambda r: None if r.url.startswith("file://") else asked.append(r.url))
    page.goto((site / "index.html").as_uri())
    page.get_by_role("heading", name="tauv: a reference lab for underwater inertial navigation").wait_for()
    page.screenshot(path=str(ARTIFACTS / "docs_home.png"))
    page.get_by_role("link", name="Tutorial", exact=True).first.click()
    page.get_by_role("heading", name=TUTORIAL_TITLE).wait_for()
    tour = page.locator("article img[src$='dashboard.png']")
    tour.scroll_into_view_if_needed()
    assert tour.evaluate("img => img.complete && img.naturalWidth > 0")   # the browser tests' screenshot
    page.screenshot(path=str(ARTIFACTS / "docs_tutorial.png"), full_page=False)
    page.get_by_role("heading", name=TUTORIAL_TITLE).scroll_into_view_if_needed()
    page.screenshot(path=str(ARTIFACTS / "docs_tutorial_top.png"))
    page.get_by_role("link", name="Aiding sources", exact=True).first.click()
    page.get_by_role("heading", name="tauvcore.aiding.source").first.wait_for()
    article = page.locator("article")
    assert article.get_by_role("heading", name="AidingSource", exact=False).first.is_visible()
    assert not article.get_by_text(":class:", exact=False).count()  # the Sphinx roles shown as code
    page.screenshot(path=str(ARTIFACTS / "docs_api_aiding.png"))
    assert asked == []
    page.close()
