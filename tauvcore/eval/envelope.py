"""A long run's results at screen resolution, reduced chunk by chunk: memory bounded by the number
of time bins, not by the mission's length.

The output epochs of a mission (T of them, known before it starts: the duration, the IMU rate and
``filter.output_rate_hz``) are cut into bins of ``k`` consecutive epochs, ``k =
ceil(T / max_bins)`` (:func:`epochs_per_bin`), so a mission has at most ``max_bins`` bins
(:data:`SCREEN_BINS` by default) of ``k * dt_out_s`` seconds each. A mission with ``k = 1`` is
not reduced at all. Per bin :class:`EnvelopeReducer` keeps

- every series of :class:`~tauvcore.engine.results.MethodResult` at the bin's last epoch (its
  representative: what hover and the time cursor read, and what the 3-D view, the components and
  the map's covariance ellipses draw); the mission's last epoch is always a bin's last, so final values are exact;
- the minimum and maximum over the bin's epochs (``DecimatedResult.low`` and ``high``) of every
  curve the dashboard plots: each error and 1-sigma series as the plots draw it (the single run's
  value, or with R runs the RMS over runs, :func:`run_curve`), each NEES block averaged over the
  runs (:func:`nees_curve`, undivided by the dimension), and per run the estimated sensor errors,
  their 1-sigma and their truth;
- of every aiding source's updates, per bin that has any, the last update (its representative,
  every field of :class:`~tauvcore.engine.results.UpdateRecord`), and per run and measurement row
  the minimum and maximum innovation and the largest 3-sigma ``3 sqrt(S_ii)`` over the updates
  that measured that row, and the last innovation the gate rejected (:class:`DecimatedUpdates`);
  whether any update of the bin was rejected or reset the velocity, and per beam whether any ping
  of the bin lost it (the events of tauvcore.eval.events survive the reduction);
- the VKF's trace (method ``vkf``) at the last ping of each bin.

Numbers that sum over the mission (RMS, NEES/dim, NIS/dof, the DVL's counts) are not taken from
the bins: the reducer feeds every chunk to :class:`~tauvcore.eval.running.RunningSummary` and
hands its summary out with the bins (``DecimatedResult.summary``), equal to the whole series'
to 1e-9 (tests/unit/app/dashboard/test_dashboard_decimation.py).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, TypeGuard

import numpy as np

from tauvcore.engine.results import (
    BLOCK_DIMS,
    SENSOR_FIELDS,
    SERIES_FIELDS,
    STATE_FIELDS,
    MethodResult,
    UpdateRecord,
)
from tauvcore.eval.consistency import nees_series
from tauvcore.eval.metrics import rms
from tauvcore.eval.running import MethodSummary, RunningSummary

SCREEN_BINS = 4000
"""Bins a mission's output epochs are reduced to at most: two per pixel of a plot 2,000 pixels
wide. The dashboard's default mission (250 s at 10 Hz, 2,501 epochs) fits and is not reduced; a
10 h mission at 10 Hz becomes 3,957 bins of 9.1 s."""
SERIES = tuple(SERIES_FIELDS.values())
"""Every (T, R) series of :class:`~tauvcore.engine.results.MethodResult` (errors, 1-sigma, NEES)."""
RUN_CURVES = tuple(name for name in SERIES if name != "nees")
"""The series whose run curve (:func:`run_curve`) the bins bound: every error and 1-sigma series
(the NEES's plotted curve is :func:`nees_curve`'s)."""
_BIN_TOLERANCE = 1e-9  # an update exactly on a bin's edge belongs to the later bin


def epochs_per_bin(num_epochs: int, max_bins: int = SCREEN_BINS) -> int:
    """Output epochs per bin ``k = ceil(T / max_bins)`` (1: the mission is not reduced).

    Parameters
    ----------
    num_epochs : int
        Output epochs T of the whole mission.
    max_bins : int
        The most bins the mission may have (at least 1).

    Returns
    -------
    int
        Epochs per bin, at least 1.
    """
    if max_bins < 1:
        raise ValueError(f"max_bins must be >= 1, got {max_bins}")
    return max(1, math.ceil(int(num_epochs) / int(max_bins)))


def run_curve(series: np.ndarray) -> np.ndarray:
    """The curve an error plot draws of a (T, R) series: the single run's value, or the RMS over
    the R runs (the paper's figures), shape (T,), in the series' unit."""
    series = np.asarray(series, dtype=float)
    return series[:, 0] if series.shape[1] == 1 else rms(series, axis=1)


def nees_curve(result: MethodResult, block: str) -> np.ndarray:
    """The NEES of ``block`` averaged over the runs, shape (T,) (NaN where a run's is not finite;
    the consistency plot divides it by the block's dimension)."""
    series = nees_series(result, block)
    with np.errstate(invalid="ignore", over="ignore"):
        curve = series.mean(axis=1)
    return np.where(np.isfinite(curve), curve, np.nan)


def curve_key(block: str) -> str:
    """The key of ``DecimatedResult.low`` / ``high`` holding :func:`nees_curve` of ``block``."""
    return f"nees_curve_{block}"


@dataclass(frozen=True)
class DecimatedUpdates(UpdateRecord):
    """One aiding source's updates reduced to bins: every field of
    :class:`~tauvcore.engine.results.UpdateRecord` at the last update of each bin that has any
    (U_b rows), and over each bin's updates, per run and measurement row (U_b, R, m):"""

    innovation_low: np.ndarray | None = None  # smallest innovation of the rows measured (NaN: none)
    innovation_high: np.ndarray | None = None  # largest innovation of the rows measured (NaN: none)
    sigma3_high: np.ndarray | None = None  # largest 3 sqrt(S_ii) of the rows measured (NaN: none)
    rejected_innovation: np.ndarray | None = None  # the last innovation the gate rejected (NaN: none)
    rejected_in_bin: np.ndarray | None = None  # (U_b, R) bool: any update of the bin was rejected
    reset_in_bin: np.ndarray | None = None  # (U_b, R) bool: any update of the bin reset the velocity
    # after a lock-out (None: the record has no resets)
    lost_in_bin: np.ndarray | None = None  # (U_b, R, 4) bool: the beam did not return at some ping of
    # the bin (None: the record has no beams)


@dataclass(frozen=True)
class DecimatedResult(MethodResult):
    """One method's results reduced to bins (module docstring): the series of
    :class:`~tauvcore.engine.results.MethodResult` at each bin's last epoch (t_s those epochs'
    times), the monitor's verdict of the whole run, and:"""

    bin_s: float = math.nan  # width of a bin: epochs_per_bin output intervals [s]
    epochs_per_bin: int = 1  # output epochs per bin
    low: dict[str, np.ndarray] = field(default_factory=dict)  # curve -> its minimum per bin:
    # RUN_CURVES (B,) in their unit; curve_key(block) (B,); SENSOR_FIELDS (B, R, S) in SI units
    high: dict[str, np.ndarray] = field(default_factory=dict)  # the same, maximum per bin
    summary: MethodSummary | None = None  # RMS, consistency, DVL counts of every epoch and update


def is_decimated(result: MethodResult) -> TypeGuard[DecimatedResult]:
    """Whether ``result`` is reduced to bins (a :class:`DecimatedResult` with more than one epoch
    per bin)."""
    return isinstance(result, DecimatedResult) and result.epochs_per_bin > 1


class _Bins:
    """Per bin, the last row, the minimum and the maximum of arrays handed in chunk by chunk with
    their bin indices (non-decreasing over the whole mission)."""

    def __init__(self, num_bins: int) -> None:
        self.num_bins = num_bins
        self.filled = np.zeros(num_bins, dtype=bool)
        self.last: dict[str, np.ndarray] = {}
        self.low: dict[str, np.ndarray] = {}
        self.high: dict[str, np.ndarray] = {}
        self.any: dict[str, np.ndarray] = {}

    def _store(self, store: dict[str, np.ndarray], name: str, like: np.ndarray, nan: bool) -> np.ndarray:
        """``store[name]``, made at the first chunk: (num_bins, ...) of ``like``'s trailing shape,
        NaN (``nan``) or zeros of ``like``'s type (rows not yet filled are never read)."""
        arr = store.get(name)
        if arr is None:
            shape = (self.num_bins, *like.shape[1:])
            arr = store[name] = np.full(shape, np.nan) if nan else np.zeros(shape, dtype=like.dtype)
        return arr

    def add(
        self,
        bins: np.ndarray,
        last: dict[str, np.ndarray],
        extremes: dict[str, np.ndarray],
        last_where: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
        anys: dict[str, np.ndarray] | None = None,
    ) -> None:
        """Fold in one chunk: ``bins`` (n,) the bin of each row; ``last`` arrays (n, ...) whose
        last row per bin is kept; ``extremes`` float arrays (n, ...) whose minimum and maximum
        per bin (NaN ignored) are kept; ``last_where`` name -> (values, mask) (n, ...): per bin
        and element the last value where the mask holds (NaN where it never did); ``anys`` bool
        arrays (n, ...): per bin and element whether any row held."""
        if bins.size == 0:
            return
        starts = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
        ends = np.r_[starts[1:], bins.size] - 1
        which = bins[starts]
        self.filled[which] = True
        for name, values in last.items():
            self._store(self.last, name, values, False)[which] = values[ends]
        for name, values in extremes.items():
            values = np.asarray(values, dtype=float)
            lo = self._store(self.low, name, values, True)
            hi = self._store(self.high, name, values, True)
            lo[which] = np.fmin(lo[which], np.fmin.reduceat(values, starts, axis=0))
            hi[which] = np.fmax(hi[which], np.fmax.reduceat(values, starts, axis=0))
        for name, (values, mask) in (last_where or {}).items():
            values = np.asarray(values, dtype=float)
            kept = self._store(self.last, name, values, True)
            index = np.where(mask, np.arange(bins.size).reshape((-1,) + (1,) * (values.ndim - 1)), -1)
            row = np.maximum.reduceat(index, starts, axis=0)
            found = row >= 0
            taken = np.take_along_axis(values, np.maximum(row, 0), axis=0)
            kept[which] = np.where(found, taken, kept[which])
        for name, flags in (anys or {}).items():
            flags = np.asarray(flags, dtype=bool)
            held = self._store(self.any, name, flags, False)
            held[which] |= np.logical_or.reduceat(flags, starts, axis=0)


def _last_fields(record: UpdateRecord) -> dict[str, np.ndarray]:
    return {
        f.name: getattr(record, f.name)
        for f in dataclasses.fields(UpdateRecord)
        if getattr(record, f.name) is not None
    }


class _MethodBins:
    """The bins of one method: its series by epoch, each source's updates by time."""

    def __init__(self, num_bins: int) -> None:
        self.series = _Bins(num_bins)
        self.updates: dict[str, _Bins] = {}
        self.vkf: _Bins | None = None
        self.latest: MethodResult | None = None  # the last chunk's (the monitor's verdict so far)


class EnvelopeReducer:
    """Reduces a mission's results, handed in chunk by chunk in order, to bins (module docstring).

    Parameters
    ----------
    num_epochs : int
        Output epochs T of the whole mission (the first at t = 0 s).
    dt_out_s : float
        Interval between two output epochs [s].
    epochs_per_bin : int
        Output epochs per bin k (:func:`epochs_per_bin`); the mission has ``ceil(T / k)`` bins.
    """

    def __init__(self, num_epochs: int, dt_out_s: float, epochs_per_bin: int) -> None:
        if epochs_per_bin < 1:
            raise ValueError(f"epochs_per_bin must be >= 1, got {epochs_per_bin}")
        self.num_epochs = int(num_epochs)
        self.k = int(epochs_per_bin)
        self.num_bins = max(1, math.ceil(self.num_epochs / self.k))
        self.bin_s = self.k * float(dt_out_s)
        self.running = RunningSummary()
        self._methods: dict[str, _MethodBins] = {}
        self._epochs_seen: dict[str, int] = {}

    def _update_bins(self, t_s: np.ndarray) -> np.ndarray:
        b = np.floor(np.asarray(t_s, dtype=float) / self.bin_s + _BIN_TOLERANCE).astype(np.int64)
        return np.clip(b, 0, self.num_bins - 1)

    def add(self, results: dict[str, MethodResult]) -> None:
        """Fold in one chunk's results (series (T_chunk, R), the chunk's updates, the monitor's
        verdict so far), method name -> :class:`~tauvcore.engine.results.MethodResult`."""
        self.running.add(results)
        for method, r in results.items():
            mb = self._methods.setdefault(method, _MethodBins(self.num_bins))
            mb.latest = r
            n = len(r.t_s)
            first = self._epochs_seen.get(method, 0)
            self._epochs_seen[method] = first + n
            if n:
                bins = np.minimum((first + np.arange(n)) // self.k, self.num_bins - 1)
                last = {"t_s": np.asarray(r.t_s), "nees_block": r.nees_block, "est_pos_n": r.est_pos_n}
                last.update({name: getattr(r, name) for name in SERIES})
                for name in ("est_vel_n", "est_euler_rad", "pos_cov_ne_m2", *SENSOR_FIELDS, *STATE_FIELDS):
                    if getattr(r, name) is not None:
                        last[name] = getattr(r, name)
                extremes = {name: run_curve(getattr(r, name)) for name in RUN_CURVES}
                extremes.update({curve_key(b): nees_curve(r, b) for b in (r.block_dims or BLOCK_DIMS)})
                extremes.update(
                    {name: getattr(r, name) for name in SENSOR_FIELDS if getattr(r, name) is not None}
                )
                mb.series.add(bins, last, extremes)
            for source, record in r.updates.items():
                if len(record.t_s) == 0:
                    continue
                ub = mb.updates.setdefault(source, _Bins(self.num_bins))
                var = np.asarray(record.innovation_var, dtype=float)
                measured = record.valid[..., None] & np.isfinite(var)
                with np.errstate(invalid="ignore"):
                    sigma3 = np.where(measured, 3.0 * np.sqrt(var), np.nan)
                nu = np.where(measured, record.innovation, np.nan)
                ub.add(
                    self._update_bins(record.t_s),
                    _last_fields(record),
                    {"innovation": nu, "sigma3": sigma3},
                    {"rejected_innovation": (record.innovation, record.rejected_rows & measured)},
                    _event_flags(record),
                )
            trace = r.vkf_trace
            if trace is not None and len(trace["t_s"]):
                if mb.vkf is None:
                    mb.vkf = _Bins(self.num_bins)
                mb.vkf.add(self._update_bins(trace["t_s"]), dict(trace), {})

    def results(self) -> dict[str, DecimatedResult]:
        """The bins so far, method name -> :class:`DecimatedResult`, in the order the methods came
        (the last bin may be partly filled while the run goes on)."""
        summaries = self.running.summaries()
        out: dict[str, DecimatedResult] = {}
        for method, mb in self._methods.items():
            r = mb.latest
            assert r is not None  # a method is known once a chunk of it came
            filled = int(np.count_nonzero(mb.series.filled))
            last: dict[str, np.ndarray] = {name: a[:filled] for name, a in mb.series.last.items()}
            if not last:  # no epoch yet: the chunk's own empty arrays
                last = {name: getattr(r, name) for name in ("t_s", "nees_block", "est_pos_n", *SERIES)}
            updates: dict[str, UpdateRecord] = {
                source: self._updates(ub) for source, ub in mb.updates.items()
            }
            vkf = None
            if mb.vkf is not None:
                rows = mb.vkf.filled
                vkf = {name: a[rows] for name, a in mb.vkf.last.items()}
            sensors: dict[str, Any] = {name: last.get(name) for name in (*SENSOR_FIELDS, *STATE_FIELDS)}
            if r.state_labels and sensors["state_est"] is not None:  # the sources' states, each bin's last
                sensors["state_labels"] = r.state_labels
            out[method] = DecimatedResult(
                method=method,
                t_s=last["t_s"],
                **{name: last[name] for name in SERIES},
                nees_block=last["nees_block"],
                est_pos_n=last["est_pos_n"],
                est_vel_n=last.get("est_vel_n"),
                est_euler_rad=last.get("est_euler_rad"),
                pos_cov_ne_m2=last.get("pos_cov_ne_m2"),
                **sensors,
                diverged=r.diverged,
                diverged_at_s=r.diverged_at_s,
                p_floor_count=r.p_floor_count,
                updates=updates,
                block_dims=r.block_dims,
                vkf_trace=vkf if vkf is not None else None,
                bin_s=self.bin_s,
                epochs_per_bin=self.k,
                low={name: a[:filled] for name, a in mb.series.low.items()},
                high={name: a[:filled] for name, a in mb.series.high.items()},
                summary=summaries.get(method),
            )
        return out

    @staticmethod
    def _updates(ub: _Bins) -> DecimatedUpdates:
        rows = ub.filled
        last = {name: a[rows] for name, a in ub.last.items() if name != "rejected_innovation"}
        return DecimatedUpdates(
            **last,
            innovation_low=ub.low["innovation"][rows],
            innovation_high=ub.high["innovation"][rows],
            sigma3_high=ub.high["sigma3"][rows],
            rejected_innovation=ub.last["rejected_innovation"][rows],
            **{name: a[rows] for name, a in ub.any.items()},
        )


def _event_flags(record: UpdateRecord) -> dict[str, np.ndarray]:
    """The flags :class:`DecimatedUpdates` keeps per bin of ``record``'s updates: rejected, reset
    (with resets), beams lost (with beams), by their field's name."""
    flags = {"rejected_in_bin": record.rejected}
    if record.reset is not None:
        flags["reset_in_bin"] = record.reset
    if record.beams_available is not None:
        flags["lost_in_bin"] = ~np.asarray(record.beams_available, dtype=bool)
    return flags


__all__ = [
    "RUN_CURVES",
    "SCREEN_BINS",
    "SERIES",
    "DecimatedResult",
    "DecimatedUpdates",
    "EnvelopeReducer",
    "curve_key",
    "epochs_per_bin",
    "is_decimated",
    "nees_curve",
    "run_curve",
]
