"""The house's shape, checked by the test command: the import contract of pyproject.toml
(``[tool.importlinter]``: data flows one way, truth -> sensors -> ins/filter -> aiding -> engine ->
eval -> app, the logs' room in layers of its own, and no circle of imports anywhere in ``tauvcore``
or ``app``) holds, and would fail on
an upward import or a circle; no module grows past about 800 lines unless it is one of the few
that are still to be split, each held to the size it has now."""

from __future__ import annotations

import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

pytestmark = pytest.mark.release

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("tauvcore", "app")

MAX_LINES = 800
"""A module longer than this is split along its own sections."""
STILL_TO_SPLIT: dict[str, int] = {}
"""The modules over MAX_LINES, each at most the size it has now (a ratchet: it may shrink, not grow;
once under MAX_LINES it leaves this table)."""


LINT = """
import sys
root, site_packages = sys.argv.pop(1), sys.argv.pop(1)
sys.path[:0] = [root, site_packages]
from importlinter.cli import lint_imports_command
sys.exit(lint_imports_command())
"""
"""``lint-imports`` under ``python -S``: the site's .pth files are not read, so the editable
install's finder (which maps ``tauvcore``, a namespace package, and ``app`` to this checkout) does
not join the packages under ``root``."""


def _lint_imports(root: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on the packages under ``root`` (the contract of REPO's pyproject.toml)."""
    assert Path(sys.executable).with_name("lint-imports").exists(), (
        "import-linter not installed: pip install -e '.[test]'"
    )
    site_packages = sysconfig.get_paths()["purelib"]
    return subprocess.run(
        [sys.executable, "-S", "-c", LINT, str(root), site_packages, str(REPO / "pyproject.toml"), "--no-cache"],
        cwd=root, capture_output=True, text=True, timeout=300,
    )


def test_the_import_contract_holds() -> None:
    done = _lint_imports(REPO)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "4 kept, 0 broken" in done.stdout, done.stdout


@pytest.fixture(scope="module")
def copy_of_the_tree(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("tree")
    for package in PACKAGES:
        shutil.copytree(REPO / package, root / package, ignore=shutil.ignore_patterns("__pycache__"))
    return root


@pytest.mark.parametrize(
    ("module", "line", "broken"),
    [
        # an upward import: the configuration reaching into the engine
        ("tauvcore/config.py", "import tauvcore.engine.mission\n", "Data flows one way"),
        # a circle inside one layer: the engine's results importing the bank that builds them
        ("tauvcore/engine/results.py", "import tauvcore.engine.filter_bank\n", "No circles"),
        # a circle in the app: the JSON document importing the command line that writes it
        ("app/reports/payload.py", "import app.cli\n", "No circles"),
        # inside the logs' room: the record reaching up to the reader that assembles it
        ("tauvcore/logs/log_record.py", "import tauvcore.logs.reader\n", "Inside the logs' room"),
        # the app's rooms: a figure reaching up into the dashboard that shows it
        ("app/figures/shared.py", "import app.dashboard.inputs\n", "The app's rooms"),
    ],
)
def test_the_contract_fails_on_an_upward_import_or_a_circle(
    copy_of_the_tree: Path, module: str, line: str, broken: str
) -> None:
    path = copy_of_the_tree / module
    original = path.read_text()
    path.write_text(original + line)
    try:
        done = _lint_imports(copy_of_the_tree)
    finally:
        path.write_text(original)
    assert done.returncode != 0, done.stdout
    assert f"{broken}" in done.stdout and "BROKEN" in done.stdout, done.stdout


def test_no_module_grows_past_its_size() -> None:
    sizes = {
        str(path.relative_to(REPO)): len(path.read_text().splitlines())
        for package in PACKAGES
        for path in sorted((REPO / package).rglob("*.py"))
    }
    too_long = {name: n for name, n in sizes.items() if n > STILL_TO_SPLIT.get(name, MAX_LINES)}
    assert not too_long, f"split these modules along their sections (lines now): {too_long}"
    gone = {name for name in STILL_TO_SPLIT if sizes.get(name, 0) <= MAX_LINES}
    assert not gone, f"under {MAX_LINES} lines now, take them out of STILL_TO_SPLIT: {sorted(gone)}"
