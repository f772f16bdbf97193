"""Where a benchmark's table goes: a Markdown fragment under docs/results/ that a page of the
documentation site includes (``--8<-- "docs/results/<name>.md"``, pymdownx.snippets), so that a
re-run refreshes the page and no figure is typed by hand.

The fragment is the table, then one line naming the command that wrote it, the machine (cores,
processor, memory, Python) and the date. It is written whole into a temporary file and moved into
place, so an interrupted run leaves the previous fragment.
"""

from __future__ import annotations

import contextlib
import datetime
import io
import os
import platform
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[1] / "docs" / "results"


def machine() -> str:
    """This machine in a few words: cores, processor, memory, Python."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        pages = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        memory = f", {pages / 2**30:.0f} GiB"
    except (ValueError, OSError):
        memory = ""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return f"{cores} cores ({cpu}){memory}, Python {platform.python_version()}"


def write(name: str, markdown: str, argv: list[str] | None = None) -> Path:
    """Write ``markdown`` (the table) as docs/results/``name``.md with the line saying how it was
    measured; returns the path. ``argv``: the benchmark's own command line (default sys.argv)."""
    argv = sys.argv if argv is None else argv
    script = Path(argv[0])
    command = " ".join(["python", f"benchmarks/{script.name}", *argv[1:]])
    today = datetime.date.today().isoformat()
    text = f"{markdown.rstrip()}\n\n*Written by `{command}` on {machine()}, {today}.*\n"
    RESULTS.mkdir(parents=True, exist_ok=True)
    target = RESULTS / f"{name}.md"
    fd, tmp = tempfile.mkstemp(prefix=f".{name}-", suffix=".md", dir=RESULTS)
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, target)
    return target


class _Tee(io.TextIOBase):
    def __init__(self, out) -> None:
        self.out = out
        self.kept = io.StringIO()

    def write(self, text: str) -> int:
        self.kept.write(text)
        return self.out.write(text)

    def flush(self) -> None:
        self.out.flush()


@contextlib.contextmanager
def capture() -> Iterator[io.StringIO]:
    """Print as usual inside the block and keep what was printed (``.getvalue()`` afterwards), so
    that the fragment is exactly what the terminal showed."""
    tee = _Tee(sys.stdout)
    sys.stdout = tee
    try:
        yield tee.kept
    finally:
        sys.stdout = tee.out
