"""The divergence monitor: whether a filter has lost its way, judged as a real filter could,
without truth, from its own innovations and its sensor-error estimates against its own prior
(the banks flag a run with it: tauvcore.engine.filter_bank)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tauvcore.filter.statistics import chi2_isf

NIS_WINDOW_UPDATES = 30
"""Window of the divergence monitor's innovation test: the last 30 updates of one source in which
the source produced a measurement (30 s of DVL pings at 1 Hz)."""

NIS_FALSE_ALARM = 1e-6
"""Probability that a consistent filter's windowed NIS exceeds the bound, per window. Far below the
usual 0.1 %: the window slides by one update, so a 10-hour run tests some 36,000 (overlapping)
windows, and a consistent run must practically never be flagged. The bound for 90 degrees of
freedom (30 three-axis DVL updates) is 1.87 times the expected sum; a diverged filter exceeds it
by orders of magnitude."""

NIS_CAP_FALSE_ALARM = 1e-3
"""What one update may add to a window of :func:`innovation_divergence_s`: at most the NIS its
degrees of freedom exceed with this probability (16.3 for 3, 10.8 for 1). A consistent filter's
NIS is capped once in a thousand updates, by little; an outlier's, by orders of magnitude."""

RESET_REPEAT_UPDATES = 100
"""A filter locked out again within 100 updates of its last reset (tauvcore.engine.lockout) is not
recovering (100 s of DVL pings at 1 Hz): the monitor flags it at the second reset."""

LOCKOUT_UPDATES = 10
"""Locked out: the last 10 measurements of a source all rejected by the gate (or unusable). A
consistent filter rejects a three-axis DVL update at a 3-sigma gate with probability 0.8 %, ten in
a row with probability 1e-21."""


def _explained_by_reset(fused: np.ndarray, reset: np.ndarray) -> np.ndarray:
    """Updates (in order) that a reset explains: each reset and the streak of updates that fused
    nothing ending in it."""
    out = reset.copy()
    for k in np.flatnonzero(reset)[::-1]:
        j = k - 1
        while j >= 0 and not fused[j] and not out[j]:
            out[j] = True
            j -= 1
    return out


def innovation_divergence_s(
    t_s: np.ndarray,
    nis: np.ndarray,
    nis_dof: np.ndarray,
    fused: np.ndarray,
    valid: np.ndarray,
    window: int = NIS_WINDOW_UPDATES,
    false_alarm: float = NIS_FALSE_ALARM,
    lockout: int = LOCKOUT_UPDATES,
    reset: np.ndarray | None = None,
) -> np.ndarray:
    """Time of the first innovation inconsistency of one aiding source per run, NaN if none. -> (R,).

    Without truth, a filter can only judge itself by its innovations. Over the updates in which
    the source produced a measurement (``valid`` and at least one active row), a run is flagged

    - *inconsistent* at the first update that completes a window of ``window`` updates whose summed
      normalised innovation squared (before the gate) exceeds the chi-square quantile
      ``1 - false_alarm`` for the window's summed degrees of freedom: for a consistent filter each
      NIS is chi-square with ``nis_dof`` degrees of freedom and independent of the others. Each
      update counts at most its own ``1 - NIS_CAP_FALSE_ALARM`` quantile (16.3 for 3 degrees of
      freedom): a sensor's outlier (a USBL's multipath fix, thousands of sigmas off) is the gate's
      to catch and cannot flag a window alone, while a filter that underrates its sensor's noise
      raises many NIS values and still does (a real DVL's heavier tails than the tuning's);
    - *locked out* at the ``lockout``-th consecutive update that fused nothing (every row rejected
      by the gate, or S unusable): the filter no longer accepts its sensor;
    - *locked out despite a reset*: at a reset (``reset``, tauvcore.engine.lockout) within
      :data:`RESET_REPEAT_UPDATES` updates of the one before.

    A reset explains the rejected updates that led to it: they and the reset are left out of
    both tests, and no window spans a reset (the test starts again after it).

    t_s (U,) update times [s]; nis (U, R); nis_dof (U, R) int; fused, valid, reset (U, R) bool.
    """
    _, R = nis.shape
    out = np.full(R, np.nan)
    for r in range(R):
        used = np.flatnonzero(valid[:, r] & (nis_dof[:, r] > 0))
        first = np.inf
        stretches = [used]
        if reset is not None and reset[used, r].any():
            at = np.flatnonzero(reset[used, r])
            again = np.flatnonzero(np.diff(at) <= RESET_REPEAT_UPDATES)
            if again.size:
                first = float(t_s[used[at[again[0] + 1]]])
            explained = _explained_by_reset(fused[used, r], reset[used, r])
            stretch = np.cumsum(reset[used, r])  # the reset starts the next stretch
            stretches = [used[(stretch == i) & ~explained] for i in range(at.size + 1)]
        for part in stretches:
            hit = _first_hit(nis[:, r], nis_dof[:, r], fused[:, r], part, window, false_alarm, lockout)
            if hit >= 0:
                first = min(first, float(t_s[hit]))
        if np.isfinite(first):
            out[r] = first
    return out


def _first_hit(
    nis: np.ndarray,
    nis_dof: np.ndarray,
    fused: np.ndarray,
    used: np.ndarray,
    window: int,
    false_alarm: float,
    lockout: int,
) -> int:
    """The first lock-out or windowed-NIS flag of one run over its updates ``used``: the index of
    the update that raises it, -1 if none; ``nis``, ``nis_dof``, ``fused`` (U,) the run's columns."""
    first = -1
    if used.size >= lockout:
        run = np.convolve((~fused[used]).astype(np.int64), np.ones(lockout, dtype=np.int64), "valid")
        hit = np.flatnonzero(run == lockout)
        if hit.size:
            first = int(used[hit[0] + lockout - 1])
    ok = used[np.isfinite(nis[used])]
    if ok.size >= window:
        each = nis_dof[ok]
        capped = np.minimum(nis[ok], _quantiles(NIS_CAP_FALSE_ALARM, int(each.max()))[each])
        s = np.concatenate(([0.0], np.cumsum(capped)))
        d = np.concatenate(([0], np.cumsum(each)))
        total, dof = s[window:] - s[:-window], d[window:] - d[:-window]
        hit = np.flatnonzero(total > _quantiles(false_alarm, int(dof.max()))[dof])
        if hit.size:
            at_window = int(ok[hit[0] + window - 1])
            first = at_window if first < 0 else min(first, at_window)
    return first


@lru_cache(maxsize=64)
def _quantile_table(p: float, size: int) -> np.ndarray:
    q = chi2_isf(p, np.arange(size))
    q.setflags(write=False)
    return q


def _quantiles(p: float, max_dof: int) -> np.ndarray:
    """``chi2_isf(p, k)`` for k = 0 .. at least ``max_dof`` (a cached, read-only table: the
    windows' degrees of freedom are small integers)."""
    return _quantile_table(p, 1 << (max_dof + 1).bit_length())


class InnovationTest:
    """:func:`innovation_divergence_s` over a record that only grows, each call reading the updates
    added since the last one (and the window before them), not the whole mission again: over a
    ten-hour mission checked every chunk, the whole test costs what its last call does.

    Without a reset a run's flag is its first lock-out or window over the updates so far, which no
    later update changes: a flagged run is done, and an unflagged one is scanned again from the
    last ``window - 1`` finite-NIS updates and ``lockout - 1`` used updates before the end (every
    window and lock-out ending later starts there). A reset explains the rejected updates before
    it and splits the record, so a run with a reset is tested whole at every call, as
    :func:`innovation_divergence_s` does (a filter that needed a reset is the rare run).

    Each call returns exactly what :func:`innovation_divergence_s` returns for the same columns.
    """

    def __init__(
        self,
        num_runs: int,
        window: int = NIS_WINDOW_UPDATES,
        false_alarm: float = NIS_FALSE_ALARM,
        lockout: int = LOCKOUT_UPDATES,
    ) -> None:
        self.window, self.false_alarm, self.lockout = window, false_alarm, lockout
        self.seen = 0  # updates read so far
        self.out = np.full(num_runs, np.nan)
        self.hit = np.full(num_runs, -1)  # the flagging update of a run without a reset, -1 none
        self.start = np.zeros(num_runs, dtype=np.int64)  # where the next scan of a run starts
        self.with_reset = np.zeros(num_runs, dtype=bool)

    def __call__(
        self,
        t_s: np.ndarray,
        nis: np.ndarray,
        nis_dof: np.ndarray,
        fused: np.ndarray,
        valid: np.ndarray,
        reset: np.ndarray | None = None,
    ) -> np.ndarray:
        """The first flag of each run over the record so far [s], NaN if none. -> (R,).

        Parameters
        ----------
        t_s : np.ndarray
            (U,) update times [s]: the previous call's, with the updates since appended.
        nis, nis_dof, fused, valid, reset : np.ndarray
            (U, R) the columns of :func:`innovation_divergence_s`, grown likewise.

        Returns
        -------
        np.ndarray
            (R,) the time of each run's first flag [s], NaN if none.
        """
        n = t_s.size
        if n == self.seen:
            return self.out.copy()
        if reset is not None:
            self.with_reset |= reset[self.seen : n].any(axis=0)
        self.seen = n
        for r in range(self.out.size):
            if self.with_reset[r]:
                assert reset is not None
                cols = (nis[:, r : r + 1], nis_dof[:, r : r + 1], fused[:, r : r + 1], valid[:, r : r + 1])
                self.out[r] = innovation_divergence_s(
                    t_s, *cols, self.window, self.false_alarm, self.lockout, reset[:, r : r + 1]
                )[0]
            elif self.hit[r] < 0:
                self._scan(r, t_s, nis[:, r], nis_dof[:, r], fused[:, r], valid[:, r])
        return self.out.copy()

    def _scan(
        self,
        r: int,
        t_s: np.ndarray,
        nis: np.ndarray,
        nis_dof: np.ndarray,
        fused: np.ndarray,
        valid: np.ndarray,
    ) -> None:
        """Run ``r`` (no reset, not flagged) scanned from its start to the end of the record."""
        start = int(self.start[r])
        used = start + np.flatnonzero(valid[start:] & (nis_dof[start:] > 0))
        hit = _first_hit(nis, nis_dof, fused, used, self.window, self.false_alarm, self.lockout)
        if hit >= 0:
            self.hit[r] = hit
            self.out[r] = t_s[hit]
            return
        ok = used[np.isfinite(nis[used])]
        self.start[r] = min(
            _back(ok, self.window - 1, start, t_s.size), _back(used, self.lockout - 1, start, t_s.size)
        )


def _back(indices: np.ndarray, count: int, start: int, end: int) -> int:
    """Where a scan must start to see the last ``count`` of ``indices`` (``start`` if there are
    fewer; ``end`` if none is needed)."""
    if count <= 0:
        return end
    return int(indices[-count]) if indices.size >= count else start


SENSOR_PRIOR_FALSE_ALARM = 1e-6
"""Probability, per output epoch, that a consistent filter's sensor-error estimates fail
:func:`implausible_sensor_errors` (shared over the components, Bonferroni)."""


@lru_cache(maxsize=16)
def sensor_prior_bound(num_states: int, false_alarm: float = SENSOR_PRIOR_FALSE_ALARM) -> float:
    """The chi-square (1 dof) quantile :func:`implausible_sensor_errors` holds each of
    ``num_states`` estimates to (Bonferroni)."""
    return float(chi2_isf(false_alarm / num_states, 1))


def implausible_sensor_errors(
    estimate: np.ndarray, prior_var: np.ndarray, false_alarm: float = SENSOR_PRIOR_FALSE_ALARM
) -> np.ndarray:
    """True where an estimated sensor error lies far outside the filter's own prior. -> (...).

    The sensor-error states (IMU biases, DVL beam biases and scale factor) have a prior: zero mean,
    variance ``prior_var = sigma_0^2 + q t`` (turn-on sigma and random walk, the tuning the filter
    was given). For a consistent filter the estimate's variance is the prior's minus P, so each
    ``x_hat_i^2 / prior_var_i`` is at most chi-square with one degree of freedom; a component above
    its ``1 - false_alarm / n`` quantile (5.3 sigma for the 11 states) says the filter explains its
    measurements with a sensor error its own model calls impossible, e.g. a DVL scale factor near
    -100 % that cancels a velocity estimate of kilometres per second. The innovations of such a
    filter can look perfect. estimate (..., n), prior_var (n,).
    """
    bound = sensor_prior_bound(estimate.shape[-1], false_alarm)
    with np.errstate(invalid="ignore"):
        return np.any(np.square(estimate) > bound * prior_var, axis=-1)
