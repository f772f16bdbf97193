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
