"""The documentation site (mkdocs.yml, docs/): built as `bash scripts/docs.sh` builds it, with
every warning an error (a broken link or anchor, a page left out of the navigation, a docstring
the API reference cannot read), into a temporary directory; nothing in it is fetched when a page
is viewed; the README stays a front door whose links reach the site's pages."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.release

REPO = Path(__file__).resolve().parents[2]
README_MAX_LINES = 250


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str], float]:
    out = tmp_path_factory.mktemp("site")
    mkdocs = Path(sys.executable).with_name("mkdocs")
    assert mkdocs.exists(), "mkdocs not installed: pip install -e '.[test]'"
    started = time.perf_counter()
    proc = subprocess.run(
        [str(mkdocs), "build", "--strict", "--site-dir", str(out)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    return out, proc, time.perf_counter() - started


def test_the_site_builds_with_warnings_as_errors_in_under_a_minute(site) -> None:
    out, proc, elapsed_s = site
    assert proc.returncode == 0, proc.stdout + proc.stderr
    warnings = [line for line in (proc.stdout + proc.stderr).splitlines() if line.startswith(("WARNING", "ERROR"))]
    assert warnings == []
    assert elapsed_s < 60.0, f"the build took {elapsed_s:.1f} s"
    assert (out / "index.html").is_file() and (out / "api" / "engine.html").is_file()


def test_the_api_reference_holds_the_library_s_docstrings(site) -> None:
    out, _, _ = site
    engine = (out / "api" / "engine.html").read_text(encoding="utf-8")
    for name in ("run_streaming", "SimChunk", "MethodResult"):
        assert 'id="tauvcore.engine.' in engine and name in engine, name
    aiding = (out / "api" / "aiding.html").read_text(encoding="utf-8")
    assert "AidingSource" in aiding and "observes" in aiding


def test_nothing_in_the_site_is_fetched_when_a_page_is_viewed(site) -> None:
    out, _, _ = site
    external = re.compile(r"""<(?:script|link|img|iframe)\b[^>]*\b(?:src|href)=["'](?:https?:)?//""", re.I)
    for page in out.rglob("*.html"):
        found = external.findall(page.read_text(encoding="utf-8"))
        assert not found, f"{page.relative_to(out)}: {found}"
    for sheet in out.rglob("*.css"):
        assert not re.search(r"@import\s+url\(\s*[\"']?https?:", sheet.read_text(encoding="utf-8")), sheet


def test_the_readme_is_a_front_door_whose_links_reach_the_site() -> None:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= README_MAX_LINES
    links = re.findall(r"\]\((docs/[^)#]+)", text)
    assert len(links) >= 10
    for link in links:
        assert (REPO / link).is_file(), link
    assert not re.search(r"\b(issue|session) [0-9]", text, re.I)


def test_the_cli_page_holds_every_subcommand_s_help_as_tauv_prints_it(site) -> None:
    """docs/hooks/cli_reference.py writes the help from the parser at build time; here each is
    compared with what the installed `tauv CMD --help` prints (COLUMNS=100), so the page cannot
    drift from the command line."""
    import html

    from app.cli import build_parser

    out, _, _ = site
    page = html.unescape(re.sub(r"<[^>]+>", "", (out / "cli.html").read_text(encoding="utf-8")))
    tauv = Path(sys.executable).with_name("tauv")
    parser = build_parser()
    commands = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction").choices
    assert {"run", "mc", "replay", "reproduce", "serve", "config"} <= set(commands)
    for argv in ([], *([name] for name in commands)):
        printed = subprocess.run(
            [str(tauv), *argv, "--help"], capture_output=True, text=True, timeout=60,
            env={**os.environ, "COLUMNS": "100"},
        ).stdout.rstrip()
        assert printed.startswith("usage: tauv"), argv
        assert printed in page, f"tauv {' '.join(argv)} --help is not on the page as printed"


def test_every_included_table_is_written_by_the_benchmark_it_names() -> None:
    """A page's table comes from its benchmark (benchmarks/fragment.py): the fragment ends with the
    command that wrote it, and that benchmark writes fragments and names this one in its source."""
    includes = {
        name
        for page in (REPO / "docs").glob("*.md")
        for name in re.findall(r'^--8<-- "docs/results/([\w.-]+)\.md"', page.read_text(encoding="utf-8"), re.M)
    }
    assert {"longrange", "bench_run", "yoo_mag", "paper_table", "partial_kinematic", "consistency_table",
            "akit_table", "usbl_table", "container"} <= includes
    for name in includes:
        text = (REPO / "docs" / "results" / f"{name}.md").read_text(encoding="utf-8")
        command = re.search(r"\*Written by `python (benchmarks/\w+\.py)[^`]*` on ", text.splitlines()[-1])
        assert command, f"docs/results/{name}.md does not say which benchmark wrote it"
        source = (REPO / command.group(1)).read_text(encoding="utf-8")
        assert "fragment.write(" in source, command.group(1)
        assert f"'{name}'" in source or f"{name}.md" in source, (name, command.group(1))


def test_every_fragment_is_shown_on_a_page() -> None:
    """No table is written for nobody: every fragment under docs/results/ is included by a page."""
    pages = "".join(p.read_text(encoding="utf-8") for p in (REPO / "docs").glob("*.md"))
    for fragment in (REPO / "docs" / "results").glob("*.md"):
        assert f'--8<-- "docs/results/{fragment.name}"' in pages, fragment.name
