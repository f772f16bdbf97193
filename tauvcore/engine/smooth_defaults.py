"""The smoother's memory default, in a module of its own: the command line's flags and the
dashboard's control quote it without importing the smoother and its compiled kernels (numba),
which ``tauv --help`` does not need."""

from __future__ import annotations

DEFAULT_BUDGET_MB = 64.0
"""Megabytes of tape the smoother holds in memory by default; the rest goes to a temporary file."""

__all__ = ["DEFAULT_BUDGET_MB"]
