#!/usr/bin/env bash
# Install everything the tests need (Debian's packages below, the Python packages in .venv) and
# run the whole suite (two passes, below). Extra arguments go to one pytest run instead.
set -euo pipefail
cd "$(dirname "$0")/.."
# Debian's Chromium for the browser tests; podman, runc and debootstrap for the container test
# (tests/browser/test_container.py builds and runs the Dockerfile's image)
NEED=""
command -v chromium >/dev/null 2>&1 || NEED="$NEED chromium"
for tool in podman runc debootstrap; do command -v "$tool" >/dev/null 2>&1 || NEED="$NEED $tool"; done
if [ -n "$NEED" ]; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  # shellcheck disable=SC2086
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $NEED >/dev/null
fi
python3 -m venv .venv
# the versions the suite last passed with (requirements-test.lock, refreshed by scripts/lock.sh)
.venv/bin/pip install -q -e '.[test]' -c requirements-test.lock
.venv/bin/python -m tauvcore.engine.warmup   # compile the filter bank once, not inside a test
if [ "$#" -gt 0 ]; then
  exec .venv/bin/python -m pytest "$@"
fi
# The whole suite: everything but the browser and container tests on both cores (pytest-xdist; a
# module's tests stay on one worker, so a module's fixture is computed once), then those, which
# time a page against a real clock, alone on a quiet machine.
status=0
.venv/bin/python -m pytest -n 2 --dist loadscope -m "not browser and not container" --durations=25 || status=$?
.venv/bin/python -m pytest -m "browser or container" --durations=25 || status=$?
exit "$status"
