"""What a run's summary needs, reduced chunk by chunk: memory flat in the mission's length.

The streaming engine hands its results out chunk by chunk (tauvcore.engine.mission.run_streaming
with ``keep=False`` and ``on_chunk``); :class:`RunningSummary` keeps of them only the sums the
summary is made of, per method:

- of run 0 (the run ``tauv run`` prints): the last epoch's errors and velocity 1-sigma, and the
  sums of squares and counts of the velocity, attitude, tilt, heading and position errors (their
  RMS over the mission), the times of its velocity resets (tauvcore.engine.lockout), the
  monitor's verdict;
- of every run, the same sums of squares over all runs (the RMS over runs and epochs the
  dashboard's Results tab shows), the number of velocity resets, and per aiding source the updates
  fused, rejected and unused and the DVL pings coasted on (tauvcore.eval.counts);
- of every run, the consistency (tauvcore.eval.consistency.method_consistency): per NEES block
  the sum and count of the finite NEES and the epochs whose run-average lies in the 99 % band, per
  aiding source the sums of NIS and dof over the updates that measured and how many lay in their
  band.

:meth:`RunningSummary.summaries` gives the same numbers as :func:`summarise` of the whole
results (tests/unit/app/commands/test_json_stream.py: to 1e-9 for any chunking); the sums differ from numpy's
pairwise means only in the last bits.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore.engine.results import BLOCK_DIMS, MethodResult, UpdateRecord
from tauvcore.eval.consistency import (
    CONFIDENCE,
    MethodConsistency,
    NeesSummary,
    NisSummary,
    nees_band,
    nees_series,
)
from tauvcore.eval.counts import MethodCounts, method_counts
from tauvcore.filter.statistics import chi2_ppf

RMS_SERIES = ("vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "pos_err_m")
"""The error series whose RMS over the mission the summary gives (run 0)."""
FINAL_SERIES = ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps")
"""The series whose last value the summary gives (run 0)."""


@dataclass(frozen=True)
class MethodSummary:
    """One method's summary: run 0's errors and verdict, the counts of its updates and the
    consistency over every run."""

    method: str
    final: dict[str, float]  # FINAL_SERIES -> run 0's value at the last epoch, in the series' unit
    rms: dict[str, float]  # RMS_SERIES -> run 0's RMS over the epochs (NaN: no epoch), the series' unit
    rms_all_runs: dict[str, float]  # RMS_SERIES -> RMS over every run and epoch, the series' unit (with one
    # run, ``rms``; with R runs the RMS over time of the RMS-over-runs curve)
    counts: MethodCounts  # per aiding source its updates fused, rejected and unused, and the DVL pings
    # coasted on, over the runs (tauvcore.eval.counts)
    reset_times_s: tuple[float, ...]  # run 0's velocity resets after a DVL lock-out [s]
    dvl_resets: int  # velocity resets after a DVL lock-out over every run
    diverged: bool  # run 0 flagged by the divergence monitor
    diverged_at_s: float  # when [s], NaN if never
    consistency: MethodConsistency
    block_dims: dict[str, int] | None  # as MethodResult.block_dims


@dataclass
class _NeesSums:
    total: float = 0.0
    count: int = 0
    inside: int = 0  # epochs whose run-average NEES lies in the band
    epochs: int = 0
    any_finite: bool = False


@dataclass
class _NisSums:
    nis: float = 0.0
    dof: int = 0
    inside: int = 0
    count: int = 0


@dataclass
class _MethodSums:
    method: str
    block_dims: dict[str, int] | None
    runs: int
    sum_sq: dict[str, float] = field(default_factory=lambda: dict.fromkeys(RMS_SERIES, 0.0))
    sum_sq_all: dict[str, float] = field(default_factory=lambda: dict.fromkeys(RMS_SERIES, 0.0))
    epochs: int = 0
    final: dict[str, float] = field(default_factory=lambda: dict.fromkeys(FINAL_SERIES, float("nan")))
    nees: dict[str, _NeesSums] = field(default_factory=dict)
    nis: dict[str, _NisSums] = field(default_factory=dict)
    counts: MethodCounts = field(default_factory=MethodCounts)
    resets: list[float] = field(default_factory=list)
    resets_all: int = 0
    diverged: bool = False
    diverged_at_s: float = float("nan")


class RunningSummary:
    """The summary's sums over the chunks of a run (module docstring); feed :meth:`add` every
    chunk's results in order, then read :meth:`summaries`."""

    def __init__(self) -> None:
        self._sums: dict[str, _MethodSums] = {}

    def add(self, results: dict[str, MethodResult]) -> None:
        """Reduce one chunk's results (series (T_chunk, R), updates of the chunk, the monitor's
        verdict so far).

        Parameters
        ----------
        results : dict[str, MethodResult]
            Method name -> its results over the chunk's output epochs and updates.
        """
        for name, r in results.items():
            s = self._sums.get(name)
            if s is None:
                s = self._sums[name] = _MethodSums(name, r.block_dims, r.vel_err_mps.shape[1])
            if r.t_s.size:
                for n in RMS_SERIES:
                    squares = np.square(getattr(r, n))
                    s.sum_sq[n] += float(np.sum(squares[:, 0]))
                    s.sum_sq_all[n] += float(np.sum(squares))
                s.epochs += int(r.t_s.size)
                for n in FINAL_SERIES:
                    s.final[n] = float(getattr(r, n)[-1, 0])
            for block, dim in (r.block_dims or BLOCK_DIMS).items():
                _add_nees(s.nees.setdefault(block, _NeesSums()), nees_series(r, block), dim)
            for source, record in r.updates.items():
                _add_nis(s.nis.setdefault(source, _NisSums()), record)
            s.counts = s.counts + method_counts(r)
            dvl = r.updates.get("dvl")
            if dvl is not None and dvl.reset is not None:
                s.resets.extend(float(t) for t in dvl.t_s[dvl.reset[:, 0]])
                s.resets_all += int(np.sum(dvl.reset))
            s.diverged = bool(r.diverged[0])
            s.diverged_at_s = float(r.diverged_at_s[0])

    def summaries(self) -> dict[str, MethodSummary]:
        """Method name -> its summary, in the order the methods first came.

        Returns
        -------
        dict[str, MethodSummary]
            The numbers :func:`summarise` gives for the whole run.
        """
        out = {}
        for name, s in self._sums.items():
            with np.errstate(invalid="ignore", divide="ignore"):
                rms = {
                    n: float(np.sqrt(s.sum_sq[n] / s.epochs)) if s.epochs else float("nan")
                    for n in RMS_SERIES
                }
                rms_all = {
                    n: float(np.sqrt(s.sum_sq_all[n] / (s.epochs * s.runs))) if s.epochs else float("nan")
                    for n in RMS_SERIES
                }
            nees = {
                block: _nees_summary(sums, dim, s.runs, block)
                for block, dim in (s.block_dims or BLOCK_DIMS).items()
                if (sums := s.nees.get(block)) is not None
            }
            nis = {source: _nis_summary(sums, source) for source, sums in s.nis.items()}
            out[name] = MethodSummary(
                method=name,
                final=dict(s.final),
                rms=rms,
                rms_all_runs=rms_all,
                counts=s.counts,
                reset_times_s=tuple(s.resets),
                dvl_resets=s.resets_all,
                diverged=s.diverged,
                diverged_at_s=s.diverged_at_s,
                consistency=MethodConsistency(nees=nees, nis=nis),
                block_dims=s.block_dims,
            )
        return out


def summarise(results: dict[str, MethodResult]) -> dict[str, MethodSummary]:
    """The summary of a whole run's results (one chunk of :class:`RunningSummary`).

    Parameters
    ----------
    results : dict[str, MethodResult]
        Method name -> its results over the whole mission.

    Returns
    -------
    dict[str, MethodSummary]
        Method name -> its summary.
    """
    running = RunningSummary()
    running.add(results)
    return running.summaries()


def _add_nees(sums: _NeesSums, series: np.ndarray, dim: int) -> None:
    finite = np.isfinite(series)
    if not finite.any():
        sums.epochs += series.shape[0]
        return
    sums.any_finite = True
    sums.total += float(series[finite].sum())
    sums.count += int(finite.sum())
    band = nees_band(dim, series.shape[1])
    with np.errstate(invalid="ignore"):
        avg = series.mean(axis=1) / dim
        inside = finite.all(axis=1) & (avg >= band[0]) & (avg <= band[1])
    sums.inside += int(inside.sum())
    sums.epochs += series.shape[0]


def _nees_summary(sums: _NeesSums, dim: int, runs: int, block: str) -> NeesSummary:
    band = nees_band(dim, runs)
    if not sums.any_finite or sums.epochs == 0:
        return NeesSummary(block, dim, float("nan"), float("nan"), band)
    return NeesSummary(block, dim, sums.total / sums.count / dim, sums.inside / sums.epochs, band)


def _add_nis(sums: _NisSums, record: UpdateRecord) -> None:
    used = record.valid & (record.nis_dof > 0) & np.isfinite(record.nis)
    if not used.any():
        return
    nis, dof = record.nis[used], record.nis_dof[used]
    alpha = 1.0 - CONFIDENCE
    dofs, inverse = np.unique(dof, return_inverse=True)
    lo, hi = chi2_ppf(alpha / 2, dofs)[inverse], chi2_ppf(1 - alpha / 2, dofs)[inverse]
    sums.nis += float(nis.sum())
    sums.dof += int(dof.sum())
    sums.inside += int(np.sum((nis >= lo) & (nis <= hi)))
    sums.count += int(used.sum())


def _nis_summary(sums: _NisSums, source: str) -> NisSummary:
    if sums.count == 0:
        return NisSummary(source, float("nan"), float("nan"), 0)
    return NisSummary(source, sums.nis / sums.dof, sums.inside / sums.count, sums.count)
