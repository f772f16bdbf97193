"""Given the 6-DOF TAUV flying each mission (tauvcore.truth.dynamic), when an ideal INS runs on
it, it follows; and the autopilot flies the missions it is given.

The ideal-INS test is the proof that the dynamic truth's specific force and angular rate are
those of its own positions and attitudes (a frame or sign slip in the truth, or a truth that
took its IMU quantities from the integrator and its positions from somewhere else, shows here).
"""

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run, run_streaming
from tauvcore.engine.simulation import simulate
from tauvcore.truth import TRAJECTORIES, generate
from tauvcore.truth.dynamic import mission


@pytest.mark.parametrize("earth", ["flat", "wgs84"])
@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_ideal_ins_follows_the_dynamic_truth_for_250_s(trajectory: str, earth: str) -> None:
    config = (Config().replace("trajectory", name=trajectory, duration_s=250.0, truth="dynamic")
              .replace("earth", model=earth).replace("run", ideal=True, methods=("ins",)))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng)
    assert sim.truth.vehicle is not None
    result = run(config, sim, rng)["ins"]
    assert result.t_s[-1] == pytest.approx(250.0)
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 0.05
    assert np.max(result.att_err_deg) < 1e-4


@pytest.mark.parametrize("earth", ["flat", "wgs84"])
@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_ideal_ins_follows_the_dynamic_truth_in_a_sheared_varying_current(trajectory: str, earth: str) -> None:
    """The vehicle flies the whole current field (constant, shear with depth, varying over 1-8 min):
    its specific force and angular rate are still those of its own positions and attitudes."""
    config = (Config().replace("trajectory", name=trajectory, duration_s=250.0, truth="dynamic",
                               current_n_mps=(0.2, -0.3, 0.0), current_shear_ne_per_s=(0.005, 0.0),
                               current_variation_mps=0.1, current_variation_period_s=60.0)
              .replace("earth", model=earth).replace("run", ideal=True, methods=("ins",)))
    rng = np.random.default_rng(0)
    sim = simulate(config, rng)
    assert np.all(np.ptp(sim.truth.current_n_mps[:, :2], axis=0) > 0.2)   # the current the vehicle met varied
    result = run(config, sim, rng)["ins"]
    assert result.t_s[-1] == pytest.approx(250.0)
    assert np.max(result.vel_err_mps) < 1e-3
    assert np.max(result.pos_err_m) < 0.05
    assert np.max(result.att_err_deg) < 1e-4


def test_the_dynamic_truth_is_not_the_kinematic_one() -> None:
    """The same scenario flown by the vehicle: close to the kinematic path, but with its own motion
    (control activity, sway of its own, fins and propeller working)."""
    config = Config().replace("trajectory", name="figure8", duration_s=100.0)
    kinematic = generate(config.trajectory, config.earth, config.imu.rate_hz)
    dynamic = generate(config.trajectory.__class__(**{**vars(config.trajectory), "truth": "dynamic"}), config.earth,
                       config.imu.rate_hz)
    assert kinematic.vehicle is None
    gap = np.linalg.norm(dynamic.pos_n - kinematic.pos_n, axis=1)
    assert 0.1 < np.max(gap) < 20.0              # the same mission, not the same motion
    assert np.ptp(np.degrees(dynamic.vehicle.fin_angles_rad)) > 2.0
    assert np.std(dynamic.vel_b[:, 1] - kinematic.vel_b[:, 1]) > 0.005


@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_the_autopilot_tracks_each_mission(trajectory: str) -> None:
    """Cross-track and depth errors stay small (README: the RMS per mission); the vehicle keeps
    to the scenario's speed, stays within its fins' limits and its 200 m depth, and holds its roll near level."""
    config = Config().replace("trajectory", name=trajectory, duration_s=250.0, truth="dynamic")
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    v = truth.vehicle
    after_start = truth.t_s > 20.0
    assert np.sqrt(np.mean(v.cross_track_m[after_start] ** 2)) < 1.5
    assert np.sqrt(np.mean(v.depth_error_m[after_start] ** 2)) < 0.3
    schedule = mission(config.trajectory)
    speed_ref = np.interp(truth.t_s, schedule.t_s, schedule.speed_mps)   # 2 m/s; longrange: its ramp
    assert np.all(np.abs(truth.vel_b[after_start, 0] - speed_ref[after_start]) < 0.1)
    assert np.max(np.abs(v.fin_angles_rad)) <= np.radians(25.0) + 1e-12
    assert np.max(truth.depth_m) < 200.0
    assert np.max(np.abs(np.degrees(truth.euler[after_start, 0]))) < 3.0


def test_a_current_is_crabbed_into_and_the_path_still_held() -> None:
    """A 0.3 m/s cross current: the vehicle heads into it (integral LOS) and keeps to its path;
    the DVL-relevant velocity (over ground) differs from the velocity through the water."""
    config = Config().replace("trajectory", name="straight", duration_s=250.0, truth="dynamic",
                              current_n_mps=(0.0, 0.3, 0.0))
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    late = truth.t_s > 150.0
    assert np.sqrt(np.mean(truth.vehicle.cross_track_m[late] ** 2)) < 0.5
    crab_deg = np.degrees(np.mean(truth.euler[late, 2]))
    assert -12.0 < crab_deg < -5.0                # asin(0.3 / 2) = 8.6 deg into the current (west of north)
    assert np.mean(np.abs(truth.vel_n[late, 1])) < 0.05   # over ground it goes north


def test_streamed_runs_on_the_dynamic_truth_do_not_depend_on_the_chunk_size() -> None:
    config = (Config().replace("trajectory", name="lawnmower", duration_s=30.0, truth="dynamic")
              .replace("run", methods=("lc",)))
    a = run_streaming(config, np.random.default_rng(3), chunk_s=10.0)["lc"]
    b = run_streaming(config, np.random.default_rng(3), chunk_s=7.3)["lc"]
    np.testing.assert_array_equal(a.pos_err_m, b.pos_err_m)
    np.testing.assert_array_equal(a.nees, b.nees)
