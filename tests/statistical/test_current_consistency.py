"""The current states (tauvcore.aiding.dvl_water) know their error: over 30 seeded runs of the
lawnmower, each in its own constant current drawn from the filter's prior, the run-averaged NEES
of the current block lies in its two-sided 99 % band, for every method that fuses the DVL's
water-track beams: the 20-state ones and Yoo 2014's 12-state ones (tauvcore.engine.yoo_velocity).

The truth's current is constant, so the filter models it as a random walk with a small walk (a
Gauss-Markov model adds process noise the constant current does not have, and is cautious by it:
docs/currents.md)."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.eval.metrics import average_nees_bounds

NUM_RUNS = 30
SIGMA_MPS = 0.3
METHODS = ("lc", "tc", "nsv", "iekf", "ins-dvl", "vkf")


@pytest.mark.slow
@pytest.mark.parametrize("water_track, inside_min", [("always", 0.9), ("both", 0.7)])
def test_the_current_s_nees_is_in_its_99_percent_band_over_30_runs(water_track: str, inside_min: float) -> None:
    """Water-track on every beam (measured: 1.0 of the epochs inside the band), or beside
    bottom-track (``both``, the DVL's range 35 m so that the lawnmower's deeper legs lose bottom
    lock: 0.82 and 0.76 of the epochs for LC and TC, 0.80 and 0.93 for INS-DVL and VKF, dipping
    below the band in the middle of the run, cautious, while bottom-track and water-track
    together pin the current)."""
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate

    nees: dict[str, list[np.ndarray]] = {m: [] for m in METHODS}
    for seed in np.random.SeedSequence(2030).spawn(NUM_RUNS):
        rng = np.random.default_rng(seed)
        current = rng.normal(0.0, SIGMA_MPS, 2)
        config = (Config().replace("trajectory", name="lawnmower", duration_s=300.0,
                                   current_n_mps=(current[0], current[1], 0.0))
                  .replace("dvl", water_track=water_track, current_states="random-walk",
                           current_sigma_mps=SIGMA_MPS, current_walk_mps_per_sqrt_s=1e-4, max_altitude_m=35.0)
                  .replace("initial_error", mode="random").replace("earth", model="flat")
                  .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag")))
        for method, r in run(config, simulate(config, rng), rng).items():
            assert r.block_dims is not None and r.updates["water"].fused.any()
            block = [b for b in r.block_dims if b != "full"].index("current")
            nees[method].append(r.nees_block[:, 0, block])
    lo, hi = average_nees_bounds(2, NUM_RUNS)
    for method, runs in nees.items():
        avg = np.mean(runs, axis=0)  # over the runs, at every output epoch
        assert lo <= avg.mean() <= hi, (method, lo, hi, avg.mean())
        inside = ((avg >= lo) & (avg <= hi)).mean()
        assert inside >= inside_min, (method, inside)
