"""Given perfect sensors and no initial error, when the standalone INS runs 250 s, it follows truth.

This is the consistency proof of the truth generator against the strapdown mechanization: any
sign or frame slip in either (earth rate, Coriolis, gravity, coning, sculling) shows up here.
"""

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
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


# ------------------------------------------------------------------ on the WGS-84 ellipsoid

@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_ideal_geodetic_ins_follows_truth_for_250_s(trajectory: str) -> None:
    """Truth and INS on the ellipsoid: gravity, earth rate and transport rate along the path."""
    config = (Config().replace("trajectory", name=trajectory, duration_s=250.0).replace("earth", model="wgs84")
              .replace("run", ideal=True, methods=("ins",)))
    rng = np.random.default_rng(0)
    result = run(config, simulate(config, rng), rng)["ins"]
    assert np.max(result.vel_err_mps) < 1e-4
    assert np.max(result.pos_err_m) < 0.01
    assert np.max(result.att_err_deg) < 1e-5


@pytest.mark.parametrize("latitude_deg", [32.8, 60.0, -45.0])
def test_ideal_geodetic_ins_over_an_hour_and_kilometres(latitude_deg: float) -> None:
    """A one-hour mission: a figure eight of 1 km turns, 7.2 km travelled over 2.1 x 5.6 km, 107 m
    of descent (over a 200 m seabed); the issue's bounds 0.05 m and 1e-3 m/s (measured: under 1 mm and 2e-6 m/s). The
    flat model's INS fed the same round-Earth IMU data ends kilometres off."""
    trajectory = dict(name="figure8", duration_s=3600.0, turn_radius_m=1000.0, dive_rate_mps=0.035,
                      seabed_depth_m=200.0)          # deep water: the descent never levels off
    config = (Config().replace("trajectory", **trajectory).replace("earth", model="wgs84", latitude_deg=latitude_deg)
              .replace("run", ideal=True, methods=("ins",)))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng)
    result = run(config, sim, rng)["ins"]
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 0.05
    assert np.linalg.norm(result.est_pos_n[-1, 0] - sim.truth.pos_n[-1]) < 0.05
    travelled = np.sum(np.linalg.norm(np.diff(sim.truth.pos_n, axis=0), axis=1))
    assert travelled > 5000.0 and np.ptp(sim.truth.pos_n[:, 1]) > 5000.0
    assert np.ptp(sim.truth.depth_m) > 100.0
    flat = run(config.replace("earth", model="flat"), sim, rng)["ins"]
    assert np.linalg.norm(flat.est_pos_n[-1, 0] - sim.truth.pos_n[-1]) > 1000.0


@pytest.mark.parametrize("trajectory", ["figure8", "lawnmower", "longrange"])
def test_ideal_ins_follows_the_kinematic_truth_crabbing_into_a_current(trajectory: str) -> None:
    """In a sheared, varying current the kinematic truth keeps its track over ground and crabs
    (tauvcore.truth.current.crab_profile): its attitude, rates and specific force stay consistent,
    so an ideal INS follows it as in still water, and its positions are still water's exactly."""
    current = dict(current_n_mps=(0.3, -0.4, 0.0), current_shear_ne_per_s=(0.01, 0.0), current_variation_mps=0.1,
                   current_variation_period_s=60.0)
    config = (Config().replace("trajectory", name=trajectory, duration_s=250.0, **current)
              .replace("run", ideal=True, methods=("ins",)))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng)
    result = run(config, sim, rng)["ins"]
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 0.05
    assert np.max(result.att_err_deg) < 1e-4
    still = simulate(config.replace("trajectory", current_n_mps=(0.0, 0.0, 0.0), current_shear_ne_per_s=(0.0, 0.0),
                                    current_variation_mps=0.0), np.random.default_rng(0))
    np.testing.assert_array_equal(sim.truth.pos_n, still.truth.pos_n)
    assert np.ptp(np.degrees(sim.truth.euler[:, 2] - still.truth.euler[:, 2])) > 1.0   # it crabs
