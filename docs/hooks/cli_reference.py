"""An MkDocs hook (mkdocs.yml ``hooks:``): the command line's reference on the page docs/cli.md,
written at build time from the parser itself (app.cli.build_parser), so that it cannot drift from
``tauv --help``: the top-level help, then each subcommand's, in the parser's order."""

from __future__ import annotations

import argparse
import os
from typing import Any

MARKER = "<!-- the subcommands' help, written by docs/hooks/cli_reference.py -->"
WIDTH = "100"  # argparse wraps at $COLUMNS; fixed, so the page is the same on every terminal


def reference() -> str:
    """The page's reference section (Markdown): every subcommand's help, as ``tauv CMD --help``
    prints it with ``COLUMNS=100``."""
    os.environ["COLUMNS"] = WIDTH
    from app.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    parts = ["## Reference", "", "`tauv --help`:", "", "```text", parser.format_help().rstrip(), "```"]
    for name, command in sub.choices.items():
        parts += ["", f"### `tauv {name}`", "", "```text", command.format_help().rstrip(), "```"]
        for inner in (a for a in command._actions if isinstance(a, argparse._SubParsersAction)):
            for inner_name, inner_command in inner.choices.items():  # tauv log info, tauv log convert
                help_text = inner_command.format_help().rstrip()
                parts += ["", f"### `tauv {name} {inner_name}`", "", "```text", help_text, "```"]
    return "\n".join(parts) + "\n"


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    if page.file.src_uri == "cli.md":
        if MARKER not in markdown:
            raise ValueError(f"docs/cli.md lost its marker {MARKER!r}")
        return markdown.replace(MARKER, reference())
    return markdown
