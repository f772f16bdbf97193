"""Given only beams 1 and 2 for the whole run (the paper's section 4.2 case), when every method
runs, then the partial-measurement methods behave as Tal et al. 2017 report.

Straight line: nullified sway keeps the velocity near the paper's 0.05 m/s, because the sway
it nullifies really is zero there, and no method ends worse than the standalone INS. Loosely
coupled cannot form a velocity from two beams and coasts, exactly as the INS does.
"""

import numpy as np
import pytest

from tauvcore.config import METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate


@pytest.fixture(scope="module")
def straight() -> dict:
    config = Config().replace("trajectory", name="straight").replace("dvl", beams=(1, 2)).replace("run", methods=METHODS)
    rng = np.random.default_rng(0)
    return run(config, simulate(config, rng), rng)


def test_nsv_holds_the_paper_velocity_on_the_straight_line(straight: dict) -> None:
    nsv = straight["nsv"]
    assert nsv.vel_err_mps[-1, 0] < 0.1
    assert np.sqrt(np.mean(nsv.vel_err_mps[nsv.t_s >= 50.0, 0] ** 2)) < 0.1


def test_no_method_ends_worse_than_the_standalone_ins(straight: dict) -> None:
    ins_final = straight["ins"].vel_err_mps[-1, 0]
    for method, result in straight.items():
        assert result.vel_err_mps[-1, 0] <= ins_final * (1 + 1e-9), method


def test_lc_coasts_on_two_beams_and_the_others_aid(straight: dict) -> None:
    assert np.allclose(straight["lc"].vel_err_mps, straight["ins"].vel_err_mps)
    assert not straight["lc"].updates["dvl"].valid.any()
    for method in ("tc", "vb", "nsv", "plcf", "vhv", "elc"):
        assert straight[method].updates["dvl"].fused.mean() > 0.9, method
    # the selector is at least as good as the best single construction it chooses from, to 2x
    best = min(straight[m].vel_err_mps[-1, 0] for m in ("vb", "nsv", "plcf", "vhv"))
    assert straight["elc"].vel_err_mps[-1, 0] < 2 * max(best, 0.05)


def test_manoeuvres_make_every_partial_method_useful() -> None:
    """Figure eight: turning makes the velocity the pair cannot see observable through the
    attitude dynamics, so every method holds the velocity far below the INS drift (the paper's
    worst on this trajectory, PLCF, reaches 1.2 m/s)."""
    config = Config().replace("trajectory", name="figure8").replace("dvl", beams=(1, 2)).replace("run", methods=METHODS)
    rng = np.random.default_rng(0)
    res = run(config, simulate(config, rng), rng)
    for method in ("tc", "vb", "nsv", "plcf", "vhv", "elc"):
        assert res[method].vel_err_mps[-1, 0] < 1.2, method
    assert res["ins"].vel_err_mps[-1, 0] > 20.0
