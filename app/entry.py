"""The ``tauv`` console script's entry: ``tauv --help`` answered from the commands' names and
one-line help alone, without numpy, tauvcore or any command module; everything else is
app.cli's :func:`~app.cli.main`.

app.cli builds its parser's subcommands from the same names and help (app.commands.names), so
the two helps are one text (tests/unit/app/test_cli_imports.py compares them).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from app.commands.names import COMMANDS, DESCRIPTION, PROG


def top_help() -> str:
    """``tauv --help``: the usage, the description and the commands with their help."""
    parser = argparse.ArgumentParser(prog=PROG, description=DESCRIPTION, allow_abbrev=False)
    sub = parser.add_subparsers(dest="command", required=True)
    for name, text in COMMANDS.items():
        sub.add_parser(name, help=text)
    return parser.format_help()


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tauv`` console script: app.cli.main, but for ``tauv --help``."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args in (["-h"], ["--help"]):
        try:
            sys.stdout.write(top_help())
            sys.stdout.flush()
        except BrokenPipeError:  # `tauv --help | head -1`: quiet, as app.cli.main is
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0
        return 0
    from app.cli import main as cli_main

    return cli_main(args)


if __name__ == "__main__":
    sys.exit(main())
