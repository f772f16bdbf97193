"""``--smooth``, ``--smooth-memory-mb`` and ``--smooth-dir`` of ``tauv run``, ``tauv replay`` and
``tauv mc``: the fixed-interval smoother (tauvcore.engine.smoothing) asked for, its flags checked
before anything runs, and its failures as one line naming the flag.

The smoother keeps a tape of the forward pass, in memory up to ``--smooth-memory-mb`` and in a
temporary directory beyond it (made in ``--smooth-dir``, else the system's, and removed when the
command ends, also on an error or an interruption: tauvcore.engine.smoothing.scratch). Its budget
cannot be below what it holds of one chunk whatever the budget
(tauvcore.engine.smoothing.spill_floor_bytes): such a budget is refused before the run.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
from collections.abc import Iterator
from typing import TYPE_CHECKING

from app.commands.values import UsageError, parse_flag
from tauvcore.config import Config
from tauvcore.validation import show, show_path

if TYPE_CHECKING:
    from tauvcore.engine.smoothing import SmoothOptions

MAX_SMOOTH_MEMORY_MB = 1_000_000.0
"""Largest ``--smooth-memory-mb`` [MB]: a terabyte, more memory than any machine that runs the
lab has (a budget beyond the machine's memory only means the tape is never spilled to disk, and
the run fails for want of memory instead). Past about 1e302 MB the budget in bytes is no longer a
number at all."""


def smooth_options(args: argparse.Namespace, config: Config, runs: int = 1) -> SmoothOptions | None:
    """The smoother's options from the command line, checked; None without ``--smooth``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``smooth``, ``smooth_memory_mb``, ``smooth_dir``).
    config : Config
        The run's configuration: its methods (each is smoothed) and output rate.
    runs : int
        Runs the engine filters in one batch (``tauv mc``: runs per chunk), for the budget's floor.

    Returns
    -------
    SmoothOptions or None
        The budget [MB] and the directory for the tape's temporary files; None: no smoother.

    Raises
    ------
    UsageError
        ``--smooth-memory-mb`` or ``--smooth-dir`` without ``--smooth``; a budget that is not a
        positive number, above :data:`MAX_SMOOTH_MEMORY_MB`, or below what one chunk needs (the line says the minimum); a
        ``--smooth-dir`` that is not a writable directory.
    """
    from tauvcore.engine.mission import STREAM_CHUNK_S
    from tauvcore.engine.smoothing import DEFAULT_BUDGET_MB, SmoothOptions, spill_floor_bytes

    memory, directory = getattr(args, "smooth_memory_mb", None), getattr(args, "smooth_dir", None)
    if not getattr(args, "smooth", False):
        for flag, value in (("--smooth-memory-mb", memory), ("--smooth-dir", directory)):
            if value is not None:
                raise UsageError(f"{flag} {show(value)}: only with --smooth (the smoother is off without it)")
        return None
    budget_mb = DEFAULT_BUDGET_MB
    if memory is not None:
        budget_mb = parse_flag("--smooth-memory-mb", memory, float, "a positive number of megabytes")
        if budget_mb <= 0:
            raise UsageError(
                f"--smooth-memory-mb: expected a positive number of megabytes, got {show(memory)}"
            )
        if budget_mb > MAX_SMOOTH_MEMORY_MB:
            raise UsageError(
                f"--smooth-memory-mb: {show(memory)} MB is more than the {MAX_SMOOTH_MEMORY_MB:.0f} MB "
                "(a terabyte) any machine has; the tape beyond the budget goes to disk, so a budget "
                "within the machine's memory is enough"
            )
    smoothed = max(1, len(config.run.methods))
    floor = spill_floor_bytes((smoothed, runs), config.filter.output_rate_hz, STREAM_CHUNK_S)
    if budget_mb * 1e6 < floor:
        least = math.ceil(floor / 1e5) / 10
        raise UsageError(
            f"--smooth-memory-mb: {show(memory)} MB is below what the smoother holds of one chunk: "
            f"at least {least:g} MB for {smoothed} smoothed method{'s' if smoothed > 1 else ''}"
            + (f" and {runs} runs per chunk" if runs > 1 else "")
        )
    if directory is not None:
        if not directory.strip() or not os.path.isdir(directory):
            raise UsageError(f"--smooth-dir: {show_path(directory)} is not a directory")
        if not os.access(directory, os.W_OK | os.X_OK):
            raise UsageError(f"--smooth-dir: cannot write into {show_path(directory)}: permission denied")
    return SmoothOptions(budget_mb=budget_mb, directory=directory)


@contextlib.contextmanager
def smoothing(options: SmoothOptions | None) -> Iterator[SmoothOptions | None]:
    """``options`` with a temporary directory of their own, removed on leaving whatever happens
    (tauvcore.engine.smoothing.scratch); the smoother's failure (its directory cannot be made or
    written) as one line naming ``--smooth-dir``.

    Parameters
    ----------
    options : SmoothOptions or None
        From :func:`smooth_options`; None: no smoother.

    Yields
    ------
    SmoothOptions or None
        What to give the engine.

    Raises
    ------
    UsageError
        The smoother could not make or write its temporary directory.
    """
    from tauvcore.engine.smoothing import scratch
    from tauvcore.engine.tape import SmoothingError

    try:
        with scratch(options) as own:
            yield own
    except SmoothingError as exc:
        raise UsageError(f"--smooth-dir: {exc}") from None
