"""Sensor epochs on the IMU clock (every aiding sensor samples at an IMU sample time), and the
random walks of the sensor errors, both usable chunk by chunk (tauvcore.sensors.stream)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tauvcore.truth.truth_record import Truth


def epoch_indices(truth: Truth, rate_hz: float) -> np.ndarray:
    """IMU sample indices of the epochs ``t = m / rate_hz``, m = 1, 2, ... within the run.

    Each epoch is the IMU sample nearest to its nominal time (exact when the IMU rate is a
    multiple of the sensor rate, as with the defaults). ``truth`` is the whole mission.
    """
    k = truth.num_samples
    return epoch_indices_between(rate_hz, float(truth.t_s[-1]), truth.dt_s, k, 0, k)


def epoch_indices_between(
    rate_hz: float, t_end_s: float, dt_s: float, num_samples: int, k0: int, k1: int
) -> np.ndarray:
    """The indices :func:`epoch_indices` gives for a whole mission (last sample at ``t_end_s``,
    ``num_samples`` samples ``dt_s`` apart), restricted to the samples ``k0 <= k < k1``.

    Only the epochs near the chunk are computed (the index grows with m), so the cost is that of
    the chunk, not of the mission; for ``[0, num_samples)`` the arithmetic is that of the whole
    mission, element for element.
    """
    period = 1.0 / rate_hz
    last = int(np.floor(t_end_s / period + 1e-9))  # epochs m = 1 .. last
    first_m = max(1, int(np.floor((k0 - 1) * dt_s / period)) - 1)
    last_m = min(last, int(np.ceil((k1 + 1) * dt_s / period)) + 1)
    times = np.arange(first_m, last_m + 1) * period
    idx = np.unique(np.clip(np.rint(times / dt_s).astype(int), 0, num_samples - 1))
    return idx[(idx >= k0) & (idx < k1)]


Rng = np.random.Generator | Sequence[np.random.Generator]
"""Where a sensor's errors are drawn from: one generator for every run (each draw has the run
axis), or one generator per run (a study's runs, tauvcore.eval.study): run r's numbers are then
drawn from its own generator alone, exactly the numbers it would draw as a batch of one run, and
the runs' arithmetic is done together."""


def _per_run(
    rng: Sequence[np.random.Generator], shape: tuple[int, ...], run_axis: int
) -> tuple[list[np.random.Generator], tuple[int, ...]]:
    rngs = list(rng)
    if len(shape) <= run_axis or shape[run_axis] != len(rngs):
        raise ValueError(f"{len(rngs)} generators for a draw of shape {shape} (run axis {run_axis})")
    return rngs, shape[:run_axis] + shape[run_axis + 1 :]


def _draw(rng: Rng, shape: tuple[int, ...], run_axis: int, method: str) -> np.ndarray:
    """``rng.<method>(shape)``, or with one generator per run each run's slice along ``run_axis``
    from its own generator (in that slice's C order, as the generator would draw it alone)."""
    if isinstance(rng, np.random.Generator):
        return getattr(rng, method)(shape)
    rngs, each = _per_run(rng, shape, run_axis)
    out = np.empty((len(rngs),) + each)
    for r, g in enumerate(rngs):
        if each:
            getattr(g, method)(out=out[r])
        else:
            out[r] = getattr(g, method)()
    return np.moveaxis(out, 0, run_axis)


def standard_normal(rng: Rng, shape: tuple[int, ...], run_axis: int = 0) -> np.ndarray:
    """Standard normal draws of ``shape`` (:func:`_draw`)."""
    return _draw(rng, shape, run_axis, "standard_normal")


def uniform(rng: Rng, shape: tuple[int, ...], run_axis: int = 0) -> np.ndarray:
    """Uniform [0, 1) draws of ``shape`` (:func:`_draw`)."""
    return _draw(rng, shape, run_axis, "random")


def batch_shape(num_runs: int | None) -> tuple[int, ...]:
    """Run axis to insert after time: () for a single run, (R,) for R runs."""
    return () if num_runs is None else (int(num_runs),)


@dataclass(frozen=True)
class WalkState:
    """What a random walk generated chunk by chunk carries from one chunk to the next."""

    initial: np.ndarray | None = None  # (S) the walk's first sample (turn-on value); None until drawn
    travelled: np.ndarray | None = None  # (S) running sum of the steps drawn so far
    num_samples: int = 0  # samples of the walk emitted so far


def random_walk_chunk(
    rng: Rng,
    state: WalkState,
    shape: tuple[int, ...],
    initial_sigma: float,
    density: float,
    dt_s: float,
    num_samples: int,
) -> tuple[np.ndarray, WalkState]:
    """The next ``num_samples`` samples of a random walk ``x_0 ~ N(0, initial_sigma^2)``,
    ``x_j = x_j-1 + w_j``, ``w_j ~ N(0, density^2 dt_s)``. -> ((num_samples, *shape), new state).

    Draws from ``rng``, in this order: ``x_0`` (at the first call, even for zero samples), then one
    step per sample after the first. The sum of the steps is carried and extended in sequence
    (``np.cumsum`` adds left to right), so a walk cut into chunks of any sizes is the same walk,
    bit for bit, as one drawn whole, when ``rng`` serves this walk alone. Given one generator per
    run (:data:`Rng`), the run axis is the first of ``shape``.
    """
    if state.initial is None:
        initial = standard_normal(rng, shape) * initial_sigma
        travelled = np.zeros(shape)
    else:
        initial, travelled = state.initial, state.travelled
        assert travelled is not None  # set together with initial (the returned WalkState below)
    if num_samples == 0:
        return np.zeros((0,) + shape), WalkState(initial, travelled, state.num_samples)
    starts = state.num_samples == 0
    steps = standard_normal(rng, (num_samples - starts,) + shape, 1) * (density * np.sqrt(dt_s))
    if starts:
        offsets = np.concatenate([np.zeros((1,) + shape), np.cumsum(steps, axis=0)])
    else:
        offsets = np.cumsum(np.concatenate([travelled[None], steps]), axis=0)[1:]
    return initial + offsets, WalkState(initial, offsets[-1], state.num_samples + num_samples)
