"""Error metrics: RMS over runs, NEES and its chi-square consistency bounds."""

from __future__ import annotations

import numpy as np
from scipy import stats


def rms(x: np.ndarray, axis: int | tuple[int, ...] = -1) -> np.ndarray:
    """Root mean square along ``axis``."""
    return np.sqrt(np.mean(np.square(x), axis=axis))


def nees(dx: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``dx^T P^-1 dx``. dx (..., n), P (..., n, n) -> (...)."""
    return np.einsum("...i,...i->...", dx, np.linalg.solve(P, dx[..., None])[..., 0])


def average_nees_bounds(dim: int, num_runs: int, confidence: float = 0.99) -> tuple[float, float]:
    """Two-sided bounds of the run-averaged NEES of a consistent filter.

    ``num_runs * mean(NEES)`` is chi-square with ``num_runs * dim`` degrees of freedom
    (Bar-Shalom, Li & Kirubarajan 2001, section 5.4.2).
    """
    dof = num_runs * dim
    alpha = 1.0 - confidence
    return (float(stats.chi2.ppf(alpha / 2, dof) / num_runs), float(stats.chi2.ppf(1 - alpha / 2, dof) / num_runs))
