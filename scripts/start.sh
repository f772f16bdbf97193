#!/usr/bin/env bash
# Install the product in .venv (only when pyproject.toml, a lock or requirements file, or the
# Python version changed since the last successful install: scripts/install_if_changed.sh) and
# start the dashboard (prints its address). Extra arguments go to `tauv serve`, e.g.
# `bash scripts/start.sh --port 9000`.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/install_if_changed.sh
install_if_changed .venv
.venv/bin/python -m tauvcore.engine.warmup   # compile the filter bank once (later: loads the cache, ~1 s)
exec .venv/bin/tauv serve "$@"
