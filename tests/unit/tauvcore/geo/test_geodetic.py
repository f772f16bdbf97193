"""Known answers and consistency checks for the WGS-84 functions of tauvcore.geo.earth."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.geo import earth as E
from tauvcore.geo.rotations import vee

DEG = np.pi / 180.0


# --------------------------------------------------------------------------------- normal gravity

@pytest.mark.parametrize("lat_deg, h_m, expected", [
    (0.0, 0.0, 9.7803253359),          # TR8350.2 table 3.4: equator
    (90.0, 0.0, 9.8321849378),         # TR8350.2 table 3.4: pole
    (-90.0, 0.0, 9.8321849378),
    (45.0, 0.0, 9.8061977694),         # Somigliana with TR8350.2's constants (eq. 4-2)
    (36.0, 100.0, 9.79788193),         # |gamma| of an independent implementation (itrm's somigliana)
])
def test_normal_gravity_known_answers(lat_deg, h_m, expected):
    g = np.linalg.norm(E.gravity_n_mps2(lat_deg * DEG, h_m))
    assert g == pytest.approx(expected, abs=1.5e-9 if h_m == 0.0 else 1e-8)
    assert E.normal_gravity_mps2(lat_deg * DEG, h_m) == pytest.approx(expected, abs=1.5e-9 if h_m == 0.0 else 1e-8)


def test_free_air_gradient_and_its_sign_under_water():
    """Gravity grows with depth at the free-air gradient, about 3.086e-6 s^-2 (2 g / a), and
    its second-order term makes the change over 11 km of depth 3 h^2 / a^2 larger than linear."""
    lat = 32.8 * DEG
    g0 = E.normal_gravity_mps2(lat)
    gradient = (E.normal_gravity_mps2(lat, 1.0) - E.normal_gravity_mps2(lat, -1.0)) / 2.0
    assert gradient == pytest.approx(-3.086e-6, rel=2e-3)
    assert E.normal_gravity_mps2(lat, -100.0) - g0 == pytest.approx(100.0 * 3.086e-6, rel=3e-3)
    h = -11000.0
    linear = g0 * (1.0 - 2.0 * h / E.A_M * (1.0 + E.FLATTENING + E._M_GRAVITY - 2.0 * E.FLATTENING * np.sin(lat) ** 2))
    assert E.normal_gravity_mps2(lat, h) - linear == pytest.approx(g0 * 3.0 * (h / E.A_M) ** 2, rel=1e-9)


def test_gravity_vector_components():
    g_n, g_e, g_d = E.gravity_n_mps2(45.0 * DEG, -200.0)
    assert g_n == pytest.approx(8.08e-9 * 200.0, rel=1e-12)   # Groves eq. 2.140: -8.08e-9 h sin(2 lat)
    assert g_e == 0.0
    assert g_d == pytest.approx(E.normal_gravity_mps2(45.0 * DEG, -200.0), rel=1e-15)
    assert E.gravity_n_mps2(0.0, -200.0)[0] == 0.0 and E.gravity_n_mps2(30.0 * DEG, 0.0)[0] == 0.0


def test_gravity_takes_arrays():
    lat = np.linspace(-80, 80, 7) * DEG
    h = np.linspace(-5000, 100, 7)
    g = np.stack(E.gravity_n_mps2(lat, h), axis=-1)
    assert g.shape == (7, 3)
    np.testing.assert_allclose(g[:, 2], [E.normal_gravity_mps2(a, b) for a, b in zip(lat, h)], rtol=0, atol=1e-15)


# --------------------------------------------------------------------------------- radii and rates

def test_radii_of_curvature_known_answers():
    R_N, R_E = E.radii_of_curvature_m(0.0)
    assert R_N == pytest.approx(6335439.327, abs=1e-3)      # a (1 - e^2)
    assert R_E == pytest.approx(6378137.0, abs=1e-9)        # a
    R_N, R_E = E.radii_of_curvature_m(np.pi / 2)
    assert R_N == pytest.approx(6399593.626, abs=1e-3)      # a^2 / b at the pole, both radii
    assert R_E == pytest.approx(6399593.626, abs=1e-3)
    assert E.A_M**2 / E.B_M == pytest.approx(6399593.6258, abs=1e-4)


@pytest.mark.parametrize("lat_deg", [0.0, 32.8, -60.0, 89.0])
def test_earth_rate_in_the_local_frame_is_the_earth_axis(lat_deg):
    """omega_ie_n resolved back in ECEF is (0, 0, Omega) at any longitude."""
    lat = lat_deg * DEG
    w_n = np.array(E.earth_rate_n_rps(lat))
    for lon in (-2.0, 0.3, 3.0):
        np.testing.assert_allclose(E.C_en(lat, lon) @ w_n, [0.0, 0.0, E.OMEGA_IE_RPS], rtol=0, atol=1e-19)


def _path(t: float) -> tuple[float, float, float]:
    """A geodetic path with closed-form position, for finite differences: lat, lon, h."""
    return 0.6 + 3e-5 * np.sin(0.1 * t), -1.2 + 4e-5 * t, -50.0 - 2.0 * t


def _ned_velocity(t: float) -> np.ndarray:
    """NED velocity of :func:`_path`, from d/dt of its ECEF position resolved in n."""
    dt = 1e-3
    r = lambda s: np.array(E.ecef_from_geodetic(*_path(s)))  # noqa: E731
    lat, lon, _ = _path(t)
    return E.C_en(lat, lon).T @ ((r(t + dt) - r(t - dt)) / (2 * dt))


def test_geodetic_rates_invert_the_ned_velocity():
    """lat', lon', h' from the NED velocity equal the path's own derivatives (central differences)."""
    t, dt = 3.0, 1e-3
    lat, lon, h = _path(t)
    v = _ned_velocity(t)
    rates = np.array(E.geodetic_rates(lat, h, *v))
    fd = (np.array(_path(t + dt)) - np.array(_path(t - dt))) / (2 * dt)
    np.testing.assert_allclose(rates, fd, rtol=1e-7, atol=1e-16)


def test_transport_rate_is_the_turn_of_the_local_frame():
    """C_en' = C_en [omega_en_n x] along a moving path (Groves eq. 5.44), by central differences."""
    t, dt = 3.0, 1e-3
    lat, lon, h = _path(t)
    v = _ned_velocity(t)
    C = E.C_en(lat, lon)
    C_dot = (E.C_en(*_path(t + dt)[:2]) - E.C_en(*_path(t - dt)[:2])) / (2 * dt)
    w = vee(C.T @ C_dot)
    np.testing.assert_allclose(w, E.transport_rate_n_rps(lat, h, v[0], v[1]), rtol=1e-6, atol=1e-15)


# --------------------------------------------------------------------------------- conversions

def test_C_en_known_answer_and_orthonormal():
    np.testing.assert_allclose(E.C_en(0.0, 0.0), [[0, 0, -1], [0, 1, 0], [1, 0, 0]], rtol=0, atol=1e-16)
    rng = np.random.default_rng(3)
    C = E.C_en(rng.uniform(-1.5, 1.5, 50), rng.uniform(-np.pi, np.pi, 50))
    np.testing.assert_allclose(C @ np.swapaxes(C, -1, -2), np.broadcast_to(np.eye(3), (50, 3, 3)), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-15)


def test_ecef_known_answers():
    np.testing.assert_allclose(E.ecef_from_geodetic(0.0, 0.0, 0.0), [E.A_M, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(E.ecef_from_geodetic(np.pi / 2, 0.7, -100.0), [0.0, 0.0, E.B_M - 100.0], atol=1e-9)
    np.testing.assert_allclose(E.ecef_from_geodetic(0.0, np.pi / 2, 10.0), [0.0, E.A_M + 10.0, 0.0], atol=1e-9)


def test_geodetic_ecef_round_trip_to_the_last_place():
    """ECEF coordinates are near 6.4e6 m, whose last place is 9.3e-10 m: the round trip through
    them holds latitude and longitude to 4 units in their last place (at most 9e-16 rad, 6 nm)
    and height to 5e-9 m, from 11 km under the sea to 100 km up, poles and equator included."""
    rng = np.random.default_rng(11)
    lat = np.concatenate([rng.uniform(-np.pi / 2, np.pi / 2, 5000), [np.pi / 2, -np.pi / 2, 0.0]])
    lon = np.concatenate([rng.uniform(-np.pi, np.pi, 5000), [0.0, 1.0, np.pi]])
    h = np.concatenate([rng.uniform(-11000.0, 100000.0, 5000), [-11000.0, 0.0, 3.0]])
    x, y, z = E.ecef_from_geodetic(lat, lon, h)
    lat2, lon2, h2 = E.geodetic_from_ecef(x, y, z)
    assert np.all(np.abs(lat2 - lat) <= 4 * np.spacing(np.abs(lat)))
    off_pole = np.abs(np.cos(lat)) > 1e-12          # longitude is undefined on the axis
    assert np.all(np.abs(lon2 - lon)[off_pole] <= 4 * np.spacing(np.abs(lon[off_pole])))
    assert np.max(np.abs(h2 - h)) < 5e-9


def test_local_ned_round_trip_and_meaning():
    origin = (32.8 * DEG, 34.9 * DEG, -20.0)
    rng = np.random.default_rng(5)
    pos = rng.uniform(-8000.0, 8000.0, (500, 3)) * np.array([1.0, 1.0, 0.02])
    lat, lon, h = E.geodetic_from_ned(pos, origin)
    np.testing.assert_allclose(E.ned_from_geodetic(lat, lon, h, origin), pos, rtol=0, atol=1e-9)
    lat2, lon2, h2 = E.geodetic_from_ned(E.ned_from_geodetic(lat, lon, h, origin), origin)
    assert np.all(np.abs(lat2 - lat) <= np.spacing(lat)) and np.all(np.abs(lon2 - lon) <= np.spacing(lon))
    assert np.max(np.abs(h2 - h)) < 1e-9
    np.testing.assert_allclose(E.ned_from_geodetic(*origin, origin), 0.0, atol=1e-9)
    # 1 km due north along the meridian: dlat = 1000 / (R_N + h) to first order, and the straight
    # chord dips below the tangent plane by d^2 / (2 R)
    R_N, _ = E.radii_of_curvature_m(origin[0])
    lat1, lon1, h1 = E.geodetic_from_ned(np.array([1000.0, 0.0, 0.0]), origin)
    assert (lat1 - origin[0]) * (R_N + origin[2]) == pytest.approx(1000.0, abs=1e-3)
    assert lon1 == pytest.approx(origin[1], abs=1e-15)
    assert h1 - origin[2] == pytest.approx(1000.0**2 / (2 * (R_N + origin[2])), rel=1e-3)


def test_ned_offset_is_the_error_in_the_reference_frame():
    lat, lon, h = 0.5, 1.0, -30.0
    R_N, R_E = E.radii_of_curvature_m(lat)
    d = np.array([2.0 / (R_N + h), -3.0 / ((R_E + h) * np.cos(lat)), 0.5])
    off = E.ned_offset_m(lat + d[0], lon + d[1], h + d[2], lat, lon, h)
    np.testing.assert_allclose(off, [2.0, -3.0, -0.5], atol=2e-6)      # first order: metres north, east, down
    np.testing.assert_allclose(E.ned_offset_m(lat, lon, h, lat, lon, h), 0.0, atol=0)
    # batched: each point against its own reference
    lats = np.array([0.1, 0.9])
    out = E.ned_offset_m(lats + 1e-6, lats * 0, lats * 0, lats, lats * 0, lats * 0)
    np.testing.assert_allclose(out[:, 0], [1e-6 * r for r in E.radii_of_curvature_m(lats)[0]], rtol=1e-6)
