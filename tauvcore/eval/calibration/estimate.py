"""What the calibration's fits share (tauvcore.eval.calibration): the estimate with its covariance's
parts, the error, and the residuals' statistics (robust sigma, correlation time, long-run covariance)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

OUTLIER_SIGMAS = 5.0
"""A residual beyond this many robust sigmas (1.4826 times the median absolute deviation, per log)
of the first fit is left out of the second (a lost lock, a fish, a reference's jump)."""


class CalibrationError(ValueError):
    """A log cannot be calibrated from (no reference, no DVL pings, too short); one line naming it."""


@dataclass(frozen=True)
class Estimate:
    """Estimated quantities with their covariance and its parts."""

    names: tuple[str, ...]  # what each is (DVL_NAMES, BORESIGHT_NAMES)
    units: tuple[str, ...]  # the unit of each: "deg" or "%"
    value: np.ndarray  # (n,) in those units
    cov: np.ndarray  # (n, n) total covariance, in those units squared
    parts: dict[str, np.ndarray]  # name -> (n, n): "noise" (the residuals', correlation included) and
    # each consider part ("beam biases", "boresight", "IMU biases"); they add up to cov

    @property
    def sigma(self) -> np.ndarray:
        """(n,) 1-sigma of each, in its unit."""
        return np.sqrt(np.diag(self.cov))

    def part_sigma(self, name: str) -> np.ndarray:
        """(n,) the 1-sigma the part ``name`` alone gives, in each quantity's unit."""
        return np.sqrt(np.diag(self.parts[name]))


def correlation_time(series: np.ndarray) -> float:
    """Integrated autocorrelation time of a series about its mean: ``1 + 2 sum_{k>=1} rho_k`` over
    the lags before the first non-positive ``rho_k`` (at most a quarter of its length); 1 for a
    series of fewer than 8 values or no variance. ``n`` correlated values weigh as ``n / tau``
    independent ones.

    Parameters
    ----------
    series : numpy.ndarray
        Shape (n,), in time order.

    Returns
    -------
    float
        ``tau`` >= 1 [samples].
    """
    x = np.asarray(series, dtype=float) - np.mean(series)
    n = x.size
    if n < 8:
        return 1.0
    spectrum = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), 2 * n)[: n // 4]
    if acf[0] <= 0.0:
        return 1.0
    rho = acf[1:] / acf[0]
    stop = np.flatnonzero(rho <= 0.0)
    kept = rho[: stop[0]] if stop.size else rho
    return float(1.0 + 2.0 * kept.sum())


def robust_sigma(r: np.ndarray) -> float:
    """1.4826 times the median absolute deviation: a standard deviation that outliers leave alone."""
    return float(1.4826 * np.median(np.abs(r - np.median(r)))) if r.size else 0.0


def newey_west(score: np.ndarray) -> np.ndarray:
    """The long-run covariance of a series of scores (n, k) in time order (Newey & West 1987):
    ``sum_t g_t g_t^T`` plus each lag l <= L's ``(1 - l / (L + 1)) (G_l + G_l^T)``,
    ``L = floor(4 (n / 100)^(2/9))`` (their rule of the thumb: 5 lags at n = 400)."""
    n = len(score)
    lags = int(np.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))) if n else 0
    out = score.T @ score
    for lag in range(1, min(lags, n - 1) + 1):
        G = score[lag:].T @ score[:-lag]
        out += (1.0 - lag / (lags + 1.0)) * (G + G.T)
    return out


def rms(e: np.ndarray, dof: float = 1.0) -> float:
    """Root mean square of every entry of ``e`` (0 for none), divided by ``dof`` under the root."""
    return float(np.sqrt(np.mean(np.square(e)) / dof)) if e.size else 0.0


def weight(sigma: float) -> float:
    return 1.0 / sigma**2 if sigma > 0.0 else 0.0
