"""The command-line page names everything the code offers, and the pages name nothing it does not:
every flag of every subcommand (the parser of app/cli.py) is on docs/cli.md with its generated
reference, and every method, IMU profile and aiding source in its own text; every ``--flag``
in backticks on a page is a flag of ``tauv`` (of its subcommand, in a backticked ``tauv CMD ...``),
and every value a backticked ``--method``, ``--imu``, ``--imu-errors`` or ``--aiding`` takes
exists; the README names every method and every page of the site."""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PAGES = sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md"]
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)
_spec = importlib.util.spec_from_file_location(
    "docs_cli_reference", REPO / "docs" / "hooks" / "cli_reference.py"
)
assert _spec and _spec.loader
cli_reference = importlib.util.module_from_spec(_spec)
sys.modules["docs_cli_reference"] = cli_reference
_spec.loader.exec_module(cli_reference)

OTHER_PROGRAMS = {
    "--nthreads": "dask worker",
    "--nworkers": "dask worker",
    "--strict": "mkdocs build",
    "--dist": "pytest-xdist",
    "--durations": "pytest",
    "--part": "python -m tauvcore.engine.warmup",
    "--junit": "benchmarks/suite_time.py",
    "--wall": "benchmarks/suite_time.py",
    "--format": "podman build, docker inspect",
    "--pull": "podman build",
    "--check": "ruff format",
    "--rm": "docker run",
    "--name": "docker run",
    "--hours": "benchmarks",
    "--rate": "benchmarks",
    "--runs-10h": "benchmarks/mission_table.py",
    "--only": "benchmarks/run_memory.py",
    "--attitude-scale": "benchmarks/consistency_table.py",
    "--data": "benchmarks",
    "--upgrade": "scripts/lock.sh (uv pip compile)",
    "--screenshot": "benchmarks/bench_dashboard.py",
    "--headless": "chromium",
    "--init": "docker run",
    "--variant": "debootstrap",
    "--pid": "unshare",
    "--fork": "unshare",
    "--mount-proc": "unshare",
    "--skip-study": "benchmarks/engine_table.py",
    "--skip-long": "benchmarks/engine_table.py",
    "--fragment": "benchmarks/akit_tuning.py",
    "--no-study": "benchmarks/speed.py",
    "--no-first-start": "benchmarks/speed.py",
}
"""Flags of other programs the pages name (in backticks), and whose."""


def _flags() -> dict[str, set[str]]:
    from app.cli import OPTIONS

    return {command: {s for a in actions for s in a.option_strings} for command, actions in OPTIONS.items()}


_spec = importlib.util.spec_from_file_location("docs_defaults_hook", REPO / "docs" / "hooks" / "defaults.py")
assert _spec and _spec.loader
defaults_hook = importlib.util.module_from_spec(_spec)
sys.modules["docs_defaults_hook"] = defaults_hook
_spec.loader.exec_module(defaults_hook)


def _cli_page() -> tuple[str, str]:
    """docs/cli.md's own text (its prose, its defaults rendered) and the reference the hook writes into it."""
    return defaults_hook.render(
        (REPO / "docs" / "cli.md").read_text(encoding="utf-8")
    ), cli_reference.reference()


def _backticked(page: Path) -> list[str]:
    return re.findall(r"`([^`\n]+)`", FENCE.sub("", page.read_text(encoding="utf-8")))


def test_every_flag_of_every_subcommand_is_on_the_cli_page() -> None:
    prose, reference = _cli_page()
    flags = _flags()
    assert {"run", "replay", "mc", "reproduce", "serve", "config", "log info", "log convert"} <= set(flags)
    for command, names in flags.items():
        for flag in names - {"-h", "--help"}:
            assert flag in prose + reference, f"tauv {command} {flag} is not on docs/cli.md"
        assert command == "" or f"### `tauv {command}`" in reference, command


@pytest.mark.parametrize("kind", ["method", "IMU profile", "aiding source"])
def test_every_method_profile_and_source_is_named_in_the_cli_page_s_own_text(kind: str) -> None:
    from tauvcore.aiding import AIDING_SOURCES
    from tauvcore.config import RUN_METHODS
    from tauvcore.sensors.imu import IMU_PROFILES

    offered = {
        "method": RUN_METHODS,
        "IMU profile": tuple(IMU_PROFILES),
        "aiding source": tuple(AIDING_SOURCES),
    }[kind]
    prose, _ = _cli_page()
    named = {word for quote in re.findall(r"`([^`\n]+)`", prose) for word in re.split(r"[\s,=]+", quote)}
    missing = [name for name in offered if name not in named]
    assert missing == [], f"docs/cli.md's text names no {kind} {missing} (in backticks)"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_flag_a_page_names_exists(page: Path) -> None:
    flags = _flags()
    every = set().union(*flags.values())
    for quote in _backticked(page):
        words = quote.split()
        named = re.findall(r"(?<![\w-])--[a-z][\w-]*", quote)
        if words[:1] == ["tauv"] and len(words) > 1 and words[1] in flags:
            command = " ".join(words[1:3]) if " ".join(words[1:3]) in flags else words[1]
            wrong = [f for f in named if f not in flags[command]]
            assert wrong == [], f"{page.name}: `{quote}`: tauv {command} has no {wrong}"
        else:
            wrong = [f for f in named if f not in every and f not in OTHER_PROGRAMS]
            assert wrong == [], f"{page.name}: `{quote}`: no tauv flag {wrong}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_method_profile_and_source_a_page_passes_exists(page: Path) -> None:
    from tauvcore.aiding import AIDING_SOURCES
    from tauvcore.config import RUN_METHODS
    from tauvcore.sensors.imu import IMU_PROFILES

    choices = {
        "--method": set(RUN_METHODS) | {"all"},
        "--imu": set(IMU_PROFILES),
        "--imu-errors": set(IMU_PROFILES),
        "--aiding": set(AIDING_SOURCES),
    }
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    quotes = re.findall(r"`([^`\n]+)`", text) + [
        b
        for b in re.findall(
            r"^```[^\n]*\n(.*?)^```", page.read_text(encoding="utf-8"), re.MULTILINE | re.DOTALL
        )
    ]
    for quote in quotes:
        for flag, value in re.findall(r"(--method|--imu-errors|--imu|--aiding)[ =]([\w,|.-]+)", quote):
            if value.isupper() or value == "...":  # a placeholder (--imu PROFILE, --method ...)
                continue
            unknown = [v for v in re.split(r"[,|]", value) if v and v not in choices[flag]]
            assert unknown == [], f"{page.name}: `{quote.strip()[:80]}`: {flag} has no {unknown}"


def test_the_readme_names_every_method_and_every_page_of_the_site() -> None:
    import yaml

    from tauvcore.config import RUN_METHODS

    readme = (REPO / "README.md").read_text(encoding="utf-8")
    table = set(re.findall(r"^\| `([\w-]+)` \|", readme, re.MULTILINE))
    assert set(RUN_METHODS) <= table, f"the README's methods table lacks {sorted(set(RUN_METHODS) - table)}"

    class _Loader(yaml.SafeLoader):
        pass

    _Loader.add_multi_constructor("", lambda loader, suffix, node: None)  # mkdocs.yml's !!python/name tags
    nav = yaml.load((REPO / "mkdocs.yml").read_text(encoding="utf-8"), Loader=_Loader)["nav"]

    def pages(entry) -> list[str]:
        if isinstance(entry, str):
            return [entry]
        if isinstance(entry, list):
            return [p for e in entry for p in pages(e)]
        return [p for v in entry.values() for p in pages(v)]

    site = {p for p in pages(nav) if not p.startswith("api/") and p != "index.md"}
    linked = set(re.findall(r"\]\(docs/([\w.-]+\.md)\)", readme))
    assert site <= linked, f"the README's page list lacks {sorted(site - linked)}"


def test_the_help_says_what_all_runs() -> None:
    from app.cli import build_parser
    from tauvcore.config import METHODS

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    help_text = " ".join(sub.choices["run"].format_help().split())
    assert f"'all' ({', '.join(METHODS)})" in help_text
