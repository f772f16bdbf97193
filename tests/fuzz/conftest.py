"""Fuzz tier: print how many hostile cases ran (CI logs show the count)."""

from __future__ import annotations

from tests.fuzz.harness import BAG_STATS, CASE_TIMEOUT_S, STATS


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:  # pytest's hook signature
    if STATS.cases:
        total = sum(STATS.cases.values())
        tiers = ", ".join(f"{tier} {n}" for tier, n in sorted(STATS.cases.items()))
        exits = ", ".join(f"exit {code}: {n}" for code, n in sorted(STATS.exits.items()))
        terminalreporter.write_line(f"fuzz: {total} cases ({tiers}; {exits}); slowest case {STATS.slowest_s:.2f} s "
                                    f"(bound {CASE_TIMEOUT_S:g} s): {STATS.slowest_argv}")
    if STATS.log_classes:
        total = sum(STATS.log_classes.values())
        exits = ", ".join(f"exit {code}: {n}" if isinstance(code, int) else f"{code}: {n}"
                          for code, n in sorted(STATS.log_exits.items(), key=lambda item: str(item[0])))
        terminalreporter.write_line(f"fuzz: hostile logs: {total} cases in {len(STATS.log_classes)} classes "
                                    f"({exits}); slowest case {STATS.log_slowest_s:.2f} s")
    if BAG_STATS.classes:
        total = sum(BAG_STATS.classes.values())
        exits = ", ".join(f"exit {code}: {n}" if isinstance(code, int) else f"{code}: {n}"
                          for code, n in sorted(BAG_STATS.exits.items(), key=lambda item: str(item[0])))
        tiers = ", ".join(f"{tier} {n}" for tier, n in sorted(BAG_STATS.tiers.items()))
        terminalreporter.write_line(f"fuzz: hostile bags: {total} cases in {len(BAG_STATS.classes)} classes "
                                    f"({exits}; {tiers}); slowest case {BAG_STATS.slowest_s:.2f} s "
                                    f"({BAG_STATS.slowest_case})")
