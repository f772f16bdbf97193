"""``tauv tune LOG... --method lc``: the filter's noise parameters found from recorded logs, by the
maximum likelihood of the innovations (tauvcore.eval.tuning), with a before/after table and a TOML
file that ``tauv replay --config`` takes.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time
from collections.abc import Iterator, Sequence
from typing import Any

import tomli_w

from app.commands.outputs import writable_target, write_text_atomic
from app.commands.values import UsageError, check_dask, choice, resolve_config
from app.reports.vehicle_reports import report
from tauvcore.config import LOG_TOML_OMITTED, Config, to_dict
from tauvcore.filter.families import family_of
from tauvcore.validation import one_line, show, show_path

LOCAL_DASK = "local"
"""``--dask`` without an address: a Dask cluster of local processes, one per core."""

MAX_EVALUATIONS = 100000
"""Largest ``--max-evaluations``: a day of 400 s logs at a second each."""

NOT_WRITTEN_SECTIONS = ("run", "replay")
"""Sections the written file leaves out: what to run (methods, seed, the start off the reference),
given again on the command line of the replay, not what the filter is."""


def cmd_tune(args: argparse.Namespace) -> int:
    """``tauv tune LOG...``: read the logs and their configurations (defaults, each log's own
    log.toml, ``--config``, the flags), search the parameters (tauvcore.eval.tuning.tune) with a
    progress bar on stderr, replay each log before and after with the gate as configured, print the
    tables and write ``--out``. Every input is checked before the search; nothing is written on an
    error or an interrupt."""
    from tauvcore.eval import tuning

    names = _params(args.params)
    max_evaluations = _whole(
        "--max-evaluations", args.max_evaluations, 1, MAX_EVALUATIONS, tuning.MAX_EVALUATIONS
    )
    choice("--optimizer", args.optimizer, tuning.OPTIMIZERS, "optimiser")
    if args.dask is not None and (not args.dask.strip() or args.dask.startswith("-")):
        raise UsageError(
            f"--dask: expected a scheduler address such as tcp://host:8786, got {show(args.dask)}"
        )
    out = _out_target(args) if args.out is not None else None
    if args.dask is not None and args.dask != LOCAL_DASK:
        check_dask(args.dask)
    cases, bases = _cases(args)
    started = time.perf_counter()
    prepared = [_prepared(case) for case in cases]
    start = tuning.start_values(cases, names)
    with _evaluator(args.dask, prepared) as evaluator, _progress_bar() as bar:
        try:
            result = tuning.tune(
                prepared,
                names,
                start=start,
                optimizer=args.optimizer,
                max_evaluations=max_evaluations,
                evaluator=evaluator,
                progress=bar,
            )
        except ValueError as exc:  # the configuration leaves the filter no likelihood at the start
            raise UsageError(str(exc)) from None
    before_values = tuning.parameter_values(cases[0].config, names)
    tables = []
    for p in prepared:
        before = p.results(tuning.parameter_values(p.case.config, names), tuning=False)
        after = p.results(result.tuned, tuning=False)
        tables.append((p.case, before[p.case.method], after[p.case.method]))
    elapsed = time.perf_counter() - started
    print(report(result, before_values, tables, start.still is not None, elapsed, args.dask is not None))
    if out is not None:
        sections = file_sections(result, cases, bases)
        name = show_path(str(args.out))
        try:
            write_text_atomic(out, lambda fh: fh.write(tomli_w.dumps(sections)))
        except OSError as exc:
            raise UsageError(f"--out: cannot write {name}: {exc.strerror or exc}") from None
        print(f"\nwritten: {name} (tauv replay LOG --config {name} --method {cases[0].method})")
    return 0


def _params(text: str | None) -> tuple[str, ...]:
    """``--params``: a comma-separated list of tauvcore.eval.tuning.PARAMETERS, or its default."""
    from tauvcore.eval.tuning import DEFAULT_PARAMETERS, PARAMETERS

    if text is None:
        return DEFAULT_PARAMETERS
    items = tuple(s.strip() for s in text.split(",") if s.strip())
    if not items:
        raise UsageError(
            f"--params: expected a comma-separated list from {', '.join(PARAMETERS)}, got {show(text)}"
        )
    for item in items:
        choice("--params", item, PARAMETERS, "parameter")
    if len(set(items)) != len(items):
        raise UsageError(f"--params: repeated parameter in {show(text)}")
    return items


def _whole(flag: str, text: str | None, low: int, high: int, default: int) -> int:
    if text is None:
        return default
    try:
        value = int(text)
    except ValueError:
        raise UsageError(
            f"{flag}: expected a whole number within [{low}, {high}], got {show(text)}"
        ) from None
    if not low <= value <= high:
        raise UsageError(f"{flag}: expected a whole number within [{low}, {high}], got {show(text)}")
    return value


def _cases(args: argparse.Namespace) -> tuple[list[Any], list[Config]]:
    """Each log read with its configuration (defaults, its own log.toml unless --no-log-config,
    --config, the flags) and the same without --config and the flags (what its own file makes it),
    as one line naming the log on any error."""
    from tauvcore.eval.replay import log_config
    from tauvcore.eval.tuning import TuningLog
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.bags import is_bag

    if args.method is None:
        raise UsageError("--method: tuning needs the one method to tune, e.g. --method lc")
    seen: set[str] = set()
    cases, bases = [], []
    for path in args.logs:
        if not path.strip():
            raise UsageError(f"LOG: {show_path(path)} is not a log's name (the current directory is '.')")
        if is_bag(path, by_name=True):
            raise UsageError(
                f"LOG: {show_path(path)} is a ROS bag; write it as a log first (tauv log convert {show_path(path)} DIR)"
            )
        real = os.path.realpath(path)
        if real in seen:
            raise UsageError(f"LOG: {show_path(path)} is given twice")
        seen.add(real)
        try:
            raw, _ = ({}, None) if args.no_log_config else log_config(path)
        except LogError as exc:
            raise UsageError(str(exc)) from None
        config = resolve_config(args, under=raw)
        methods = config.run.methods
        if len(methods) != 1:
            raise UsageError(f"--method: tuning takes one method, got {show(args.method)}")
        method = methods[0]
        if method == "ins":
            raise UsageError("--method: ins fuses no aiding source: it has no innovations to tune on")
        family = family_of(method)
        if not family.log_det:
            raise UsageError(
                f"--method: {method} is {family.title}, whose records keep no log det S; "
                "tuning takes the methods of a filter that keeps it"
            )
        base = resolve_config(argparse.Namespace(config=None), under=raw)
        try:
            log = read_log(path)
        except LogError as exc:
            raise UsageError(str(exc)) from None
        cases.append(TuningLog(show_path(path), log, config))
        bases.append(base)
    return cases, bases


def _prepared(case: Any) -> Any:
    """tauvcore.eval.tuning.PreparedLog of a log, a log that does not fit as one line."""
    from tauvcore.eval.tuning import PreparedLog
    from tauvcore.logs import LogError

    try:
        return PreparedLog(case)
    except LogError as exc:
        raise UsageError(str(exc)) from None


def _out_target(args: argparse.Namespace) -> str:
    """The real path ``--out`` will be written to, checked before the search: a file name in an
    existing writable directory, not a directory or special file, not one of the inputs (the
    --config file, a log's directory), and an existing file only with --replace."""
    from tauvcore.logs.writer import same_file

    path = args.out
    if not path.strip() or "\x00" in path:
        raise UsageError(f"--out: expected a file name, got {show(path)}")
    name = show_path(path)
    real = os.path.realpath(path)
    inputs = [("the --config file", args.config)] + [("the log directory", p) for p in args.logs]
    for what, source in inputs:
        if source is None:
            continue
        source_real = os.path.realpath(source)
        if real == source_real or same_file(source_real, real):
            raise UsageError(f"--out: {name} is {what}; writing it would overwrite it")
        if os.path.isdir(source_real) and os.path.commonpath([real, source_real]) == source_real:
            raise UsageError(
                f"--out: {name} is in {what} {show_path(source)}; writing it could overwrite its files"
            )
    return writable_target("--out", path, None if args.replace else "exists (--replace replaces it)")


@contextlib.contextmanager
def _evaluator(address: str | None, prepared: Sequence[Any]) -> Iterator[Any]:
    """The evaluator of the search: None (in this process), or with ``--dask`` every (point, log)
    pair of a batch on a Dask cluster, local processes (``--dask`` alone) or the scheduler at
    ``address``; one line if none answers."""
    if address is None:
        yield None
        return
    from distributed import Client, LocalCluster

    from tauvcore.eval.study import DASK_CONNECT_TIMEOUT_S
    from tauvcore.eval.tuning import dask_evaluator

    with contextlib.ExitStack() as stack:
        try:
            if address == LOCAL_DASK:
                options: dict[str, Any] = {"dashboard_address": None}  # no web dashboard
                cluster = stack.enter_context(
                    LocalCluster(
                        n_workers=max(1, os.cpu_count() or 1), threads_per_worker=1, processes=True, **options
                    )
                )
                client = stack.enter_context(Client(cluster))
            else:
                client = stack.enter_context(Client(address, timeout=DASK_CONNECT_TIMEOUT_S))
        except (OSError, TimeoutError, ValueError) as exc:
            raise UsageError(
                f"--dask: cannot reach a scheduler at {show(address)}: {one_line(str(exc)) or type(exc).__name__}"
            ) from None
        yield dask_evaluator(prepared, client)


@contextlib.contextmanager
def _progress_bar() -> Iterator[Any]:
    """A tqdm counter on stderr of the likelihood's evaluations (each a replay of every log: the
    search stops when it converges, so there is no total), the phase and the best objective so far
    beside it; silent when stderr is not a terminal. Yields the progress callback."""
    from tqdm import tqdm

    bar = tqdm(
        unit="eval",
        desc="tauv tune",
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
        dynamic_ncols=True,
    )

    def progress(evaluation: Any) -> None:
        bar.set_postfix_str(f"{evaluation.phase}, best {evaluation.best_nll:.2f}", refresh=False)
        bar.update(1)

    try:
        yield progress
    finally:
        bar.close()


def file_sections(result: Any, cases: Sequence[Any], bases: Sequence[Config]) -> dict[str, dict[str, Any]]:
    """What ``--out`` holds: each tuned key, and every key ``--config`` and the flags set that
    every log's replay had alike (so ``tauv replay LOG --config FILE`` is configured as the tuning
    was, each log's own log.toml beneath), in the configuration's sections and units.

    Left out: the sections of :data:`NOT_WRITTEN_SECTIONS` and the keys
    tauvcore.config.LOG_TOML_OMITTED (a log's own events: the DVL's outages and dropout).

    Parameters
    ----------
    result : tauvcore.eval.tuning.TuningResult
        What the search found.
    cases : Sequence[TuningLog]
        The logs with the configuration each was tuned with.
    bases : Sequence[Config]
        Each log's configuration without --config and the flags (defaults and its own file).

    Returns
    -------
    dict[str, dict[str, Any]]
        Section -> key -> value (plain TOML values).
    """
    from tauvcore.eval.tuning import tuned_sections, with_values

    tuned = tuned_sections(result)
    finals = [to_dict(with_values(case.config, result.tuned)) for case in cases]
    base_dicts = [to_dict(b) for b in bases]
    out: dict[str, dict[str, Any]] = {}
    for section, values in finals[0].items():
        if section in NOT_WRITTEN_SECTIONS:
            continue
        for key, value in values.items():
            if key in LOG_TOML_OMITTED.get(section, ()):
                continue
            alike = all(f[section][key] == value for f in finals)
            changed = any(f[section][key] != b[section][key] for f, b in zip(finals, base_dicts))
            if alike and (changed or key in tuned.get(section, {})):
                out.setdefault(section, {})[key] = value
    return out
