"""The IMU's white noise from a still stretch: known densities recovered from a synthetic still
IMU (white noise on the earth's rate and gravity, with a bias walk), the stretch found inside a
record that moves before and after it, and none in one that never rests."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore import units
from tauvcore.eval.tuning.allan import MIN_STILL_S, still_noise, still_stretches, white_noise_density

DT_S = 0.01
ARW_DEG_PER_SQRT_H = 0.125  # Yoo 2014 Table 1's
VRW_MPS_PER_SQRT_H = 0.0588


def _still(rng: np.random.Generator, seconds: float, bias_walk: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Increments of a still IMU: the earth's rate and gravity in a tilted body frame, biases walking
    (Yoo 2014's walks: 1 deg/h and 1 mg in an hour), white noise of the known densities."""
    k = round(seconds / DT_S)
    omega = np.array([5.2e-5, 1.1e-5, -4.9e-5])  # rad/s, about the earth's rate
    f = np.array([0.3, -0.2, -9.79])  # m/s^2
    walk = (lambda s: np.cumsum(rng.normal(0.0, s * np.sqrt(DT_S), (k, 3)), axis=0)) if bias_walk else (
        lambda s: np.zeros((k, 3))
    )
    gyro_bias = 2e-6 + walk(1.0 * units.DEG_PER_HOUR / 60.0)
    accel_bias = 5e-3 + walk(1.0 * units.MG / 60.0)
    n_g = ARW_DEG_PER_SQRT_H * units.DEG_PER_SQRT_HOUR
    n_a = VRW_MPS_PER_SQRT_H * units.MPS_PER_SQRT_HOUR
    dth = (omega + gyro_bias) * DT_S + rng.normal(0.0, n_g * np.sqrt(DT_S), (k, 3))
    dv = (f + accel_bias) * DT_S + rng.normal(0.0, n_a * np.sqrt(DT_S), (k, 3))
    return dth, dv


def _moving(rng: np.random.Generator, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """Increments of a vehicle turning and accelerating (a slalom): rates of several deg/s."""
    k = round(seconds / DT_S)
    t = np.arange(k) * DT_S
    omega = np.stack([0.02 * np.sin(0.3 * t), 0.01 * np.cos(0.2 * t), 0.08 * np.sin(0.1 * t)], axis=1)
    f = np.stack([0.3 * np.sin(0.1 * t), 0.5 * np.cos(0.3 * t), -9.8 + 0.1 * np.sin(0.5 * t)], axis=1)
    dth = omega * DT_S + rng.normal(0.0, 1e-6, (k, 3))
    dv = f * DT_S + rng.normal(0.0, 1e-5, (k, 3))
    return dth, dv


@pytest.mark.parametrize("bias_walk", [False, True])
def test_white_noise_density_of_a_still_imu_is_recovered(bias_walk: bool) -> None:
    rng = np.random.default_rng(11)
    dth, dv = _still(rng, 300.0, bias_walk)
    for i in range(3):
        arw = white_noise_density(dth[:, i] / DT_S, DT_S) / units.DEG_PER_SQRT_HOUR
        vrw = white_noise_density(dv[:, i] / DT_S, DT_S) / units.MPS_PER_SQRT_HOUR
        assert arw == pytest.approx(ARW_DEG_PER_SQRT_H, rel=0.05)
        assert vrw == pytest.approx(VRW_MPS_PER_SQRT_H, rel=0.05)


def test_the_still_stretch_is_found_between_manoeuvres_and_gives_the_noise() -> None:
    rng = np.random.default_rng(12)
    parts = [_moving(rng, 100.0), _still(rng, 150.0), _moving(rng, 80.0)]
    dth = np.concatenate([p[0] for p in parts])
    dv = np.concatenate([p[1] for p in parts])
    stretches = still_stretches(dth, dv, DT_S)
    assert len(stretches) == 1
    k0, k1 = stretches[0]
    assert abs(k0 * DT_S - 100.0) <= 1.0 and abs(k1 * DT_S - 250.0) <= 1.0
    still = still_noise(dth, dv, DT_S)
    assert still is not None
    assert still.duration_s == pytest.approx((k1 - k0) * DT_S)
    assert still.gyro_noise_deg_per_sqrt_h == pytest.approx(ARW_DEG_PER_SQRT_H, rel=0.05)
    assert still.accel_noise_mps_per_sqrt_h == pytest.approx(VRW_MPS_PER_SQRT_H, rel=0.05)
    # a 150 s stretch at 100 Hz: the Allan deviation's own error is about 1 %, the axes alike
    assert 0.005 < still.gyro_sigma_ln < 0.05 and 0.005 < still.accel_sigma_ln < 0.05


def test_no_stretch_in_a_moving_record_or_a_short_rest() -> None:
    rng = np.random.default_rng(13)
    dth, dv = _moving(rng, 400.0)
    assert still_stretches(dth, dv, DT_S) == [] and still_noise(dth, dv, DT_S) is None
    parts = [_moving(rng, 100.0), _still(rng, MIN_STILL_S - 5.0), _moving(rng, 100.0)]
    dth = np.concatenate([p[0] for p in parts])
    dv = np.concatenate([p[1] for p in parts])
    assert still_stretches(dth, dv, DT_S) == []


def test_the_allan_deviation_needs_enough_samples() -> None:
    with pytest.raises(ValueError, match="at least 100 samples"):
        white_noise_density(np.zeros(50), DT_S)
