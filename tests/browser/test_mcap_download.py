"""The MCAP download in a real browser: offered beside JSON, Parquet and HTML once a run ends, and
saved as an MCAP file (its content against the command line's: tests/unit/app/test_mcap.py)."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.browser


def test_the_mcap_download_is_offered_and_is_an_mcap_file(new_tab, tmp_path) -> None:
    """Given a 10 s run in the page, when MCAP is clicked in Results > Download, then the browser
    saves a .mcap file whose bytes start and end with the MCAP magic."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"LC"})
    tab.type_into("Duration [s]", "10")
    page.get_by_role("tab", name="Results").click()
    button = page.get_by_role("button", name="MCAP", exact=True)
    assert button.is_disabled()  # no run yet
    page.get_by_role("tab", name="Mission").click()
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    page.get_by_role("tab", name="Results").click()
    with page.expect_download(timeout=60000) as info:
        button.click()
    download = info.value
    assert download.suggested_filename.endswith(".mcap")
    download.save_as(tmp_path / "page.mcap")
    content = (tmp_path / "page.mcap").read_bytes()
    assert content[:8] == b"\x89MCAP0\r\n" and content[-8:] == b"\x89MCAP0\r\n"
    assert tab.external_requests == []
