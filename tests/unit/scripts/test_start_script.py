"""``scripts/start.sh`` installs only when the install's inputs changed (it would otherwise re-install
on every start, 7 s). The script and its helper run as they are, in a copy of the repository's
layout, with stubs on PATH: ``python3 -m venv`` makes a fake virtualenv whose ``pip``,
``python`` and ``tauv`` record their arguments (every other ``python3`` call is a real
interpreter: it computes the stamp)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
INSTALL = "pip install -q -e ."
WARMUP = "python -m tauvcore.engine.warmup"

PYTHON3_STUB = """#!/usr/bin/env bash
# python3: `-m venv DIR` makes a fake virtualenv (and is recorded); anything else runs $REAL_PYTHON
if [ "${1:-}" = "-m" ] && [ "${2:-}" = "venv" ]; then
    echo "venv $3" >> "$CALLS"
    mkdir -p "$3/bin"
    for tool in pip python tauv; do cp "$STUBS/$tool" "$3/bin/$tool"; done
    exit 0
fi
exec "$REAL_PYTHON" "$@"
"""
TOOL_STUB = """#!/usr/bin/env bash
echo "{name} $*" >> "$CALLS"
exit {status}
"""


@pytest.fixture
def repo(tmp_path: Path) -> Path:
    """A repository's layout: the two scripts, a pyproject.toml and a module, plus the stubs."""
    root = tmp_path / "repo"
    (root / "scripts").mkdir(parents=True)
    for name in ("start.sh", "install_if_changed.sh"):
        shutil.copy(REPO / "scripts" / name, root / "scripts" / name)
    (root / "pyproject.toml").write_text('[project]\nname = "tauv"\ndependencies = ["numpy>=1.26"]\n')
    (root / "tauvcore").mkdir()
    (root / "tauvcore" / "mod.py").write_text("X = 1\n")
    stubs = tmp_path / "stubs"
    stubs.mkdir()
    _executable(stubs / "python3", PYTHON3_STUB)
    _executable(stubs / "pip", TOOL_STUB.format(name="pip", status="${FAKE_PIP_STATUS:-0}"))
    _executable(stubs / "python", TOOL_STUB.format(name="python", status=0))
    _executable(stubs / "tauv", TOOL_STUB.format(name="tauv", status=0))
    return root


def _executable(path: Path, text: str) -> None:
    path.write_text(text)
    path.chmod(0o755)


def _env(repo: Path, real_python: str = sys.executable, pip_status: int = 0) -> dict[str, str]:
    stubs = repo.parent / "stubs"
    return {**os.environ, "PATH": f"{stubs}{os.pathsep}{os.environ['PATH']}", "STUBS": str(stubs),
            "CALLS": str(repo.parent / "calls.log"), "REAL_PYTHON": real_python,
            "FAKE_PIP_STATUS": str(pip_status)}


def _calls(repo: Path) -> list[str]:
    """The recorded calls since the last look (the record is emptied)."""
    log = repo.parent / "calls.log"
    lines = log.read_text().splitlines() if log.exists() else []
    log.write_text("")
    return lines


def _start(repo: Path, *args: str, **env: object) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(repo / "scripts" / "start.sh"), *args], cwd=repo.parent,
                          env=_env(repo, **env), capture_output=True, text=True, timeout=60)


def _install_if_changed(repo: Path, **env: object) -> subprocess.CompletedProcess:
    script = "set -euo pipefail; . scripts/install_if_changed.sh; install_if_changed .venv"
    return subprocess.run(["bash", "-c", script], cwd=repo, env=_env(repo, **env), capture_output=True, text=True,
                          timeout=60)


def _stamp(repo: Path) -> Path:
    return repo / ".venv" / ".tauv-install-stamp"


def test_the_first_start_installs_and_a_start_with_nothing_changed_does_not(repo: Path) -> None:
    first = _start(repo, "--port", "9000")
    assert first.returncode == 0, first.stderr
    assert _calls(repo) == ["venv .venv", INSTALL, WARMUP, "tauv serve --port 9000"]
    assert _stamp(repo).is_file()
    (repo / "tauvcore" / "mod.py").write_text("X = 2\n")          # the editable install reads it in place
    again = _start(repo, "--port", "9000")
    assert again.returncode == 0, again.stderr
    assert _calls(repo) == [WARMUP, "tauv serve --port 9000"]
    assert again.stderr == ""                                     # no install, nothing said about one


@pytest.mark.parametrize("change", ["pyproject", "new lock file", "new requirements file", "venv removed"])
def test_a_changed_input_installs_again(repo: Path, change: str) -> None:
    assert _install_if_changed(repo).returncode == 0 and _calls(repo) == ["venv .venv", INSTALL]
    if change == "pyproject":
        (repo / "pyproject.toml").write_text('[project]\nname = "tauv"\ndependencies = ["numpy>=2"]\n')
    elif change == "new lock file":
        (repo / "uv.lock").write_text("version = 1\n")
    elif change == "new requirements file":
        (repo / "requirements.txt").write_text("scipy==1.11\n")
    else:
        shutil.rmtree(repo / ".venv")
    assert _install_if_changed(repo).returncode == 0 and _calls(repo) == ["venv .venv", INSTALL]
    assert _install_if_changed(repo).returncode == 0 and _calls(repo) == []


def test_another_python_installs_again(repo: Path) -> None:
    other = _other_python()
    if other is None:
        pytest.skip("no second Python interpreter with another version on this machine")
    assert _install_if_changed(repo).returncode == 0 and _calls(repo) == ["venv .venv", INSTALL]
    assert _install_if_changed(repo, real_python=other).returncode == 0
    assert _calls(repo) == ["venv .venv", INSTALL]


def test_a_failed_install_leaves_no_stamp_and_the_next_start_installs(repo: Path) -> None:
    assert _install_if_changed(repo).returncode == 0
    (repo / "pyproject.toml").write_text('[project]\nname = "tauv"\ndependencies = ["numpy>=3"]\n')
    _calls(repo)
    failed = _start(repo, pip_status=1)
    assert failed.returncode != 0
    assert _calls(repo) == ["venv .venv", INSTALL]                # no warm-up, no server after a failed install
    assert not _stamp(repo).exists() and not _stamp(repo).with_suffix(".tmp").exists()
    assert _start(repo).returncode == 0
    assert _calls(repo) == ["venv .venv", INSTALL, WARMUP, "tauv serve"]
    assert _stamp(repo).is_file()


def _other_python() -> str | None:
    """A Python 3 interpreter whose ``sys.version`` differs from this one's, if any."""
    for name in ("/usr/bin/python3", "python3.12", "python3.11", "python3.10", "python3.13"):
        path = shutil.which(name)
        if path is None:
            continue
        probe = subprocess.run([path, "-c", "import sys; print(sys.version)"], capture_output=True, text=True)
        if probe.returncode == 0 and probe.stdout.strip() != sys.version:
            return path
    return None


def test_the_install_takes_the_test_lock_as_its_constraints(repo: Path) -> None:
    """Given requirements-test.lock beside pyproject.toml, when the product is installed, then pip
    takes it as its constraints (a fresh machine gets the versions the suite passed with), and a
    change to it installs again."""
    (repo / "requirements-test.lock").write_text("numpy==2.2.6\n")
    assert _install_if_changed(repo).returncode == 0
    assert _calls(repo) == ["venv .venv", f"{INSTALL} -c requirements-test.lock"]
    (repo / "requirements-test.lock").write_text("numpy==2.3.0\n")
    assert _install_if_changed(repo).returncode == 0
    assert _calls(repo) == ["venv .venv", f"{INSTALL} -c requirements-test.lock"]
