"""The two locks: ``requirements-test.lock`` (what scripts/start.sh and scripts/test.sh install
with as pip's constraints) pins every package of the product and of the test extra within
pyproject.toml's specifiers, agrees with ``requirements.lock`` (the Docker image's, with hashes) on
every package both hold, and says which script made it; both README commands install with it."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

pytestmark = pytest.mark.release

REPO = Path(__file__).resolve().parents[2]
TEST_LOCK = REPO / "requirements-test.lock"
LOCK = REPO / "requirements.lock"


def _pins(path: Path) -> dict[str, Version]:
    pins = {}
    for line in path.read_text().splitlines():
        m = re.match(r"^([A-Za-z0-9_.\-]+)==([^\s;\\]+)", line)
        if m:
            pins[_canonical(m.group(1))] = Version(m.group(2))
    return pins


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def test_the_test_lock_pins_the_product_and_the_test_extra_within_pyproject() -> None:
    """Given pyproject.toml, then every dependency of the product and of the test extra (the docs
    extra it names included) is pinned in requirements-test.lock within its specifier."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    pins = _pins(TEST_LOCK)
    specs = [*project["dependencies"], *project["optional-dependencies"]["test"],
             *project["optional-dependencies"]["docs"]]
    for spec in specs:
        req = Requirement(spec)
        if req.name == "tauv":
            continue                                       # the project itself: the extra names its docs extra
        name = _canonical(req.name)
        assert name in pins, f"{req.name} is not in requirements-test.lock: bash scripts/lock.sh"
        assert req.specifier.contains(pins[name], prereleases=True), f"{name}=={pins[name]} outside {req.specifier}"


def test_the_two_locks_agree_and_the_test_lock_says_how_it_was_made() -> None:
    """Given both locks, then each package in both has one version, and the test lock's header
    names scripts/lock.sh and carries no hashes (pip refuses an editable install in hash mode)."""
    docker, tested = _pins(LOCK), _pins(TEST_LOCK)
    differ = {name: (str(docker[name]), str(tested[name])) for name in docker.keys() & tested.keys()
              if docker[name] != tested[name]}
    assert not differ, f"the locks disagree: {differ}; bash scripts/lock.sh"
    assert docker.keys() <= tested.keys(), sorted(docker.keys() - tested.keys())
    text = TEST_LOCK.read_text()
    assert text.splitlines()[1].strip() == "#    bash scripts/lock.sh"
    assert "--hash" not in text


@pytest.mark.parametrize("script", ["scripts/test.sh", "scripts/install_if_changed.sh"])
def test_both_readme_commands_install_with_the_test_lock(script: str) -> None:
    """Given the README's two commands, then the pip install each runs takes the test lock as its
    constraints."""
    text = (REPO / script).read_text()
    installs = [line for line in text.splitlines() if re.search(r"pip\"? install", line) and not line.lstrip().startswith("#")]
    assert "-c requirements-test.lock" in text
    assert installs and all("requirements-test.lock" in line or "constraints" in line for line in installs), installs
