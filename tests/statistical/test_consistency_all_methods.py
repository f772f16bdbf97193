"""Every aided method knows its own error, with the defaults.

20 seeded Monte Carlo runs per trajectory (initial errors drawn as Table 2's 1-sigma), 250 s, DVL
aiding only; LC with four beams, TC and every extended loosely coupled method with beams 1 and 2
(the paper's two-beam case). A consistent filter's NEES divided by its dimension averages 1; we
require [0.5, 2] (the issue's bound) for the full 20-state NEES and for every block (position,
velocity, tilt, heading, sensor errors), and that the velocity NEES averaged over runs lies inside
its two-sided 99 % band at 70 % of the epochs at least (epochs are correlated, so with 20 runs
the fraction itself varies by seed: 0.78-1.00 measured; VB at n_f = 2 had 0.01-0.03).

One documented exception (README, "Consistency"): PLCF on the straight line measures surge
only; its sway and heave errors grow unaided to tens of m/s, where the error model's
second-order terms exceed the thinnest directions of P, so its full-state NEES is about 10 while
every block stays consistent. For it the blocks are checked, not the full state.

With the paper's settings this fails: VB at n_f = 2 (velocity NEES/dim 11,416 on the straight
line), NSV and ELC at epsilon = 1e-4 (37 on the figure eight), VHV without the n_f inflation of its
predicted heave (7.7 on the straight line).
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.montecarlo import monte_carlo
from tauvcore.truth import PAPER_TRAJECTORIES as TRAJECTORIES

NUM_RUNS = 20
SEED = 8
TWO_BEAM_METHODS = ("tc", "vb", "nsv", "plcf", "vhv", "elc")
NONLINEAR_FULL_STATE = {("straight", "plcf")}
BOUNDS = (0.5, 2.0)


@pytest.fixture(scope="module", params=TRAJECTORIES)
def consistency(request):
    name = request.param
    base = Config().replace("trajectory", name=name).replace("run", seed=SEED)
    out = {}
    for beams, methods in (((1, 2, 3, 4), ("lc",)), ((1, 2), TWO_BEAM_METHODS)):
        config = base.replace("dvl", beams=beams).replace("run", methods=methods)
        for method, result in monte_carlo(config, NUM_RUNS, np.random.default_rng(SEED)).items():
            out[method] = method_consistency(result)
    return name, out


@pytest.mark.slow
def test_lc_tc_and_every_elc_method_are_consistent(consistency):
    name, by_method = consistency
    failures = []
    for method, c in by_method.items():
        for block in BLOCK_DIMS:
            if block == "full" and (name, method) in NONLINEAR_FULL_STATE:
                continue
            per_dim = c.nees[block].per_dim
            if not BOUNDS[0] <= per_dim <= BOUNDS[1]:
                failures.append(f"{name} {method} {block}: NEES/dim {per_dim:.3g}")
        if c.nees["vel"].in_band < 0.7:
            failures.append(f"{name} {method} vel: {c.nees['vel'].in_band:.2f} of epochs in the 99 % band")
    assert not failures, "\n".join(failures)
    for (trajectory, method) in NONLINEAR_FULL_STATE:
        if trajectory == name:     # still over 2, as the README says; if it comes back to 1, update the README
            assert by_method[method].nees["full"].per_dim > 2.0
