"""Given Table 2 errors, the standalone INS drifts as Tal et al. 2017 section 4.2 reports, and the
loosely coupled filter with all four beams holds the velocity at the centimetre level.

The paper's figures are Monte Carlo RMS values at 250 s, so ours are too (50 seeded runs,
initial errors drawn as 1-sigma). The drift is dominated by the 0.57 deg roll and pitch errors:
g * 0.01 rad * 250 s * sqrt(2) = 34.4 m/s (the filter's own 1-sigma, 34.6 m/s, on every
trajectory); a sign error in the tilt coupling or the gyro-bias path would cancel or double it.
The tolerance against the paper, 25 %, is the Monte Carlo scatter of a 50-run RMS of a
two-dimensional tilt (1 / sqrt(4 x 50) = 7 %, three sigma 21 %) plus the paper's own spread
around the tilt-driven value (31.8 to 36.5 m/s for one physics); 20 runs with 15 % passed or
failed with the seed.
"""

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.eval.montecarlo import monte_carlo, rms_over_runs

PAPER_INS_250S = {"straight": (34.0, 1.4), "figure8": (31.8, 1.26), "lawnmower": (36.5, 1.29)}  # m/s, deg


@pytest.fixture(scope="module", params=sorted(PAPER_INS_250S))
def results(request: pytest.FixtureRequest) -> tuple[str, dict]:
    config = Config().replace("trajectory", name=request.param).replace("run", methods=("ins", "lc"))
    return request.param, monte_carlo(config, 50, np.random.default_rng(11))


@pytest.mark.slow
def test_standalone_ins_drifts_like_the_paper(results: tuple[str, dict]) -> None:
    trajectory, res = results
    vel_paper, att_paper = PAPER_INS_250S[trajectory]
    assert rms_over_runs(res["ins"].vel_err_mps)[-1] == pytest.approx(vel_paper, rel=0.25)
    # the initial attitude errors alone have an RMS norm of sqrt(0.57^2 + 0.57^2 + 1.14^2) = 1.40 deg,
    # above two of the paper's figures (+11 % on the figure eight); a 50-run RMS of a
    # three-dimensional error scatters by 1 / sqrt(6 x 50) = 6 % (three sigma 17 %): hence 30 %
    assert rms_over_runs(res["ins"].att_err_deg)[-1] == pytest.approx(att_paper, rel=0.3)
    # and the filter's own 1-sigma of the standalone INS predicts that drift
    assert rms_over_runs(res["ins"].vel_err_mps)[-1] == pytest.approx(np.mean(res["ins"].vel_sigma_mps[-1]), rel=0.2)


@pytest.mark.slow
def test_lc_four_beams_keeps_centimetre_velocity(results: tuple[str, dict]) -> None:
    _, res = results
    lc = res["lc"]
    settled = lc.t_s >= 50.0
    assert np.all(rms_over_runs(lc.vel_err_mps)[settled] < 0.1)
    dvl = lc.updates["dvl"]
    assert dvl.fused.mean() > 0.97          # the 3-sigma gate rejects only the tails
    assert dvl.rejected.sum() + dvl.fused.sum() == dvl.valid.sum()
    assert rms_over_runs(lc.att_err_deg)[-1] < rms_over_runs(res["ins"].att_err_deg)[-1]
