"""Sensor simulations: noise levels, bias statistics and the exact noise-free outputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore import units
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import wrap_angle
from tauvcore.sensors import dvl, imu, magnetometer, pressure
from tauvcore.truth import TrajectoryConfig, generate
from tauvcore.validation import ConfigError

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


def test_imu_axis_errors_multiply_the_true_increments(short_truth):
    """With scale factors and misalignments only, the increments are exactly (I + M) times the
    true ones, M the same for every sample of a run and different between runs."""
    cfg = dataclasses.replace(_no_bias_imu(), accel_scale_factor_ppm=300.0, gyro_scale_factor_ppm=150.0,
                              accel_misalignment_mrad=0.5, gyro_misalignment_mrad=2.0)
    assert cfg.has_axis_errors and not _no_bias_imu().has_axis_errors
    rng = np.random.default_rng(35)
    data, state = imu.simulate_chunk(short_truth, 0, cfg, imu.ImuState(), imu.ImuStreams(rng, rng, rng, rng, rng),
                                     3, short_truth.dt_s)
    assert state.accel_axes.shape == (3, 3, 3) and state.gyro_axes.shape == (3, 3, 3)
    for r in range(3):
        M_a, M_g = state.accel_axes[r], state.gyro_axes[r]
        np.testing.assert_allclose(data.dv_b[1:, r], short_truth.dv_b[1:] @ (np.eye(3) + M_a).T, rtol=0, atol=1e-15)
        np.testing.assert_allclose(data.dtheta_b[1:, r], short_truth.dtheta_ib_b[1:] @ (np.eye(3) + M_g).T,
                                   rtol=0, atol=1e-16)
    assert not np.array_equal(state.accel_axes[0], state.accel_axes[1])
    # the "true bias" the records compare the filter's bias states with: what M does at the sample
    np.testing.assert_allclose(data.accel_bias[:, 1], short_truth.f_b @ state.accel_axes[1].T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(data.gyro_bias[:, 2], short_truth.omega_ib_b @ state.gyro_axes[2].T, rtol=0, atol=1e-18)
    # the next chunk keeps the run's matrices and draws nothing more for them
    again, state2 = imu.simulate_chunk(short_truth, short_truth.num_samples, cfg, state,
                                       imu.ImuStreams(rng, rng, rng, rng), 3, short_truth.dt_s)
    assert state2.accel_axes is state.accel_axes
    np.testing.assert_allclose(again.dv_b[:, 0], short_truth.dv_b @ (np.eye(3) + state.accel_axes[0]).T,
                               rtol=0, atol=1e-15)


def test_imu_axis_error_statistics():
    M = imu.axis_error_matrices(np.random.default_rng(36), (20000,), 300e-6, 0.5e-3)
    diagonal = np.stack([M[:, i, i] for i in range(3)], axis=-1)
    off = np.stack([M[:, i, j] for i in range(3) for j in range(3) if i != j], axis=-1)
    assert np.std(diagonal, axis=0) == pytest.approx([300e-6] * 3, rel=0.03)
    assert np.std(off, axis=0) == pytest.approx([0.5e-3] * 6, rel=0.03)
    assert abs(np.corrcoef(off[:, 0], off[:, 2])[0, 1]) < 0.03     # m_xy and m_yx are independent
    np.testing.assert_array_equal(imu.axis_error_matrices(np.random.default_rng(0), (), 0.0, 0.0), np.zeros((3, 3)))


def test_imu_profiles_and_their_units():
    yoo = imu.imu_profile("yoo-table1")
    assert imu.imu_profile("table2") == imu.ImuConfig()
    assert yoo.rate_hz == 100.0 and yoo.gyro_bias_rps == pytest.approx(1.0 * units.DEG_PER_HOUR)
    assert yoo.accel_bias_mps2 == pytest.approx(1e-3 * 9.80665)
    assert yoo.gyro_noise_rad_per_sqrt_s == pytest.approx(0.125 * np.pi / 180 / 60)
    # VRW "0.1 mg" read as 0.1 mg/sqrt(Hz): 9.8e-4 m/s^2/sqrt(Hz) = 9.8e-4 m/s/sqrt(s)
    assert yoo.accel_noise_mps_per_sqrt_s == pytest.approx(0.1e-3 * 9.80665, rel=1e-12)
    # bias stability: the walk moves the bias by the stated amount, 1 sigma, in one hour
    assert yoo.gyro_bias_rw_rps_per_sqrt_s * np.sqrt(3600.0) == pytest.approx(1.0 * units.DEG_PER_HOUR)
    assert yoo.accel_bias_rw_mps2_per_sqrt_s * np.sqrt(3600.0) == pytest.approx(1e-3 * 9.80665)
    assert (yoo.accel_scale_factor, yoo.gyro_scale_factor) == pytest.approx((300e-6, 150e-6))
    assert (yoo.accel_misalignment_rad, yoo.gyro_misalignment_rad) == pytest.approx((0.5e-3, 0.5e-3))
    # the PHINS class: 0.01 deg/h is the gyro whose Schuler-bounded drift R * eps is the class's
    # published 0.6 NM/h free-inertial drift; 50 ug of accelerometer bias and noise density
    phins = imu.imu_profile("phins")
    assert phins.gyro_bias_rps * 6.371e6 * 3600.0 / 1852.0 == pytest.approx(0.6, rel=0.05)
    assert phins.gyro_bias_rw_rps_per_sqrt_s * np.sqrt(3600.0) == pytest.approx(0.01 * units.DEG_PER_HOUR)
    assert phins.gyro_noise_rad_per_sqrt_s == pytest.approx(0.0025 * np.pi / 180 / 60)
    assert phins.accel_bias_mps2 == pytest.approx(50e-6 * 9.80665)
    assert phins.accel_noise_mps_per_sqrt_s == pytest.approx(50e-6 * 9.80665, rel=1e-12)
    assert phins.accel_bias_rw_mps2_per_sqrt_s * np.sqrt(3600.0) == pytest.approx(50e-6 * 9.80665)
    assert not phins.has_axis_errors
    with pytest.raises(ConfigError, match="imu profile.*'nope'"):
        imu.imu_profile("nope")
    with pytest.raises(ConfigError, match="imu.gyro_misalignment_mrad"):
        imu.ImuConfig(gyro_misalignment_mrad=-1.0)


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
    err = data.depth_m - long_truth.depth_m[data.index][:, None]
    sigma = 194.0 / (1025.0 * 9.80665)
    assert cfg.depth_noise_m == pytest.approx(sigma, rel=1e-12)
    assert np.std(err) == pytest.approx(sigma, rel=0.05)
    assert abs(np.mean(err)) < 5 * sigma / np.sqrt(err.size)


def test_pressure_ideal_is_exact_depth(long_truth):
    data = pressure.simulate(long_truth, pressure.PressureConfig().ideal(), np.random.default_rng(39))
    np.testing.assert_array_equal(data.depth_m, long_truth.depth_m[data.index])


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


def test_filter_takes_the_axis_errors_on_gravity_into_its_accelerometer_bias_sigma():
    """P0's accelerometer-bias block: the turn-on bias, plus what the misalignment (x, y) and the
    scale factor (z) make of gravity on a level vehicle."""
    from tauvcore.config import Config
    from tauvcore.engine.start import initial_covariance
    from tauvcore.filter.layout import STATE
    config = Config().replace("imu", accel_scale_factor_ppm=300.0, accel_misalignment_mrad=0.5)
    P0 = initial_covariance(config, np.zeros(3))
    g = np.linalg.norm(config.earth.g_n)
    b = config.imu.accel_bias_mps2
    np.testing.assert_allclose(np.diag(P0[STATE.ba, STATE.ba]),
                               np.array([b**2 + (0.5e-3 * g) ** 2, b**2 + (0.5e-3 * g) ** 2, b**2 + (300e-6 * g) ** 2])
                               + 1e-16, rtol=1e-12)
    plain = initial_covariance(Config(), np.zeros(3))
    np.testing.assert_allclose(np.diag(plain[STATE.ba, STATE.ba]), b**2 + 1e-16, rtol=1e-12)
