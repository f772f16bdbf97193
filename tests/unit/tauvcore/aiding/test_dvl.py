"""DVL beam geometry (eq. 13-14), least-squares velocity (eq. 17-21) and the loose DVL measurement."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tauvcore.aiding.dvl_loose import DvlLoose, solve_velocity
from tauvcore.filter.eskf import Nominal, difference, inject
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import C_nb_from_euler, mv
from tauvcore.sensors.dvl import DvlConfig, beam_directions_b, beam_velocity

EARTH = Earth()
A = DvlConfig().A_b
NOISE = DvlConfig().noise_mps
THREE_BEAM_SETS = [tuple(s) for s in itertools.combinations(range(4), 3)]


# ------------------------------------------------------------------------------------------ geometry

def test_beam_directions_known_answer():
    theta = np.deg2rad(20.0)
    s, c = np.sin(theta), np.cos(theta)
    h = s / np.sqrt(2.0)                             # cos(45 deg) sin(20 deg)
    expected = np.array([[h, h, c], [-h, h, c], [-h, -h, c], [h, -h, c]])
    np.testing.assert_allclose(beam_directions_b(theta), expected, rtol=0, atol=1e-15)
    np.testing.assert_allclose(A, expected, rtol=0, atol=1e-15)   # the config's default pitch is 20 deg


def test_beam_directions_properties():
    b = A
    np.testing.assert_allclose(np.linalg.norm(b, axis=-1), 1.0, rtol=0, atol=1e-15)
    # beam 1 forward-starboard-down
    assert b[0, 0] > 0 and b[0, 1] > 0 and b[0, 2] > 0
    assert b[0, 0] == pytest.approx(-b[1, 0], abs=1e-15)
    assert b[0, 1] == pytest.approx(b[1, 1], abs=1e-15)
    assert b[0, 2] == pytest.approx(b[1, 2], abs=1e-15)
    # every beam is 20 deg off the body z axis, at yaw 45 + (k-1) 90 deg
    np.testing.assert_allclose(np.arccos(b[:, 2]), np.deg2rad(20.0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.rad2deg(np.arctan2(b[:, 1], b[:, 0])) % 360.0, [45.0, 135.0, 225.0, 315.0],
                               rtol=0, atol=1e-10)


@pytest.mark.parametrize("pitch_deg", (10.0, 30.0))
def test_beam_directions_follow_configured_pitch(pitch_deg):
    b = DvlConfig(beam_pitch_deg=pitch_deg).A_b
    np.testing.assert_allclose(b[:, 2], np.cos(np.deg2rad(pitch_deg)), rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.hypot(b[:, 0], b[:, 1]), np.sin(np.deg2rad(pitch_deg)), rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------------------ least squares

def _noise_free_beams(v_true: np.ndarray) -> np.ndarray:
    n = v_true.shape[0]
    return beam_velocity(A, v_true, np.zeros((n, 3)), np.zeros(3), np.zeros(n), np.zeros((n, 4)))


def test_solve_velocity_noise_free_four_beams():
    rng = np.random.default_rng(20)
    v_true = rng.normal(0.0, 2.0, (10, 3))
    y = _noise_free_beams(v_true)
    v, cov, A_pinv, valid = solve_velocity(A, y, np.ones((10, 4), bool), NOISE)
    assert np.all(valid)
    np.testing.assert_allclose(v, v_true, rtol=0, atol=1e-9)
    np.testing.assert_allclose(A_pinv @ A, np.broadcast_to(np.eye(3), (10, 3, 3)), rtol=0, atol=1e-12)


@pytest.mark.parametrize("beams", THREE_BEAM_SETS, ids=[f"beams{''.join(str(i + 1) for i in s)}" for s in THREE_BEAM_SETS])
def test_solve_velocity_noise_free_three_beams(beams):
    rng = np.random.default_rng(21)
    v_true = rng.normal(0.0, 2.0, (10, 3))
    available = np.zeros((10, 4), bool)
    available[:, list(beams)] = True
    y = np.where(available, _noise_free_beams(v_true), np.nan)    # a missing beam's value must not leak in
    v, cov, A_pinv, valid = solve_velocity(A, y, available, NOISE)
    assert np.all(valid)
    np.testing.assert_allclose(v, v_true, rtol=0, atol=1e-9)
    missing = [k for k in range(4) if k not in beams][0]
    np.testing.assert_array_equal(A_pinv[..., missing], 0.0)
    A3 = A[list(beams)]
    np.testing.assert_allclose(cov[0], np.linalg.inv(A3.T @ A3) * NOISE**2, rtol=0, atol=1e-14)


def test_solve_velocity_mixed_batch_and_too_few_beams():
    rng = np.random.default_rng(22)
    v_true = rng.normal(0.0, 2.0, (4, 3))
    available = np.array([[True] * 4, [True, True, True, False], [True, False, True, False], [False] * 4])
    y = np.where(available, _noise_free_beams(v_true), np.nan)
    v, cov, A_pinv, valid = solve_velocity(A, y, available, NOISE)
    np.testing.assert_array_equal(valid, [True, True, False, False])
    np.testing.assert_allclose(v[:2], v_true[:2], rtol=0, atol=1e-9)
    assert np.all(np.isfinite(v)) and np.all(np.isfinite(cov))


def test_solve_velocity_covariance_is_inverse_normal_matrix_and_matches_monte_carlo():
    rng = np.random.default_rng(23)
    v_true = np.array([1.8, -0.3, 0.1])
    n = 20000
    for available_row in ([True, True, True, True], [True, True, False, True]):
        available = np.broadcast_to(np.array(available_row), (n, 4))
        W = np.diag(np.array(available_row, float) / NOISE**2)
        y = _noise_free_beams(np.broadcast_to(v_true, (n, 3))) + rng.standard_normal((n, 4)) * NOISE
        v, cov, _, valid = solve_velocity(A, y, available, NOISE)
        assert np.all(valid)
        expected = np.linalg.inv(A.T @ W @ A)
        np.testing.assert_allclose(cov, np.broadcast_to(expected, (n, 3, 3)), rtol=0, atol=1e-14)
        err = v - v_true
        sample = err.T @ err / n
        scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
        assert np.all(np.abs(sample - expected) <= 0.05 * scale), (sample, expected)
        assert np.all(np.abs(err.mean(axis=0)) <= 5 * np.sqrt(np.diag(expected) / n))   # unbiased


# ------------------------------------------------------------------------------------------ DvlLoose

def _truth_state(rng: np.random.Generator, n: int) -> dict:
    euler = np.stack([rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), rng.uniform(-np.pi, np.pi, n)], -1)
    C = C_nb_from_euler(euler)
    vel_b = rng.normal(0.0, 1.5, (n, 3))
    return dict(C=C, vel_b=vel_b, pos=rng.normal(0.0, 20.0, (n, 3)),
                omega_nb_b=rng.normal(0.0, 0.3, (n, 3)),          # nonzero rate
                gyro_bias=rng.normal(0.0, 1e-4, (n, 3)), dvl_bias=rng.normal(0.0, 5e-3, (n, 4)),
                dvl_sf=rng.normal(0.0, 7e-3, n))


def _beams_and_gyro(cfg: DvlConfig, s: dict) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free beams (eq. 15) and the measured gyro rate (true inertial rate + true bias)."""
    y = beam_velocity(cfg.A_b, s["vel_b"], s["omega_nb_b"], cfg.l_dvl_b, s["dvl_sf"], s["dvl_bias"])
    omega_ib_b = s["omega_nb_b"] + mv(np.swapaxes(s["C"], -1, -2), EARTH.omega_ie_n)
    return y, omega_ib_b + s["gyro_bias"]


def _nominal(s: dict) -> Nominal:
    nav = NavState(pos_n=s["pos"], vel_n=mv(s["C"], s["vel_b"]), C_nb=s["C"])
    return Nominal(nav=nav, accel_bias=np.zeros_like(s["pos"]), gyro_bias=s["gyro_bias"], dvl_bias=s["dvl_bias"],
                   dvl_sf=s["dvl_sf"])


@pytest.mark.parametrize("available_row", ([True] * 4, [True, False, True, True]), ids=["4 beams", "3 beams"])
def test_dvl_loose_innovation_is_zero_at_truth(available_row):
    rng = np.random.default_rng(24)
    cfg = DvlConfig(lever_arm_m=(0.6, -0.2, 0.15))
    s = _truth_state(rng, 6)
    y, omega_meas = _beams_and_gyro(cfg, s)
    available = np.broadcast_to(np.array(available_row), (6, 4))
    y = np.where(available, y, np.nan)
    meas = DvlLoose(cfg, EARTH, 1e-3).measure(_nominal(s), y, available, omega_meas)
    assert np.all(meas.valid)
    assert np.max(np.abs(meas.innovation)) < 1e-9
    # z is the lever-arm compensated velocity: (1 + SF) v_b + A+ b_dvl (A+ over the returned beams)
    on = np.flatnonzero(available_row)
    A_pinv = np.zeros((3, 4))
    A_pinv[:, on] = np.linalg.pinv(cfg.A_b[on])
    expected_z = (1.0 + s["dvl_sf"])[:, None] * s["vel_b"] + s["dvl_bias"] @ A_pinv.T
    np.testing.assert_allclose(meas.z, expected_z, rtol=0, atol=1e-9)


def test_dvl_loose_innovation_is_H_dx_to_first_order():
    """End to end: the measurement model (not only H vs predict) sees a nominal error dx as H dx + O(dx^2)."""
    rng = np.random.default_rng(25)
    cfg = DvlConfig(lever_arm_m=(0.6, -0.2, 0.15))
    s = _truth_state(rng, 4)
    y, omega_meas = _beams_and_gyro(cfg, s)
    available = np.ones((4, 4), bool)
    model = DvlLoose(cfg, EARTH, 1e-3)
    true = _nominal(s)
    direction = rng.standard_normal((4, STATE.dim))
    residuals = []
    for scale in (1e-2, 5e-3):
        dx = scale * direction
        est = inject(true, -dx)
        dx_exact = difference(true, est)
        meas = model.measure(est, y, available, omega_meas)
        residuals.append(np.abs(meas.innovation - mv(meas.H, dx_exact)).max())
    # the only second-order term is dsf * dv (~scale^2); a wrong H column leaves a first-order
    # residual (halves with dx), the right one a second-order one (quarters)
    assert residuals[0] < 1e-3
    assert residuals[1] < 0.3 * residuals[0] or residuals[1] < 1e-12
