"""Error metrics: RMS over runs, NEES and its chi-square consistency bounds, and the divergence
monitor (which needs no truth: it reads only the filter's own innovations)."""

from __future__ import annotations

from functools import lru_cache

import numpy as np


def chi2_ppf(q: float | np.ndarray, dof: float | np.ndarray) -> np.ndarray:
    """Quantile of the chi-square distribution, ``2 P^-1(dof / 2, q)`` (the regularised incomplete
    gamma function's inverse: what ``scipy.stats.chi2.ppf`` computes, without importing
    scipy.stats, which costs 0.3 s of every command's start). scipy.special itself is imported
    here, at the first call, not with this module: it costs 0.25 s, which ``tauv --help`` and
    ``tauv config`` need not pay."""
    from scipy import special

    return 2.0 * special.gammaincinv(np.asarray(dof, dtype=float) / 2.0, q)


def chi2_isf(p: float | np.ndarray, dof: float | np.ndarray) -> np.ndarray:
    """Upper quantile: ``chi2_ppf(1 - p, dof)`` without the round-off of ``1 - p`` for tiny p."""
    from scipy import special

    return 2.0 * special.gammainccinv(np.asarray(dof, dtype=float) / 2.0, p)


def rms(x: np.ndarray, axis: int | tuple[int, ...] = -1) -> np.ndarray:
    """Root mean square along ``axis``."""
    return np.sqrt(np.mean(np.square(x), axis=axis))


def _flat(dx: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """dx and P broadcast together, in the kernels' one-leading-axis layout, and their batch shape."""
    from tauvcore.filter import kernels

    n = dx.shape[-1]
    batch = np.broadcast_shapes(dx.shape[:-1], P.shape[:-2])
    return kernels.flat(dx, batch, (n,)), kernels.flat(P, batch, (n, n)), batch


def nees(dx: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``dx^T P^-1 dx``. dx (..., n), P (..., n, n) -> (...).

    By Cholesky (the kernel :func:`tauvcore.filter.kernels.quadratic_into` the filter bank's records
    use). NaN for an entry whose dx or P is not finite or whose P is not positive definite (a
    diverged filter's record, never an exception)."""
    from tauvcore.filter import kernels

    dx_f, P_f, batch = _flat(np.asarray(dx), np.asarray(P))
    return kernels.nees_batch(dx_f, P_f).reshape(batch)


def block_nees(dx: np.ndarray, P: np.ndarray, block_of_state: np.ndarray, num_blocks: int) -> np.ndarray:
    """NEES of every block of a partition of the state at once. -> (..., num_blocks).

    ``block_of_state`` (n,) gives each state's block (0 .. num_blocks - 1; every state in one).
    Block b's NEES is ``dx_b^T (P_bb)^-1 dx_b`` with P_bb the marginal covariance of the block,
    one Cholesky factorisation per block. NaN for a block whose error or marginal covariance is not
    finite or not positive definite (the other blocks keep their values)."""
    from tauvcore.filter import kernels

    dx_f, P_f, batch = _flat(np.asarray(dx), np.asarray(P))
    out = kernels.block_nees_batch(
        dx_f, P_f, np.ascontiguousarray(block_of_state, dtype=np.int64), int(num_blocks)
    )
    return out.reshape(batch + (num_blocks,))


def average_nees_bounds(dim: int, num_runs: int, confidence: float = 0.99) -> tuple[float, float]:
    """Two-sided bounds of the run-averaged NEES of a consistent filter.

    ``num_runs * mean(NEES)`` is chi-square with ``num_runs * dim`` degrees of freedom
    (Bar-Shalom, Li & Kirubarajan 2001, section 5.4.2).
    """
    dof = num_runs * dim
    alpha = 1.0 - confidence
    return (float(chi2_ppf(alpha / 2, dof) / num_runs), float(chi2_ppf(1 - alpha / 2, dof) / num_runs))


NIS_WINDOW_UPDATES = 30
"""Window of the divergence monitor's innovation test: the last 30 updates of one source in which
the source produced a measurement (30 s of DVL pings at 1 Hz)."""

NIS_FALSE_ALARM = 1e-6
"""Probability that a consistent filter's windowed NIS exceeds the bound, per window. Far below the
usual 0.1 %: the window slides by one update, so a 10-hour run tests some 36,000 (overlapping)
windows, and a consistent run must practically never be flagged. The bound for 90 degrees of
freedom (30 three-axis DVL updates) is 1.87 times the expected sum; a diverged filter exceeds it
by orders of magnitude."""

LOCKOUT_UPDATES = 10
"""Locked out: the last 10 measurements of a source all rejected by the gate (or unusable). A
consistent filter rejects a three-axis DVL update at a 3-sigma gate with probability 0.8 %, ten in
a row with probability 1e-21."""


def innovation_divergence_s(
    t_s: np.ndarray,
    nis: np.ndarray,
    nis_dof: np.ndarray,
    fused: np.ndarray,
    valid: np.ndarray,
    window: int = NIS_WINDOW_UPDATES,
    false_alarm: float = NIS_FALSE_ALARM,
    lockout: int = LOCKOUT_UPDATES,
) -> np.ndarray:
    """Time of the first innovation inconsistency of one aiding source per run, NaN if none. -> (R,).

    Without truth, a filter can only judge itself by its innovations. Over the updates in which
    the source produced a measurement (``valid`` and at least one active row), a run is flagged

    - *inconsistent* at the first update that completes a window of ``window`` updates whose summed
      normalised innovation squared (before the gate) exceeds the chi-square quantile
      ``1 - false_alarm`` for the window's summed degrees of freedom: for a consistent filter each
      NIS is chi-square with ``nis_dof`` degrees of freedom and independent of the others;
    - *locked out* at the ``lockout``-th consecutive update that fused nothing (every row rejected
      by the gate, or S unusable): the filter no longer accepts its sensor.

    t_s (U,) update times [s]; nis (U, R); nis_dof (U, R) int; fused, valid (U, R) bool.
    """
    _, R = nis.shape
    out = np.full(R, np.nan)
    for r in range(R):
        used = np.flatnonzero(valid[:, r] & (nis_dof[:, r] > 0))
        first = np.inf
        if used.size >= lockout:
            run = np.convolve((~fused[used, r]).astype(np.int64), np.ones(lockout, dtype=np.int64), "valid")
            hit = np.flatnonzero(run == lockout)
            if hit.size:
                first = min(first, float(t_s[used[hit[0] + lockout - 1]]))
        ok = used[np.isfinite(nis[used, r])]
        if ok.size >= window:
            s = np.concatenate(([0.0], np.cumsum(nis[ok, r])))
            d = np.concatenate(([0], np.cumsum(nis_dof[ok, r])))
            total, dof = s[window:] - s[:-window], d[window:] - d[:-window]
            dofs, inverse = np.unique(dof, return_inverse=True)
            bound = chi2_isf(false_alarm, dofs)[inverse]
            hit = np.flatnonzero(total > bound)
            if hit.size:
                first = min(first, float(t_s[ok[hit[0] + window - 1]]))
        if np.isfinite(first):
            out[r] = first
    return out


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
