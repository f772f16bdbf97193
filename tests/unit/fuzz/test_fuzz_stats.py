"""The fuzz tier's closing lines sum the counts of every process (pytest-xdist's workers), so the
suite's two-core run says how many hostile cases ran in all."""

from tests.fuzz import stats


def _state(cases: dict, bags: dict, exits: dict, slowest: tuple[float, str]) -> dict:
    empty = {name: [] for name in ("cases", "exits", "log_classes", "log_exits", "bag_tiers")}
    return {**empty, "bag_classes": list(map(list, bags.items())), "bag_exits": list(map(list, exits.items())),
            "cases": list(map(list, cases.items())), "slowest": [0.0, ""], "log_slowest": 0.0,
            "bag_slowest": list(slowest)}


def test_the_closing_lines_sum_the_workers_counts_and_keep_the_slowest_case() -> None:
    one = _state({"fast": 3}, {"truncated": 2, "stamps": 1}, {2: 3}, (0.2, "truncated #0"))
    two = _state({"fast": 4}, {"truncated": 5}, {0: 1, 2: 3, "raised": 1}, (0.4, "truncated #4"))
    lines = stats.closing_lines([one, two])
    assert lines[0].startswith("fuzz: 7 cases (fast 7; ")
    assert lines[1] == ("fuzz: hostile bags: 8 cases in 2 classes (exit 0: 1, exit 2: 6, raised: 1; ); "
                        "slowest case 0.40 s (truncated #4)")


def test_a_process_that_ran_no_fuzz_case_adds_no_line() -> None:
    assert stats.closing_lines([_state({}, {}, {}, (0.0, ""))]) == []
