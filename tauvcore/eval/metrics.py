"""Error metrics: RMS over runs and the chi-square consistency bounds of a run-averaged NEES
(the NEES itself: tauvcore.filter.statistics; the divergence monitor, which needs no truth:
tauvcore.engine.monitor)."""

from __future__ import annotations

import numpy as np

from tauvcore.filter.statistics import chi2_ppf


def rms(x: np.ndarray, axis: int | tuple[int, ...] = -1) -> np.ndarray:
    """Root mean square along ``axis``.

    Parameters
    ----------
    x : numpy.ndarray
        Values of any shape, e.g. an error series (T, R) over output epochs and runs, in any unit.
    axis : int or tuple[int, ...]
        The axis or axes averaged over (1 for the runs of a (T, R) series; the last by default).

    Returns
    -------
    numpy.ndarray
        ``sqrt(mean(x^2))`` along ``axis``: ``x``'s shape without those axes (a NumPy scalar for a
        1-D ``x``), in ``x``'s unit.
    """
    return np.sqrt(np.mean(np.square(x), axis=axis))


def average_nees_bounds(dim: int, num_runs: int, confidence: float = 0.99) -> tuple[float, float]:
    """Two-sided bounds of the run-averaged NEES of a consistent filter.

    ``num_runs * mean(NEES)`` is chi-square with ``num_runs * dim`` degrees of freedom
    (Bar-Shalom, Li & Kirubarajan 2001, section 5.4.2).

    Parameters
    ----------
    dim : int
        Dimension n of the state (or block) the NEES is of: its degrees of freedom.
    num_runs : int
        Monte Carlo runs R averaged over.
    confidence : float
        Two-sided probability inside the bounds, in (0, 1) (0.99: 99 %).

    Returns
    -------
    tuple[float, float]
        Lower and upper bound of the run-averaged NEES (not divided by ``dim``), dimensionless.
    """
    dof = num_runs * dim
    alpha = 1.0 - confidence
    return (float(chi2_ppf(alpha / 2, dof) / num_runs), float(chi2_ppf(1 - alpha / 2, dof) / num_runs))
