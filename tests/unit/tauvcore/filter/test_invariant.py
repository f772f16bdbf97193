"""The right-invariant EKF (tauvcore.filter.invariant): its coordinate map against finite differences
of the exact invariant error, the retraction against the SE_2(3) group product, the covariance's
carry, the compiled kernel against the numpy reference, and the bank running it."""

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine import dvl_fusion, filter_bank
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.filter.eskf import Nominal, _state_arrays, inject
from tauvcore.filter.invariant import carry_matrix, invariant_map, left_jacobian_so3, retract
from tauvcore.filter.kernels.common import radii_nav
from tauvcore.filter.kernels.invariant_kernels import left_jacobian_so3_into, retract_batch
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3, log_so3, skew


def _se23(C, v, p):
    X = np.eye(5)
    X[:3, :3], X[:3, 3], X[:3, 4] = C, v, p
    return X


def _se23_exp(xi_R, xi_v, xi_p):
    J = left_jacobian_so3(xi_R)
    return _se23(exp_so3(xi_R), J @ xi_v, J @ xi_p)


def _se23_log(X):
    phi = log_so3(X[:3, :3])
    Jinv = np.linalg.inv(left_jacobian_so3(phi))
    return phi, Jinv @ X[:3, 3], Jinv @ X[:3, 4]


@pytest.fixture
def nominal():
    rng = np.random.default_rng(5)
    C = C_nb_from_euler(np.array([0.05, -0.08, 2.3]))
    return Nominal(NavState(np.array([1500.0, -800.0, 40.0]), np.array([1.2, 1.5, 0.1]), C),
                   rng.normal(0.0, 1e-3, 3), rng.normal(0.0, 1e-5, 3), rng.normal(0.0, 5e-3, 4),
                   np.array(0.004))


@pytest.mark.parametrize("phi", [np.zeros(3), np.array([1e-6, -2e-6, 3e-7]), np.array([0.3, -1.2, 0.7]),
                                 np.array([2.0, 1.0, -0.5])])
def test_left_jacobian_is_the_series_and_its_kernel_twin(phi):
    J = left_jacobian_so3(phi)
    np.testing.assert_allclose(exp_so3(phi), np.eye(3) + skew(phi) @ J, atol=1e-15)
    out = np.empty((3, 3))
    left_jacobian_so3_into(*phi, out)
    np.testing.assert_allclose(out, J, atol=1e-15)
    # d/dt exp(phi + t u) at t = 0 is [(J_l u) x] exp(phi)
    u, h = np.array([0.3, -0.1, 0.2]), 1e-6
    d = (exp_so3(phi + h * u) - exp_so3(phi - h * u)) / (2 * h)
    np.testing.assert_allclose(d, skew(J @ u) @ exp_so3(phi), atol=1e-8)


def test_the_map_is_the_jacobian_of_the_exact_invariant_error(nominal):
    """xi(dx) = log(X(dx) X_hat^-1) with X(dx) = x_hat (+) dx, by central differences."""
    X_hat = _se23(nominal.nav.C_nb, nominal.nav.vel_n, nominal.nav.pos_n)

    def xi(dx):
        true = inject(nominal, dx[None])
        X = _se23(true.nav.C_nb[0], true.nav.vel_n[0], true.nav.pos_n[0])
        xi_R, xi_v, xi_p = _se23_log(X @ np.linalg.inv(X_hat))
        return np.concatenate([xi_p, xi_R, xi_v])        # the state's order: pos, att, vel

    T = invariant_map(nominal.nav.C_nb, nominal.nav.pos_n)
    h = 1e-6
    for j in range(9):
        dx = np.zeros(STATE.dim)
        dx[j] = h
        col = (xi(dx) - xi(-dx)) / (2 * h)
        np.testing.assert_allclose(col, T[:9, j], atol=1e-6 * max(1.0, np.abs(T[:9, j]).max()), err_msg=f"column {j}")
    np.testing.assert_array_equal(T[9:, 9:], np.eye(STATE.dim - 9))


def test_the_retraction_is_the_group_product(nominal):
    rng = np.random.default_rng(6)
    dx = rng.normal(0.0, 1.0, STATE.dim) * np.r_[[3.0] * 3, [0.02] * 3, [0.1] * 3, [1e-3] * 11]
    new, M = retract(nominal, dx[None])
    T = invariant_map(nominal.nav.C_nb, nominal.nav.pos_n)
    d_xi = T @ dx
    X_new = _se23_exp(d_xi[STATE.att], d_xi[STATE.vel], d_xi[STATE.pos]) @ _se23(
        nominal.nav.C_nb, nominal.nav.vel_n, nominal.nav.pos_n)
    np.testing.assert_allclose(new.nav.C_nb[0], X_new[:3, :3], atol=1e-14)
    np.testing.assert_allclose(new.nav.vel_n[0], X_new[:3, 3], atol=1e-13)
    np.testing.assert_allclose(new.nav.pos_n[0], X_new[:3, 4], atol=1e-10)  # metres, from 1.7 km
    np.testing.assert_allclose(new.dvl_bias[0], nominal.dvl_bias + dx[STATE.b_dvl], atol=0.0)
    # the carry: T(after)^-1 T(before), whatever the origin
    T_after = invariant_map(new.nav.C_nb[0], new.nav.pos_n[0])
    np.testing.assert_allclose(M[0], np.linalg.solve(T_after, T), atol=1e-12)
    shifted = np.array([-4e4, 2e4, 10.0])
    np.testing.assert_allclose(M[0], np.linalg.solve(invariant_map(new.nav.C_nb[0], new.nav.pos_n[0] + shifted),
                                                     invariant_map(nominal.nav.C_nb, nominal.nav.pos_n + shifted)),
                               atol=1e-12)


@pytest.mark.parametrize("geodetic", [False, True])
def test_the_kernel_equals_the_reference(nominal, geodetic):
    rng = np.random.default_rng(8)
    n = 4
    noms = Nominal(NavState(np.broadcast_to(nominal.nav.pos_n, (n, 3)), rng.normal(0, 1, (n, 3)),
                            np.stack([C_nb_from_euler(rng.normal(0, [0.1, 0.1, 2.0])) for _ in range(n)])),
                   rng.normal(0, 1e-3, (n, 3)), rng.normal(0, 1e-5, (n, 3)), rng.normal(0, 5e-3, (n, 4)),
                   rng.normal(0, 5e-3, n))
    if geodetic:   # latitude, longitude [rad], depth [m]: the kernel moves them through the metric
        noms = noms.with_nav(NavState(np.array([[0.57, 0.61, 30.0]] * n), noms.nav.vel_n, noms.nav.C_nb))
    dx = rng.normal(0.0, 1.0, (n, STATE.dim)) * np.r_[[3.0] * 3, [0.02] * 3, [0.1] * 3, [1e-3] * 11]
    A = rng.normal(size=(n, STATE.dim, STATE.dim))
    P = A @ np.swapaxes(A, 1, 2)
    invariant = np.array([True, False, True, True])
    arrays = _state_arrays(noms, (n,))
    P_k = P.copy()
    retract_batch(*arrays, P_k, dx, invariant, geodetic)
    ref, M = retract(noms.with_nav(NavState(np.zeros((n, 3)), noms.nav.vel_n, noms.nav.C_nb)), dx)
    for i in range(n):
        if not invariant[i]:
            np.testing.assert_array_equal(P_k[i], P[i])
            np.testing.assert_array_equal(arrays[2][i], noms.nav.C_nb[i])
            continue
        np.testing.assert_allclose(arrays[2][i], ref.nav.C_nb[i], atol=1e-15)
        np.testing.assert_allclose(arrays[1][i], ref.nav.vel_n[i], atol=1e-14)
        np.testing.assert_allclose(P_k[i], M[i] @ P[i] @ M[i].T, rtol=0.0, atol=1e-12 * np.abs(P[i]).max())
        np.testing.assert_allclose(arrays[6][i], ref.dvl_sf[i], atol=1e-17)
        if not geodetic:
            np.testing.assert_allclose(arrays[0][i], noms.nav.pos_n[i] + ref.nav.pos_n[i], atol=1e-12)
        else:   # the same metres north and east at the estimate
            move = ref.nav.pos_n[i]
            lat0 = 0.57
            R_N, _ = radii_nav(lat0)
            np.testing.assert_allclose((arrays[0][i, 0] - lat0) * (R_N - 30.0), move[0], rtol=1e-9)
            np.testing.assert_allclose(arrays[0][i, 2] - 30.0, move[2], atol=1e-12)


def test_carry_matrix_shape_and_blocks():
    C0 = C_nb_from_euler(np.array([0.1, 0.2, 0.3]))
    C1 = exp_so3(np.array([0.01, -0.02, 0.03])) @ C0
    M = carry_matrix(C0, C1, np.array([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(M[STATE.pos, STATE.att], -skew(np.array([1.0, 2.0, 3.0])))
    np.testing.assert_allclose(M[STATE.vel, STATE.vel], C1.T @ C0)
    rest = np.ones((STATE.dim, STATE.dim), bool)
    rest[STATE.pos, STATE.att] = False
    rest[STATE.vel, STATE.vel] = False
    np.testing.assert_array_equal(M[rest], np.eye(STATE.dim)[rest])


def _run(methods, seed=4):
    config = (Config().replace("trajectory", name="figure8", duration_s=120.0)
              .replace("initial_error", mode="random").replace("run", methods=methods, aiding=("dvl", "depth", "mag")))
    rng = np.random.default_rng(seed)
    return run(config, simulate(config, rng, 2), rng)


def test_without_the_group_correction_the_bank_s_iekf_is_tc(monkeypatch):
    """The only difference between iekf and tc is the correction on SE_2(3) and the carry."""
    monkeypatch.setattr(dvl_fusion, "INVARIANT_METHODS", frozenset())
    monkeypatch.setattr(filter_bank, "INVARIANT_METHODS", frozenset())
    res = _run(("tc", "iekf"))
    for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "nees"):
        np.testing.assert_array_equal(getattr(res["iekf"], name), getattr(res["tc"], name))


def test_the_bank_s_iekf_differs_from_tc_at_second_order():
    res = _run(("tc", "iekf"))
    a, b = res["tc"], res["iekf"]
    assert not np.array_equal(a.pos_err_m, b.pos_err_m)
    np.testing.assert_allclose(b.vel_err_mps, a.vel_err_mps, atol=5e-3)
    np.testing.assert_allclose(b.pos_err_m, a.pos_err_m, atol=0.05)
