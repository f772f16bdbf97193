"""Every script of ``examples/``: discovered by name (``NN_*.py``, so a new
example is covered without touching this file), each checked to have a module docstring, a
``def main() -> None`` and the ``__main__`` guard, then run as a user would, in a subprocess from
a temporary working directory with short missions (``TAUV_EXAMPLE_SHORT=1``) and its output
directory under ``tmp_path``: exit status 0, and nothing written into the repository."""

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
EXAMPLES = sorted((REPO / "examples").glob("[0-9][0-9]_*.py"))
TIMEOUT_S = 120     # one example on a short mission takes 2-4 s; the margin is for a loaded machine


def test_the_examples_are_there() -> None:
    names = [p.name for p in EXAMPLES]
    assert names[:5] == ["01_scenario_errors.py", "02_two_beams.py", "03_monte_carlo.py", "04_replay_log.py",
                         "05_long_range.py"], names


def _is_main_guard(node: ast.stmt) -> bool:
    return (isinstance(node, ast.If) and isinstance(node.test, ast.Compare)
            and isinstance(node.test.left, ast.Name) and node.test.left.id == "__name__")


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_has_docstring_main_and_guard(path: Path) -> None:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    doc = ast.get_docstring(tree)
    assert doc and "Run::" in doc, f"{path.name}: a module docstring saying what it shows and how to run it"
    mains = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main"]
    assert mains and not mains[0].args.args, f"{path.name}: def main() -> None"
    returns = mains[0].returns
    assert isinstance(returns, ast.Constant) and returns.value is None, f"{path.name}: main must be -> None"
    assert any(_is_main_guard(n) for n in tree.body), f"{path.name}: if __name__ == '__main__': main()"


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_on_a_short_mission(path: Path, tmp_path: Path) -> None:
    before = {p.name for p in (REPO / "examples").iterdir()}
    work = tmp_path / "cwd"
    work.mkdir()
    env = {**os.environ, "TAUV_EXAMPLE_SHORT": "1", "TMPDIR": str(tmp_path), "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.run([sys.executable, str(path), "--out", str(tmp_path / "out")], cwd=work, env=env,
                          capture_output=True, text=True, timeout=TIMEOUT_S, check=False)
    assert proc.returncode == 0, f"{path.name} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    assert proc.stdout.strip(), f"{path.name} printed nothing"
    after = {p.name for p in (REPO / "examples").iterdir()}
    assert after <= before | {"__pycache__"}, f"{path.name} wrote into the repository: {after - before}"
