"""Yoo 2014's 12-state error model (tauvcore.filter.families.yoo.model): every entry of F against central finite
differences of the exact nonlinear error dynamics, and the paper's printed F against ours."""

import numpy as np
import pytest

from tauvcore.filter.families.yoo import model as yoo
from tauvcore.geo.earth import gravity_n_mps2
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3, skew, vee

LAT, H = np.radians(35.0), -80.0
F_B = np.array([0.3, -0.2, -9.6])          # measured specific force, body [m/s^2]
W_B = np.array([0.01, -0.02, 0.05])        # measured rate, body [rad/s]


def _rates(v: np.ndarray, C: np.ndarray, ba: np.ndarray, bg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 1 and 6 (exact): v' and C' on the geodetic mechanization, at the fixed position."""
    w_ie, w_en, _ = yoo.rates(LAT, H, v)
    g = np.array(gravity_n_mps2(LAT, H))
    v_dot = C @ (F_B - ba) - np.cross(2.0 * w_ie + w_en, v) + g
    C_dot = C @ skew(W_B - bg) - skew(w_ie + w_en) @ C
    return v_dot, C_dot


def _error_rate(est: tuple, dx: np.ndarray) -> np.ndarray:
    """dx' of the true state est (+) dx against est, exactly (the attitude error's rate from the
    skew part of d/dt (C_true C_est^T), exact to second order in dx)."""
    v, C, ba, bg = est
    v_t, C_t, ba_t, bg_t = v + dx[yoo.VEL], exp_so3(dx[yoo.ATT]) @ C, ba + dx[yoo.BA], bg + dx[yoo.BG]
    v_dot_t, C_dot_t = _rates(v_t, C_t, ba_t, bg_t)
    v_dot_e, C_dot_e = _rates(v, C, ba, bg)
    M_dot = C_dot_t @ C.T + C_t @ C_dot_e.T
    out = np.zeros(yoo.DIM)
    out[yoo.VEL] = v_dot_t - v_dot_e
    out[yoo.ATT] = vee(0.5 * (M_dot - M_dot.T))
    return out


@pytest.mark.parametrize("vel_n", [np.array([5.1, 0.4, -0.2]), np.array([-1.0, 3.0, 0.5])])
def test_F_is_the_jacobian_of_the_exact_error_dynamics(vel_n: np.ndarray) -> None:
    C = C_nb_from_euler(np.radians([3.0, -4.0, 40.0]))
    est = (vel_n, C, np.array([1e-3, -2e-3, 5e-4]), np.array([1e-5, 2e-5, -1e-5]))
    F = yoo.F_matrix(LAT, H, vel_n, C @ (F_B - est[2]), C)
    scale = np.r_[np.full(3, 1e-2), np.full(3, 1e-4), np.full(3, 1e-3), np.full(3, 1e-5)]
    for j in range(yoo.DIM):
        e = np.zeros(yoo.DIM)
        e[j] = scale[j]
        column = (_error_rate(est, e) - _error_rate(est, -e)) / (2.0 * scale[j])
        np.testing.assert_allclose(F[:, j], column, rtol=1e-5, atol=1e-9 * np.abs(F).max(), err_msg=f"column {j}")


def test_the_papers_F_is_ours_in_its_sign_convention_but_for_one_typo() -> None:
    """F_paper = S F S with one radius (R_N = R_E = R, h = 0) and the (3, 2) entry of F21 of the
    opposite sign: printed tan L / R, the derivative of omega_en,D = -v_E tan L / R is -tan L / R."""
    from tauvcore.geo.earth import radii_of_curvature_m

    vel_n, f_n = np.array([5.1, 0.4, -0.2]), np.array([0.2, -0.1, -9.8])
    C = C_nb_from_euler(np.radians([3.0, -4.0, 40.0]))
    R_N, R_E = radii_of_curvature_m(LAT)
    ours = yoo.F_matrix(LAT, 0.0, vel_n, f_n, C)
    S = yoo.paper_convention()
    # evaluated with our two radii: the paper's single R makes its 1/R terms differ by R_N vs R_E (< 1 %)
    corrected = yoo.F_paper(LAT, vel_n, f_n, C, R_m=np.sqrt(R_N * R_E), typo=False)
    np.testing.assert_allclose(S @ ours @ S, corrected, rtol=1e-2, atol=1e-12)
    printed = yoo.F_paper(LAT, vel_n, f_n, C, R_m=np.sqrt(R_N * R_E), typo=True)
    differs = ~np.isclose(S @ ours @ S, printed, rtol=1e-2, atol=1e-12)
    assert list(zip(*np.nonzero(differs), strict=True)) == [(5, 1)]


def test_the_engines_batched_F_is_the_checked_F() -> None:
    """tauvcore.filter.families.yoo.model.F_batch (what the filter propagates with) equals F_matrix (what the
    finite differences above check), state by state, on WGS-84."""
    from tauvcore.filter.families.yoo.model import F_batch

    rng = np.random.default_rng(3)
    lat, h = np.radians(rng.uniform(-60, 60, 4)), rng.uniform(-200, 0, 4)
    vel, f = rng.normal(size=(4, 3)) * 3.0, rng.normal(size=(4, 3)) + [0, 0, -9.8]
    C = C_nb_from_euler(np.radians(rng.uniform(-30, 30, (4, 3))))
    batch = F_batch(lat, h, vel, f, C, True, np.zeros(3))
    for b in range(4):
        np.testing.assert_allclose(batch[b], yoo.F_matrix(lat[b], h[b], vel[b], f[b], C[b]), rtol=1e-12, atol=1e-18)
