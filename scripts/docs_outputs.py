"""The command outputs the documentation shows, written by running their commands.

    python scripts/docs_outputs.py            # run every shown command, rewrite its output file
    python scripts/docs_outputs.py NAME ...   # only these (docs/results/outputs/NAME.txt)
    python scripts/docs_outputs.py --check    # rewrite nothing; exit 1 if a shown output differs

A shown output is a file docs/results/outputs/NAME.txt: one or more ``$ COMMAND`` lines, each
followed by what the command printed (its standard output, then its standard error). A page shows
it inside a fenced block with pymdownx.snippets, so the page and the suite read the same file::

    ```text
    --8<-- "docs/results/outputs/NAME.txt"
    ```

To show a new output, write the file with its ``$ `` lines alone and run this script. The
commands run in order in a new empty directory with ``bash`` (``tauv`` is this checkout's
``python -m app.cli``, ``COLUMNS=100``), each within a minute. Timing figures (``(0.7 s wall)``)
are masked when outputs are compared (:func:`mask`), so the check holds on any machine;
tests/release/test_docs_outputs.py runs the check in the suite.
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUTPUTS = REPO / "docs" / "results" / "outputs"
PROMPT = "$ "
TIMEOUT_S = 60.0
"""Longest a shown command may take: a shown run is shortened (``--duration``) until it takes seconds."""
MASKS = ((re.compile(r"\(\d+(?:\.\d+)? s wall\)"), "(... s wall)"),)
"""Figures that differ from run to run (wall-clock times), and what they read as when compared."""


class ShownCommandError(Exception):
    """A shown command failed or took longer than :data:`TIMEOUT_S`; the message names it."""


def commands(text: str) -> list[str]:
    """The ``$ `` command lines of an output file's text, in order."""
    return [line.removeprefix(PROMPT) for line in text.splitlines() if line.startswith(PROMPT)]


def mask(text: str) -> str:
    """``text`` with :data:`MASKS` applied and trailing blanks dropped, as outputs are compared."""
    for pattern, replacement in MASKS:
        text = pattern.sub(replacement, text)
    return "\n".join(line.rstrip() for line in text.rstrip().splitlines())


def run(shown: list[str], workdir: Path) -> str:
    """The output file's text for the commands ``shown``, each run in ``workdir`` (see the module's
    docstring). Raises :class:`ShownCommandError` if one exits with an error or times out."""
    bin_dir = workdir / ".bin"
    bin_dir.mkdir()
    shim = bin_dir / "tauv"
    shim.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m app.cli "$@"\n', encoding="utf-8")
    shim.chmod(0o755)
    env = {
        **os.environ,
        "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}",
        "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p),
        "COLUMNS": "100",
    }
    parts = []
    for command in shown:
        try:
            proc = subprocess.run(
                ["bash", "-c", command],
                cwd=workdir,
                env=env,
                capture_output=True,
                text=True,
                timeout=TIMEOUT_S,
                check=False,
            )
        except subprocess.TimeoutExpired:
            raise ShownCommandError(f"{command!r} took more than {TIMEOUT_S:g} s") from None
        if proc.returncode != 0:
            raise ShownCommandError(
                f"{command!r} exited with {proc.returncode}: {proc.stderr.strip()[-500:]}"
            )
        parts.append(f"{PROMPT}{command}\n{proc.stdout.rstrip()}\n{proc.stderr.rstrip()}".rstrip())
    return "\n".join(parts) + "\n"


def regenerate(path: Path) -> tuple[str, str]:
    """Run ``path``'s commands; (the file's text, the text they print now)."""
    old = path.read_text(encoding="utf-8")
    shown = commands(old)
    if not shown:
        raise ShownCommandError(f"{path.relative_to(REPO)} has no '{PROMPT}' command line")
    with tempfile.TemporaryDirectory(prefix="tauv-docs-") as tmp:
        return old, run(shown, Path(tmp))


def write(path: Path, text: str) -> None:
    """``text`` into ``path`` whole (a temporary file beside it, then renamed)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".txt", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="output files to refresh (default: all)")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if an output differs")
    args = parser.parse_args(argv)
    paths = sorted(OUTPUTS.glob("*.txt")) if not args.names else [OUTPUTS / f"{n}.txt" for n in args.names]
    differ = 0
    for path in paths:
        try:
            old, new = regenerate(path)
        except (ShownCommandError, OSError) as exc:
            print(f"docs_outputs: {path.name}: {exc}", file=sys.stderr)
            return 2
        if mask(old) == mask(new):
            print(f"{path.relative_to(REPO)}: as shown")
            continue
        differ += 1
        if args.check:
            diff = difflib.unified_diff(
                mask(old).splitlines(), mask(new).splitlines(), "shown", "printed", lineterm=""
            )
            print(f"{path.relative_to(REPO)}: differs\n" + "\n".join(diff))
        else:
            write(path, new)
            print(f"{path.relative_to(REPO)}: rewritten")
    return 1 if args.check and differ else 0


if __name__ == "__main__":
    raise SystemExit(main())
