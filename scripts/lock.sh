#!/usr/bin/env bash
# Refresh the two locks from pyproject.toml with uv (in a throw-away virtualenv, not in .venv):
#   requirements.lock       the product's dependencies, pinned with hashes (the Docker image installs it)
#   requirements-test.lock  the product's and the test extra's, pinned within requirements.lock's pins;
#                           scripts/start.sh and scripts/test.sh install with it as pip's constraints,
#                           so a fresh machine gets the versions the suite last passed with
# Each lock keeps its pins (uv takes an existing output file as its preferences) unless a newer
# release is needed; `bash scripts/lock.sh --upgrade` moves every pin to its newest release. Run the
# whole suite after a refresh and commit both locks with it.
set -euo pipefail
cd "$(dirname "$0")/.."
UV_VERSION="0.13.9"
tools="$(mktemp -d)"
trap 'rm -rf "$tools"' EXIT
python3 -m venv "$tools"
"$tools/bin/pip" install -q "uv==$UV_VERSION"
common=(--python-version 3.11 --python-platform linux "$@")
"$tools/bin/uv" pip compile pyproject.toml "${common[@]}" --generate-hashes -o requirements.lock
"$tools/bin/uv" pip compile pyproject.toml --extra test -c requirements.lock "${common[@]}" \
    --custom-compile-command "bash scripts/lock.sh" -o requirements-test.lock
