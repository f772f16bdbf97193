"""Sensor epochs on the IMU clock: every aiding sensor samples at an IMU sample time."""

from __future__ import annotations

import numpy as np

from tauvcore.truth.record import Truth


def epoch_indices(truth: Truth, rate_hz: float) -> np.ndarray:
    """IMU sample indices of the epochs ``t = m / rate_hz``, m = 1, 2, ... within the run.

    Each epoch is the IMU sample nearest to its nominal time (exact when the IMU rate is a
    multiple of the sensor rate, as with the defaults).
    """
    period = 1.0 / rate_hz
    t_end = truth.t_s[-1]
    times = np.arange(1, int(np.floor(t_end / period + 1e-9)) + 1) * period
    return np.unique(np.clip(np.rint(times / truth.dt_s).astype(int), 0, truth.num_samples - 1))


def batch_shape(num_runs: int | None) -> tuple[int, ...]:
    """Run axis to insert after time: () for a single run, (R,) for R runs."""
    return () if num_runs is None else (int(num_runs),)


def random_walk(rng: np.random.Generator, initial: np.ndarray, density: float, dt_s: float,
                num_steps: int) -> np.ndarray:
    """``num_steps`` samples of a random walk starting at ``initial`` (shape S), step std ``density*sqrt(dt)``.

    Returns (num_steps, *S); sample 0 equals ``initial``.
    """
    if num_steps == 0:
        return np.zeros((0,) + initial.shape)
    steps = rng.standard_normal((num_steps - 1,) + initial.shape) * (density * np.sqrt(dt_s))
    return initial + np.concatenate([np.zeros((1,) + initial.shape), np.cumsum(steps, axis=0)])
