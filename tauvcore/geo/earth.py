"""Earth model: WGS-84 ellipsoid, normal gravity, earth and transport rates, geodetic frames.

Two uses live here.

- :class:`Earth`, the flat model the filters run today: a local NED tangent frame at the origin,
  with the WGS-84 normal (plumb-bob) gravity of the origin's latitude held constant and the
  earth rate of that latitude. Truth and INS use this same model, so it introduces no
  inconsistency between them; its limits over long missions are what the geodetic functions
  below are for (the free-air change 2 g h / a with depth, and the plumb line tilting by d / R
  with horizontal distance d: 0.16 mg per km).
- Geodetic functions of latitude ``lat`` [rad], longitude ``lon`` [rad] and height ``h`` [m]
  above the ellipsoid (a depth is ``-h``), for navigation on the round, rotating Earth (Groves,
  *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed. 2013,
  ch. 2; NIMA TR8350.2, 3rd ed., *Department of Defense World Geodetic System 1984*). Each takes
  and returns floats or numpy arrays of one shape, component by component (vectors as tuples of
  arrays), so the same code serves a whole trajectory at once and the compiled kernels (which
  compile the functions that call no other function of this module: numba cannot call plain
  Python functions, and this module must not import numba, for ``tauv --help``'s sake).

The local-level navigation frame n of the geodetic functions is north-east-down at the point
itself: its down axis is the ellipsoid normal there, and it turns with the position (the
transport rate) as well as with the Earth (the earth rate).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TypeAlias, overload

import numpy as np

from tauvcore import units
from tauvcore.validation import require_choice, require_range

FloatOrArray: TypeAlias = float | np.ndarray
"""What the geodetic functions take and return: a float, or an array of them (elementwise; arrays
broadcast). A float in gives a numpy float out."""

OMEGA_IE_RPS = 7.292115e-5
"""WGS-84 earth rotation rate [rad/s]."""
A_M = 6378137.0
"""WGS-84 semi-major axis (equatorial radius) [m]."""
FLATTENING = 1.0 / 298.257223563
"""WGS-84 flattening."""
B_M = A_M * (1.0 - FLATTENING)
"""WGS-84 semi-minor axis (polar radius) [m], 6356752.3142 m."""
GM_M3PS2 = 3.986004418e14
"""WGS-84 earth's gravitational constant (atmosphere included) [m^3/s^2]."""
_E2 = FLATTENING * (2.0 - FLATTENING)  # first eccentricity squared, 0.00669437999014
_GE = 9.7803253359  # WGS-84 normal gravity at the equator [m/s^2] (TR8350.2 table 3.4)
_GP = 9.8321849378  # ... at the poles [m/s^2]
_K_SOMIGLIANA = (
    0.00193185265241  # TR8350.2 eq. 4-2 (b g_p / (a g_e) - 1 from the rounded g_p: 0.0019318526464)
)
_M_GRAVITY = OMEGA_IE_RPS**2 * A_M**2 * B_M / GM_M3PS2  # 0.00344978650684
_GRAVITY_NORTH_PER_M = 8.08e-9  # north component of gravity per metre of height [1/s^2] (Groves eq. 2.140)


def normal_gravity_mps2(latitude_rad: FloatOrArray, height_m: FloatOrArray = 0.0) -> FloatOrArray:
    """WGS-84 normal gravity magnitude [m/s^2] at a geodetic latitude and height.

    On the ellipsoid, Somigliana's closed form (TR8350.2 eq. 4-1)
    ``gamma_0 = g_e (1 + k sin^2 lat) / sqrt(1 - e^2 sin^2 lat)``; above or below it, the
    free-air series (TR8350.2 eq. 4-3, Groves eq. 2.140)
    ``gamma = gamma_0 (1 - 2 h / a (1 + f + m - 2 f sin^2 lat) + 3 h^2 / a^2)``. Under water
    ``h < 0``: the same normal field continued downwards (the ocean's own attraction is not
    modelled; a real survey's gravity anomalies are of the order of 1e-4 m/s^2).
    """
    s2 = np.sin(latitude_rad) ** 2
    gamma_0 = _GE * (1.0 + _K_SOMIGLIANA * s2) / np.sqrt(1.0 - _E2 * s2)
    h_a = height_m / A_M
    return gamma_0 * (
        1.0 - 2.0 * h_a * (1.0 + FLATTENING + _M_GRAVITY - 2.0 * FLATTENING * s2) + 3.0 * h_a * h_a
    )


def gravity_n_mps2(
    latitude_rad: FloatOrArray, height_m: FloatOrArray
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Plumb-bob (gravity plus centrifugal) acceleration in the local-level NED frame [m/s^2].

    ``(-8.08e-9 h sin(2 lat), 0, gamma(lat, h))`` (Groves eq. 2.140): off the ellipsoid the
    normal field's direction leans from the ellipsoid normal towards the equator; the north
    component is 1.6e-6 m/s^2 at 200 m depth and 45 deg.
    """
    g_north = gravity_north_mps2(latitude_rad, height_m)
    return g_north, 0.0 * g_north, normal_gravity_mps2(latitude_rad, height_m)


def gravity_north_mps2(latitude_rad: FloatOrArray, height_m: FloatOrArray) -> FloatOrArray:
    """North component of :func:`gravity_n_mps2` [m/s^2]: ``-8.08e-9 h sin(2 lat)``."""
    return -_GRAVITY_NORTH_PER_M * height_m * np.sin(2.0 * latitude_rad)


@overload
def radii_of_curvature_m(latitude_rad: float) -> tuple[float, float]: ...
@overload
def radii_of_curvature_m(latitude_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
def radii_of_curvature_m(latitude_rad: FloatOrArray) -> tuple[FloatOrArray, FloatOrArray]:
    """Meridian radius ``R_N = a (1 - e^2) / (1 - e^2 sin^2 lat)^1.5`` and transverse (prime
    vertical) radius ``R_E = a / sqrt(1 - e^2 sin^2 lat)`` [m] (Groves eq. 2.105, 2.106)."""
    w2 = 1.0 - _E2 * np.sin(latitude_rad) ** 2
    w = np.sqrt(w2)
    return A_M * (1.0 - _E2) / (w2 * w), A_M / w


def earth_rate_n_rps(latitude_rad: FloatOrArray) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Earth rotation in the local-level NED frame [rad/s]: ``Omega (cos lat, 0, -sin lat)``."""
    return OMEGA_IE_RPS * np.cos(latitude_rad), 0.0 * latitude_rad, -OMEGA_IE_RPS * np.sin(latitude_rad)


def transport_rate_n_rps(
    latitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    vel_north_mps: FloatOrArray,
    vel_east_mps: FloatOrArray,
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Turn rate of the local-level NED frame over the ellipsoid [rad/s] (Groves eq. 5.44):
    ``(v_E / (R_E + h), -v_N / (R_N + h), -v_E tan(lat) / (R_E + h))``."""
    R_N, R_E = radii_of_curvature_m(latitude_rad)
    return transport_rate_with_radii(R_N, R_E, latitude_rad, height_m, vel_north_mps, vel_east_mps)


def transport_rate_with_radii(
    R_N: FloatOrArray,
    R_E: FloatOrArray,
    latitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    vel_north_mps: FloatOrArray,
    vel_east_mps: FloatOrArray,
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """:func:`transport_rate_n_rps` with the radii of curvature at ``latitude_rad`` given."""
    east = vel_east_mps / (R_E + height_m)
    return east, -vel_north_mps / (R_N + height_m), -east * np.tan(latitude_rad)


def geodetic_rates(
    latitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    vel_north_mps: FloatOrArray,
    vel_east_mps: FloatOrArray,
    vel_down_mps: FloatOrArray,
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Time derivatives of latitude, longitude [rad/s] and height [m/s] from NED velocity
    (Groves eq. 5.56): ``v_N / (R_N + h)``, ``v_E / ((R_E + h) cos lat)``, ``-v_D``."""
    R_N, R_E = radii_of_curvature_m(latitude_rad)
    return (
        vel_north_mps / (R_N + height_m),
        vel_east_mps / ((R_E + height_m) * np.cos(latitude_rad)),
        -vel_down_mps,
    )


def ecef_from_geodetic(
    latitude_rad: FloatOrArray, longitude_rad: FloatOrArray, height_m: FloatOrArray
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Earth-centred earth-fixed Cartesian position [m] of a geodetic point (Groves eq. 2.112)."""
    _, R_E = radii_of_curvature_m(latitude_rad)
    c = (R_E + height_m) * np.cos(latitude_rad)
    return (
        c * np.cos(longitude_rad),
        c * np.sin(longitude_rad),
        (R_E * (1.0 - _E2) + height_m) * np.sin(latitude_rad),
    )


GEODETIC_ITERATIONS = 6
"""Fixed-point iterations of :func:`geodetic_from_ecef`; each gains about six digits near the
surface. Measured (tests/unit/tauvcore/geo/test_geodetic.py): from 11 km under the sea to 100 km up, latitude
and longitude come back within 4 units in their last place and height within 5e-9 m."""


@overload
def geodetic_from_ecef(x_m: float, y_m: float, z_m: float) -> tuple[float, float, float]: ...
@overload
def geodetic_from_ecef(
    x_m: np.ndarray, y_m: np.ndarray, z_m: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
def geodetic_from_ecef(
    x_m: FloatOrArray, y_m: FloatOrArray, z_m: FloatOrArray
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """Geodetic latitude, longitude [rad] and height [m] of an ECEF position.

    Bowring's parametric-latitude iteration (Bowring 1976; Groves section C.2): start from the
    spherical guess and repeat ``tan(beta) = (1 - f) tan(lat)``,
    ``tan(lat) = (z + e'^2 b sin^3 beta) / (p - e^2 a cos^3 beta)`` with ``p = sqrt(x^2 + y^2)``;
    the height then follows from ``p cos(lat) + z sin(lat) - a sqrt(1 - e^2 sin^2 lat)``, which
    holds at the poles too.
    """
    p = np.sqrt(x_m * x_m + y_m * y_m)
    ep2 = _E2 / (1.0 - _E2)
    lat = np.arctan2(z_m, p * (1.0 - _E2))
    for _ in range(GEODETIC_ITERATIONS):
        beta = np.arctan2((1.0 - FLATTENING) * np.sin(lat), np.cos(lat))
        lat = np.arctan2(z_m + ep2 * B_M * np.sin(beta) ** 3, p - _E2 * A_M * np.cos(beta) ** 3)
    s = np.sin(lat)
    h = p * np.cos(lat) + z_m * s - A_M * np.sqrt(1.0 - _E2 * s * s)
    return lat, np.arctan2(y_m, x_m), h


def C_en(latitude_rad: FloatOrArray, longitude_rad: FloatOrArray) -> np.ndarray:
    """Rotation from the local-level NED frame to ECEF (Groves eq. 2.150 transposed): columns
    north, east, down resolved in e. -> (..., 3, 3)."""
    sl, cl = np.sin(latitude_rad), np.cos(latitude_rad)
    so, co = np.sin(longitude_rad), np.cos(longitude_rad)
    return np.stack(
        [
            np.stack([-sl * co, -so, -cl * co], axis=-1),
            np.stack([-sl * so, co, -cl * so], axis=-1),
            np.stack([cl, 0.0 * cl, -sl], axis=-1),
        ],
        axis=-2,
    )


def ned_offset_components(
    latitude_rad: FloatOrArray,
    longitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    latitude_ref_rad: FloatOrArray,
    longitude_ref_rad: FloatOrArray,
    height_ref_m: FloatOrArray,
) -> tuple[FloatOrArray, FloatOrArray, FloatOrArray]:
    """North, east and down [m] of a point's offset from a reference point, resolved in the
    reference's own NED frame: the straight ECEF offset, not a distance along the surface (a
    position error, estimate against truth; or a position in the tangent frame of a mission
    origin). Elementwise (arrays broadcast), and compiled as it is by the filter bank.

    Each ECEF coordinate is near 6.4e6 m, so subtracting two of them loses everything below
    about 1e-9 m. The offset is instead written in differences that are small themselves
    (``cos a - cos b = -2 sin((a + b) / 2) sin((a - b) / 2)``, and the same for the transverse
    radius), which keeps its error near 1e-16 of the offset.
    """
    lat, lon, h = latitude_rad, longitude_rad, height_m
    lat0, lon0, h0 = latitude_ref_rad, longitude_ref_rad, height_ref_m
    half_sum, half_diff = 0.5 * (lat + lat0), 0.5 * (lat - lat0)
    d_cos_lat = -2.0 * np.sin(half_sum) * np.sin(half_diff)
    d_sin_lat = 2.0 * np.cos(half_sum) * np.sin(half_diff)
    lon_sum, lon_diff = 0.5 * (lon + lon0), 0.5 * (lon - lon0)
    d_cos_lon = -2.0 * np.sin(lon_sum) * np.sin(lon_diff)
    d_sin_lon = 2.0 * np.cos(lon_sum) * np.sin(lon_diff)
    s, s0 = np.sin(lat), np.sin(lat0)
    c0 = np.cos(lat0)
    w, w0 = np.sqrt(1.0 - _E2 * s * s), np.sqrt(1.0 - _E2 * s0 * s0)
    R_E0 = A_M / w0
    # R_E - R_E0 = a (w0 - w) / (w w0), w0^2 - w^2 = e^2 (sin^2 lat - sin^2 lat0)
    d_R_E = A_M * _E2 * d_sin_lat * (s + s0) / (w * w0 * (w + w0))
    d_h = h - h0
    axis_0 = (R_E0 + h0) * c0  # distance from the polar axis
    d_axis = (d_R_E + d_h) * np.cos(lat) + (R_E0 + h0) * d_cos_lat
    cl, sl = np.cos(lon), np.sin(lon)
    dx = d_axis * cl + axis_0 * d_cos_lon
    dy = d_axis * sl + axis_0 * d_sin_lon
    dz = (d_R_E * (1.0 - _E2) + d_h) * s + (R_E0 * (1.0 - _E2) + h0) * d_sin_lat
    cl0, sl0 = np.cos(lon0), np.sin(lon0)
    horizontal = cl0 * dx + sl0 * dy  # along the reference's meridian plane, outwards
    return -s0 * horizontal + c0 * dz, -sl0 * dx + cl0 * dy, -c0 * horizontal - s0 * dz


def ned_offset_m(
    latitude_rad: FloatOrArray,
    longitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    latitude_ref_rad: FloatOrArray,
    longitude_ref_rad: FloatOrArray,
    height_ref_m: FloatOrArray,
) -> np.ndarray:
    """:func:`ned_offset_components` stacked: (..., 3) [m]."""
    n, e, d = ned_offset_components(
        latitude_rad, longitude_rad, height_m, latitude_ref_rad, longitude_ref_rad, height_ref_m
    )
    return np.stack(np.broadcast_arrays(n, e, d), axis=-1)


def ned_from_geodetic(
    latitude_rad: FloatOrArray,
    longitude_rad: FloatOrArray,
    height_m: FloatOrArray,
    origin: tuple[float, float, float],
) -> np.ndarray:
    """Position [m] in the NED tangent frame at ``origin`` = (lat, lon, h) of geodetic points:
    :func:`ned_offset_m` from the origin. -> (..., 3)."""
    return ned_offset_m(latitude_rad, longitude_rad, height_m, *origin)


def geodetic_from_ned(
    pos_n_m: np.ndarray, origin: tuple[float, float, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inverse of :func:`ned_from_geodetic`: latitude, longitude [rad] and height [m] of tangent-frame
    positions (..., 3) about ``origin``. The ECEF solution (:func:`geodetic_from_ecef`) is refined
    by two Newton steps on :func:`ned_from_geodetic` itself, so the round trip is as exact as the
    forward conversion, not limited by the 1e-9 m of an ECEF coordinate."""
    pos = np.asarray(pos_n_m, dtype=float)
    r = pos @ C_en(origin[0], origin[1]).T + np.array(ecef_from_geodetic(*origin))
    lat, lon, h = geodetic_from_ecef(r[..., 0], r[..., 1], r[..., 2])
    C_0 = C_en(origin[0], origin[1])
    for _ in range(2):
        residual_e = (pos - ned_from_geodetic(lat, lon, h, origin)) @ C_0.T
        residual_n = (residual_e[..., None, :] @ C_en(lat, lon))[..., 0, :]
        R_N, R_E = radii_of_curvature_m(lat)
        lat = lat + residual_n[..., 0] / (R_N + h)
        lon = lon + residual_n[..., 1] / ((R_E + h) * np.cos(lat))
        h = h - residual_n[..., 2]
    return lat, lon, h


EARTH_MODELS = ("flat", "wgs84")
"""``flat``: the paper's (Tal et al. 2017) tangent frame at the origin with its gravity and earth
rate held constant; ``wgs84``: navigation on the ellipsoid (geodetic position, gravity and earth
rate along the path, transport rate)."""


@dataclass(frozen=True)
class Earth:
    """The earth model and the mission origin's latitude and longitude (its depth is the
    trajectory's starting depth). The properties are the flat model's constants at the origin."""

    latitude_deg: float = (
        32.8  # origin latitude [deg]; default: off Haifa, where TAUV operates; [-89, 89]: the
    )
    # NED frame and Euler yaw are singular at the poles
    longitude_deg: float = 34.9  # origin longitude [deg]; default: off Haifa; [-180, 180]
    model: str = "wgs84"  # one of EARTH_MODELS; "flat" is the paper's (tauv reproduce uses it)

    def __post_init__(self) -> None:
        require_range("earth.latitude_deg", self.latitude_deg, -89.0, 89.0)
        require_range("earth.longitude_deg", self.longitude_deg, -180.0, 180.0)
        require_choice("earth.model", self.model, EARTH_MODELS)

    @property
    def geodetic(self) -> bool:
        """Whether navigation is on the ellipsoid (``model = "wgs84"``)."""
        return self.model == "wgs84"

    @property
    def longitude_rad(self) -> float:
        return self.longitude_deg * units.DEG

    @property
    def latitude_rad(self) -> float:
        return self.latitude_deg * units.DEG

    @cached_property
    def g_n(self) -> np.ndarray:
        """Plumb-bob gravity vector in n [m/s^2] (positive down)."""
        return np.array([0.0, 0.0, normal_gravity_mps2(self.latitude_rad)])

    @cached_property
    def omega_ie_n(self) -> np.ndarray:
        """Earth rate in n [rad/s]: ``[cos(lat), 0, -sin(lat)] * omega_ie``."""
        lat = self.latitude_rad
        return OMEGA_IE_RPS * np.array([np.cos(lat), 0.0, -np.sin(lat)])
