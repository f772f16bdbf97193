#!/usr/bin/env bash
# Build the documentation site into site/ (open site/index.html; for search, serve it:
# python3 -m http.server -d site). Offline: nothing is fetched at build or view time. Installs the
# docs extra into .venv first. Extra arguments go to mkdocs build (e.g. --site-dir DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
python3 -m venv .venv
.venv/bin/pip install -q -e '.[docs]'
NO_MKDOCS_2_WARNING=1 exec .venv/bin/mkdocs build --strict "$@"
