"""Results of a Monte Carlo split into batches of runs, joined into one: every array of a
:class:`~tauvcore.engine.results.MethodResult` laid end to end along its runs axis.

A run's numbers depend only on its own generator (tauvcore.eval.study.run_rng), so the batches
``[0, k)`` and ``[k, R)`` computed apart (two worker processes of the dashboard) and joined are
the batch ``[0, R)`` computed at once, to the last bit (tests/unit/tauvcore/engine/test_run_joining.py).
Batches stopped early reach different epochs; :func:`until` cuts each to the epochs all reached
before they are joined.

Plain arrays (numpy only), as tauvcore.engine.results.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from tauvcore.engine.results import MethodResult, UpdateRecord

RUN_FIELDS = ("diverged", "diverged_at_s", "p_floor_count", "smoother_cuts")
"""MethodResult's arrays of one value per run (R,); every other array but ``t_s`` is time first
(T, R, ...)."""
SAME_FIELDS = ("method", "t_s", "block_dims", "state_labels")
"""What every batch of a method must carry alike."""


def joined_runs(parts: Sequence[Mapping[str, MethodResult]]) -> dict[str, MethodResult]:
    """The results of the batches ``parts`` (each method name -> its results over that batch's
    runs, in run order) as one batch: runs of ``parts[0]`` first.

    Parameters
    ----------
    parts : Sequence[Mapping[str, MethodResult]]
        At least one batch; each with the same methods, in the same order, over the same output
        epochs (:func:`until` cuts batches that stopped at different epochs).

    Returns
    -------
    dict[str, MethodResult]
        Method name -> its results over every run of every batch.

    Raises
    ------
    ValueError
        No batch, batches of different methods, or a method whose batches differ in anything
        but their runs (its output epochs, its update times, its NEES dimensions...).
    """
    if not parts:
        raise ValueError("no batch of runs to join")
    methods = list(parts[0])
    for part in parts[1:]:
        if list(part) != methods:
            raise ValueError(f"batches of different methods: {methods} and {list(part)}")
    return {m: _joined([part[m] for part in parts]) for m in methods}


def _joined(results: list[MethodResult]) -> MethodResult:
    first = results[0]
    out: dict[str, Any] = {}
    for f in dataclasses.fields(MethodResult):
        values = [getattr(r, f.name) for r in results]
        name = f.name
        if name in SAME_FIELDS:
            _check_same(first.method, name, values)
            out[name] = values[0]
        elif name == "updates":
            keys = list(values[0])
            if any(list(v) != keys for v in values):
                raise ValueError(f"{first.method}: batches of different sources: {[list(v) for v in values]}")
            out[name] = {k: _joined_record(first.method, k, [v[k] for v in values]) for k in keys}
        elif name == "vkf_trace":
            out[name] = _joined_trace(first.method, values)
        elif name == "smoothed":
            out[name] = _joined_optional(first.method, name, values, _joined)
        else:
            axis = 0 if name in RUN_FIELDS else 1
            out[name] = _joined_optional(
                first.method, name, values, lambda v, a=axis: np.concatenate(v, axis=a)
            )
    return MethodResult(**out)


def _joined_optional(method: str, name: str, values: list[Any], join: Any) -> Any:
    present = [v is not None for v in values]
    if not any(present):
        return None
    if not all(present):
        raise ValueError(f"{method}: {name} is recorded in some batches only")
    return join(values)


def _check_same(method: str, name: str, values: list[Any]) -> None:
    a = values[0]
    for b in values[1:]:
        same = (
            a.shape == b.shape and np.array_equal(a, b)
            if isinstance(a, np.ndarray) and isinstance(b, np.ndarray)
            else a == b
        )
        if not same:
            raise ValueError(f"{method}: the batches' {name} differ")


def _joined_record(method: str, source: str, records: list[UpdateRecord]) -> UpdateRecord:
    _check_same(method, f"{source} update times", [r.t_s for r in records])
    out: dict[str, Any] = {"t_s": records[0].t_s}
    for f in dataclasses.fields(UpdateRecord):
        if f.name != "t_s":
            values = [getattr(r, f.name) for r in records]
            out[f.name] = _joined_optional(
                method, f"{source}'s {f.name}", values, lambda v: np.concatenate(v, axis=1)
            )
    return UpdateRecord(**out)


def _joined_trace(method: str, traces: list[dict[str, np.ndarray] | None]) -> dict[str, np.ndarray] | None:
    def join(values: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
        _check_same(method, "velocity Kalman filter's ping times", [v["t_s"] for v in values])
        return {
            k: values[0][k] if k == "t_s" else np.concatenate([v[k] for v in values], axis=1)
            for k in values[0]
        }

    return _joined_optional(method, "vkf_trace", traces, join)


def until(results: Mapping[str, MethodResult], num_epochs: int) -> dict[str, MethodResult]:
    """``results`` over their first ``num_epochs`` output epochs only: every series cut there, every
    update record (and the velocity Kalman filter's trace) cut after the last of those epochs, a
    divergence flagged later forgotten.

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results.
    num_epochs : int
        Output epochs to keep (at most each method's own).

    Returns
    -------
    dict[str, MethodResult]
        Method name -> its results cut; a method with no more epochs than that as it is.
    """
    return {m: _until(r, num_epochs) for m, r in results.items()}


def _until(r: MethodResult, num_epochs: int) -> MethodResult:
    if len(r.t_s) <= num_epochs:
        return r
    t_end_s = float(r.t_s[num_epochs - 1]) if num_epochs else -np.inf
    out: dict[str, Any] = {}
    for f in dataclasses.fields(MethodResult):
        value = getattr(r, f.name)
        if f.name == "updates":
            out[f.name] = {k: rec.until(t_end_s) for k, rec in value.items()}
        elif f.name == "vkf_trace":
            out[f.name] = None if value is None else _trace_until(value, t_end_s)
        elif f.name == "smoothed":
            out[f.name] = None if value is None else _until(value, num_epochs)
        elif f.name == "diverged_at_s":
            out[f.name] = np.where(value <= t_end_s, value, np.nan)
        elif f.name == "diverged":
            out[f.name] = r.diverged_at_s <= t_end_s
        elif isinstance(value, np.ndarray) and f.name not in RUN_FIELDS:
            out[f.name] = value[:num_epochs]
        else:
            out[f.name] = value
    return MethodResult(**out)


def _trace_until(trace: dict[str, np.ndarray], t_end_s: float) -> dict[str, np.ndarray]:
    count = int(np.searchsorted(trace["t_s"], t_end_s, side="right"))
    return {k: v[:count] for k, v in trace.items()}
