"""ESKF correction against a hand-computed Kalman update; gating, masking, inject/difference."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.filter.eskf import (
    Measurement,
    Nominal,
    correct,
    difference,
    inject,
    propagate,
)
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import exp_so3, log_so3, mv

GATE = 3.0


def _nominal(rng: np.random.Generator, batch: tuple[int, ...]) -> Nominal:
    C = exp_so3(rng.standard_normal(batch + (3,)))
    vel_b = rng.normal(0.0, 2.0, batch + (3,))
    nav = NavState(pos_n=rng.normal(0.0, 10.0, batch + (3,)), vel_n=mv(C, vel_b), C_nb=C)
    return Nominal(nav=nav, accel_bias=rng.normal(0.0, 1e-3, batch + (3,)), gyro_bias=rng.normal(0.0, 1e-4, batch + (3,)),
                   dvl_bias=rng.normal(0.0, 5e-3, batch + (4,)), dvl_sf=rng.normal(0.0, 7e-3, batch))


def _spd(rng: np.random.Generator, n: int, scale: float) -> np.ndarray:
    L = rng.normal(0.0, scale, (n, n))
    return L @ L.T / n + np.eye(n) * scale**2 * 0.1


def _assert_nominal_equal(a: Nominal, b: Nominal, atol: float = 1e-12) -> None:
    for get in (lambda n: n.nav.pos_n, lambda n: n.nav.vel_n, lambda n: n.nav.C_nb, lambda n: n.accel_bias,
                lambda n: n.gyro_bias, lambda n: n.dvl_bias, lambda n: n.dvl_sf):
        np.testing.assert_allclose(get(a), get(b), rtol=0, atol=atol)


def _toy(seed: int, batch: tuple[int, ...] = (1,)):
    rng = np.random.default_rng(seed)
    nom = _nominal(rng, batch)
    P = np.broadcast_to(_spd(rng, STATE.dim, 0.05), batch + (STATE.dim, STATE.dim)).copy()
    H = np.zeros(batch + (2, STATE.dim))
    H[..., 0, STATE.vel] = [1.0, 0.2, 0.0]
    H[..., 1, STATE.pos.start + 2] = 1.0
    H[..., 1, STATE.att] = [0.0, 0.3, -0.1]
    R = np.broadcast_to(np.array([[0.01, 0.002], [0.002, 0.02]]), batch + (2, 2)).copy()
    return rng, nom, P, H, R


def test_correct_matches_hand_computed_kalman_update():
    rng, nom, P, H, R = _toy(50)
    nu = np.array([[0.05, -0.08]])
    meas = Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.array([True]))
    P1, nom1, out = correct(P, nom, meas, GATE)

    P0, H0, R0 = P[0], H[0], R[0]
    S = H0 @ P0 @ H0.T + R0
    K = P0 @ H0.T @ np.linalg.inv(S)
    np.testing.assert_allclose(P1[0], (np.eye(STATE.dim) - K @ H0) @ P0, rtol=0, atol=1e-14)
    dx = K @ nu[0]
    _assert_nominal_equal(nom1, inject(nom, dx[None]), atol=1e-14)
    # and the injection itself, written out: position and biases add, attitude rotates on the left
    np.testing.assert_allclose(nom1.nav.pos_n[0], nom.nav.pos_n[0] + dx[STATE.pos], rtol=0, atol=1e-14)
    np.testing.assert_allclose(nom1.nav.C_nb[0], exp_so3(dx[STATE.att]) @ nom.nav.C_nb[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(nom1.vel_b[0], nom.vel_b[0] + dx[STATE.vel], rtol=0, atol=1e-14)
    np.testing.assert_allclose(nom1.dvl_sf[0], nom.dvl_sf[0] + dx[STATE.sf_dvl][0], rtol=0, atol=1e-16)
    # the record
    np.testing.assert_allclose(out.innovation_var[0], np.diag(S), rtol=1e-14)
    assert out.test_ratio[0] == pytest.approx(np.max(nu[0] ** 2 / (GATE**2 * np.diag(S))), rel=1e-12)
    assert out.fused[0] and not out.rejected[0]
    # posterior covariance stays symmetric positive definite
    np.testing.assert_array_equal(P1, np.swapaxes(P1, -1, -2))
    assert np.all(np.linalg.eigvalsh(P1) > 0)


def test_gated_out_innovation_leaves_state_and_covariance_unchanged():
    rng, nom, P, H, R = _toy(51)
    S = H[0] @ P[0] @ H[0].T + R[0]
    nu = np.array([[0.0, 10.0 * np.sqrt(S[1, 1])]])        # 10 sigma on one component only
    meas = Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.array([True]))
    P1, nom1, out = correct(P, nom, meas, GATE)
    np.testing.assert_array_equal(P1, P)
    _assert_nominal_equal(nom1, nom)
    assert out.rejected[0] and not out.fused[0]
    assert out.test_ratio[0] == pytest.approx(100.0 / GATE**2, rel=1e-12)


def test_apply_mask_and_invalid_entries_are_left_untouched():
    rng, nom, P, H, R = _toy(52, batch=(3,))
    nu = np.array([[0.05, -0.08], [0.05, -0.08], [0.05, -0.08]])
    meas = Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.array([True, True, False]))
    P1, nom1, out = correct(P, nom, meas, GATE, apply=np.array([True, False, True]))
    # entry 0 is updated exactly as on its own
    P_alone, nom_alone, _ = correct(P[:1], Nominal(NavState(nom.nav.pos_n[:1], nom.nav.vel_n[:1], nom.nav.C_nb[:1]),
                                                   nom.accel_bias[:1], nom.gyro_bias[:1], nom.dvl_bias[:1],
                                                   nom.dvl_sf[:1]),
                                    Measurement(nu[:1], nu[:1], H[:1], R[:1], np.array([True])), GATE)
    np.testing.assert_allclose(P1[0], P_alone[0], rtol=0, atol=1e-15)
    assert not np.allclose(P1[0], P[0])
    np.testing.assert_allclose(nom1.nav.pos_n[0], nom_alone.nav.pos_n[0], rtol=0, atol=1e-14)
    # entry 1 (apply False) and entry 2 (invalid) are untouched, neither fused nor rejected
    for i in (1, 2):
        np.testing.assert_array_equal(P1[i], P[i])
        np.testing.assert_allclose(nom1.nav.pos_n[i], nom.nav.pos_n[i], rtol=0, atol=0)
        np.testing.assert_allclose(nom1.nav.C_nb[i], nom.nav.C_nb[i], rtol=0, atol=0)
        np.testing.assert_allclose(nom1.vel_b[i], nom.vel_b[i], rtol=0, atol=1e-14)
        np.testing.assert_array_equal(nom1.dvl_bias[i], nom.dvl_bias[i])
        assert not out.fused[i] and not out.rejected[i]
        assert np.isnan(out.test_ratio[i]) and np.all(np.isnan(out.innovation_var[i]))


@pytest.mark.parametrize("size", (1e-8, 1e-5, 1e-3))
def test_inject_and_difference_are_inverses(size):
    rng = np.random.default_rng(53)
    nom = _nominal(rng, (4,))
    dx = rng.standard_normal((4, STATE.dim)) * size
    np.testing.assert_allclose(difference(inject(nom, dx), nom), dx, rtol=0, atol=1e-12)
    # and the other way round: inject(est, true (-) est) recovers true
    true = _nominal(rng, (4,))
    est = inject(true, -dx)
    _assert_nominal_equal(inject(est, difference(true, est)), true, atol=1e-12)


def test_difference_uses_left_misalignment():
    rng = np.random.default_rng(54)
    est = _nominal(rng, (2,))
    rho = np.array([[0.01, -0.02, 0.005], [0.0, 0.0, 0.03]])
    C_true = exp_so3(rho) @ est.nav.C_nb
    true = Nominal(NavState(est.nav.pos_n, mv(C_true, est.vel_b), C_true), est.accel_bias, est.gyro_bias,
                   est.dvl_bias, est.dvl_sf)
    dx = difference(true, est)
    np.testing.assert_allclose(dx[:, STATE.att], rho, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.delete(dx, np.r_[STATE.att], axis=-1), 0.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(log_so3(C_true @ np.swapaxes(est.nav.C_nb, -1, -2)), rho, rtol=0, atol=1e-14)


def _structured_transition(rng: np.random.Generator, batch: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """F and G of the error model at random nominal states (their zero blocks are the model's)."""
    from tauvcore.geo.earth import Earth
    from tauvcore.ins.error_model import F_matrix, G_matrix
    C = exp_so3(rng.normal(0.0, 1.0, batch + (3,)))
    v = rng.normal(0.0, 2.0, batch + (3,))
    om = rng.normal(0.0, 0.3, batch + (3,))
    return F_matrix(C, v, om, Earth()), G_matrix(C, v)


def test_propagate_known_answer():
    """The structured sandwich of the compiled kernel equals the dense product."""
    from tauvcore.ins.error_model import discretise
    rng = np.random.default_rng(55)
    F, G = _structured_transition(rng, (3,))
    Phi, _ = discretise(F, G, np.ones(G.shape[-1]), 0.1)
    P = np.stack([_spd(rng, STATE.dim, 1.0) for _ in range(3)])
    Q = np.stack([_spd(rng, STATE.dim, 0.1) for _ in range(3)])
    dense = Phi @ P @ np.swapaxes(Phi, -1, -2) + Q
    np.testing.assert_allclose(propagate(P, Phi, Q), 0.5 * (dense + np.swapaxes(dense, -1, -2)), rtol=1e-13,
                               atol=1e-14)
    with pytest.raises(ValueError, match="Phi must be"):
        propagate(P[0], np.eye(STATE.dim) + 0.01, Q[0])


def test_discretise_equals_the_dense_series_and_trapezoid():
    """The kernel's structured Phi and Qd equal the dense third-order series and Van Loan trapezoid
    (the numpy engine's formulas) at random nominal states, over steps up to 1 s."""
    from tauvcore.ins.error_model import discretise
    rng = np.random.default_rng(56)
    F, G = _structured_transition(rng, (4,))
    q = rng.uniform(1e-6, 1.0, G.shape[-1])
    for dt in (1 / 150, 0.1, 1.0):
        A = F * dt
        A2 = A @ A
        Phi_dense = np.eye(STATE.dim) + A + A2 / 2.0 + (A2 @ A) / 6.0
        GQG = (G * q) @ np.swapaxes(G, -1, -2) * dt
        Qd_dense = 0.5 * (Phi_dense @ GQG @ np.swapaxes(Phi_dense, -1, -2) + GQG)
        Phi, Qd = discretise(F, G, q, dt)
        np.testing.assert_allclose(Phi, Phi_dense, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(Qd, Qd_dense, rtol=1e-12, atol=1e-15 * np.abs(Qd_dense).max())
    F_bad = F.copy()
    F_bad[..., 15, 0] = 1.0
    with pytest.raises(ValueError, match="F must be zero"):
        discretise(F_bad, G, q, 0.1)


def test_the_filter_bank_s_covariance_step_equals_discretise_and_propagate():
    """propagate_bank (F's non-zero block, Horner Phi, the structured G Q G^T of the IMU
    noise and the random walks, one sandwich) equals the dense path P <- Phi P Phi^T + Qd of
    F_matrix, G_matrix and discretise at random nominal states, for several filters at once."""
    from tauvcore.filter.kernels.error_model_kernels import propagate_bank
    from tauvcore.geo.earth import Earth
    from tauvcore.ins.error_model import F_matrix, G_matrix, discretise
    rng = np.random.default_rng(57)
    M, R, dt = 2, 3, 0.1
    earth = Earth()
    C = exp_so3(rng.normal(0.0, 1.0, (M, R, 3)))
    vel_n = rng.normal(0.0, 2.0, (M, R, 3))
    bg = rng.normal(0.0, 1e-3, (M, R, 3))
    dtheta_sum = rng.normal(0.0, 0.05, (R, 3))
    q = rng.uniform(1e-8, 1e-2, 17)
    P = np.stack([np.stack([_spd(rng, STATE.dim, 1.0) for _ in range(R)]) for _ in range(M)])
    vel_b = np.einsum("mrji,mrj->mri", C, vel_n)
    omega = dtheta_sum[None] / dt - bg
    F = F_matrix(C, vel_b, omega, earth)
    G = G_matrix(C, vel_b)
    Phi, Qd = discretise(F, G, q, dt)
    dense = Phi @ P @ np.swapaxes(Phi, -1, -2) + Qd
    bank = P.copy()
    no_tape = np.zeros((0, R, 9, 15))
    propagate_bank(bank, np.zeros(vel_n.shape), np.ascontiguousarray(C), vel_n, bg, dtheta_sum, dt,
                   np.ascontiguousarray(earth.g_n), np.ascontiguousarray(earth.omega_ie_n), q, False, no_tape,
                   np.zeros(0), np.zeros(0))
    np.testing.assert_allclose(bank, 0.5 * (dense + np.swapaxes(dense, -1, -2)), rtol=1e-12, atol=1e-13)
    np.testing.assert_array_equal(bank, np.swapaxes(bank, -1, -2))
    # the smoother's tape: the transitions of two steps composed, Phi2 Phi1 - I, on its block
    acc = np.zeros((M, R, 9, 15))
    twice = P.copy()
    C2 = exp_so3(rng.normal(0.0, 1.0, (M, R, 3)))
    for Cs in (C, C2):
        propagate_bank(twice, np.zeros(vel_n.shape), np.ascontiguousarray(Cs), vel_n, bg, dtheta_sum, dt,
                       np.ascontiguousarray(earth.g_n), np.ascontiguousarray(earth.omega_ie_n), q, False, acc,
                       np.zeros(0), np.zeros(0))
    Phi2, _ = discretise(F_matrix(C2, np.einsum("mrji,mrj->mri", C2, vel_n), omega, earth), G_matrix(C2, vel_b), q, dt)
    composed = Phi2 @ Phi - np.eye(STATE.dim)
    np.testing.assert_allclose(acc, composed[..., :9, :15], rtol=0, atol=1e-12)
    assert np.abs(composed[..., 9:, :]).max() == 0.0 and np.abs(composed[..., :9, 15:]).max() == 0.0


def test_geodetic_inject_and_difference_are_inverse() -> None:
    """On WGS-84 (latitude, longitude, depth) ``difference(inject(x, dx), x) == dx``: the position
    error in metres goes through the metric at the estimate both ways (to second order in dx)."""
    from tauvcore.filter.eskf import Nominal, difference, inject
    from tauvcore.filter.layout import NavState
    rng = np.random.default_rng(4)
    n = 20
    nav = NavState(pos_n=np.column_stack([rng.uniform(-1.4, 1.4, n), rng.uniform(-3, 3, n), rng.uniform(0, 3000, n)]),
                   vel_n=rng.normal(0, 2, (n, 3)), C_nb=exp_so3(rng.normal(0, 1, (n, 3))))
    est = Nominal(nav, rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-5, (n, 3)), rng.normal(0, 1e-2, (n, 4)),
                  rng.normal(0, 1e-3, n))
    dx = rng.normal(0, 1e-3, (n, STATE.dim)) * np.r_[[1e3] * 3, [1.0] * 17]   # metres of position error
    moved = inject(est, dx, geodetic=True)
    back = difference(moved, est, geodetic=True)
    np.testing.assert_allclose(back[:, STATE.pos], dx[:, STATE.pos], rtol=0, atol=1e-6)   # (1 m)^2 / R
    np.testing.assert_allclose(back[:, 3:], dx[:, 3:], rtol=1e-6, atol=1e-12)
    # one metre north is 1 / (R_N + h) of latitude
    from tauvcore.geo.earth import radii_of_curvature_m
    north = np.zeros((n, STATE.dim))
    north[:, STATE.pos.start] = 1.0
    lat = inject(est, north, geodetic=True).nav.pos_n[:, 0]
    R_N, _ = radii_of_curvature_m(nav.pos_n[:, 0])
    # (the latitudes differ by 1.6e-7 rad, whose last place is 1.4e-9 of it)
    np.testing.assert_allclose((lat - nav.pos_n[:, 0]) * (R_N - nav.pos_n[:, 2]), 1.0, rtol=4e-9)
