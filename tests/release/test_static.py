"""Static checks of the package, run by the test command: ruff's lint (its default rules, import
order and pep8-naming, with the field's matrix names allowed in pyproject.toml) and ruff's format
find nothing in `app` and `tauvcore`, and pyright's checker (basedpyright, "standard" mode) finds no
type error. Each test fails with the tool's own report, so the offending line is named."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.release

REPO = Path(__file__).resolve().parents[2]
CHECKED = ["app", "tauvcore", "examples"]


def _tool(name: str) -> str:
    """The console script of the test extra, next to this interpreter."""
    path = Path(sys.executable).with_name(name)
    assert path.exists(), f"{name} not installed: pip install -e '.[test]'"
    return str(path)


def _run(argv: list[str], timeout_s: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=timeout_s)


def test_ruff_lint_finds_nothing() -> None:
    done = _run([_tool("ruff"), "check", "--no-cache", *CHECKED], 120)
    assert done.returncode == 0, done.stdout + done.stderr


def test_ruff_format_would_change_nothing() -> None:
    done = _run([_tool("ruff"), "format", "--check", "--no-cache", *CHECKED], 120)
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_matrix_names_are_allowed_by_configuration_not_by_suppressions() -> None:
    """pep8-naming is on, and no line in the package silences it: `P`, `F`, `H`, `C_nb` pass by the
    pyproject's ignore-names."""
    done = _run([_tool("ruff"), "check", "--no-cache", "--select", "N", "--isolated", "app", "tauvcore"], 120)
    assert done.returncode != 0 and "N806" in done.stdout, "without the configuration the names must be flagged"
    hits = [
        f"{path.relative_to(REPO)}:{i}"
        for folder in ("app", "tauvcore")
        for path in sorted((REPO / folder).rglob("*.py"))
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if "noqa: N" in line or "noqa:N" in line
    ]
    assert hits == [], f"pep8-naming suppressed line by line: {hits}"


def test_pyright_finds_no_type_error() -> None:
    done = _run([_tool("basedpyright"), "--pythonpath", sys.executable], 600)
    assert done.returncode == 0, done.stdout[-20000:] + done.stderr
    assert "0 errors" in done.stdout, done.stdout[-2000:]


def test_the_tests_benchmarks_and_scripts_have_no_pyflakes_finding() -> None:
    """Outside the package, pyflakes' findings (unused or undefined names) and import order."""
    done = _run([_tool("ruff"), "check", "--no-cache", "--select", "F,I", "tests", "benchmarks", "scripts"], 120)
    assert done.returncode == 0, done.stdout + done.stderr
