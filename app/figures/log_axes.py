"""The y-axis of the error plots: log or linear, and what a log axis leaves out.

``log_y="auto"`` (:func:`log_axis`) draws a log axis where the values span more than LOG_SPAN and no
curve starts at a zero: a replay's error is exactly 0 at its first epoch (the filter starts on the
reference) and a log axis would stretch down to the rounding of that zero (1e-16) and squash the
data. A log axis drops every value at or below a zero (:func:`drop_for_log`) and labels the powers
of ten only (:func:`error_axis`: no minor labels to collide with "10^-2").
"""

from __future__ import annotations

from typing import Any

import numpy as np

AUTO = "auto"
LOG_SPAN = 10.0
"""``log_y="auto"`` draws a log axis only when the drawn values span more than this factor: over a
narrower range (heading error 1.0-1.2 deg) a log axis has no ticks and flattens the curves."""
ZERO_FRACTION = 1e-9
"""A value at most this fraction of the largest drawn value is a zero and its rounding (a replay's
error at its first epoch): ``log_y="auto"`` keeps a linear axis for errors that start there, and a
log axis drops such values (with every value not above zero) rather than stretch down to 1e-16."""


def error_axis(log: bool) -> dict[str, Any]:
    """The y-axis of the errors' plots: logarithmic with ``log`` (labels at the powers of ten
    only, "10^-2", none between them to collide with those), else linear."""
    if log:
        return {"type": "log", "exponentformat": "power", "minorloglabels": "none", "nticks": 6}
    return {"type": "linear", "exponentformat": "power", "nticks": 6}


def _floor(curves: list[np.ndarray]) -> float:
    """ZERO_FRACTION of the largest finite value of ``curves``: at or below it a value is a zero."""
    values = np.concatenate([np.ravel(c) for c in curves]) if curves else np.empty(0)
    values = values[np.isfinite(values)]
    return ZERO_FRACTION * float(np.abs(values).max()) if values.size else 0.0


def _spans_decades(curves: list[np.ndarray]) -> bool:
    """True if the values of ``curves`` above zero (above :func:`_floor`) span more than LOG_SPAN."""
    values = np.concatenate([np.ravel(c) for c in curves]) if curves else np.empty(0)
    values = values[np.isfinite(values) & (values > max(_floor(curves), 0.0))]
    return values.size > 0 and float(values.max()) > LOG_SPAN * float(values.min())


def _starts_at_zero(curves: list[np.ndarray]) -> bool:
    """True if a curve of ``curves`` starts (its first finite value) at a zero (:func:`_floor`):
    a replay's error at its first epoch, where the filter starts on the reference."""
    floor = _floor(curves)
    for curve in curves:
        values = np.ravel(curve)
        first = values[np.isfinite(values)][:1]
        if first.size and abs(float(first[0])) <= floor:
            return True
    return False


def log_axis(curves: list[np.ndarray], log_y: bool | str) -> bool:
    """Whether the errors' plot of ``curves`` has a log y-axis: ``log_y`` True or False as asked;
    AUTO: where the values span more than LOG_SPAN and no curve starts at a zero (a log axis would
    stretch down to that zero's rounding, 1e-16, and squash the data).

    Parameters
    ----------
    curves : list[numpy.ndarray]
        The values drawn, one array per curve, time first.
    log_y : bool or str
        True, False or AUTO.

    Returns
    -------
    bool
        True for a log axis.
    """
    if log_y != AUTO:
        return bool(log_y)
    return _spans_decades(curves) and not _starts_at_zero(curves)


def drop_for_log(data: list[dict[str, Any]], curves: list[np.ndarray]) -> list[dict[str, Any]]:
    """The traces ``data`` with every y value at or below a zero (:func:`_floor` of ``curves``,
    and every value not above 0) made NaN, a gap: what a log axis cannot draw."""
    floor = max(_floor(curves), 0.0)
    out = []
    for trace in data:
        y = np.asarray(trace.get("y", []), dtype=float)
        out.append({**trace, "y": np.where(y > floor, y, np.nan)} if y.size else trace)
    return out
