"""Fuzz ``tauv replay``, ``tauv log info`` and ``tauv log convert`` with hostile ROS bags and bag
mappings (tests/fuzz/bag_cases.py makes them).

One test per class; each runs its seeded cases in-process through ``app.cli.main`` (the harness's
:func:`~tests.fuzz.harness.invoke`: a time alarm and a soft address-space limit per case) and
checks every one against the oracle of the hostile logs, then fails listing the cases that broke
it:

- exit 0 (a class that may be accepted): nothing else to say; ``log convert``'s OUT written;
- exit 2 (every class may be refused, some must): exactly one line on stderr, starting
  ``tauv: error: ``, naming the bag or the mapping file; nothing on stdout; no OUT (``--json``
  target or ``log convert`` directory);
- either way: no exception out of ``main`` (a traceback in a process), no RuntimeWarning, every
  input (the bag, its mapping, every entry of the case's directory, links not followed, a FIFO
  never opened) as before, no file left or removed but OUT.

Fast tier: :data:`FAST` cases per unit of a class's weight (19 units: 152 cases); slow tier
(``-m slow``): :data:`SLOW` per unit (228), other seeds.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from tests.fuzz.bag_cases import CLASSES, EITHER, REFUSE, Base, Case, HostileClass, build_bases
from tests.fuzz.harness import BAG_STATS, RSS_GROWTH_LIMIT_BYTES, Result, invoke, rss_growth_bytes

pytestmark = pytest.mark.fuzz

FAST = 8
"""Cases per unit of weight in the fast tier."""
SLOW = 12
"""Cases per unit of weight in the slow tier."""
SHOWN_CASES = 10


@dataclass(frozen=True)
class Workspace:
    root: Path
    bases: list[Base]


@pytest.fixture(scope="session")
def bag_workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    root = tmp_path_factory.mktemp("hostile-bags")
    return Workspace(root, build_bases(root / "bases"))


def _entry(path: str) -> tuple:
    mode = os.lstat(path).st_mode
    if stat.S_ISLNK(mode):
        return ("link", os.readlink(path))
    if stat.S_ISREG(mode):
        with open(path, "rb") as fh:
            return ("file", hashlib.sha256(fh.read()).hexdigest())
    if stat.S_ISDIR(mode):
        return ("dir",)
    return ("special", stat.S_IFMT(mode))


def _inputs(case_dir: Path) -> dict[str, tuple]:
    """Every entry below the case's directory (links not followed) by relative path."""
    return {os.path.relpath(os.path.join(d, n), case_dir): _entry(os.path.join(d, n))
            for d, ds, fs in os.walk(case_dir) for n in ds + fs}


COMMANDS = ("info", "replay", "convert")


def _argv(case: Case, command: str) -> list[str]:
    mapping = ["--bag-mapping", case.mapping] if case.mapping else []
    if command == "info":
        return ["log", "info", case.target, *mapping]
    if command == "convert":
        return ["log", "convert", case.target, "OUT", *mapping]
    return ["replay", case.target, "--method", "ins,lc", "--json", "OUT", *mapping]


def oracle(case: Case, command: str, result: Result, before: dict, after: dict) -> list[str]:
    problems = []
    if result.code not in (0, 2):
        problems.append(f"exit {result.code}")
    listed = case.listed and command == "info"  # info lists the topics; a replay's checks are not its
    if case.outcome == REFUSE and result.code != 2 and not listed:
        problems.append(f"accepted (exit {result.code}), must be refused")
    if "Traceback" in result.err:
        problems.append("traceback")
    if result.warnings:
        problems.append(f"warnings: {result.warnings[:3]}")
    if result.code == 2:
        lines = result.err.splitlines()
        if len(lines) != 1 or not lines[0].startswith("tauv: error: "):
            problems.append(f"not one error line: {result.err[:600]!r}")
        elif not any(name in lines[0] for name in case.names):
            problems.append(f"names none of {case.names}: {lines[0][:300]}")
        if result.out:
            problems.append(f"stdout on exit 2: {result.out[:200]!r}")
        if "OUT" in after:
            problems.append("OUT written on exit 2")
    elif result.code == 0 and command != "info" and "OUT" not in after:
        problems.append("exit 0 without OUT")
    growth = rss_growth_bytes()
    if growth > RSS_GROWTH_LIMIT_BYTES:
        problems.append(f"peak RSS grew by {growth / 2**20:.0f} MiB")
    changed = sorted(k for k in before if before[k] != after.get(k))
    if changed:
        problems.append(f"inputs changed or removed: {changed[:5]}")
    extra = sorted(k for k in after if k not in before and k != "OUT" and not k.startswith("OUT" + os.sep))
    if extra:
        problems.append(f"files left: {extra[:5]}")
    return problems


def _clear(path: Path) -> None:
    for entry in list(path.iterdir()) if path.exists() else ():
        if entry.is_dir() and not entry.is_symlink():
            shutil.rmtree(entry)
        else:
            entry.unlink()
    path.mkdir(exist_ok=True)


def run_class(klass: HostileClass, ws: Workspace, tier: str, per_weight: int) -> None:
    seed = [sum(map(ord, klass.name)), 1 if tier == "fast" else 2]
    rng = np.random.default_rng(seed)
    failures: list[str] = []
    case_dir = ws.root / f"case-{klass.name}"
    cwd = os.getcwd()
    try:
        for index in range(per_weight * klass.weight):
            _clear(case_dir)
            base = ws.bases[int(rng.integers(0, len(ws.bases)))]
            case = klass.make(rng, base, case_dir)
            command = COMMANDS[int(rng.integers(0, len(COMMANDS)))]
            argv = _argv(case, command)
            before = _inputs(case_dir)
            os.chdir(case_dir)
            try:
                result, raised = invoke(argv, record_warnings=True), None
            except BaseException as exc:  # noqa: BLE001  (what escaped main is the failure)
                result, raised = None, "".join(traceback.format_exception(exc))[-1500:]
            finally:
                os.chdir(cwd)
            BAG_STATS.classes[klass.name] += 1
            BAG_STATS.tiers[tier] += 1
            BAG_STATS.exits[result.code if result is not None else "raised"] += 1
            if result is not None and result.elapsed_s > BAG_STATS.slowest_s:
                BAG_STATS.slowest_s = result.elapsed_s
                BAG_STATS.slowest_case = f"{klass.name} #{index}: {' '.join(argv)} ({case.what})"[:200]
            problems = [f"raised: {raised}"] if result is None else oracle(case, command, result, before,
                                                                           _inputs(case_dir))
            if problems:
                failures.append(f"{klass.name} #{index} ({case.what}; {' '.join(argv)}): {'; '.join(problems)}"
                                + ("" if result is None else f"\n    stderr: {result.err[-400:]!r}"))
    finally:
        os.chdir(cwd)
        _clear(case_dir)
    shown = "\n".join(failures[:SHOWN_CASES])
    assert not failures, f"{len(failures)} hostile bags broke the contract:\n{shown}"


def _id(klass: HostileClass) -> str:
    return klass.name


@pytest.mark.parametrize("klass", CLASSES, ids=_id)
def test_hostile_bag(klass: HostileClass, bag_workspace: Workspace) -> None:
    run_class(klass, bag_workspace, "fast", FAST)


@pytest.mark.slow
@pytest.mark.parametrize("klass", CLASSES, ids=_id)
def test_hostile_bag_slow(klass: HostileClass, bag_workspace: Workspace) -> None:
    run_class(klass, bag_workspace, "slow", SLOW)


def test_the_families_hold_enough_cases() -> None:
    assert sum(k.weight for k in CLASSES) * FAST >= 150
    assert {REFUSE, EITHER} >= {REFUSE}
