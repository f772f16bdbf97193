"""Does a filter know its own error? NEES and NIS summaries of a method's results.

A consistent filter's NEES of an n-dimensional block is chi-square with n degrees of freedom, so
its mean divided by n is 1. Averaged over R Monte Carlo runs at one epoch, ``R * mean(NEES)`` is
chi-square with ``R n`` degrees of freedom, which gives the two-sided 99 % band of
:func:`~tauvcore.eval.metrics.average_nees_bounds` (Bar-Shalom, Li & Kirubarajan 2001, 5.4.2).
Each summary reports

- ``per_dim``: the mean NEES over epochs and runs divided by n (1.0 consistent; above 1 the
  filter is over-confident, below 1 it is cautious);
- ``in_band``: the fraction of output epochs whose run-averaged NEES lies inside the band (99 %
  for a consistent filter, less by chance since epochs are correlated).

NIS (normalised innovation squared, ``nu^T S^-1 nu`` before the gate) is the same test made
without truth, per aiding source: chi-square with as many degrees of freedom as rows were
active. Its ``per_dof`` is ``sum(NIS) / sum(dof)`` over every update that produced a measurement,
``in_band`` the fraction of those updates whose NIS lies inside its own two-sided 99 % band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.engine.results import BLOCK_DIMS, MethodResult, UpdateRecord
from tauvcore.eval.metrics import average_nees_bounds
from tauvcore.filter.statistics import chi2_ppf

CONFIDENCE = 0.99
"""Two-sided confidence of every band."""


@dataclass(frozen=True)
class NeesSummary:
    """The NEES consistency of one block of one method's results over its R runs."""

    block: str
    dim: int
    per_dim: float  # mean NEES / dim over epochs and runs (NaN if none finite)
    in_band: float  # fraction of epochs with the run-averaged NEES inside the 99 % band
    band_per_dim: tuple[float, float]  # the band of the run-averaged NEES, divided by dim


@dataclass(frozen=True)
class NisSummary:
    """The NIS consistency of one aiding source's updates for one method."""

    source: str
    per_dof: float  # sum(NIS) / sum(dof) over the updates that produced a measurement
    in_band: float  # fraction of those whose NIS lies inside its two-sided 99 % band
    count: int  # number of (update, run) entries counted


def nees_series(result: MethodResult, block: str) -> np.ndarray:
    """The NEES series of one block of a method's results.

    Parameters
    ----------
    result : MethodResult
        One method's results over T output epochs and R runs.
    block : str
        "full" (the whole state) or a block of the result's ``block_dims`` (the 20-state filter's:
        ``tauvcore.filter.layout.NEES_BLOCKS``; a source's states add theirs after them).

    Returns
    -------
    numpy.ndarray
        The NEES of ``block``, shape (T, R), dimensionless (NaN where unknown).
    """
    if block == "full":
        return result.nees
    order = [b for b in (result.block_dims or BLOCK_DIMS) if b != "full"]  # the records' block order
    return result.nees_block[..., order.index(block)]


def nees_band(dim: int, num_runs: int) -> tuple[float, float]:
    """Two-sided band of the run-averaged NEES of an n-dimensional block, divided by n.

    At :data:`CONFIDENCE` (99 %), from :func:`~tauvcore.eval.metrics.average_nees_bounds`.

    Parameters
    ----------
    dim : int
        The block's dimension n (its degrees of freedom).
    num_runs : int
        Monte Carlo runs R averaged over (fewer than 1 counts as 1).

    Returns
    -------
    tuple[float, float]
        Lower and upper bound of the run-averaged NEES divided by n, dimensionless.
    """
    lo, hi = average_nees_bounds(dim, max(int(num_runs), 1), CONFIDENCE)
    return lo / dim, hi / dim


def summarise_nees(series: np.ndarray, dim: int, block: str = "") -> NeesSummary:
    """Summary of a (T, R) NEES series.

    Epochs where a run's NEES is not finite (a diverged filter) count as outside the band and are
    left out of the mean. A series with no finite value at all is unknown, not outside (a replayed
    log knows no true sensor errors): NaN, NaN.

    Parameters
    ----------
    series : numpy.ndarray
        NEES over T output epochs and R runs, shape (T, R), dimensionless.
    dim : int
        The block's dimension n (the NEES's degrees of freedom).
    block : str
        The block's name, carried into the summary.

    Returns
    -------
    NeesSummary
        ``per_dim`` (mean NEES / n over the finite entries), ``in_band`` (fraction of the T
        epochs inside the 99 % band) and the band divided by n; NaN, NaN for no finite value.
    """
    series = np.asarray(series, dtype=float)
    band = nees_band(dim, series.shape[1])
    if series.size == 0 or not np.isfinite(series).any():
        return NeesSummary(block, dim, float("nan"), float("nan"), band)
    finite = np.isfinite(series)
    per_dim = float(series[finite].mean() / dim) if finite.any() else float("nan")
    with np.errstate(invalid="ignore"):
        avg = series.mean(axis=1) / dim
        inside = finite.all(axis=1) & (avg >= band[0]) & (avg <= band[1])
    return NeesSummary(block, dim, per_dim, float(inside.mean()), band)


def summarise_nis(record: UpdateRecord, source: str = "") -> NisSummary:
    """Summary of one aiding source's NIS over the updates that produced a measurement.

    Parameters
    ----------
    record : UpdateRecord
        Every update of the source for one method, U epochs x R runs (``nis`` and ``nis_dof``
        (U, R), ``valid`` (U, R) bool).
    source : str
        The source's name, carried into the summary.

    Returns
    -------
    NisSummary
        ``per_dof`` (sum(NIS) / sum(dof)), ``in_band`` (fraction of the updates whose NIS lies
        inside its two-sided 99 % band) and the number of (update, run) entries counted; NaN,
        NaN and 0 when no update produced a measurement.
    """
    used = record.valid & (record.nis_dof > 0) & np.isfinite(record.nis)
    if not used.any():
        return NisSummary(source, float("nan"), float("nan"), 0)
    nis, dof = record.nis[used], record.nis_dof[used]
    alpha = 1.0 - CONFIDENCE
    dofs, inverse = np.unique(dof, return_inverse=True)  # a few distinct dof: one quantile each
    lo, hi = chi2_ppf(alpha / 2, dofs)[inverse], chi2_ppf(1 - alpha / 2, dofs)[inverse]
    return NisSummary(
        source, float(nis.sum() / dof.sum()), float(np.mean((nis >= lo) & (nis <= hi))), int(used.sum())
    )


@dataclass(frozen=True)
class MethodConsistency:
    """NEES and NIS summaries of one method."""

    nees: dict[str, NeesSummary]  # "full" and every block of NEES_BLOCKS
    nis: dict[str, NisSummary]  # every aiding source the method used


def method_consistency(result: MethodResult) -> MethodConsistency:
    """NEES of the full state and every block, and NIS of every aiding source, of one method.

    Parameters
    ----------
    result : MethodResult
        One method's results over T output epochs and R runs; its ``block_dims`` (or
        ``BLOCK_DIMS``) give the blocks and their dimensions.

    Returns
    -------
    MethodConsistency
        Block name -> :class:`NeesSummary`, and source name -> :class:`NisSummary`.
    """
    return MethodConsistency(
        nees={
            block: summarise_nees(nees_series(result, block), dim, block)
            for block, dim in (result.block_dims or BLOCK_DIMS).items()
        },
        nis={src: summarise_nis(rec, src) for src, rec in result.updates.items()},
    )
