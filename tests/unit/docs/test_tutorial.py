"""docs/tutorial.md runs as written: each ``tauv`` command of its bash blocks on a short mission
(``--duration 20`` added, a study of 3 runs; ``tauv serve`` is tests/server's, which start real
servers), and its Python block, which must print one line per method."""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import pytest

from app.cli import main

REPO = Path(__file__).resolve().parents[3]
PAGE = REPO / "docs" / "tutorial.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)


def _commands() -> list[list[str]]:
    lines = [line for block in _blocks("bash") for line in block.splitlines() if line.strip()]
    assert all(line.startswith("tauv ") for line in lines), lines
    return [shlex.split(line)[1:] for line in lines]


def test_the_page_has_the_commands_it_promises() -> None:
    subcommands = [argv[0] for argv in _commands()]
    assert subcommands == ["run", "run", "mc", "serve"]
    assert any("--beams" in argv for argv in _commands())


@pytest.mark.parametrize("argv", [a for a in _commands() if a[0] != "serve"], ids=lambda a: " ".join(a))
def test_each_command_runs(argv: list[str], tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    short = argv + ["--duration", "20"]
    if argv[0] == "mc":
        short = [a if a != "20" or short[i - 1] != "--runs" else "3" for i, a in enumerate(short)]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(short) == 0
    if argv[0] == "mc":
        assert {"summary.json", "runs.parquet", "report.html"} <= {p.name for p in (tmp_path / "study").iterdir()}
    else:
        assert "NEES" in out.getvalue()


def test_the_python_block_runs_and_prints_one_line_per_method() -> None:
    (block,) = _blocks("python")
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(block.replace('name="figure8")', 'name="figure8", duration_s=20.0)'), str(PAGE), "exec"), {})
    lines = out.getvalue().splitlines()
    assert [line.split()[0] for line in lines] == ["lc", "nsv", "elc"]
    assert all(float(line.split()[1]) >= 0.0 for line in lines)
