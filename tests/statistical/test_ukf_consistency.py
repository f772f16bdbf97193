"""The unscented error-state filter (tauvcore.filter.families.ukf) knows its own error, with the
defaults.

30 seeded Monte Carlo runs per trajectory (initial errors drawn as Table 2's 1-sigma), 250 s, DVL
aiding only; ``ukf`` and ``ukf-tc`` with four beams, ``ukf-tc`` with beams 1 and 2 (the paper's
two-beam case). A consistent filter's NEES divided by its dimension averages 1; required: [0.5, 2]
for the full 20-state NEES and for every block (position, velocity, tilt, heading, sensor errors),
and the velocity NEES averaged over runs inside its two-sided 99 % band at 70 % of the epochs at
least (as tests/statistical/test_consistency_all_methods.py holds the EKF's methods).
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.montecarlo import monte_carlo
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

NUM_RUNS = 30
SEED = 8
BOUNDS = (0.5, 2.0)


@pytest.fixture(scope="module", params=TRAJECTORIES)
def consistency(request):
    base = Config().replace("trajectory", name=request.param).replace("run", seed=SEED)
    out = {}
    for beams, methods in (((1, 2, 3, 4), ("ukf", "ukf-tc")), ((1, 2), ("ukf-tc",))):
        config = base.replace("dvl", beams=beams).replace("run", methods=methods)
        for method, result in monte_carlo(config, NUM_RUNS, np.random.default_rng(SEED)).items():
            out[f"{method} beams {','.join(map(str, beams))}"] = method_consistency(result)
    return request.param, out


@pytest.mark.slow
def test_ukf_and_ukf_tc_are_consistent(consistency):
    name, by_case = consistency
    failures = []
    for case, c in by_case.items():
        for block in BLOCK_DIMS:
            per_dim = c.nees[block].per_dim
            if not BOUNDS[0] <= per_dim <= BOUNDS[1]:
                failures.append(f"{name} {case} {block}: NEES/dim {per_dim:.3g}")
        if c.nees["vel"].in_band < 0.7:
            failures.append(f"{name} {case} vel: {c.nees['vel'].in_band:.2f} of epochs in the 99 % band")
    assert len(by_case) == 3 and not failures, "\n".join(failures)
