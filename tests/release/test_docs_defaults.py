"""Every default a page quotes is the code's: written ``{{ default("KEY") }}`` and rendered at build
time by docs/hooks/defaults.py, never typed; the dashboard's Smoother memory starts at the command
line's ``--smooth-memory-mb`` default."""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PAGES = sorted((REPO / "docs").glob("*.md"))
_spec = importlib.util.spec_from_file_location("docs_defaults_hook", REPO / "docs" / "hooks" / "defaults.py")
assert _spec and _spec.loader
hook = importlib.util.module_from_spec(_spec)
sys.modules["docs_defaults_hook"] = hook
_spec.loader.exec_module(hook)

FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)
VALUE = r"(?:`[^`]+`|\"[^\"]+\"|\d[\d.,]*(?:\s?(?:MB|MiB|GiB|Hz|s|m))?)"
QUOTED = re.compile(
    rf"\bdefault[:,]?\s+(?P<after>{VALUE})"  # "default 256", "default `dvl`"
    rf"|(?P<before>{VALUE})\s*(?:\(the\s+default\b|by default\b)",  # "`off` (the default", "64 MB by default"
    re.IGNORECASE,
)
MACRO_TEXT = re.compile(r"\{\{\s*default\([^}]*\)\s*\}\}")


def _prose(page: Path) -> str:
    """The page's own text: its fenced blocks (code, an included output) left out."""
    return FENCE.sub("", page.read_text(encoding="utf-8"))


NOT_FROM_THE_CODE = {
    ("dashboard.md", "default `min(2, CPUs)`"): "a rule, not a value (app.dashboard.worker.default_workers)",
    ("studies.md", "default 1"): "--workers: one process, the study without a pool",
}
"""Quotes the wording check finds that are not a value to render, each with its reason."""
OTHER_OWNER = {"bags.md"}
"""Pages whose defaults are the bag mapping's (tauvcore.logs.bags.mapping), checked with that work."""


def _quoted_defaults() -> list[tuple[str, str]]:
    found = []
    for page in (p for p in PAGES if p.name not in OTHER_OWNER):
        text = MACRO_TEXT.sub("{{MACRO}}", _prose(page))
        for match in QUOTED.finditer(text):
            found.append((page.name, match.group(0)))
    return found


def test_no_page_types_a_default() -> None:
    """A default written by hand ("default 256") is found by its wording and refused; the same
    wording around a macro ("default {{ default(...) }}") passes."""
    typed = [
        (page, quote)
        for page, quote in _quoted_defaults()
        if "{{MACRO}}" not in quote and (page, quote) not in NOT_FROM_THE_CODE
    ]
    assert typed == [], (
        f'defaults typed by hand (write {{{{ default("KEY") }}}}, docs/hooks/defaults.py): {typed}'
    )


def test_the_wording_check_finds_a_typed_default() -> None:
    for typed in (
        "(default 256)",
        "default `dvl` alone",
        '`"off"` (the default)',
        "64 MB by default",
        "default 10 Hz",
    ):
        assert QUOTED.search(typed), typed
    assert not QUOTED.search("its default OCI format"), "a default named without a value is not a quote"


def test_the_pages_quote_defaults_through_the_hook() -> None:
    macros = [m for page in PAGES for m in hook.MACRO.findall(page.read_text(encoding="utf-8"))]
    keys = {key for key, _ in macros}
    assert {
        "tauvcore.engine.smooth_defaults.DEFAULT_BUDGET_MB",
        "config:run.methods",
        "config:partial.vb_nf",
    } <= keys
    assert len(macros) >= 15


@pytest.mark.parametrize(
    "page", [p for p in PAGES if hook.MACRO.search(p.read_text(encoding="utf-8"))], ids=lambda p: p.name
)
def test_every_default_on_a_page_renders_to_the_code_s_value(page: Path) -> None:
    """Each macro names something in the code (an unknown key fails the build), and renders to it."""
    from tauvcore.config import Config
    from tauvcore.engine.smooth_defaults import DEFAULT_BUDGET_MB

    text = page.read_text(encoding="utf-8")
    rendered = hook.render(text)
    assert "{{ default(" not in rendered or page.name == "contributing.md"  # it explains the macro
    expected = {
        "tauvcore.engine.smooth_defaults.DEFAULT_BUDGET_MB": f"{DEFAULT_BUDGET_MB:g}",
        "config:run.methods": ",".join(Config().run.methods),
        "config:partial.vb_nf": f"{Config().partial.vb_nf:g}",
        "config:filter.output_rate_hz": f"{Config().filter.output_rate_hz:g}",
    }
    for key, spec in ((k, s) for k, s in hook.MACRO.findall(text) if not hook.placeholder(k)):
        assert hook.show(hook.lookup(key), spec or None)
        if key in expected and not spec:
            assert hook.show(hook.lookup(key)) == expected[key], key


def test_the_hook_refuses_a_key_that_names_nothing() -> None:
    with pytest.raises(ValueError, match="no_such_field"):
        hook.render('{{ default("config:partial.no_such_field") }}')
    with pytest.raises(ValueError, match="NO_SUCH"):
        hook.render('{{ default("tauvcore.engine.smoothing.NO_SUCH") }}')
    assert (
        hook.render('n_f {{ default("config:partial.vb_nf") }}, "{{ default("imu:profile") }}"')
        == 'n_f 20, "table2"'
    )
    assert hook.render('{{ default("app.dashboard.budget.DEFAULT_BUDGET_BYTES", "MiB") }}') == "1536"
    assert hook.render('write {{ default("KEY") }}') == 'write {{ default("KEY") }}'  # a placeholder stays


def test_the_smoother_s_default_is_one_number_on_the_pages_the_cli_and_the_dashboard() -> None:
    """``--smooth-memory-mb``'s default (tauvcore.engine.smooth_defaults.DEFAULT_BUDGET_MB) is what
    ``tauv run --help`` says, what a new dashboard page's Smoother memory holds, and what
    docs/cli.md, docs/studies.md, docs/smoother.md and docs/dashboard.md say once built."""
    from app.cli import build_parser
    from app.dashboard.inputs import SMOOTHER_MB_DEFAULT, Controls
    from tauvcore.engine.smoothing import DEFAULT_BUDGET_MB, SmoothOptions

    assert SmoothOptions().budget_mb == DEFAULT_BUDGET_MB
    assert SMOOTHER_MB_DEFAULT == DEFAULT_BUDGET_MB
    fields = {f.name: f for f in dataclasses.fields(Controls)}
    assert fields["smoother_mb"].default == f"{DEFAULT_BUDGET_MB:g}"
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    assert f"(default {DEFAULT_BUDGET_MB:g};" in " ".join(sub.choices["run"].format_help().split())
    for name in ("cli.md", "studies.md", "smoother.md", "dashboard.md"):
        rendered = hook.render((REPO / "docs" / name).read_text(encoding="utf-8"))
        quoted = re.findall(r"(?:default (\d+)[ ,)]|(\d+) MB by default)", rendered)
        numbers = {a or b for a, b in quoted}
        assert f"{DEFAULT_BUDGET_MB:g}" in numbers, name
        assert "256" not in numbers, name
