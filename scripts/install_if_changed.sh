# Sourced by scripts/start.sh (bash): install the product in a virtualenv only when what the
# install depends on changed, so a start with nothing changed skips the 7 s of `pip install`.
#
#   . scripts/install_if_changed.sh && install_if_changed [VENV]    # from the repository's root
#
# The stamp of an install is a SHA-256 of python3's version and of every file that decides what
# `pip install -e .` installs: pyproject.toml and any setup.py, setup.cfg, requirements*.txt,
# constraints*.txt or *.lock beside it. The package's own modules are not in it: the editable
# install reads them in place. The stamp is recorded in VENV only after an install succeeded.

# Print the stamp of the current inputs (one line of hex).
install_stamp() {
    python3 - <<'PY'
import glob
import hashlib
import sys

digest = hashlib.sha256(sys.version.encode())
names = {"pyproject.toml", "setup.py", "setup.cfg"}
for pattern in ("requirements*.txt", "constraints*.txt", "*.lock"):
    names.update(glob.glob(pattern))
for name in sorted(names):
    try:
        with open(name, "rb") as fh:
            content = fh.read()
    except FileNotFoundError:
        continue
    digest.update(b"\0%s\0%d\0" % (name.encode(), len(content)))
    digest.update(content)
print(digest.hexdigest())
PY
}

# Create VENV (default .venv) with python3 and `pip install -e .` into it (with requirements-test.lock
# as pip's constraints where it exists: the versions the suite passed with, scripts/lock.sh), unless VENV's python
# exists and its recorded stamp is the current one. Returns non-zero if the install failed (the
# stamp is then absent, so the next call installs again).
install_if_changed() {
    local venv="${1:-.venv}"
    local stamp_file="$venv/.tauv-install-stamp"
    local stamp
    stamp="$(install_stamp)" || return
    if [ -x "$venv/bin/python" ] && [ -f "$stamp_file" ] && [ "$(cat "$stamp_file")" = "$stamp" ]; then
        return 0
    fi
    echo "tauv: installing into $venv (first start, or pyproject.toml or Python changed)" >&2
    rm -f "$stamp_file"
    python3 -m venv "$venv" || return
    local constraints=()
    [ -f requirements-test.lock ] && constraints=(-c requirements-test.lock)
    "$venv/bin/pip" install -q -e . "${constraints[@]}" || return
    printf '%s\n' "$stamp" > "$stamp_file.tmp" && mv "$stamp_file.tmp" "$stamp_file"
}
