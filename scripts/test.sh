#!/usr/bin/env bash
# Install everything the tests need (Debian's Chromium for the browser tests, the Python packages
# in .venv) and run the whole suite. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v chromium >/dev/null 2>&1; then
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq chromium >/dev/null
fi
python3 -m venv .venv
.venv/bin/pip install -q -e '.[test]'
.venv/bin/python -m tauvcore.engine.warmup   # compile the filter bank once, not inside a test
exec .venv/bin/python -m pytest "$@"
