"""The exact nonlinear error dynamics of tauvcore.ins.error_model (its module docstring, flat and
WGS-84), no linearisation: the reference tests/unit/tauvcore/aiding/test_jacobians.py holds the
product's F and G (tauvcore.ins.error_model.F_matrix, G_matrix) equal to by central finite
differences."""

from __future__ import annotations

import numpy as np

from tauvcore.filter.layout import NOISE, STATE
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import exp_so3, left_jacobian_inv_so3, log_so3, skew, vee


def error_rate(
    C_hat: np.ndarray,
    vel_b_hat: np.ndarray,
    omega_ib_meas: np.ndarray,
    f_meas: np.ndarray,
    bias_hat: dict[str, np.ndarray],
    dx: np.ndarray,
    w: np.ndarray,
    earth: Earth,
) -> np.ndarray:
    """Exact nonlinear error dynamics ``dx'`` (no linearisation), for verification of F and G.

    The true state is the nominal one with ``dx`` applied; both evolve under the continuous model
    of this module's docstring, the truth with the measured IMU minus its true biases and the
    noise ``w``, the nominal with the estimated biases. ``bias_hat``: ``ba``, ``bg`` (3,).
    Misalignment rate: with ``E = C C_hat^T = exp([rho x])``, ``rho' = J_l(rho)^-1 vee(E' E^T)``.
    """
    g, Wv = earth.g_n, earth.omega_ie_n
    W = skew(Wv)
    rho = dx[STATE.att]
    C = exp_so3(rho) @ C_hat
    v_b = vel_b_hat + dx[STATE.vel]
    f_true = f_meas - (bias_hat["ba"] + dx[STATE.ba]) - w[NOISE.accel]
    om_true = omega_ib_meas - (bias_hat["bg"] + dx[STATE.bg]) - w[NOISE.gyro]
    f_hat = f_meas - bias_hat["ba"]
    om_hat = omega_ib_meas - bias_hat["bg"]

    def vel_rate(Cm: np.ndarray, v: np.ndarray, f: np.ndarray, om: np.ndarray) -> np.ndarray:
        return f + Cm.T @ g - np.cross(om + Cm.T @ Wv, v)

    out = np.zeros(STATE.dim)
    out[STATE.pos] = C @ v_b - C_hat @ vel_b_hat
    out[STATE.vel] = vel_rate(C, v_b, f_true, om_true) - vel_rate(C_hat, vel_b_hat, f_hat, om_hat)
    C_dot = C @ skew(om_true) - W @ C
    C_hat_dot = C_hat @ skew(om_hat) - W @ C_hat
    _attitude_and_walk_rates(out, C, C_hat, C_dot, C_hat_dot, w)
    return out


def _attitude_and_walk_rates(
    out: np.ndarray, C: np.ndarray, C_hat: np.ndarray, C_dot: np.ndarray, C_hat_dot: np.ndarray, w: np.ndarray
) -> None:
    """The misalignment rate ``rho' = J_l(rho)^-1 vee(E' E^T)`` (``E = C C_hat^T``) and the
    random walks' rates (their noise), into ``out``."""
    E = C @ C_hat.T
    E_dot = C_dot @ C_hat.T + C @ C_hat_dot.T
    out[STATE.att] = left_jacobian_inv_so3(log_so3(E)) @ vee(E_dot @ E.T)
    out[STATE.ba] = w[NOISE.ba]
    out[STATE.bg] = w[NOISE.bg]
    out[STATE.b_dvl] = w[NOISE.b_dvl]
    out[STATE.sf_dvl] = w[NOISE.sf_dvl]


def error_rate_geodetic(
    position_hat: tuple[float, float, float],
    C_hat: np.ndarray,
    vel_b_hat: np.ndarray,
    omega_ib_meas: np.ndarray,
    f_meas: np.ndarray,
    bias_hat: dict[str, np.ndarray],
    dx: np.ndarray,
    w: np.ndarray,
) -> np.ndarray:
    """Exact nonlinear error dynamics on the WGS-84 ellipsoid (the module docstring's second
    part), for verification of F's geodetic terms: ``dx'`` at the nominal geodetic position
    ``position_hat`` = (lat, lon, h) and state, with the error ``dx`` applied to make the truth,
    both moving under the geodetic mechanization, the truth with the IMU minus its true biases
    and the noise ``w``. ``bias_hat``: ``ba``, ``bg`` (3,)."""
    from tauvcore.geo import earth as E

    lat_h, lon_h, h_h = position_hat
    R_N, R_E = E.radii_of_curvature_m(lat_h)
    lat = lat_h + dx[STATE.pos][0] / (R_N + h_h)
    lon = lon_h + dx[STATE.pos][1] / ((R_E + h_h) * np.cos(lat_h))
    h = h_h - dx[STATE.pos][2]
    C = exp_so3(dx[STATE.att]) @ C_hat
    v_b = vel_b_hat + dx[STATE.vel]
    f_true = f_meas - (bias_hat["ba"] + dx[STATE.ba]) - w[NOISE.accel]
    om_true = omega_ib_meas - (bias_hat["bg"] + dx[STATE.bg]) - w[NOISE.gyro]
    f_hat = f_meas - bias_hat["ba"]
    om_hat = omega_ib_meas - bias_hat["bg"]

    def rates(la: float, hh: float, Cm: np.ndarray, v: np.ndarray, f: np.ndarray, om: np.ndarray):
        vel_n = Cm @ v
        g = np.array(E.gravity_n_mps2(la, hh))
        w_ie = np.array(E.earth_rate_n_rps(la))
        w_en = np.array(E.transport_rate_n_rps(la, hh, vel_n[0], vel_n[1]))
        v_dot = f + Cm.T @ g - np.cross(om + Cm.T @ w_ie, v)
        C_dot = Cm @ skew(om) - skew(w_ie + w_en) @ Cm
        return np.array(E.geodetic_rates(la, hh, *vel_n)), v_dot, C_dot

    geo, v_dot, C_dot = rates(lat, h, C, v_b, f_true, om_true)
    geo_h, v_dot_h, C_dot_h = rates(lat_h, h_h, C_hat, vel_b_hat, f_hat, om_hat)
    w2 = 1.0 - E._E2 * np.sin(lat_h) ** 2
    dR_N = 3.0 * E.A_M * (1.0 - E._E2) * E._E2 * np.sin(lat_h) * np.cos(lat_h) / w2**2.5
    dR_E = E.A_M * E._E2 * np.sin(lat_h) * np.cos(lat_h) / w2**1.5
    out = np.zeros(STATE.dim)
    # d/dt of (R_N(lat_h) + h_h)(lat - lat_h), (R_E(lat_h) + h_h) cos(lat_h) (lon - lon_h), -(h - h_h)
    out[STATE.pos.start + 0] = (dR_N * geo_h[0] + geo_h[2]) * (lat - lat_h) + (R_N + h_h) * (
        geo[0] - geo_h[0]
    )
    out[STATE.pos.start + 1] = (
        (dR_E * geo_h[0] + geo_h[2]) * np.cos(lat_h) - (R_E + h_h) * np.sin(lat_h) * geo_h[0]
    ) * (lon - lon_h) + (R_E + h_h) * np.cos(lat_h) * (geo[1] - geo_h[1])
    out[STATE.pos.start + 2] = -(geo[2] - geo_h[2])
    out[STATE.vel] = v_dot - v_dot_h
    _attitude_and_walk_rates(out, C, C_hat, C_dot, C_dot_h, w)
    return out
