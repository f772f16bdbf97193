"""Helpers the numbered examples share (not an example itself: the test runs ``[0-9][0-9]_*.py``).

Each example accepts ``--duration`` (seconds of mission) and ``--out`` (a directory for what it
writes; a new temporary directory if not given, never the repository). ``TAUV_EXAMPLE_SHORT=1``
in the environment makes every default mission short (the test of the examples sets it).
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

import numpy as np

from tauvcore.engine.results import MethodResult
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.metrics import rms

SHORT_ENV = "TAUV_EXAMPLE_SHORT"
"""Set to 1 for short missions (tests/unit/examples/test_examples.py)."""


def short() -> bool:
    """Whether the environment asks for short missions."""
    return os.environ.get(SHORT_ENV, "") not in ("", "0")


def parser(doc: str | None, duration_s: float, short_duration_s: float) -> argparse.ArgumentParser:
    """The examples' common flags: ``--duration`` (default ``duration_s``, or ``short_duration_s``
    under ``TAUV_EXAMPLE_SHORT=1``) and ``--out``."""
    p = argparse.ArgumentParser(
        description=(doc or "").split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--duration",
        type=float,
        default=short_duration_s if short() else duration_s,
        help=f"mission length [s] (default {duration_s:g}; {short_duration_s:g} with {SHORT_ENV}=1)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="directory for the files the example writes (default: a new temporary directory)",
    )
    return p


def out_dir(path: Path | None, prefix: str) -> Path:
    """``path`` (created if need be), or a new temporary directory."""
    if path is None:
        return Path(tempfile.mkdtemp(prefix=prefix))
    path.mkdir(parents=True, exist_ok=True)
    return path


def error_table(results: dict[str, MethodResult], run: int = 0, block: str = "full") -> str:
    """End and RMS errors of run ``run`` and the NEES/dim of ``block`` ("full", "pos", "vel",
    "tilt", "heading", "sensor": tauvcore.engine.results.BLOCK_DIMS) of every method, one line each."""
    lines = [
        f"{'method':<8} {'pos end':>9} {'pos RMS':>9} {'vel end':>9} {'att end':>9} {'NEES/dim':>9}",
        f"{'':<8} {'[m]':>9} {'[m]':>9} {'[m/s]':>9} {'[deg]':>9} {'(' + block + ')':>9}",
    ]
    for name, r in results.items():
        nees = method_consistency(r).nees[block].per_dim
        flag = "  diverged" if bool(r.diverged[run]) else ""
        lines.append(
            f"{name:<8} {r.pos_err_m[-1, run]:>9.3f} {rms(r.pos_err_m[:, run]):>9.3f} "
            f"{r.vel_err_mps[-1, run]:>9.4f} {r.att_err_deg[-1, run]:>9.4f} {nees:>9.2f}{flag}"
        )
    return "\n".join(lines)


def finite(results: dict[str, MethodResult]) -> bool:
    """Every method's errors finite (what the examples check before they say they are done)."""
    return all(np.isfinite(r.pos_err_m).all() and np.isfinite(r.vel_err_mps).all() for r in results.values())
