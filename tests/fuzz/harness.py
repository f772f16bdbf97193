"""Run one hostile ``tauv`` invocation in-process and check the contract every input must meet.

The contract: exit status 0 or 2; never a traceback; on 2 exactly one line on stderr
that names the field, flag or file and quotes the value shortened; no partial output file (the
``--json`` target is untouched on 2, valid strict JSON on 0, and no temporary file is left);
bounded time (an alarm per case) and memory (a soft address-space limit during each case, and
the process's peak RSS may not grow by more than :data:`RSS_GROWTH_LIMIT_BYTES` over its peak
when the test began).
"""

from __future__ import annotations

import contextlib
import glob
import io
import json
import os
import re
import resource
import signal
import stat
import time
import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field

from app.cli import main
from tests.fuzz.stats import BAG_STATS, CASE_TIMEOUT_S, STATS  # noqa: F401  (the tests take them from here too)

ADDRESS_SPACE_MARGIN_BYTES = 2 << 30
"""Address space a case may add to the process (soft RLIMIT_AS during the case): a runaway
allocation (the old code read /dev/zero to 20 GB and met the OOM killer) becomes a MemoryError
in this test instead of a machine out of memory."""
RSS_GROWTH_LIMIT_BYTES = 768 << 20
"""Peak RSS may grow by this much over the whole session; the old code reading /dev/zero grew
it by 3.7 GB, a 100,000-entry method list by 3.3 GB."""
MESSAGE_LIMIT = 500
"""Longest acceptable error line; every quoted value must be shortened to fit."""
LONG_VALUE = 200
"""A value longer than this must never be echoed whole."""




class CaseTimeout(Exception):
    """A case exceeded CASE_TIMEOUT_S (a hang)."""


def peak_rss_bytes() -> int:
    """The process's peak resident set size [bytes]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024     # Linux reports kB


def _vm_size_bytes() -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmSize in /proc/self/status")


@contextlib.contextmanager
def _address_space_limit() -> Iterator[None]:
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = _vm_size_bytes() + ADDRESS_SPACE_MARGIN_BYTES
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _on_alarm(signum: int, frame: object) -> None:
    raise CaseTimeout(f"case still running after {CASE_TIMEOUT_S} s")


@dataclass
class Result:
    code: int
    out: str
    err: str
    warnings: list[str] = field(default_factory=list)  # RuntimeWarnings raised in the case (if recorded)
    elapsed_s: float = 0.0


def _temp_leftovers(dirs: Iterable[str]) -> list[str]:
    return [p for d in dirs for p in glob.glob(os.path.join(glob.escape(d), ".tauv-*.tmp"))]


def _snapshot(path: str | None) -> bytes | None:
    """The content of a regular file (None otherwise: a FIFO must never be opened here)."""
    if path is None:
        return None
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as fh:
            return fh.read()
    except OSError:
        return None


def invoke(argv: Sequence[str], *, record_warnings: bool = False) -> Result:
    """``main(argv)`` with its output captured, under the time alarm and the address-space limit.

    record_warnings: collect the RuntimeWarnings the case raises (a process would print them on
    stderr; in-process pytest would only count them) into :attr:`Result.warnings`.
    """
    if not STATS.rss_start_bytes:
        STATS.rss_start_bytes = peak_rss_bytes()
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.setitimer(signal.ITIMER_REAL, CASE_TIMEOUT_S)
    started = time.perf_counter()
    recorder = warnings.catch_warnings(record=True) if record_warnings else contextlib.nullcontext()
    with recorder as caught:
        if record_warnings:
            warnings.simplefilter("always", RuntimeWarning)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), _address_space_limit():
                try:
                    code = main(list(argv))
                except SystemExit as exc:           # --help / -h: argparse prints and exits 0
                    code = exc.code if isinstance(exc.code, int) else 1
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    found = [f"{w.category.__name__}: {w.message} ({os.path.basename(w.filename)}:{w.lineno})"
             for w in caught or () if issubclass(w.category, RuntimeWarning)]
    return Result(code, out.getvalue(), err.getvalue(), found, time.perf_counter() - started)


def run_case(argv: Sequence[str], tier: str, *, names: Sequence[str] = (), json_path: str | None = None,
             watch_dirs: Sequence[str] = (), long_values: Sequence[str] = ()) -> Result:
    """``main(argv)`` with its output captured, then every check of the contract.

    names: the message on exit 2 must contain one of these (field, flag, file, section), if given.
    json_path: the ``--json`` target (a real path) to check for partial output.
    watch_dirs: directories that must hold no temporary file afterwards.
    long_values: values that must not appear whole in the message.
    """
    before = _snapshot(json_path)
    result = invoke(argv)
    STATS.cases[tier] += 1
    STATS.exits[result.code] += 1
    if result.elapsed_s > STATS.slowest_s:
        STATS.slowest_s, STATS.slowest_argv = result.elapsed_s, " ".join(a[:40] for a in argv)[:200]
    check(result, names=names, json_path=json_path, before=before, watch_dirs=watch_dirs, long_values=long_values)
    return result


def rss_growth_bytes() -> int:
    """How much the process's peak RSS has grown since the test began (tests/fuzz/conftest.py)."""
    return peak_rss_bytes() - STATS.rss_start_bytes


def check(result: Result, *, names: Sequence[str], json_path: str | None, before: bytes | None,
          watch_dirs: Sequence[str], long_values: Sequence[str]) -> None:
    code, err = result.code, result.err
    assert code in (0, 2), f"exit status {code}: {err[-2000:]}"
    assert "Traceback" not in err, err[-2000:]
    growth = rss_growth_bytes()
    assert growth < RSS_GROWTH_LIMIT_BYTES, f"peak RSS grew by {growth / 2**20:.0f} MiB"
    if code == 2:
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("tauv: error: "), err[:2000]
        line = lines[0]
        assert len(line) <= MESSAGE_LIMIT, f"{len(line)} characters: {line[:300]}"
        assert result.out == "", result.out[:500]
        if names:
            assert any(n in line for n in names), f"message names none of {list(names)[:8]}: {line}"
        for value in long_values:
            if len(value) > LONG_VALUE:
                assert value not in line and value[:LONG_VALUE] not in line, f"long value echoed: {line[:300]}"
        if json_path is not None:
            assert _snapshot(json_path) == before, f"--json target {json_path} changed on exit 2"
    elif json_path is not None and result.out:       # exit 0 of `run` with --json: strict JSON, complete
        data = _snapshot(json_path)
        assert data is not None, "exit 0 but no --json file"
        parsed = strict_json(data)
        assert set(parsed) == {"config", "results"}
        for method in parsed["results"].values():
            assert isinstance(method["diverged"], bool) and isinstance(method["p_floor_count"], int)
    assert not _temp_leftovers(watch_dirs), _temp_leftovers(watch_dirs)


def _refuse_constant(name: str) -> None:
    raise AssertionError(f"--json holds {name}, which is not JSON")


def strict_json(data: bytes) -> object:
    """``data`` parsed as strict JSON: NaN, Infinity and -Infinity raise AssertionError."""
    return json.loads(data, parse_constant=_refuse_constant)


FIELD_NAME = re.compile(r"[a-z_]+\.[a-z_]+|\[[^\]]*\]|--[a-z]+")
"""Something a message may name: section.key, [section], --flag."""


