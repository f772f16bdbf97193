"""Error metrics: RMS over runs and the chi-square consistency bounds of a run-averaged NEES
(the NEES itself: tauvcore.filter.statistics; the divergence monitor, which needs no truth:
tauvcore.engine.monitor)."""

from __future__ import annotations

import numpy as np

from tauvcore.filter.statistics import chi2_ppf


def rms(x: np.ndarray, axis: int | tuple[int, ...] = -1) -> np.ndarray:
    """Root mean square along ``axis``."""
    return np.sqrt(np.mean(np.square(x), axis=axis))


def average_nees_bounds(dim: int, num_runs: int, confidence: float = 0.99) -> tuple[float, float]:
    """Two-sided bounds of the run-averaged NEES of a consistent filter.

    ``num_runs * mean(NEES)`` is chi-square with ``num_runs * dim`` degrees of freedom
    (Bar-Shalom, Li & Kirubarajan 2001, section 5.4.2).
    """
    dof = num_runs * dim
    alpha = 1.0 - confidence
    return (float(chi2_ppf(alpha / 2, dof) / num_runs), float(chi2_ppf(1 - alpha / 2, dof) / num_runs))
