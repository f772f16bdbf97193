"""Fuzz ``tauv replay`` with hostile recorded logs (tests/fuzz/log_cases.py makes them).

One test per class of hostile log; each runs its seeded cases in-process through
``app.cli.main(["replay", DIR, ...flags, "--json", OUT])`` and checks every one against one
oracle, then fails listing the cases that broke it (the class, the mutation, the command, what
was printed, what broke). The oracle:

- exit 0 (a class that must be accepted, or may be): OUT is strict JSON holding every method run;
  stderr holds only ``tauv: note:`` lines (and the note the class expects, if any);
- exit 2 (a class that must be refused, or may be): exactly one line on stderr, starting
  ``tauv: error: ``, naming the table's file and, where the class says, the column, ``row N`` and
  the value; nothing on stdout; no OUT;
- either way: no exception out of ``main`` (a traceback in a process), no RuntimeWarning, every
  input file (the log's and the ``--config`` file) byte for byte as before, no file left or
  removed anywhere in the workspace but OUT, and the harness's bounds on time and memory.

Fast tier: :data:`FAST` cases per unit of a class's weight (360 in all, 35-50 s on two loaded
cores); slow tier (``-m slow``): :data:`SLOW` per unit (720, about a minute), other seeds.
``TAUV_FUZZ_KEEP=DIR``: the logs of failing cases are copied there (``DIR/<class>-<case>``) to
replay by hand.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import stat
import traceback
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.fuzz.harness import RSS_GROWTH_LIMIT_BYTES, STATS, Result, invoke, rss_growth_bytes, strict_json
from tests.fuzz.log_cases import (
    ACCEPT,
    CLASSES,
    EITHER,
    REFUSE,
    Base,
    Case,
    Expect,
    HostileClass,
    build_bases,
    make_case,
    mentions,
    plan,
)

pytestmark = pytest.mark.fuzz

FAST = 6
"""Cases per unit of weight in the fast tier."""
SLOW = 12
"""Cases per unit of weight in the slow tier."""
TUNING = "[dvl]\nnoise_mps = 0.05\n\n[run]\nseed = 3\n"
"""The ``--config`` file some cases lay over the log."""
SHOWN_CASES = 12
"""Failing cases a class's assertion prints in full (the rest are counted)."""
ROW = re.compile(r"\brow (\d+)\b")


@dataclass(frozen=True)
class Workspace:
    root: Path  # every case runs with this as its working directory
    bases: list[Base]
    config: Path  # the --config file
    case_dir: Path  # where each case's log is made
    out: Path  # the --json target


@pytest.fixture(scope="session")
def log_workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    root = tmp_path_factory.mktemp("hostile-logs")
    bases = build_bases(root / "bases")
    config = root / "tuning.toml"
    config.write_text(TUNING)
    return Workspace(root, bases, config, root / "log", root / "out.json")


@pytest.fixture
def workspace(log_workspace: Workspace) -> Iterator[Workspace]:
    cwd = os.getcwd()
    os.chdir(log_workspace.root)
    try:
        yield log_workspace
    finally:
        os.chdir(cwd)


# ------------------------------------------------------------------------------------ observation
def _entry(path: str | os.PathLike) -> tuple:
    """A regular file's SHA-256, a link's target, a directory, or another kind (a FIFO is never
    opened)."""
    mode = os.lstat(path).st_mode
    if stat.S_ISLNK(mode):
        return ("link", os.readlink(path))
    if stat.S_ISREG(mode):
        with open(path, "rb") as fh:
            return ("file", hashlib.sha256(fh.read()).hexdigest())
    if stat.S_ISDIR(mode):
        return ("dir",)
    return ("special", stat.S_IFMT(mode))


def _inputs(ws: Workspace) -> dict[str, tuple]:
    """Every entry of the case's log (symbolic links not followed), by relative path, and the
    ``--config`` file."""
    found = {os.path.relpath(os.path.join(d, n), ws.case_dir): _entry(os.path.join(d, n))
             for d, ds, fs in os.walk(ws.case_dir) for n in ds + fs}
    found["--config"] = _entry(ws.config)
    return found


def _names(root: Path) -> set[str]:
    return {os.path.relpath(os.path.join(d, n), root) for d, ds, fs in os.walk(root) for n in ds + fs}


def _methods(flags: tuple[str, ...]) -> list[str]:
    return flags[flags.index("--method") + 1].split(",")


def _expected(expect: Expect) -> str:
    parts = [f"one of {g!r}" if len(g) > 1 else repr(g[0]) for g in expect.names]
    if expect.rows:
        parts.append(" or ".join(f"row {r}" for r in expect.rows))
    what = {REFUSE: "exit 2", ACCEPT: "exit 0", EITHER: "exit 0 or 2"}[expect.outcome]
    if expect.outcome != ACCEPT and parts:
        what += " naming " + "; ".join(parts)
    if expect.note:
        what += f" (with a note naming {expect.note!r})"
    return what


def oracle(case: Case, result: Result, ws: Workspace, inputs_before: dict, names_before: set[str]) -> list[str]:
    """What ``result`` breaks of the contract (empty: nothing)."""
    problems = []
    code, err, expect = result.code, result.err, case.expect
    if code not in (0, 2):
        problems.append(f"exit status {code}")
    if "Traceback" in err:
        problems.append("a traceback on stderr")
    if result.warnings or "Warning:" in err:
        problems.append(f"warnings: {result.warnings or err}")
    if code == 0 and expect.outcome == REFUSE:
        problems.append("accepted (exit 0): the log must be refused")
    if code == 2 and expect.outcome == ACCEPT:
        problems.append("refused (exit 2): the log must be accepted")
    lines = err.splitlines()
    if code == 2:
        if len(lines) != 1 or not lines[0].startswith("tauv: error: "):
            problems.append(f"{len(lines)} lines on stderr, not one 'tauv: error: ' line")
        message = lines[-1] if lines else ""
        for group in expect.names:
            if not any(mentions(message, name) for name in group):
                problems.append(f"the message names none of {group!r}")
        if expect.rows and not {int(n) for n in ROW.findall(message)} & set(expect.rows):
            problems.append(f"the message does not say {' or '.join(f'row {r}' for r in expect.rows)}")
        if result.out:
            problems.append(f"stdout not empty: {result.out[:200]!r}")
        if ws.out.exists() or ws.out.is_symlink():
            problems.append("the --json file was written")
    if code == 0:
        others = [line for line in lines if not line.startswith("tauv: note: ")]
        if others:
            problems.append(f"stderr holds more than notes: {others[:3]!r}")
        if expect.note and not any(expect.note in line for line in lines):
            problems.append(f"no note naming {expect.note!r}")
        try:
            parsed = strict_json(ws.out.read_bytes())
            missing = set(_methods(case.flags)) - set(parsed["results"])
            if missing or "config" not in parsed:
                problems.append(f"the --json file lacks {sorted(missing) or 'config'}")
        except FileNotFoundError:
            problems.append("exit 0 but no --json file")
        except (AssertionError, ValueError, KeyError, TypeError) as exc:
            problems.append(f"the --json file is not strict JSON of the results: {exc}")
    inputs_after = _inputs(ws)
    changed = sorted(p for p in inputs_before.keys() | inputs_after.keys()
                     if inputs_before.get(p) != inputs_after.get(p))
    if changed:
        problems.append(f"input changed: {changed[:6]}")
    allowed = {ws.out.name} if code == 0 else set()
    names_after = _names(ws.root)
    appeared = sorted(names_after - names_before - allowed)
    vanished = sorted(names_before - names_after)
    if appeared or vanished:
        problems.append(f"workspace: files appeared {appeared[:6]}, vanished {vanished[:6]}")
    growth = rss_growth_bytes()
    if growth > RSS_GROWTH_LIMIT_BYTES:
        problems.append(f"peak RSS grew by {growth / 2**20:.0f} MiB")
    return problems


# ----------------------------------------------------------------------------------------- running
def _remove(path: Path) -> None:
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.exists():
        shutil.rmtree(path)


def _keep(src: Path, dst: Path) -> None:
    """Copy a failing case's log for replaying by hand (FIFOs made anew, never opened)."""
    def copy(s: str, d: str) -> None:
        if stat.S_ISFIFO(os.lstat(s).st_mode):
            os.mkfifo(d)
        else:
            shutil.copy2(s, d)
    _remove(dst)
    shutil.copytree(src, dst, symlinks=True, copy_function=copy)


def _report(case: Case, argv: list[str], result: Result | None, raised: str | None, problems: list[str]) -> str:
    shown = " ".join(argv)
    printed = raised if raised is not None else (f"exit {result.code}; stderr: {result.err.strip()[:600]!r}"
                                                 + (f"; stdout: {result.out[:120]!r}" if result.code != 0 else ""))
    return (f"{case.label}\n    $ tauv {shown}\n    {printed}\n    expected {_expected(case.expect)}\n"
            f"    broke: {'; '.join(problems)}")


def run_class(klass: HostileClass, ws: Workspace, tier: str, per_weight: int) -> None:
    failures = []
    keep = os.environ.get("TAUV_FUZZ_KEEP")
    for index, (base, rng) in enumerate(plan(klass, ws.bases, per_weight * klass.weight, tier)):
        _remove(ws.case_dir)
        _remove(ws.out)
        case = make_case(klass, index, base, rng, ws.case_dir)
        flags = [ws.config.name if f == "{config}" else f for f in case.flags]
        argv = ["replay", ws.case_dir.name, *flags, "--json", ws.out.name]
        inputs_before = _inputs(ws)
        names_before = _names(ws.root)
        result, raised = None, None
        try:
            result = invoke(argv, record_warnings=True)
        except Exception as exc:  # noqa: BLE001 - anything out of main is a traceback in a process (or a hang)
            where = traceback.extract_tb(exc.__traceback__)[-1]
            raised = (f"raised {''.join(traceback.format_exception_only(exc)).strip()[:600]} "
                      f"(at {os.path.basename(where.filename)}:{where.lineno} in {where.name})")
        STATS.log_classes[klass.name] += 1
        STATS.log_exits[result.code if result is not None else "raised"] += 1
        if result is not None:
            STATS.log_slowest_s = max(STATS.log_slowest_s, result.elapsed_s)
            problems = oracle(case, result, ws, inputs_before, names_before)
        else:
            problems = ["an exception escaped main"]
        if problems:
            failures.append(_report(case, argv, result, raised, problems))
            if keep:
                _keep(ws.case_dir, Path(keep) / f"{klass.name.replace(' ', '_').replace('/', '_')}-{index}")
    _remove(ws.case_dir)
    _remove(ws.out)
    n = per_weight * klass.weight
    assert not failures, (f"{klass.family} / {klass.name} (expected: {klass.outcome}): {len(failures)} of {n} "
                          f"cases broke the oracle\n" + "\n".join(failures[:SHOWN_CASES])
                          + (f"\n... and {len(failures) - SHOWN_CASES} more" if len(failures) > SHOWN_CASES else ""))


def _id(klass: HostileClass) -> str:
    return klass.name.replace(" ", "-").replace("/", "-")


@pytest.mark.parametrize("klass", CLASSES, ids=_id)
def test_hostile_log(klass: HostileClass, workspace: Workspace) -> None:
    run_class(klass, workspace, "fast", FAST)


@pytest.mark.slow
@pytest.mark.parametrize("klass", CLASSES, ids=_id)
def test_hostile_log_slow(klass: HostileClass, workspace: Workspace) -> None:
    run_class(klass, workspace, "slow", SLOW)
