"""Known answers and finite-difference checks for tauvcore.geo.rotations and tauvcore.geo.earth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tauvcore.geo.earth import OMEGA_IE_RPS, Earth, normal_gravity_mps2
from tauvcore.geo.rotations import (
    C_nb_from_euler,
    euler_from_C_nb,
    euler_from_misalignment_jacobian,
    euler_rates_to_omega_nb_b,
    exp_so3,
    left_jacobian_inv_so3,
    log_so3,
    skew,
    vee,
    wrap_angle,
)

ANGLES_RAD = (1e-9, 1e-4, 1e-2, 0.5, 3.0)


def _random_unit(rng: np.random.Generator, n: int) -> np.ndarray:
    u = rng.standard_normal((n, 3))
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


def _random_euler(rng: np.random.Generator, n: int, max_pitch: float = 1.3) -> np.ndarray:
    return np.stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(-max_pitch, max_pitch, n),
                     rng.uniform(-np.pi, np.pi, n)], axis=-1)


# ------------------------------------------------------------------------------------------ skew / vee

def test_skew_is_cross_product_on_batches():
    rng = np.random.default_rng(1)
    a = rng.standard_normal((4, 5, 3))
    b = rng.standard_normal((4, 5, 3))
    K = skew(a)
    assert K.shape == (4, 5, 3, 3)
    np.testing.assert_allclose((K @ b[..., None])[..., 0], np.cross(a, b), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(K, -np.swapaxes(K, -1, -2))
    np.testing.assert_array_equal(vee(K), a)


# ------------------------------------------------------------------------------------------ exp / log

@pytest.mark.parametrize("angle", ANGLES_RAD)
def test_exp_so3_matches_scipy_and_log_inverts_it(angle):
    rng = np.random.default_rng(2)
    phi = _random_unit(rng, 16) * angle                        # one angle per batch: series branch for small ones
    C = exp_so3(phi)
    np.testing.assert_allclose(C, Rotation.from_rotvec(phi).as_matrix(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), C.shape), rtol=0, atol=1e-15)
    # log: absolute accuracy relative to the angle, so the 1e-9 rad case is checked meaningfully
    np.testing.assert_allclose(log_so3(C), phi, rtol=0, atol=max(1e-13, 1e-12 * angle))
    np.testing.assert_allclose(log_so3(C), Rotation.from_matrix(C).as_rotvec(), rtol=0, atol=max(1e-13, 1e-12 * angle))


def test_exp_log_round_trip_on_a_mixed_batch():
    """All angles in one batch (general branch of exp_so3, incl. its own small-angle guard)."""
    rng = np.random.default_rng(3)
    angles = np.repeat(np.array(ANGLES_RAD), 4)
    phi = (_random_unit(rng, angles.size) * angles[:, None]).reshape(5, 4, 3)
    C = exp_so3(phi)
    assert C.shape == (5, 4, 3, 3)
    np.testing.assert_allclose(C.reshape(-1, 3, 3), Rotation.from_rotvec(phi.reshape(-1, 3)).as_matrix(),
                               rtol=0, atol=1e-15)
    err = np.linalg.norm(log_so3(C) - phi, axis=-1)
    assert np.all(err <= np.maximum(1e-13, 1e-12 * angles.reshape(5, 4)))


# ------------------------------------------------------------------------------------------ Euler angles

def test_C_nb_from_euler_is_zyx_product():
    rng = np.random.default_rng(4)
    euler = _random_euler(rng, 20)
    # scipy "ZYX" intrinsic with angles (yaw, pitch, roll) is Rz(yaw) Ry(pitch) Rx(roll)
    expected = Rotation.from_euler("ZYX", euler[:, ::-1]).as_matrix()
    np.testing.assert_allclose(C_nb_from_euler(euler), expected, rtol=0, atol=1e-15)


def test_euler_round_trip_including_yaw_near_pi():
    rng = np.random.default_rng(5)
    euler = _random_euler(rng, 40)
    near_pi = np.array([np.pi, np.pi - 1e-12, np.pi - 1e-6, -np.pi + 1e-12, -np.pi + 1e-6, np.pi + 1e-9 - 2 * np.pi])
    edge = np.stack([rng.uniform(-1, 1, near_pi.size), rng.uniform(-1.3, 1.3, near_pi.size), near_pi], axis=-1)
    euler = np.concatenate([euler, edge])
    back = euler_from_C_nb(C_nb_from_euler(euler))
    np.testing.assert_allclose(back[:, :2], euler[:, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(wrap_angle(back[:, 2] - euler[:, 2]), 0.0, rtol=0, atol=1e-12)
    assert np.all(np.abs(back[:, 2]) <= np.pi)
    # yaw just below +pi stays near +pi, just above -pi stays near -pi (no spurious flip)
    np.testing.assert_allclose(back[-5, 2], np.pi - 1e-12, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back[-2, 2], -np.pi + 1e-6, rtol=0, atol=1e-12)


def test_wrap_angle_known_answers():
    x = np.array([0.0, np.pi, -np.pi, 3 * np.pi, 2 * np.pi + 0.1, -2 * np.pi - 0.1, 1.0])
    np.testing.assert_allclose(wrap_angle(x), [0.0, np.pi, np.pi, np.pi, 0.1, -0.1, 1.0], rtol=0, atol=1e-12)


def test_euler_rates_to_omega_nb_b_matches_finite_difference_of_attitude():
    rng = np.random.default_rng(6)
    n = 12
    e0 = _random_euler(rng, n, max_pitch=1.2)
    e1 = rng.normal(0.0, 0.5, (n, 3))                   # Euler rates at t = 0
    e2 = rng.normal(0.0, 0.5, (n, 3))                   # curvature, so the path is not a straight line

    def C_at(t: float) -> np.ndarray:
        return C_nb_from_euler(e0 + e1 * t + 0.5 * e2 * t * t)

    h = 1e-6
    C_dot = (C_at(h) - C_at(-h)) / (2 * h)
    omega_fd = vee(np.swapaxes(C_at(0.0), -1, -2) @ C_dot)
    np.testing.assert_allclose(euler_rates_to_omega_nb_b(e0, e1), omega_fd, rtol=0, atol=1e-8)


def test_euler_from_misalignment_jacobian_matches_finite_difference():
    rng = np.random.default_rng(7)
    euler = _random_euler(rng, 10, max_pitch=1.2)
    euler[0, 2] = np.pi - 1e-8                            # yaw at the wrap
    C = C_nb_from_euler(euler)
    J = euler_from_misalignment_jacobian(euler)
    eps = 1e-6
    for j in range(3):
        d = np.zeros(3)
        d[j] = eps
        ep = euler_from_C_nb(exp_so3(d) @ C)
        em = euler_from_C_nb(exp_so3(-d) @ C)
        col = wrap_angle(ep - em) / (2 * eps)
        np.testing.assert_allclose(J[..., :, j], col, rtol=0, atol=1e-8)


@pytest.mark.parametrize("angle", (0.0, 1e-6, 5e-5, 2e-4, 1e-2, 0.5, 2.0, 3.0))
def test_left_jacobian_inv_so3_matches_finite_difference_definition(angle):
    """J_l(phi) = d/d(dphi) log(exp(phi + dphi) exp(phi)^T); the function returns its inverse."""
    rng = np.random.default_rng(8)
    phi = _random_unit(rng, 1)[0] * angle
    C0T = exp_so3(phi).T
    eps = 1e-6
    J_fd = np.zeros((3, 3))
    for j in range(3):
        d = np.zeros(3)
        d[j] = eps
        J_fd[:, j] = (log_so3(exp_so3(phi + d) @ C0T) - log_so3(exp_so3(phi - d) @ C0T)) / (2 * eps)
    np.testing.assert_allclose(left_jacobian_inv_so3(phi) @ J_fd, np.eye(3), rtol=0, atol=1e-8)


def test_left_jacobian_inv_so3_batched():
    rng = np.random.default_rng(9)
    phi = rng.normal(0.0, 1.0, (3, 4, 3))
    J = left_jacobian_inv_so3(phi)
    assert J.shape == (3, 4, 3, 3)
    for idx in np.ndindex(3, 4):
        np.testing.assert_allclose(J[idx], left_jacobian_inv_so3(phi[idx]), rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------------------ earth

def test_normal_gravity_wgs84_known_answers():
    assert normal_gravity_mps2(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity_mps2(np.pi / 2) == pytest.approx(9.8321849378, abs=1e-9)
    # symmetric in latitude, increasing towards the pole
    assert normal_gravity_mps2(-0.6) == pytest.approx(normal_gravity_mps2(0.6), abs=1e-15)
    g = [normal_gravity_mps2(lat) for lat in np.linspace(0.0, np.pi / 2, 10)]
    assert np.all(np.diff(g) > 0)


@pytest.mark.parametrize("lat_deg", (0.0, 32.8, -45.0, 89.0))
def test_earth_vectors(lat_deg):
    earth = Earth(latitude_deg=lat_deg)
    assert np.linalg.norm(earth.omega_ie_n) == pytest.approx(7.292115e-5, rel=1e-12)
    assert OMEGA_IE_RPS == 7.292115e-5
    lat = np.deg2rad(lat_deg)
    np.testing.assert_allclose(earth.omega_ie_n, 7.292115e-5 * np.array([np.cos(lat), 0.0, -np.sin(lat)]),
                               rtol=0, atol=1e-20)
    np.testing.assert_allclose(earth.g_n, [0.0, 0.0, normal_gravity_mps2(lat)], rtol=0, atol=0)


def test_compiled_exp_and_log_equal_the_numpy_ones_across_the_series_switch():
    """The filter bank's single-instance Rodrigues and its inverse (tauvcore.filter.kernels.rotation_kernels) agree
    with the batched numpy functions on both sides of the 1e-2 rad series switch and near pi."""
    from tauvcore.filter.kernels.rotation_kernels import exp_so3_batch, log_so3_batch
    rng = np.random.default_rng(71)
    directions = rng.normal(size=(60, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    angles = np.concatenate([np.geomspace(1e-9, 1e-2 * 0.999, 20), np.geomspace(1e-2 * 1.001, 3.0, 40)])
    phi = directions * angles[:, None]
    for p, C in zip(phi, exp_so3_batch(phi)):
        np.testing.assert_allclose(C, exp_so3(p), rtol=0, atol=2e-16 * 4)
    np.testing.assert_allclose(log_so3_batch(exp_so3(phi)), log_so3(exp_so3(phi)), rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(log_so3_batch(exp_so3_batch(phi)), phi, rtol=1e-9, atol=1e-15)
