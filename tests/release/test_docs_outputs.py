"""What the pages show a command print is what it prints: every shown output
(docs/results/outputs/NAME.txt, included by a page) is run again by scripts/docs_outputs.py and
compared, timing figures masked; no page types an output by hand; and every ``tauv`` command in
a page's code block (docs/*.md, README.md) names only flags its subcommand has and runs, on a short
mission, in under a minute."""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PAGES = sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md"]
_spec = importlib.util.spec_from_file_location("docs_outputs", REPO / "scripts" / "docs_outputs.py")
assert _spec and _spec.loader
docs_outputs = importlib.util.module_from_spec(_spec)
sys.modules["docs_outputs"] = docs_outputs
_spec.loader.exec_module(docs_outputs)

SHOWN = sorted(docs_outputs.OUTPUTS.glob("*.txt"))
INCLUDE = re.compile(r'^--8<-- "docs/results/outputs/([\w.-]+)"$', re.MULTILINE)
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.MULTILINE | re.DOTALL)
PLACEHOLDER = re.compile(r"\b[A-Z][A-Z_]{2,}\b|\.bag\b|\.mcap\b")
"""A command naming a file the reader brings (LOG_DIR, OUT_DIR, mission.bag): checked, not run."""
SHORT_S = "20"
MAX_RUNS = 3


def _tauv_lines(page: Path) -> list[str]:
    """Every line of the page's fenced code blocks that runs ``tauv`` (its shell comment dropped)."""
    lines = []
    for block in FENCE.findall(page.read_text(encoding="utf-8")):
        for line in block.splitlines():
            line = line.removeprefix("$ ")
            if not line.startswith("tauv "):
                continue  # another program's line (docker, ruff, a formula in a text block)
            words = shlex.split(line, comments=True)
            if words[:1] == ["tauv"]:
                lines.append(shlex.join(words))
    return lines


COMMANDS = sorted({(page.name, line) for page in PAGES for line in _tauv_lines(page)})


def test_the_pages_show_outputs_and_commands() -> None:
    assert SHOWN, "no shown output under docs/results/outputs/"
    assert len(COMMANDS) >= 10
    study = "tauv mc --trajectory figure8 --method ins,tc,nsv,elc --beams 1,2 --runs 100 --seed 1 --out study/ --workers 2"
    assert ("studies.md", study) in COMMANDS


@pytest.mark.parametrize("path", SHOWN, ids=lambda p: p.name)
def test_each_shown_output_is_what_its_command_prints(path: Path, tmp_path: Path) -> None:
    """The check ``python scripts/docs_outputs.py --check`` makes, one file at a time; on a failure,
    ``python scripts/docs_outputs.py NAME`` rewrites the file from the code."""
    shown = path.read_text(encoding="utf-8")
    printed = docs_outputs.run(docs_outputs.commands(shown), tmp_path)
    assert docs_outputs.mask(printed) == docs_outputs.mask(shown), (
        f"{path.name} no longer shows what its command prints: python scripts/docs_outputs.py {path.stem}"
    )


def test_the_mask_hides_the_wall_time_and_nothing_else() -> None:
    assert docs_outputs.mask("seed 1, aiding dvl  (0.7 s wall)\n") == docs_outputs.mask(
        "seed 1, aiding dvl  (12.25 s wall)  \n\n"
    )
    assert docs_outputs.mask("pos 2.723 (0.7 s wall)") != docs_outputs.mask("pos 2.724 (0.7 s wall)")


def test_the_check_fails_on_a_shown_output_that_drifted(tmp_path: Path, monkeypatch) -> None:
    drifted = tmp_path / "config.txt"
    drifted.write_text("$ tauv config --imu phins\n[imu]\nrate_hz = 1.0\n", encoding="utf-8")
    monkeypatch.setattr(docs_outputs, "OUTPUTS", tmp_path)
    monkeypatch.setattr(docs_outputs, "REPO", tmp_path)
    assert docs_outputs.main(["--check"]) == 1
    assert drifted.read_text(encoding="utf-8").endswith("rate_hz = 1.0\n")  # --check writes nothing
    assert docs_outputs.main([]) == 0
    assert docs_outputs.main(["--check"]) == 0
    assert "rate_hz = 100.0" in drifted.read_text(encoding="utf-8")


def test_every_shown_output_is_on_a_page_and_no_page_types_one() -> None:
    included = {name for page in PAGES for name in INCLUDE.findall(page.read_text(encoding="utf-8"))}
    assert included == {p.name for p in SHOWN}
    for page in PAGES:
        for block in FENCE.findall(page.read_text(encoding="utf-8")):
            typed = [line for line in block.splitlines() if line.startswith("$ tauv")]
            assert not typed, (
                f"{page.name} types an output by hand: {typed[0]!r} (show it from a file of {docs_outputs.OUTPUTS.relative_to(REPO)})"
            )


def _subcommand_flags() -> dict[str, set[str]]:
    from app.cli import OPTIONS

    return {command: {s for a in actions for s in a.option_strings} for command, actions in OPTIONS.items()}


@pytest.mark.parametrize(("page", "line"), COMMANDS, ids=[f"{p}: {c}" for p, c in COMMANDS])
def test_every_command_on_a_page_names_only_its_subcommand_s_flags(page: str, line: str) -> None:
    flags = _subcommand_flags()
    words = shlex.split(line)[1:]
    command = " ".join(words[:2]) if " ".join(words[:2]) in flags else words[0]
    assert command in flags, f"{page}: {line!r}: no subcommand {words[0]!r}"
    named = set(re.findall(r"(?<![\w-])--[a-z][\w-]*", line))  # also a synopsis's [--flag ...]
    assert named <= flags[command], (
        f"{page}: {line!r}: tauv {command} has no {sorted(named - flags[command])}"
    )


def _short(words: list[str]) -> list[str]:
    """The command on a short mission (``--duration 20``, at most 3 runs), as
    tests/unit/docs/test_tutorial.py does."""
    out = list(words)
    if out[0] in ("run", "mc", "replay") and "--duration" not in out and out[0] != "replay":
        out += ["--duration", SHORT_S]
    if "--runs" in out:
        i = out.index("--runs") + 1
        out[i] = str(min(int(out[i]), MAX_RUNS))
    return out


def _files_written(page: Path) -> list[str]:
    """The page's ``printf ... > FILE`` lines: the files its commands then read (adding_a_method.md's cv.toml)."""
    blocks = FENCE.findall(page.read_text(encoding="utf-8"))
    return [
        line for block in blocks for line in block.splitlines() if re.match(r"printf '[^']*' > [\w.]+$", line)
    ]


RUNNABLE = [
    (page, line)
    for page, line in COMMANDS
    if page != "tutorial.md"  # tests/unit/docs/test_tutorial.py runs the tutorial's
    and not PLACEHOLDER.search(line)
    and shlex.split(line)[1] in ("run", "mc", "config")
]


@pytest.mark.parametrize(("page", "line"), RUNNABLE, ids=[f"{p}: {c}" for p, c in RUNNABLE])
def test_every_command_on_a_page_runs_on_a_short_mission(page: str, line: str, tmp_path: Path) -> None:
    words = _short(shlex.split(line)[1:])
    for written in _files_written(REPO / "docs" / page if page != "README.md" else REPO / page):
        subprocess.run(["bash", "-c", written], cwd=tmp_path, check=True, timeout=10)
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", *words],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )
    assert proc.returncode == 0, f"{page}: {line!r}: {proc.stderr.strip()}"
    assert proc.stderr.count("Traceback") == 0
