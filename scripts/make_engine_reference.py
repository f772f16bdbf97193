"""Write the numpy engine's results as the seeded reference the compiled engine is tested against.

    python scripts/make_engine_reference.py tests/fixtures/engine_reference.npz

Generated with the numpy engine of commit 9235ddc (the last before the compiled filter bank,
the streaming engine), with two changes the product made since applied to it:

- the strapdown's second-order rotation term, one line added to its ``body_increments``:
  ``dv_rot = dv_rot + np.cross(dtheta_b, np.cross(dtheta_b, dv_b)) / 6.0``;
- the kinematic truth's heave that keeps the depth in turns: ``vel_b`` and ``vel_b_dot`` of its
  ``_turn_profile`` as they are today in tauvcore/truth/kinematic.py (``w = -tan(phi) v``).

To regenerate: ``git worktree add /tmp/ref 9235ddc``, apply those changes, copy there this
script as it was at commit 0a00641 (it imports ``tauvcore.eval.runner``, that engine's entry),
and run it with ``PYTHONPATH=/tmp/ref`` (the numpy engine, not the installed one).
``tests/unit/tauvcore/engine/test_engine_reference.py`` rebuilds the same simulations from the same
seeds and requires every series to match to 1e-9. Three trajectories, all eight methods, DVL,
depth and magnetometer aiding, random initial errors (two runs), and a DVL schedule that goes
through four, two (beams 3 and 4 lost) and three beams (beam 1 lost), so every fusion mode runs.
"""

from __future__ import annotations

import sys

import numpy as np

from tauvcore.config import METHODS, Config
from tauvcore.sensors.dvl import Outage

TRAJECTORIES = ("straight", "figure8", "lawnmower")
NUM_RUNS = 2
EVERY = 4  # keep every 4th output epoch (2.5 Hz): the fixture stays small, the check stays strict
SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "pos_sigma_m",
          "vel_sigma_mps", "att_sigma_deg", "tilt_sigma_deg", "heading_sigma_deg", "nees", "nees_block",
          "est_pos_n")
UPDATE_SERIES = ("nis", "fused")


def reference_config(trajectory: str) -> Config:
    """The configuration of one trajectory's reference (also used by the test)."""
    config = Config().replace("trajectory", name=trajectory, duration_s=120.0)
    config = config.replace("dvl", outages=(Outage(beams=(3, 4), start_s=30.0, end_s=90.0),
                                            Outage(beams=(1,), start_s=100.0, end_s=110.0)))
    config = config.replace("initial_error", mode="random")
    # the flat earth of the numpy engine of 9235ddc (the round earth is newer)
    config = config.replace("earth", model="flat")
    return config.replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"), seed=11)


def main() -> None:
    from tauvcore.engine.mission import run
    from tauvcore.engine.simulation import simulate
    out = {}
    for trajectory in TRAJECTORIES:
        config = reference_config(trajectory)
        rng = np.random.default_rng(config.run.seed)
        results = run(config, simulate(config, rng, NUM_RUNS), rng)
        for method, res in results.items():
            for name in SERIES:
                out[f"{trajectory}/{method}/{name}"] = getattr(res, name)[::EVERY]
            for src, rec in res.updates.items():
                for name in UPDATE_SERIES:
                    out[f"{trajectory}/{method}/{src}/{name}"] = getattr(rec, name)
    np.savez_compressed(sys.argv[1], **out)


if __name__ == "__main__":
    main()
