"""Truth generator: internal consistency by finite differences, and the scenario shapes.

The finite-difference tolerances are set by the half-cosine blends of the lawnmower turns: roll
follows the yaw rate, so the roll acceleration steps at a blend knot and a central difference
over one IMU interval is off there by ~dt * jump (~2e-4 rad/s). A sign or frame error would be
off by the size of the quantity itself (0.1 rad/s, 1 m/s^2). The strapdown test in
tests/scenario is the tight (1e-3 m/s over 250 s) proof.
"""

import numpy as np
import pytest

from tauvcore.geo import earth as E
from tauvcore.geo.earth import EARTH_MODELS, Earth
from tauvcore.geo.rotations import C_nb_from_euler, vee
from tauvcore.truth import TRAJECTORIES, TrajectoryConfig, generate
from tauvcore.truth.kinematic import BESSEL_J0_FIRST_ZERO


@pytest.fixture(scope="module", params=[(name, model) for name in TRAJECTORIES for model in EARTH_MODELS],
                ids=lambda p: f"{p[0]}-{p[1]}")
def truth(request: pytest.FixtureRequest):
    name, model = request.param
    return generate(TrajectoryConfig(name=name, duration_s=120.0), Earth(model=model), 150.0)


def _earth_terms(truth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gravity, earth rate and transport rate in n at every sample (K, 3) each."""
    K = truth.num_samples
    if not truth.earth.geodetic:
        return (np.broadcast_to(truth.earth.g_n, (K, 3)), np.broadcast_to(truth.earth.omega_ie_n, (K, 3)),
                np.zeros((K, 3)))
    lat, h, v = truth.pos_nav[:, 0], -truth.depth_m, truth.vel_n
    return (np.stack(np.broadcast_arrays(*E.gravity_n_mps2(lat, h)), axis=-1),
            np.stack(np.broadcast_arrays(*E.earth_rate_n_rps(lat)), axis=-1),
            np.stack(E.transport_rate_n_rps(lat, h, v[:, 0], v[:, 1]), axis=-1))


def test_velocity_is_derivative_of_position(truth) -> None:
    dt = truth.dt_s
    fd = (truth.pos_nav[2:] - truth.pos_nav[:-2]) / (2 * dt)
    if truth.earth.geodetic:     # latitude, longitude and depth move at the geodetic rates, in m/s here
        lat, h, v = truth.pos_nav[1:-1, 0], -truth.depth_m[1:-1], truth.vel_n[1:-1]
        R_N, R_E = E.radii_of_curvature_m(lat)
        rates = np.stack(E.geodetic_rates(lat, h, v[:, 0], v[:, 1], v[:, 2]), axis=-1)
        scale = np.stack([R_N + h, (R_E + h) * np.cos(lat), np.ones_like(lat)], axis=-1)
        fd, expected = fd * scale * [1, 1, 1], rates * scale * [1, 1, -1]
    else:
        expected = truth.vel_n[1:-1]
    assert np.max(np.abs(fd - expected)) < 1e-5


def test_specific_force_matches_acceleration(truth) -> None:
    dt = truth.dt_s
    g, w_ie, w_en = _earth_terms(truth)
    acc = (truth.vel_n[2:] - truth.vel_n[:-2]) / (2 * dt)
    C = truth.C_nb[1:-1]
    f_n = np.einsum("kij,kj->ki", C, truth.f_b[1:-1])
    v = truth.vel_n[1:-1]
    expected = f_n + g[1:-1] - np.cross(2 * w_ie[1:-1] + w_en[1:-1], v)
    assert np.max(np.abs(acc - expected)) < 1e-3


def test_body_rate_matches_attitude_derivative(truth) -> None:
    dt = truth.dt_s
    C_dot = (truth.C_nb[2:] - truth.C_nb[:-2]) / (2 * dt)
    omega_nb_b = vee(np.swapaxes(truth.C_nb[1:-1], -1, -2) @ C_dot)
    assert np.max(np.abs(omega_nb_b - truth.omega_nb_b[1:-1])) < 5e-4
    _, w_ie, w_en = _earth_terms(truth)
    in_b = np.einsum("kji,kj->ki", truth.C_nb, w_ie + w_en)
    assert np.allclose(truth.omega_ib_b - truth.omega_nb_b, in_b, rtol=0, atol=1e-15)
    assert np.allclose(truth.C_nb, C_nb_from_euler(truth.euler))


def test_increments_integrate_the_rates(truth) -> None:
    dt = truth.dt_s
    trapezoid = 0.5 * dt * (truth.omega_ib_b[1:] + truth.omega_ib_b[:-1])
    assert np.max(np.abs(truth.dtheta_ib_b[1:] - trapezoid)) < 1e-6
    assert np.all(truth.dtheta_ib_b[0] == 0) and np.all(truth.dv_b[0] == 0)


def test_straight_goes_north_at_constant_depth() -> None:
    cfg = TrajectoryConfig(name="straight", duration_s=100.0, speed_mps=2.0, depth_m=15.0)
    t = generate(cfg, Earth(model="flat"), 150.0)
    assert t.pos_n[-1] == pytest.approx([200.0, 0.0, 15.0], abs=1e-9)
    assert np.allclose(t.vel_b, [2.0, 0.0, 0.0])
    # on the ellipsoid: 200 m along the meridian at 15 m depth, the origin's longitude
    earth = Earth(model="wgs84", latitude_deg=40.0, longitude_deg=-70.0)
    g = generate(cfg, earth, 150.0)
    R_N, _ = E.radii_of_curvature_m(earth.latitude_rad)
    assert g.pos_nav[0] == pytest.approx([earth.latitude_rad, earth.longitude_rad, 15.0], abs=1e-15)
    R_N_mid, _ = E.radii_of_curvature_m(0.5 * (earth.latitude_rad + g.pos_nav[-1, 0]))   # R_N grows 1 m on the way
    assert (g.pos_nav[-1, 0] - earth.latitude_rad) * (R_N_mid - 15.0) == pytest.approx(200.0, abs=1e-6)
    np.testing.assert_allclose(g.pos_nav[:, 1], earth.longitude_rad, rtol=0, atol=1e-15)
    np.testing.assert_allclose(g.depth_m, 15.0, rtol=0, atol=1e-12)
    # the tangent plane at the surface above the start: 200 m north, 15 m down plus the dip d^2 / 2R
    assert g.pos_n[-1] == pytest.approx([200.0, 0.0, 15.0 + 200.0**2 / (2 * R_N)], abs=2e-5)


def test_figure8_closes_and_dives_at_constant_rate() -> None:
    cfg = TrajectoryConfig(name="figure8", duration_s=200.0, turn_radius_m=15.0, dive_rate_mps=0.1)
    period = 2 * np.pi * cfg.turn_radius_m * BESSEL_J0_FIRST_ZERO / cfg.speed_mps
    t = generate(cfg, Earth(model="flat"), 150.0)
    k = int(round(period / t.dt_s))
    # horizontal track returns to the start after one period (J0(A) = 0), crossing itself mid-way
    assert np.linalg.norm(t.pos_n[k, :2] - t.pos_n[0, :2]) < 0.05  # k is within dt/2 of the period
    np.testing.assert_allclose(t.vel_n[:, 2], 0.1, atol=1e-12)  # the dive alone: heave cancels the rolled sway
    # tightest turn radius as configured: max yaw rate V/R
    assert np.max(np.abs(t.omega_nb_b[:, 2])) == pytest.approx(cfg.speed_mps / cfg.turn_radius_m, rel=0.02)
    # sway is non-zero while turning (sideslip); heave cancels the sway's vertical part in the roll
    assert np.max(np.abs(t.vel_b[:, 1])) > 0.05
    np.testing.assert_allclose(t.vel_b[:, 2], -np.tan(t.euler[:, 0]) * t.vel_b[:, 1], atol=1e-15)
    assert 0.005 < np.max(np.abs(t.vel_b[:, 2])) < 0.02


def test_lawnmower_dives_then_holds_depth_and_reverses_legs() -> None:
    cfg = TrajectoryConfig(name="lawnmower", duration_s=250.0, dive_duration_s=30.0, lawnmower_dive_rate_mps=0.3)
    t = generate(cfg, Earth(model="flat"), 150.0)
    diving = t.t_s < 30.0
    assert np.allclose(t.vel_n[diving, 2], 0.3, atol=1e-9)
    level = t.t_s > 30.0 + cfg.blend_s
    assert np.allclose(t.euler[level, 1], 0.0, atol=1e-12)   # level pitch
    # the heave cancels the sideslip seen through the turn roll: the depth holds
    np.testing.assert_allclose(t.vel_n[level, 2], 0.0, atol=1e-12)
    assert np.ptp(t.depth_m[level]) < 1e-9
    yaw_deg = np.degrees(t.euler[:, 2])
    assert np.any(np.abs(np.abs(yaw_deg) - 180.0) < 1.0)   # a southbound leg
    assert np.max(t.pos_n[:, 1]) > 2 * cfg.turn_radius_m * 0.9  # next lane to the east
