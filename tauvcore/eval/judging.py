"""What a recorded log can judge of the filters' results: errors against its reference where it
has one, and NEES only where the reference was measured.

A log without a reference has no truth: every error and NEES is unknown. A log with one is
compared with it at every output epoch, the reference interpolated between its own samples
(tauvcore.eval.replay), which is what the error plots show. Between the samples of a slow
reference (a 1 Hz post-processed solution) that interpolation can be far from the vehicle's
motion: in a turn its roll changes by degrees within a second, and a straight line between two
samples misses it by that much. A NEES holds the error against the filter's own covariance (and
the reference's stated one), which does not know of that interpolation; so the NEES is kept only
at the output epochs within half an output interval of a reference sample, and is NaN between
them. Every consistency figure (tauvcore.eval.consistency) is taken over the finite NEES, so
it is the filter's consistency at the reference's own epochs. A simulated log's reference (the
truth at the IMU's rate) has a sample at every output epoch: nothing changes.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from tauvcore.engine.results import MethodResult
from tauvcore.logs import Log

JUDGED_SERIES = (
    "vel_err_mps",
    "att_err_deg",
    "pos_err_m",
    "tilt_err_deg",
    "heading_err_deg",
    "nees",
    "nees_block",
)
"""The series of a :class:`~tauvcore.engine.results.MethodResult` measured against the truth."""

NEES_SERIES = ("nees", "nees_block")
"""The series of :data:`JUDGED_SERIES` that hold the error against the filter's covariance: kept
only at the reference's own epochs (:func:`reference_epochs`)."""


def output_interval_s(log: Log, output_rate_hz: float) -> float:
    """The interval between output epochs of a replay of ``log``.

    Parameters
    ----------
    log : Log
        The replayed log (its IMU interval).
    output_rate_hz : float
        The replay's ``filter.output_rate_hz`` [Hz].

    Returns
    -------
    float
        The interval [s]: a whole number of IMU intervals, as the engine takes them
        (tauvcore.engine.chunk_driver).
    """
    step = max(1, round((1.0 / log.dt_s) / output_rate_hz))
    return step * log.dt_s


def reference_epochs(ref_t_s: np.ndarray, t_s: np.ndarray, interval_s: float) -> np.ndarray:
    """Which output epochs have a reference sample within half an output interval.

    Parameters
    ----------
    ref_t_s : numpy.ndarray
        The reference's sample times (N,) [s], increasing.
    t_s : numpy.ndarray
        The output epochs (T,) [s].
    interval_s : float
        The interval between output epochs [s].

    Returns
    -------
    numpy.ndarray
        (T,) bool: True where the nearest reference sample is at most ``interval_s / 2`` away
        (with a margin of a millionth of the interval for the rounding of the times).
    """
    if len(ref_t_s) == 0 or len(t_s) == 0:
        return np.zeros(len(t_s), dtype=bool)
    after = np.clip(np.searchsorted(ref_t_s, t_s), 1, len(ref_t_s) - 1) if len(ref_t_s) > 1 else None
    if after is None:
        nearest = np.abs(t_s - ref_t_s[0])
    else:
        nearest = np.minimum(np.abs(t_s - ref_t_s[after - 1]), np.abs(ref_t_s[after] - t_s))
    return nearest <= 0.5 * interval_s * (1.0 + 1e-6)


def judged(
    log: Log | None, results: dict[str, MethodResult], output_rate_hz: float | None = None
) -> dict[str, MethodResult]:
    """``results`` as far as the log can judge them (module docstring), the smoothed results too.

    Parameters
    ----------
    log : Log or None
        The replayed log; None: a simulation (``results`` unchanged).
    results : dict[str, MethodResult]
        Method name -> its results.
    output_rate_hz : float or None
        The replay's ``filter.output_rate_hz``; None: the interval is the median of the results'
        own (all their epochs kept when they have fewer than two).

    Returns
    -------
    dict[str, MethodResult]
        For a log without a reference, every series of :data:`JUDGED_SERIES` NaN (same shapes:
        (T, R), and (T, R, B) for ``nees_block``); for a log with one, :data:`NEES_SERIES` NaN at
        the epochs :func:`reference_epochs` leaves out; else unchanged.
    """
    if log is None:
        return results
    out = {}
    for m, r in results.items():
        if log.ref_t_s is None:
            r = dataclasses.replace(r, **{n: np.full_like(getattr(r, n), np.nan) for n in JUDGED_SERIES})
        else:
            r = _nees_at_reference(log, r, output_rate_hz)
        if r.smoothed is not None:
            r = dataclasses.replace(r, smoothed=judged(log, {m: r.smoothed}, output_rate_hz)[m])
        out[m] = r
    return out


def _nees_at_reference(log: Log, r: MethodResult, output_rate_hz: float | None) -> MethodResult:
    assert log.ref_t_s is not None
    if output_rate_hz is not None:
        interval = output_interval_s(log, output_rate_hz)
    elif len(r.t_s) >= 2:
        interval = float(np.median(np.diff(r.t_s)))
    else:
        return r
    keep = reference_epochs(log.ref_t_s, r.t_s, interval)
    if keep.all():
        return r
    return dataclasses.replace(
        r,
        **{
            n: np.where(keep.reshape((-1,) + (1,) * (getattr(r, n).ndim - 1)), getattr(r, n), np.nan)
            for n in NEES_SERIES
        },
    )
