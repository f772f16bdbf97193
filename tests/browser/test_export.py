"""Downloads and links in a real browser.

A short mission is run in the page, its three downloads (JSON, Parquet, HTML report) are saved
by the browser and read back against what the command line writes for the same configuration and
seed; a page opened at an address carrying a configuration shows it in its controls, keeps it
through a reload, and runs it.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pyarrow.parquet as pq
import pytest

from app.reports.study_output import PARQUET_SERIES
from tests.browser.conftest import ARTIFACTS

pytestmark = pytest.mark.browser
CLI_ARGV = ["--trajectory", "straight", "--duration", "10", "--method", "lc,tc", "--seed", "3"]
"""The command line's spelling of the setup the page runs below."""


def _cli_json(tmp_path) -> dict:
    out = tmp_path / "cli.json"
    subprocess.run([sys.executable, "-m", "app.cli", "run", *CLI_ARGV, "--json", str(out)], check=True,
                   capture_output=True, timeout=120)
    return out


def _download(page, label: str, target):
    with page.expect_download(timeout=60000) as info:
        page.get_by_role("button", name=label, exact=True).click()
    download = info.value
    download.save_as(target)
    return download.suggested_filename


def test_the_three_downloads_match_the_cli_s_files(new_tab, tmp_path) -> None:
    """Given straight, 10 s, LC and TC, seed 3 run in the page, when JSON, Parquet and HTML report
    are downloaded, then the JSON is byte for byte what `tauv run --json` writes for the same
    setup, the Parquet holds its series (32-bit) in runs.parquet's columns, and the report opens
    with no network, showing the configuration, the results and five figures."""
    tab = new_tab()
    page = tab.page
    tab.set_methods({"LC", "TC"})
    tab.type_into("Duration [s]", "10")
    tab.type_into("Seed", "3")
    page.get_by_role("tab", name="Results").click()
    assert page.get_by_role("button", name="JSON", exact=True).is_disabled()       # no run yet
    page.get_by_role("tab", name="Mission").click()
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    page.get_by_role("tab", name="Results").click()
    assert page.get_by_role("button", name="JSON", exact=True).is_enabled()
    page.screenshot(path=str(ARTIFACTS / "dashboard_download.png"))
    names = {kind: _download(page, label, tmp_path / f"page.{kind}")
             for kind, label in (("json", "JSON"), ("parquet", "Parquet"), ("html", "HTML report"))}
    assert names == {k: f"tauv-straight-10s-seed3-lc_tc.{k}" for k in names}

    cli_path = _cli_json(tmp_path)
    assert (tmp_path / "page.json").read_bytes() == cli_path.read_bytes()
    cli = json.loads(cli_path.read_text())["results"]

    table = pq.read_table(tmp_path / "page.parquet")
    assert table.column_names == ["trajectory", "method", "run", "t_s", *PARQUET_SERIES]
    T = len(cli["lc"]["t"])
    assert table.column("method").to_pylist() == [m for m in cli for _ in range(T)]
    for k, method in enumerate(cli):
        rows = slice(k * T, (k + 1) * T)
        for name in PARQUET_SERIES:
            expected = np.array([np.nan if v is None else v for v in cli[method][name]], dtype=np.float32)
            np.testing.assert_array_equal(np.asarray(table.column(name))[rows], expected, err_msg=name)

    report = page.context.new_page()
    outside: list[str] = []
    report.route("**/*", lambda route: route.continue_() if route.request.url.startswith("file:")
                 else (outside.append(route.request.url), route.abort()))
    report.goto((tmp_path / "page.html").as_uri())
    report.wait_for_function("() => document.querySelectorAll('.js-plotly-plot .main-svg').length >= 5",
                             timeout=30000)
    assert outside == []
    cells = report.locator("table").first.locator("tr").all_inner_texts()
    settings = dict(tuple(c.strip() for c in row.split("\t"))[:2] for row in cells[1:])
    assert settings["Trajectory"] == "straight" and settings["Duration [s]"] == "10" and settings["Seed"] == "3"
    assert settings["Methods"] == "LC, TC"
    errors = report.locator("table").nth(1).locator("tr").all_inner_texts()
    final = {row.split("\t")[0].strip(): float(row.split("\t")[1]) for row in errors[1:]}
    assert final == {m.upper(): pytest.approx(round(cli[m]["vel_err_mps"][-1], 4), abs=1e-4) for m in cli}
    assert tab.external_requests == []


def test_an_address_sets_the_controls_a_reload_keeps_them_and_run_uses_them(new_tab) -> None:
    """Given a page opened at an address with a configuration and one unknown key, then the
    controls hold that configuration and one notification names the key; when Seed and VB are
    changed, the address follows; after a reload the controls still hold it, and Run uses it."""
    tab = new_tab("?traj=figure8&dur=10&m=lc,tc&b=1,2,3&o3=2:6&dep=1&seed=7&zzz=1")
    page = tab.page
    tab.notification("Address: settings not applied").wait_for(timeout=30000)
    assert page.get_by_text("'zzz'='1': unknown key", exact=False).is_visible()
    page.wait_for_function("() => location.search.includes('seed=7')", timeout=30000)
    assert "zzz" not in page.url

    def check(seed: str, methods: set[str]) -> None:
        assert page.get_by_label("Trajectory").input_value() == "figure8"
        assert tab.field("Duration [s]").input_value() == "10"
        assert tab.field("Seed").input_value() == seed
        for m in ("INS", "LC", "TC", "VB", "NSV", "ELC"):
            assert tab.checkbox(m).is_checked() == (m in methods), m
        assert [tab.checkbox(f"Beam {k}").is_checked() for k in range(1, 5)] == [True, True, True, False]

    page.wait_for_function("() => [...document.querySelectorAll('input')].some(i => i.value === 'figure8')",
                           timeout=30000)
    check("7", {"LC", "TC"})
    tab.type_into("Seed", "9")
    tab.set_checkbox("VB", True)
    page.wait_for_function("() => location.search.includes('seed=9') && location.search.includes('m=lc,tc,vb&')",
                           timeout=30000)
    query = page.evaluate("location.search")
    assert re.fullmatch(r"\?[A-Za-z0-9._~,:=&-]+", query) and "o3=2:6" in query and "depth=1" in query

    page.reload()
    page.get_by_role("button", name="Run", exact=True).wait_for(timeout=30000)
    page.wait_for_function("() => [...document.querySelectorAll('input')].some(i => i.value === 'figure8')",
                           timeout=30000)
    check("9", {"LC", "TC", "VB"})
    assert page.evaluate("location.search") == query
    page.get_by_role("button", name="Run", exact=True).click()
    tab.notification("Run complete").wait_for(timeout=120000)
    used = tab.run_config()
    assert used["Trajectory"] == "figure8" and used["Duration [s]"] == "10" and used["Seed"] == "9"
    assert used["Methods"] == "LC, TC, VB" and used["DVL beams"] == "1, 2, 3"
    assert used["Outages"] == "beam 3 2-6 s" and used["Aiding"] == "dvl, depth"
    assert tab.external_requests == []
