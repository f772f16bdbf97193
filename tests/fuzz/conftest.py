"""Fuzz tier: print how many hostile cases ran (CI logs show the count)."""

from __future__ import annotations

from tests.fuzz.harness import CASE_TIMEOUT_S, STATS


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:  # pytest's hook signature
    if not STATS.cases:
        return
    total = sum(STATS.cases.values())
    tiers = ", ".join(f"{tier} {n}" for tier, n in sorted(STATS.cases.items()))
    exits = ", ".join(f"exit {code}: {n}" for code, n in sorted(STATS.exits.items()))
    terminalreporter.write_line(f"fuzz: {total} cases ({tiers}; {exits}); slowest case {STATS.slowest_s:.2f} s "
                                f"(bound {CASE_TIMEOUT_S:g} s): {STATS.slowest_argv}")
