"""The statistics of a study's final errors over its runs (tauvcore.eval.study): RMS, median and
95th percentile, with and without the runs the divergence monitor flagged."""

from __future__ import annotations

import numpy as np

FINAL_STATISTICS = ("rms", "median", "p95")
"""The statistics of a study's final errors, each also over the runs the monitor did not flag
(``<name>_unflagged``)."""


def final_statistics(values: np.ndarray, flagged: np.ndarray) -> dict[str, float | int]:
    """RMS, median and 95th percentile of one error at the last epoch over the runs, and the same
    over the runs the divergence monitor did not flag, so that one locked-out run cannot hide
    behind the RMS (nor the RMS behind the median).

    Non-finite values (a run whose error is NaN) are left out of every statistic.

    Parameters
    ----------
    values : numpy.ndarray
        One error per run, shape (R,), in the series' unit ([m], [m/s], [deg]).
    flagged : numpy.ndarray
        Whether the monitor flagged each run, shape (R,), bool.

    Returns
    -------
    dict[str, float | int]
        ``rms``, ``median``, ``p95`` and ``rms_unflagged``, ``median_unflagged``,
        ``p95_unflagged`` in the series' unit (NaN where no run counts), ``runs`` and
        ``runs_unflagged``: how many runs each set holds.

    Raises
    ------
    ValueError
        ``values`` and ``flagged`` do not hold one entry per run each.
    """
    values = np.asarray(values, dtype=float)
    flagged = np.asarray(flagged, dtype=bool)
    if values.shape != flagged.shape:
        raise ValueError(f"values {values.shape} and flagged {flagged.shape} must have one entry per run")
    out: dict[str, float | int] = {}
    for suffix, keep in (("", np.ones_like(flagged)), ("_unflagged", ~flagged)):
        x = values[keep & np.isfinite(values)]
        out[f"rms{suffix}"] = float(np.sqrt(np.mean(x**2))) if x.size else float("nan")
        out[f"median{suffix}"] = float(np.median(x)) if x.size else float("nan")
        out[f"p95{suffix}"] = float(np.percentile(x, 95.0)) if x.size else float("nan")
        out[f"runs{suffix}"] = int(x.size)
    return out
