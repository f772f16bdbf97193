"""Given perfect sensors and no initial error, when the standalone INS runs 250 s, it follows truth.

This is the consistency proof of the truth generator against the strapdown mechanization: any
sign or frame slip in either (earth rate, Coriolis, gravity, coning, sculling) shows up here.
"""

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.eval.runner import run, simulate
from tauvcore.truth import TRAJECTORIES


@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_ideal_ins_follows_truth_for_250_s(trajectory: str) -> None:
    config = Config().replace("trajectory", name=trajectory, duration_s=250.0).replace("run", ideal=True, methods=("ins",))
    rng = np.random.default_rng(0)
    result = run(config, simulate(config, rng), rng)["ins"]
    assert result.t_s[-1] == pytest.approx(250.0)
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 0.05
    assert np.max(result.att_err_deg) < 1e-4


def test_ideal_lc_with_every_aid_stays_on_truth() -> None:
    """Noise-free DVL, depth and magnetometer agree with truth, so fusing them moves nothing."""
    config = (Config().replace("trajectory", name="lawnmower", duration_s=60.0)
              .replace("run", ideal=True, methods=("lc",), aiding=("dvl", "depth", "mag")))
    rng = np.random.default_rng(0)
    result = run(config, simulate(config, rng), rng)["lc"]
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 1e-2
    assert result.updates["dvl"].fused.all()
    assert result.updates["depth"].fused.all()
    assert result.updates["mag"].fused.all()
    # noise-free beams and a perfect prediction: the innovations vanish
    assert np.max(np.abs(result.updates["dvl"].innovation)) < 1e-3
