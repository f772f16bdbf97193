"""The registry's sources in Yoo 2014's 12-state filter (tauvcore.engine.yoo_sources): the
consider-state correction against the plain Kalman update, and the magnetometer fused by both
methods (the depth and a USBL, which need a position state, left out)."""

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.yoo_sources import COLUMNS, yoo_H
from tauvcore.eval.consistency import method_consistency
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.layout import STATE

N = yoo.DIM + 5  # the 12 states and the bank's 5 consider states


def _spd(rng: np.random.Generator, n: int, batch: tuple[int, ...] = ()) -> np.ndarray:
    A = rng.standard_normal(batch + (n, n))
    return A @ A.swapaxes(-1, -2) / n + 0.1 * np.eye(n)


def _problem(seed: int, m: int = 3):
    rng = np.random.default_rng(seed)
    P = _spd(rng, N, (4,))
    H = rng.standard_normal((4, m, N))
    Rm = _spd(rng, m, (4,))
    nu = 0.3 * rng.standard_normal((4, m))
    return P, H, Rm, nu


def test_the_correction_is_the_kalman_update_with_the_consider_rows_of_the_gain_zeroed() -> None:
    P, H, Rm, nu = _problem(0)
    active = np.ones(nu.shape, bool)
    P_new, dx, (s_diag, keep, nis, ratio, unusable) = yoo.correct_consider(P, H, Rm, nu, active, False, 1e6)
    S = H @ P @ H.swapaxes(-1, -2) + Rm
    K = P @ H.swapaxes(-1, -2) @ np.linalg.inv(S)
    K[:, yoo.DIM:] = 0.0
    I_KH = np.eye(N) - K @ H
    expected = I_KH @ P @ I_KH.swapaxes(-1, -2) + K @ Rm @ K.swapaxes(-1, -2)
    np.testing.assert_allclose(P_new, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(dx, np.einsum("bij,bj->bi", K, nu), rtol=0, atol=1e-12)
    assert not dx[:, yoo.DIM :].any()
    np.testing.assert_allclose(P_new[:, yoo.DIM:, yoo.DIM:], P[:, yoo.DIM:, yoo.DIM:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(s_diag, np.einsum("bii->bi", S), rtol=1e-12)
    np.testing.assert_allclose(nis, np.einsum("bi,bij,bj->b", nu, np.linalg.inv(S), nu), rtol=1e-10)
    np.testing.assert_allclose(ratio, np.max(nu**2 / (1e12 * np.einsum("bii->bi", S)), axis=-1), rtol=1e-10)
    assert keep.all() and not unusable.any()
    # with no consider state correlated to the rest, the Joseph form is the textbook (I - K H) P
    P0 = P.copy()
    P0[:, : yoo.DIM, yoo.DIM:] = P0[:, yoo.DIM:, : yoo.DIM] = 0.0
    H0 = H.copy()
    H0[..., yoo.DIM:] = 0.0
    P_new0, _, _ = yoo.correct_consider(P0, H0, Rm, nu, active, False, 1e6)
    K0 = P0 @ H0.swapaxes(-1, -2) @ np.linalg.inv(H0 @ P0 @ H0.swapaxes(-1, -2) + Rm)
    np.testing.assert_allclose(P_new0, (np.eye(N) - K0 @ H0) @ P0, rtol=0, atol=1e-12)


def test_an_inactive_row_is_dropped_exactly() -> None:
    P, H, Rm, nu = _problem(1)
    active = np.ones(nu.shape, bool)
    active[:, 1] = False
    nu_bad = nu.copy()
    nu_bad[:, 1] = np.nan  # what an unmeasured row may carry
    P_new, dx, (s_diag, keep, nis, _, _) = yoo.correct_consider(P, H, Rm, nu_bad, active, False, 1e6)
    rows = [0, 2]
    P_two, dx_two, (s_two, _, nis_two, _, _) = yoo.correct_consider(
        P, H[:, rows], Rm[:, rows][:, :, rows], nu[:, rows], np.ones((4, 2), bool), False, 1e6
    )
    np.testing.assert_allclose(P_new, P_two, rtol=0, atol=1e-12)
    np.testing.assert_allclose(dx, dx_two, rtol=0, atol=1e-12)
    np.testing.assert_allclose(nis, nis_two, rtol=1e-12)
    assert np.isnan(s_diag[:, 1]).all() and not keep[:, 1].any()


@pytest.mark.parametrize("gate_rows", [False, True])
def test_the_gate_refuses_the_vector_or_only_its_failing_row(gate_rows: bool) -> None:
    P, H, Rm, nu = _problem(2)
    S = H @ P @ H.swapaxes(-1, -2) + Rm
    nu[:, 2] = 10.0 * np.sqrt(S[:, 2, 2])  # 10 sigma off: beyond a 3-sigma gate
    nu[:, :2] = 0.1 * np.sqrt(np.einsum("bii->bi", S)[:, :2])
    active = np.ones(nu.shape, bool)
    P_new, dx, (_, keep, _, ratio, _) = yoo.correct_consider(P, H, Rm, nu, active, gate_rows, 3.0)
    assert (ratio > 1.0).all()
    if gate_rows:
        assert keep[:, :2].all() and not keep[:, 2].any()
        P_two, dx_two, _ = yoo.correct_consider(P, H[:, :2], Rm[:, :2, :2], nu[:, :2], active[:, :2], True, 3.0)
        np.testing.assert_allclose(P_new, P_two, rtol=0, atol=1e-12)
        np.testing.assert_allclose(dx, dx_two, rtol=0, atol=1e-12)
    else:
        assert not keep.any() and not dx.any()
        np.testing.assert_array_equal(P_new, P)


def test_a_non_finite_S_fuses_nothing_and_says_so() -> None:
    P, H, Rm, nu = _problem(3)
    Rm[0, 1, 1] = np.inf
    P_new, dx, (_, keep, nis, _, unusable) = yoo.correct_consider(P, H, Rm, nu, np.ones(nu.shape, bool), False, 1e6)
    assert unusable[0] and not unusable[1:].any() and not keep[0].any() and np.isnan(nis[0])
    np.testing.assert_array_equal(P_new[0], P[0])
    assert not dx[0].any() and keep[1:].all()


def test_a_20_state_H_maps_onto_the_12_states_column_for_column() -> None:
    H = np.random.default_rng(4).standard_normal((2, 3, STATE.dim))
    small = yoo_H(H, N)
    for big, twelve in COLUMNS.values():
        np.testing.assert_array_equal(small[..., twelve], H[..., big])
    assert not small[..., yoo.VEL].any() and not small[..., yoo.DIM:].any()


def _longrange(duration_s: float, aiding: tuple[str, ...]) -> Config:
    raw = merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange", "duration_s": duration_s},
                                                 "run": {"methods": ["ins-dvl", "vkf"], "aiding": list(aiding)}})
    return from_dict(raw)


def test_the_magnetometer_holds_yoos_heading_and_stays_consistent() -> None:
    """On Yoo's long-range mission (600 s, 5 runs), the magnetometer's attitude bounds both
    methods' heading error, which the DVL alone leaves to drift, and the heading's NEES and the
    magnetometer's NIS stay near their dimension."""
    rngs = lambda: [np.random.default_rng(s) for s in range(5)]  # noqa: E731
    without = run_streaming(_longrange(600.0, ("dvl",)), rngs(), num_runs=5)
    with_mag = run_streaming(_longrange(600.0, ("dvl", "mag")), rngs(), num_runs=5)
    for method in ("ins-dvl", "vkf"):
        late = with_mag[method].t_s > 300.0
        assert np.sqrt(np.mean(with_mag[method].heading_err_deg[late] ** 2)) < 0.7 * np.sqrt(
            np.mean(without[method].heading_err_deg[late] ** 2)
        ), method
        c = method_consistency(with_mag[method])
        assert 0.3 < c.nees["heading"].per_dim < 3.0, (method, c.nees["heading"].per_dim)
        assert 0.7 < c.nis["mag"].per_dof < 1.3, (method, c.nis["mag"].per_dof)
        assert "mag" not in without[method].updates


def test_yoos_methods_with_the_magnetometer_do_not_depend_on_the_chunk_size() -> None:
    config = _longrange(60.0, ("dvl", "mag"))
    a = run_streaming(config, np.random.default_rng(3), chunk_s=10.0)
    b = run_streaming(config, np.random.default_rng(3), chunk_s=3.7)
    for method in a:
        np.testing.assert_array_equal(a[method].heading_err_deg, b[method].heading_err_deg, err_msg=method)
        np.testing.assert_array_equal(a[method].updates["mag"].innovation, b[method].updates["mag"].innovation)


def test_the_depth_and_a_usbl_are_not_fused_by_yoos_methods() -> None:
    config = Config().replace("trajectory", name="figure8", duration_s=60.0).replace(
        "run", methods=("ins-dvl", "lc"), aiding=("dvl", "depth", "mag", "usbl")
    )
    results = run_streaming(config, np.random.default_rng(0))
    assert set(results["ins-dvl"].updates) == {"dvl", "mag"}
    assert {"dvl", "depth", "mag", "usbl"} <= set(results["lc"].updates)
