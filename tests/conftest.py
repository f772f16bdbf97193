"""Suite-wide hooks: the fuzz tier's closing lines (how many hostile cases ran, per family), with
the counts of every pytest-xdist worker gathered on the controller."""

from __future__ import annotations

from typing import Any

import pytest

from tests.fuzz import stats

_FROM_WORKERS: list[dict[str, Any]] = []


def pytest_sessionfinish(session: pytest.Session) -> None:
    workeroutput = getattr(session.config, "workeroutput", None)  # set on a pytest-xdist worker only
    if workeroutput is not None:
        workeroutput["tauv_fuzz"] = stats.state()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: Any) -> None:  # pytest-xdist's hook, on the controller
    counts = getattr(node, "workeroutput", {}).get("tauv_fuzz")
    if counts is not None:
        _FROM_WORKERS.append(counts)


def pytest_terminal_summary(terminalreporter: Any) -> None:
    for line in stats.closing_lines([stats.state(), *_FROM_WORKERS]):
        terminalreporter.write_line(line)
