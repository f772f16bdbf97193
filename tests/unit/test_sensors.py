"""Sensor simulations: noise levels, bias statistics and the exact noise-free outputs."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore import units
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import wrap_angle
from tauvcore.sensors import dvl, imu, magnetometer, pressure
from tauvcore.truth import TrajectoryConfig, generate

IMU_RATE_HZ = 150.0


@pytest.fixture(scope="module")
def short_truth():
    return generate(TrajectoryConfig(name="figure8", duration_s=2.0), Earth(), IMU_RATE_HZ)


@pytest.fixture(scope="module")
def long_truth():
    return generate(TrajectoryConfig(name="figure8", duration_s=250.0), Earth(), IMU_RATE_HZ)


def _no_bias_imu(**noise) -> imu.ImuConfig:
    return imu.ImuConfig(rate_hz=IMU_RATE_HZ, accel_bias_mg=0.0, gyro_bias_deg_per_h=0.0,
                         accel_noise_mps_per_sqrt_h=noise.get("accel", 0.0),
                         gyro_noise_deg_per_sqrt_h=noise.get("gyro", 0.0),
                         accel_bias_rw_mps2_per_sqrt_s=0.0, gyro_bias_rw_deg_per_s_per_sqrt_s=0.0)


# ------------------------------------------------------------------------------------------ IMU

def test_imu_ideal_outputs_the_exact_increments(short_truth):
    data = imu.simulate(short_truth, imu.ImuConfig().ideal(), np.random.default_rng(30))
    np.testing.assert_array_equal(data.dv_b, short_truth.dv_b)
    np.testing.assert_array_equal(data.dtheta_b, short_truth.dtheta_ib_b)


def test_imu_white_noise_increment_std_is_density_times_sqrt_dt(short_truth):
    cfg = _no_bias_imu(accel=0.072, gyro=0.34)
    data = imu.simulate(short_truth, cfg, np.random.default_rng(31), num_runs=200)
    dt = short_truth.dt_s
    dv_err = (data.dv_b - short_truth.dv_b[:, None])[1:]          # row 0 is no interval
    dth_err = (data.dtheta_b - short_truth.dtheta_ib_b[:, None])[1:]
    assert dv_err.shape == (short_truth.num_samples - 1, 200, 3)
    expected_a = 0.072 / 60.0 * np.sqrt(dt)                       # m/s/sqrt(h) -> m/s/sqrt(s), times sqrt(dt)
    expected_g = 0.34 * np.pi / 180.0 / 60.0 * np.sqrt(dt)
    for axis in range(3):
        assert np.std(dv_err[..., axis]) == pytest.approx(expected_a, rel=0.03)
        assert np.std(dth_err[..., axis]) == pytest.approx(expected_g, rel=0.03)
    assert abs(np.mean(dv_err)) < 5 * expected_a / np.sqrt(dv_err.size)
    np.testing.assert_array_equal(data.accel_bias, 0.0)
    np.testing.assert_array_equal(data.gyro_bias, 0.0)


def test_imu_turn_on_bias_std_across_runs(short_truth):
    cfg = imu.ImuConfig(rate_hz=IMU_RATE_HZ, accel_bias_mg=0.5, gyro_bias_deg_per_h=3.0,
                        accel_noise_mps_per_sqrt_h=0.0, gyro_noise_deg_per_sqrt_h=0.0,
                        accel_bias_rw_mps2_per_sqrt_s=0.0, gyro_bias_rw_deg_per_s_per_sqrt_s=0.0)
    data = imu.simulate(short_truth, cfg, np.random.default_rng(32), num_runs=2000)
    dt = short_truth.dt_s
    # a turn-on bias is constant within a run ...
    np.testing.assert_array_equal(data.accel_bias, np.broadcast_to(data.accel_bias[0], data.accel_bias.shape))
    # ... and it is what the measured increments carry
    np.testing.assert_allclose((data.dv_b - short_truth.dv_b[:, None])[1:] / dt, data.accel_bias[1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose((data.dtheta_b - short_truth.dtheta_ib_b[:, None])[1:] / dt, data.gyro_bias[1:],
                               rtol=0, atol=1e-12)
    ba, bg = data.accel_bias[0], data.gyro_bias[0]                # (2000, 3)
    assert np.std(ba) == pytest.approx(0.5e-3 * 9.80665, rel=0.05)
    assert np.std(bg) == pytest.approx(3.0 * np.pi / 180.0 / 3600.0, rel=0.05)
    for axis in range(3):
        assert np.std(ba[:, axis]) == pytest.approx(0.5e-3 * 9.80665, rel=0.1)
        assert np.std(bg[:, axis]) == pytest.approx(3.0 * np.pi / 180.0 / 3600.0, rel=0.1)


def test_imu_bias_random_walk_growth(short_truth):
    """Bias random walk: after t seconds the bias has moved by density * sqrt(t) (1 sigma)."""
    cfg = imu.ImuConfig(rate_hz=IMU_RATE_HZ, accel_bias_mg=0.0, gyro_bias_deg_per_h=0.0,
                        accel_noise_mps_per_sqrt_h=0.0, gyro_noise_deg_per_sqrt_h=0.0,
                        accel_bias_rw_mps2_per_sqrt_s=1e-5, gyro_bias_rw_deg_per_s_per_sqrt_s=2.8e-5)
    data = imu.simulate(short_truth, cfg, np.random.default_rng(33), num_runs=2000)
    t_end = short_truth.t_s[-1]
    assert np.std(data.accel_bias[-1]) == pytest.approx(1e-5 * np.sqrt(t_end), rel=0.05)
    assert np.std(data.gyro_bias[-1]) == pytest.approx(2.8e-5 * units.DEG * np.sqrt(t_end), rel=0.05)


def test_imu_rejects_truth_at_another_rate(short_truth):
    with pytest.raises(ValueError, match="imu.rate_hz"):
        imu.simulate(short_truth, imu.ImuConfig(rate_hz=100.0), np.random.default_rng(34))


# ------------------------------------------------------------------------------------------ DVL

def _eq15_by_hand(truth, idx, cfg: dvl.DvlConfig, sf: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """Eq. 15 written out beam by beam with the eq. 13-14 directions, no library helpers."""
    theta = np.deg2rad(cfg.beam_pitch_deg)
    l = np.asarray(cfg.lever_arm_m)
    out = np.zeros(bias.shape)
    for k in range(4):
        psi = np.deg2rad(45.0 + 90.0 * k)
        b_k = np.array([np.cos(psi) * np.sin(theta), np.sin(psi) * np.sin(theta), np.cos(theta)])
        v_head = truth.vel_b[idx] * (1.0 + sf[..., None]) + np.cross(truth.omega_nb_b[idx], l)
        out[..., k] = v_head @ b_k + bias[..., k]
    return out


def test_dvl_ideal_gives_exact_eq15_beam_velocities(long_truth):
    cfg = dvl.DvlConfig(lever_arm_m=(0.6, -0.2, 0.15)).ideal()
    data = dvl.simulate(long_truth, cfg, np.random.default_rng(35))
    np.testing.assert_allclose(long_truth.t_s[data.index], np.arange(1, 251), rtol=0, atol=1e-9)   # 1 Hz pings
    np.testing.assert_array_equal(data.t_s, long_truth.t_s[data.index])
    assert np.all(data.available)
    np.testing.assert_array_equal(data.bias_mps, 0.0)
    np.testing.assert_array_equal(data.scale_factor, 0.0)
    expected = _eq15_by_hand(long_truth, data.index, cfg, np.zeros(data.index.size), np.zeros((data.index.size, 4)))
    np.testing.assert_allclose(data.y_beam_mps, expected, rtol=0, atol=1e-12)


def test_dvl_noise_free_beams_carry_the_recorded_bias_and_scale_factor(long_truth):
    cfg = dvl.DvlConfig(noise_mps=0.0, lever_arm_m=(0.6, -0.2, 0.15), beams=(1, 3, 4))
    data = dvl.simulate(long_truth, cfg, np.random.default_rng(36), num_runs=5)
    assert np.std(data.scale_factor) > 0 and np.std(data.bias_mps) > 0
    expected = _eq15_by_hand(long_truth, data.index[:, None], cfg, data.scale_factor, data.bias_mps)
    np.testing.assert_array_equal(data.available[..., 1], False)
    assert np.all(np.isnan(data.y_beam_mps[..., 1]))
    on = [0, 2, 3]
    np.testing.assert_allclose(data.y_beam_mps[..., on], expected[..., on], rtol=0, atol=1e-12)


def test_dvl_turn_on_bias_and_scale_factor_std(short_truth):
    cfg = dvl.DvlConfig(noise_mps=0.0, bias_rw_mps_per_sqrt_s=0.0, scale_factor_rw_pct_per_sqrt_s=0.0)
    data = dvl.simulate(short_truth, cfg, np.random.default_rng(42), num_runs=2000)
    assert data.bias_mps.shape == (2, 2000, 4)
    np.testing.assert_array_equal(data.bias_mps[0], data.bias_mps[1])       # constant without random walk
    assert np.std(data.bias_mps[0]) == pytest.approx(0.005, rel=0.05)
    assert np.std(data.scale_factor[0]) == pytest.approx(0.7e-2, rel=0.05)


def test_dvl_beam_noise_std(long_truth):
    cfg = dvl.DvlConfig(bias_mps=0.0, bias_rw_mps_per_sqrt_s=0.0, scale_factor_pct=0.0,
                        scale_factor_rw_pct_per_sqrt_s=0.0)
    data = dvl.simulate(long_truth, cfg, np.random.default_rng(37), num_runs=100)
    expected = _eq15_by_hand(long_truth, data.index[:, None], cfg, np.zeros((data.index.size, 100)),
                             np.zeros((data.index.size, 100, 4)))
    err = data.y_beam_mps - expected
    for k in range(4):
        assert np.std(err[..., k]) == pytest.approx(0.042, rel=0.03)


# ------------------------------------------------------------------------------------------ pressure

def test_pressure_depth_noise_std(long_truth):
    cfg = pressure.PressureConfig()
    data = pressure.simulate(long_truth, cfg, np.random.default_rng(38), num_runs=2000)
    np.testing.assert_allclose(long_truth.t_s[data.index], 4.0 * np.arange(1, 63), rtol=0, atol=1e-9)   # 0.25 Hz
    err = data.depth_m - long_truth.pos_n[data.index, 2][:, None]
    sigma = 194.0 / (1025.0 * 9.80665)
    assert cfg.depth_noise_m == pytest.approx(sigma, rel=1e-12)
    assert np.std(err) == pytest.approx(sigma, rel=0.05)
    assert abs(np.mean(err)) < 5 * sigma / np.sqrt(err.size)


def test_pressure_ideal_is_exact_depth(long_truth):
    data = pressure.simulate(long_truth, pressure.PressureConfig().ideal(), np.random.default_rng(39))
    np.testing.assert_array_equal(data.depth_m, long_truth.pos_n[data.index, 2])


# ------------------------------------------------------------------------------------------ magnetometer

def test_magnetometer_noise_std_per_axis(long_truth):
    cfg = magnetometer.MagnetometerConfig()
    data = magnetometer.simulate(long_truth, cfg, np.random.default_rng(40), num_runs=500)
    np.testing.assert_allclose(long_truth.t_s[data.index], 2.0 * np.arange(1, 126), rtol=0, atol=1e-9)  # 0.5 Hz
    err = wrap_angle(data.euler - long_truth.euler[data.index][:, None])
    expected = np.deg2rad([1.15, 1.15, 5.72])
    for axis in range(3):
        assert np.std(err[..., axis]) == pytest.approx(expected[axis], rel=0.05)
    assert np.all(np.abs(data.euler[..., 2]) <= np.pi)


def test_magnetometer_ideal_is_exact_attitude(long_truth):
    data = magnetometer.simulate(long_truth, magnetometer.MagnetometerConfig().ideal(), np.random.default_rng(41))
    np.testing.assert_allclose(wrap_angle(data.euler - long_truth.euler[data.index]), 0.0, rtol=0, atol=1e-15)
