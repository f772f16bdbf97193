"""The Docker page, executed: the image built with a real container engine, served, checked for
health, used for a run in a browser, and stopped.

Given podman with runc (scripts/test.sh installs them) and a stand-in for the Dockerfile's base
made from Debian's packages (no registry is reachable: tests/release/container.py says what the
stand-in cannot prove), when the unchanged Dockerfile is built and run as the Docker page says,
then the dashboard answers GET /, the HEALTHCHECK passes, tini is PID 1 and the server runs as
UID 10001, a run completes in Chromium with nothing fetched from outside, and ``stop`` ends the
container with exit status 0 within 2 s. The figures are printed (``pytest -s``) and written to
``artifacts/container.txt``; ``benchmarks/bench_container.py`` puts them on the Docker page.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from tests.browser.conftest import ARTIFACTS, free_port
from tests.release.container import Engine, dashboard_run, missing_tools, sequence
from tests.release.dockerfile import REPO

pytestmark = pytest.mark.container

STOP_WITHIN_S = 2.0
DOCKER_PAGE = REPO / "docs" / "docker.md"
# the page's sequence, command by command (what the test runs, with podman's flags for this machine)
PAGE_COMMANDS = (
    "docker build -t tauv .",
    "docker run -d --rm -p 8080:8080 --name tauv tauv",
    "docker inspect --format '{{.State.Health.Status}}' tauv",
    "docker stop tauv",
)


def test_the_docker_page_lists_the_sequence_this_test_runs() -> None:
    block = re.search(r"```bash\n(.*?)```", DOCKER_PAGE.read_text(), re.S)
    assert block, f"no bash block in {DOCKER_PAGE}"
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines()]
    assert [c for c in commands if c] == list(PAGE_COMMANDS)


def test_image_builds_serves_answers_health_runs_and_stops(browser, tmp_path: Path) -> None:
    missing = missing_tools()
    if missing:
        pytest.fail(f"{', '.join(missing)} not installed: run the tests with `bash scripts/test.sh`")
    if os.geteuid() != 0:
        pytest.fail("the stand-in base needs root (debootstrap, chroot) and podman's root storage")
    engine = Engine.create(tmp_path / "engine")
    try:
        figures = sequence(engine, tag="localhost/tauv:container-test", container="tauv-container-test",
                           port=free_port(),
                           use_dashboard=lambda url: dashboard_run(browser, url, ARTIFACTS / "container_dashboard.png"))
    finally:
        print("\n".join(["engine commands:", *engine.log]))
    report = "\n".join(figures.lines())
    print(report)
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / "container.txt").write_text(report + "\n")
    assert figures.pid1 == "tini" and figures.uid == "10001"
    assert (figures.health_rc, figures.health_status) == (0, "healthy")
    assert figures.stop is not None
    assert figures.stop.exit_code == 0 and not figures.stop.oom_killed
    assert figures.stop.seconds < STOP_WITHIN_S, report
