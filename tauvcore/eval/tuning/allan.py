"""The IMU's white noise from a still stretch of a log: its Allan deviation (allantools).

On a still IMU the measured rate and specific force are constant (the earth's rate and gravity
in the body frame, plus the biases) and what varies is the sensor's own noise. For white noise of
density ``N`` (angle random walk [rad/sqrt(s)], velocity random walk [m/s/sqrt(s)]) the overlapping
Allan deviation of the rate samples is ``sigma(tau) = N / sqrt(tau)`` (IEEE Std 952-1997, annex C),
so ``N = sigma(tau) sqrt(tau)`` on the part of the curve of slope -1/2. A bias instability or a bias
random walk lifts the curve at long averaging times only, a quantisation noise at the shortest:
:func:`white_noise_density` reads ``N`` between ten samples and a tenth of the stretch, each octave's
``sigma^2 tau`` weighted by the inverse of its variance (``1 / tau``: a value at ``tau`` rests on
``T / tau`` independent averages), so the short averaging times, the best measured, count most.

:func:`still_stretches` finds where a log's IMU is still: one-second means of each of the six
axes that stay within the noise of a one-second mean (estimated from the data's own
sample-to-sample differences) of the stretch's first second, for at least
:data:`MIN_STILL_S`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tauvcore import units

MIN_STILL_S = 60.0
"""Shortest still stretch whose Allan deviation gives a starting noise [s]: ten averages of 6 s,
the longest averaging time :func:`white_noise_density` reads on it."""

BLOCK_S = 1.0
"""Length of the blocks whose means :func:`still_stretches` compares [s]."""

STILL_SIGMAS = 6.0
"""How far a block's mean may lie from the stretch's first block's, in standard deviations of the
difference of two block means, before the stretch ends: a still IMU's six axes over a minute
(360 comparisons) break a stretch by chance with probability about 1e-6."""

STILL_FLOOR_RPS = 1e-3
"""Smallest tolerance on a gyro block's mean [rad/s] (0.06 deg/s): a vehicle resting on deck or on
the seabed moves less; a quiet IMU's noise alone would make the tolerance too tight to hold
against its bias drift over minutes."""

STILL_FLOOR_MPS2 = 1e-2
"""Smallest tolerance on an accelerometer block's mean [m/s^2] (1 mg), for the same reason."""


@dataclass(frozen=True)
class StillStretch:
    """A stretch of a log where the IMU is still, and the white noise its Allan deviation gives."""

    start_s: float  # the stretch's first sample, from the log's first [s]
    end_s: float  # one past its last sample [s]
    gyro_noise_rad_per_sqrt_s: np.ndarray  # (3,) per gyro axis, angle random walk [rad/sqrt(s)]
    accel_noise_mps_per_sqrt_s: np.ndarray  # (3,) per accelerometer axis, velocity random walk [m/s/sqrt(s)]

    samples: int = 0  # the stretch's IMU samples

    @property
    def duration_s(self) -> float:
        """The stretch's length [s]."""
        return self.end_s - self.start_s

    @property
    def gyro_noise_deg_per_sqrt_h(self) -> float:
        """The mean over the axes of the angle random walk [deg/sqrt(h)] (``imu.gyro_noise_deg_per_sqrt_h``)."""
        return float(np.mean(self.gyro_noise_rad_per_sqrt_s)) / units.DEG_PER_SQRT_HOUR

    @property
    def accel_noise_mps_per_sqrt_h(self) -> float:
        """The mean over the axes of the velocity random walk [m/s/sqrt(h)] (``imu.accel_noise_mps_per_sqrt_h``)."""
        return float(np.mean(self.accel_noise_mps_per_sqrt_s)) / units.MPS_PER_SQRT_HOUR

    @property
    def gyro_sigma_ln(self) -> float:
        """1-sigma of ``ln`` :attr:`gyro_noise_deg_per_sqrt_h` [-] (:func:`sigma_ln`)."""
        return sigma_ln(self.gyro_noise_rad_per_sqrt_s, self.samples)

    @property
    def accel_sigma_ln(self) -> float:
        """1-sigma of ``ln`` :attr:`accel_noise_mps_per_sqrt_h` [-] (:func:`sigma_ln`)."""
        return sigma_ln(self.accel_noise_mps_per_sqrt_s, self.samples)


def sigma_ln(per_axis: np.ndarray, samples: int) -> float:
    """How well one number stands for a triad's white noise read off a still stretch, as a 1-sigma
    of its logarithm: the larger of the Allan deviation's own statistical error at its shortest
    averaging time read (ten samples: ``1 / sqrt(2 (K / 10 - 1))`` for K samples, IEEE Std 952
    annex C) and the spread of the three axes' values (``std ln N_i``), which one figure for the
    three cannot follow.

    Parameters
    ----------
    per_axis : numpy.ndarray
        Shape (3,): each axis's white noise density (any one unit).
    samples : int
        The stretch's samples K.

    Returns
    -------
    float
        The 1-sigma of ``ln`` of the axes' mean [-].
    """
    statistical = 1.0 / math.sqrt(2.0 * max(samples / 10.0 - 1.0, 1.0))
    return float(max(statistical, np.std(np.log(per_axis))))


def white_noise_density(rate: np.ndarray, dt_s: float) -> float:
    """White noise density of a still sensor's samples, from their overlapping Allan deviation.

    ``N^2 = sum_tau w sigma(tau)^2 tau / sum_tau w`` with ``w = 1 / tau`` (the inverse of each
    value's variance), over the octave averaging times from ten samples to a tenth of the series
    (module docstring); allantools' ``oadev``.

    Parameters
    ----------
    rate : numpy.ndarray
        Shape (K,): one axis's rate samples (angular rate [rad/s] or specific force [m/s^2]), each
        the mean over its sample interval (increment / dt).
    dt_s : float
        Sample interval [s].

    Returns
    -------
    float
        ``N`` in the rate's unit times sqrt(s) (rad/sqrt(s), m/s/sqrt(s)): the increment over ``dt``
        has the standard deviation ``N sqrt(dt)``.

    Raises
    ------
    ValueError
        Fewer than 100 samples: no averaging time of ten samples has ten averages.
    """
    import allantools

    rate = np.asarray(rate, dtype=float)
    if rate.size < 100:
        raise ValueError(f"the Allan deviation needs at least 100 samples, got {rate.size}")
    taus, adev, _, _ = allantools.oadev(rate, rate=1.0 / dt_s, data_type="freq", taus="octave")
    taus, adev = np.asarray(taus), np.asarray(adev)
    use = (taus >= 10.0 * dt_s * (1.0 - 1e-9)) & (taus <= 0.1 * rate.size * dt_s * (1.0 + 1e-9))
    weight = 1.0 / taus[use]
    return float(np.sqrt(np.sum(weight * adev[use] ** 2 * taus[use]) / np.sum(weight)))


def still_stretches(
    dtheta_b: np.ndarray, dv_b: np.ndarray, dt_s: float, min_s: float = MIN_STILL_S
) -> list[tuple[int, int]]:
    """Where the IMU is still: the stretches of at least ``min_s`` over which every axis's
    :data:`BLOCK_S` means stay within tolerance of the stretch's first block's.

    The tolerance of an axis is :data:`STILL_SIGMAS` standard deviations of the difference of two
    block means, the sample noise estimated from the data (the median over the blocks of the
    standard deviation of consecutive samples' differences, over sqrt 2: slow motion cancels in
    a difference), and no less than :data:`STILL_FLOOR_RPS` or :data:`STILL_FLOOR_MPS2`.

    Parameters
    ----------
    dtheta_b : numpy.ndarray
        Shape (K, 3): the IMU's angle increments [rad], body frame b.
    dv_b : numpy.ndarray
        Shape (K, 3): its velocity increments [m/s], body frame b.
    dt_s : float
        Sample interval [s].
    min_s : float
        Shortest stretch kept [s].

    Returns
    -------
    list[tuple[int, int]]
        Each still stretch's first sample and one past its last (whole blocks), in order, not
        overlapping.
    """
    n = max(2, round(BLOCK_S / dt_s))
    blocks = dtheta_b.shape[0] // n
    if blocks == 0:
        return []
    rates = np.concatenate([dtheta_b, dv_b], axis=1)[: blocks * n] / dt_s  # (blocks n, 6)
    shaped = rates.reshape(blocks, n, 6)
    means = shaped.mean(axis=1)
    sample_sigma = np.median(np.std(np.diff(shaped, axis=1), axis=1), axis=0) / np.sqrt(2.0)
    floor = np.array([STILL_FLOOR_RPS] * 3 + [STILL_FLOOR_MPS2] * 3)
    tol = np.maximum(STILL_SIGMAS * np.sqrt(2.0 / n) * sample_sigma, floor)
    min_blocks = int(np.ceil(min_s / (n * dt_s) - 1e-9))
    out = []
    i = 0
    while i < blocks:
        j = i + 1
        while j < blocks and np.all(np.abs(means[j] - means[i]) <= tol):
            j += 1
        if j - i >= min_blocks:
            out.append((i * n, j * n))
            i = j
        else:
            i += 1
    return out


def still_noise(dtheta_b: np.ndarray, dv_b: np.ndarray, dt_s: float) -> StillStretch | None:
    """The longest still stretch of an IMU record (:func:`still_stretches`) and the white noise of
    each of its axes (:func:`white_noise_density`); None if it has none.

    Parameters
    ----------
    dtheta_b : numpy.ndarray
        Shape (K, 3): angle increments [rad], body frame b; row k over (t_k-1, t_k].
    dv_b : numpy.ndarray
        Shape (K, 3): velocity increments [m/s], body frame b.
    dt_s : float
        Sample interval [s].

    Returns
    -------
    StillStretch or None
        The stretch (times from the record's first sample [s]) with the angle and velocity random
        walks of each axis; None without a stretch of :data:`MIN_STILL_S`.
    """
    stretches = still_stretches(dtheta_b, dv_b, dt_s)
    if not stretches:
        return None
    k0, k1 = max(stretches, key=lambda s: s[1] - s[0])
    k0 = max(k0, 1)  # row 0 of a log is no interval (a simulated log's is zero)
    gyro = np.array([white_noise_density(dtheta_b[k0:k1, i] / dt_s, dt_s) for i in range(3)])
    accel = np.array([white_noise_density(dv_b[k0:k1, i] / dt_s, dt_s) for i in range(3)])
    return StillStretch(k0 * dt_s, k1 * dt_s, gyro, accel, k1 - k0)
