"""``tauv run``: simulate a mission, run the fusion methods side by side and print their summary;
``--save-log`` writes the simulation as a log (``tauv replay`` reads it), ``--json`` the results,
``--mcap`` the results as MCAP.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from app.commands.mcap_output import McapOutput, chained, mcap_target
from app.commands.outputs import json_target
from app.commands.smooth_flags import smooth_options, smoothing
from app.commands.values import UsageError, resolve_config
from app.reports.tables import summary_table
from tauvcore.validation import show, show_path


def cmd_run(args: argparse.Namespace) -> int:
    """``tauv run``: simulate, run the methods, print the summary; with ``--save-log`` the
    simulation as a log (all or nothing, the directory locked meanwhile), with ``--json`` the
    results (atomically). Every output is checked before the run, and none may be an input.

    The results are reduced chunk by chunk as the engine hands them out (the summary's sums,
    tauvcore.eval.running; the ``--json`` document spooled to disk, app.commands.json_stream; the
    ``--mcap`` file written as a bag in a temporary directory beside it, app.commands.mcap_output),
    and the log appended chunk by chunk to its files (tauvcore.logs.writer.LogWriter), so memory
    does not grow with the mission's length.

    With ``--smooth`` the fixed-interval smoother runs after the forward pass: its results come
    chunk by chunk after the filtered ones and are reduced the same way (their summary printed
    beside the filtered, their series in ``--json``); its tape beyond ``--smooth-memory-mb`` goes to
    a temporary directory (in ``--smooth-dir``) removed when the command ends, whatever happens
    (app.commands.smooth_flags). An interruption (Ctrl-C) writes nothing."""
    config = resolve_config(args)
    smooth = smooth_options(args, config)
    log_dir = _save_log_target(args)
    inputs = [("the --config file", args.config), ("the --save-log directory", args.save_log)]
    json_path = json_target(args.json, inputs) if args.json is not None else None
    mcap_path = mcap_target(args, inputs)
    started = time.perf_counter()
    rng = np.random.default_rng(config.run.seed)
    from app.commands.json_stream import RunReduction
    from tauvcore.engine.mission import Sinks, run_streaming

    reduction = RunReduction(config, json_path, args.json, smoothed=smooth is not None)

    lock = _lock_save_log(args, log_dir) if log_dir is not None else None
    log_writer = mcap = None
    try:
        log_writer = _log_writer(args, log_dir, config) if log_dir is not None else None
        mcap = McapOutput(mcap_path, args.mcap, config) if mcap_path is not None else None
        with smoothing(smooth) as options:
            run_streaming(
                config,
                rng,
                keep=False,
                smooth=options,
                sinks=Sinks(
                    on_chunk=chained(reduction.add, None if mcap is None else mcap.add),
                    on_sim_chunk=chained(
                        None if log_writer is None else lambda chunk: _save_chunk(args, log_writer, chunk),
                        None if mcap is None else mcap.add_sim_chunk,
                    ),
                    on_smoothed_chunk=chained(
                        reduction.add_smoothed, None if mcap is None else mcap.add_smoothed
                    ),
                ),
            )
        elapsed = time.perf_counter() - started
        if mcap is not None:
            mcap.finish()
        if log_writer is not None:
            with _saving_log(args):
                log_writer.finish()
    except BaseException:
        if log_writer is not None:
            log_writer.discard()
        if mcap is not None:
            mcap.discard()
        if lock is not None:
            lock.release(remove_created=True)
        reduction.discard()
        raise
    if lock is not None:
        lock.release()
    summaries = reduction.finish()
    print(summary_table(summaries, config, elapsed, smoothed=reduction.smoothed_summaries))
    return 0


def _log_writer(args: argparse.Namespace, target: str, config: Any) -> Any:
    """The --save-log directory's :class:`~tauvcore.logs.writer.LogWriter` (its temporary
    directory inside the locked target), the log's own configuration file with it
    (tauvcore.config.to_log_toml: what a replay needs to filter the log as the run did), or one
    line if it cannot be made."""
    from tauvcore.config import to_log_toml
    from tauvcore.logs.writer import LogWriter

    with _saving_log(args):
        return LogWriter(target, args.log_format, config_toml=to_log_toml(config))


def _save_chunk(args: argparse.Namespace, log_writer: Any, chunk: Any) -> None:
    """One simulation chunk appended to the --save-log directory's tables."""
    from tauvcore.logs.writer import chunk_tables

    with _saving_log(args):
        log_writer.add(chunk_tables(chunk))


@contextlib.contextmanager
def _saving_log(args: argparse.Namespace) -> Iterator[None]:
    """An OSError while writing the --save-log directory as one line naming it and the reason."""
    from app.reports.study_output import os_reason

    try:
        yield
    except OSError as exc:
        raise UsageError(f"--save-log: cannot write {show_path(args.save_log)}: {os_reason(exc)}") from None


def _save_log_target(args: argparse.Namespace) -> str | None:
    """The --save-log directory, checked before the run by the rule of every writer
    (tauvcore.logs.writer.output_dir): a new directory in an existing writable one, or an empty
    one; not a file, not holding the --config file."""
    if args.log_format not in ("csv", "parquet"):
        raise UsageError(f"--log-format: expected csv or parquet, got {show(args.log_format)}")
    if args.save_log is None:
        return None
    return _checked_save_log(args).path


def _checked_save_log(args: argparse.Namespace) -> Any:
    """tauvcore.logs.writer.output_dir of --save-log, as one line."""
    from tauvcore.logs.writer import output_dir
    from tauvcore.validation import OutputDirError

    try:
        return output_dir(args.save_log, "--save-log", inputs=[("the --config file", args.config)])
    except OutputDirError as exc:
        raise UsageError(str(exc)) from None


def _lock_save_log(args: argparse.Namespace, target: str) -> Any:
    """The --save-log directory created if need be and locked for this run
    (app.reports.study_output.DirectoryLock), or one line if another tauv holds it or has meanwhile
    written there."""
    from app.reports.study_output import DirectoryLock, OutputDirError

    try:
        lock = DirectoryLock(target, name=args.save_log)
    except OutputDirError as exc:
        raise UsageError(f"--save-log: {exc}") from None
    try:
        _checked_save_log(args)  # again, now that no other tauv writes there
    except BaseException:
        lock.release(remove_created=True)
        raise
    return lock
