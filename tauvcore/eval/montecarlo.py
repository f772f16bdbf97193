"""Seeded Monte Carlo: R runs as one array dimension of the filter bank."""

from __future__ import annotations

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import simulate
from tauvcore.eval.metrics import rms


def monte_carlo(config: Config, num_runs: int, rng: np.random.Generator) -> dict[str, MethodResult]:
    """Run every method over ``num_runs`` runs with initial errors drawn as 1-sigma (Table 2).

    The whole simulation is made first, every draw from ``rng`` in one stream (the sampling of the
    accuracy tables (docs/accuracy.md) and of the statistical tests, reproducible since they were
    measured); it holds the mission's truth and sensors whole, so for long missions or many runs
    use :func:`tauvcore.engine.mission.run_streaming` (what ``tauv mc`` does), whose per-source
    streams give other draws of the same distributions."""
    if num_runs < 1:
        raise ValueError(f"num_runs must be >= 1, got {num_runs!r}")
    config = config.replace("initial_error", mode="random")
    return run(config, simulate(config, rng, num_runs), rng)


def rms_over_runs(series: np.ndarray) -> np.ndarray:
    """RMS across runs of a (T, R) series, as the paper's Monte Carlo curves. -> (T,)."""
    return rms(series, axis=1)
