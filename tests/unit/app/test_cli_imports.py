"""``tauv --help`` and ``tauv COMMAND --help`` load only what printing the flags needs: none of
the compiled kernels (numba) nor the libraries of the commands' work (scipy, plotly, viser,
pyarrow, rosbags, dask, mcap). Their cost is measured in benchmarks/, not here: this is which
modules load, whatever the machine."""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("numba", "scipy", "plotly", "viser", "pyarrow", "rosbags", "dask", "mcap", "tqdm")
PROBE = """
import sys
from app.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(' '.join(sorted({name.split('.')[0] for name in sys.modules})))
"""


@pytest.mark.parametrize("argv", [["--help"], ["run", "--help"], ["mc", "--help"], ["serve", "--help"]],
                         ids=lambda a: " ".join(a))
def test_help_loads_no_compiled_kernel_and_no_command_library(argv: list[str]) -> None:
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, timeout=120,
                          check=True)
    *shown, loaded = done.stdout.strip().splitlines()
    assert any("usage: tauv" in line for line in shown), done.stdout[:500]
    assert set(loaded.split()) & set(HEAVY) == set(), loaded


ENTRY_PROBE = """
import sys
from app.entry import main
main(["--help"])
print(' '.join(sorted(sys.modules)))
"""


def test_tauv_help_loads_neither_numpy_nor_tauvcore_and_is_the_parser_s_own_help() -> None:
    """The console script's ``tauv --help`` (app.entry) is answered from the commands' names and
    one-line help: no numpy, no tauvcore, no command module; and it is, to the character, the help
    of the parser that runs the commands (app.cli.build_parser)."""
    from app.cli import build_parser

    done = subprocess.run([sys.executable, "-c", ENTRY_PROBE], capture_output=True, text=True, timeout=120,
                          check=True)
    *shown, loaded = done.stdout.rstrip("\n").split("\n")
    modules = set(loaded.split())
    apps = {m for m in modules if m.startswith("app.")}
    assert apps == {"app.entry", "app.commands", "app.commands.names"}, apps  # no command module, not app.cli
    assert not {m for m in modules if m.split(".")[0] in ("numpy", "tauvcore")}, modules
    assert "\n".join(shown) + "\n" == build_parser().format_help()


def test_the_console_script_runs_every_other_command_through_app_cli(capsys) -> None:
    from app.entry import main

    assert main(["config", "--earth", "flat"]) == 0
    assert 'model = "flat"' in capsys.readouterr().out
    assert main(["rn"]) == 2  # app.cli's one-line error
    assert capsys.readouterr().err.startswith("tauv: error: argument command: invalid choice: 'rn'")
