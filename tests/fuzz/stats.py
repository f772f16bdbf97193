"""The fuzz tier's counts (cases, exit statuses, the slowest case) and its closing lines.

Each process counts its own cases here; under pytest-xdist each worker hands its counts to the
controller as plain data (:func:`state`, tests/conftest.py), which prints :func:`closing_lines`
of them all. Kept apart from tests/fuzz/harness.py so the controller reads it without importing
the product."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

CASE_TIMEOUT_S = 30.0
"""Wall-clock bound per case: a case that runs takes < 1 s (measured ~0.05-0.5 s on 2 loaded
cores); 30 s is only there to turn a hang (a FIFO read by the old code) into a failure."""


@dataclass
class Stats:
    """Hostile command lines and logs run in this process, for the closing lines."""

    cases: Counter = field(default_factory=Counter)
    exits: Counter = field(default_factory=Counter)
    slowest_s: float = 0.0
    slowest_argv: str = ""
    rss_start_bytes: int = 0
    log_classes: Counter = field(default_factory=Counter)  # hostile logs run, per class
    log_exits: Counter = field(default_factory=Counter)  # their exit statuses ("raised": an exception escaped)
    log_slowest_s: float = 0.0


STATS = Stats()


@dataclass
class BagStats:
    """Hostile bags run in this process (tests/fuzz/test_fuzz_bags.py), for the closing lines."""

    classes: Counter = field(default_factory=Counter)  # cases run, per class
    exits: Counter = field(default_factory=Counter)  # their exit statuses ("raised": an exception escaped)
    tiers: Counter = field(default_factory=Counter)  # cases run, per tier
    slowest_s: float = 0.0
    slowest_case: str = ""


BAG_STATS = BagStats()

_COUNTERS = {
    "cases": (STATS, "cases"),
    "exits": (STATS, "exits"),
    "log_classes": (STATS, "log_classes"),
    "log_exits": (STATS, "log_exits"),
    "bag_classes": (BAG_STATS, "classes"),
    "bag_exits": (BAG_STATS, "exits"),
    "bag_tiers": (BAG_STATS, "tiers"),
}


def state() -> dict[str, Any]:
    """This process's counts as plain data (counters as [key, count] pairs: an exit status is an
    int or "raised"), as a pytest-xdist worker sends them."""
    out: dict[str, Any] = {name: [[k, n] for k, n in getattr(obj, attr).items()] for name, (obj, attr) in
                           _COUNTERS.items()}
    out.update(slowest=[STATS.slowest_s, STATS.slowest_argv], log_slowest=STATS.log_slowest_s,
               bag_slowest=[BAG_STATS.slowest_s, BAG_STATS.slowest_case])
    return out


def _exits(counter: Mapping[Any, int]) -> str:
    return ", ".join(f"exit {code}: {n}" if isinstance(code, int) else f"{code}: {n}"
                     for code, n in sorted(counter.items(), key=lambda item: str(item[0])))


def closing_lines(states: Iterable[Mapping[str, Any]]) -> list[str]:
    """The closing lines of the counts of several processes together: one per family that ran."""
    total = {name: Counter() for name in _COUNTERS}
    slowest, log_slowest, bag_slowest = (0.0, ""), 0.0, (0.0, "")
    for one in states:
        for name in _COUNTERS:
            for key, n in one[name]:
                total[name][key] += n
        slowest = max(slowest, tuple(one["slowest"]))
        log_slowest = max(log_slowest, one["log_slowest"])
        bag_slowest = max(bag_slowest, tuple(one["bag_slowest"]))
    lines = []
    if total["cases"]:
        tiers = ", ".join(f"{tier} {n}" for tier, n in sorted(total["cases"].items()))
        lines.append(f"fuzz: {sum(total['cases'].values())} cases ({tiers}; {_exits(total['exits'])}); slowest case "
                     f"{slowest[0]:.2f} s (bound {CASE_TIMEOUT_S:g} s): {slowest[1]}")
    if total["log_classes"]:
        lines.append(f"fuzz: hostile logs: {sum(total['log_classes'].values())} cases in {len(total['log_classes'])} "
                     f"classes ({_exits(total['log_exits'])}); slowest case {log_slowest:.2f} s")
    if total["bag_classes"]:
        tiers = ", ".join(f"{tier} {n}" for tier, n in sorted(total["bag_tiers"].items()))
        lines.append(f"fuzz: hostile bags: {sum(total['bag_classes'].values())} cases in {len(total['bag_classes'])} "
                     f"classes ({_exits(total['bag_exits'])}; {tiers}); slowest case {bag_slowest[0]:.2f} s "
                     f"({bag_slowest[1]})")
    return lines
