#!/usr/bin/env bash
# Install the product in .venv and start the dashboard (prints its address). Extra arguments go
# to `tauv serve`, e.g. `bash scripts/start.sh --port 9000`.
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/pip install -q -e .
.venv/bin/python -m tauvcore.eval.warmup   # compile the filter bank once, not during the first run
exec .venv/bin/tauv serve "$@"
