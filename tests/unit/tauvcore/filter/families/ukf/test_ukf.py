"""The unscented error-state filter (tauvcore.filter.families.ukf): known answers.

- On a measurement linear in the error its statistical linearisation is the measurement's own H, R
  and innovation, to 1e-9: the filter is the Kalman filter, and in the bank, fed only linear aiding
  (depth and a USBL fix without lever arm or latency, on the flat earth), it is the 20-state EKF at
  every epoch.
- On a nonlinear measurement (the magnetometer's Euler angles and a depth sensor off the centre,
  both through the attitude) the bank's correction with it is filterpy's unscented update
  (``UnscentedKalmanFilter.update`` with ``MerweScaledSigmaPoints(alpha=1, beta=2, kappa=0)``, an
  independent implementation, run on the error state through the same ``x_hat (+) dx``) to 1e-9,
  and differs from the extended filter's.
- It runs in the bank beside the others, with the smoother, in Monte Carlo and from the CLI.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from app.cli import main
from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.families import FAMILIES, family_of
from tauvcore.filter.families.ukf.unscented import ALPHA, BETA, KAPPA, linearize, weights
from tauvcore.filter.kernels.correction import correct_batch
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, wrap_angle

D = STATE.dim
LEVER_B_M = np.array([0.8, -0.3, 0.5])
"""A depth sensor off the centre of navigation [m], body axes: its depth turns with the attitude."""


def _nominal(rng: np.random.Generator, batch: tuple[int, ...]) -> Nominal:
    euler = rng.normal(0.0, 0.4, batch + (3,))
    C = C_nb_from_euler(euler)
    return Nominal(
        NavState(rng.normal(0.0, 50.0, batch + (3,)), rng.normal(0.0, 1.5, batch + (3,)), C),
        rng.normal(0.0, 1e-2, batch + (3,)),
        rng.normal(0.0, 1e-3, batch + (3,)),
        rng.normal(0.0, 1e-2, batch + (4,)),
        rng.normal(0.0, 1e-2, batch),
    )


def _covariance(rng: np.random.Generator, batch: tuple[int, ...], attitude_sigma_rad: float) -> np.ndarray:
    sigma = np.full(D, 0.1)
    sigma[STATE.att] = attitude_sigma_rad
    A = rng.normal(size=batch + (D, D))
    corr = A @ np.swapaxes(A, -1, -2) / D + np.eye(D)
    scale = sigma / np.sqrt(np.diagonal(corr, axis1=-2, axis2=-1))
    return corr * scale[..., :, None] * scale[..., None, :]


ADDITIVE = np.r_[np.arange(STATE.pos.start, STATE.pos.stop), np.arange(STATE.ba.start, STATE.sf_dvl.stop)]
"""The error states that add to the estimate on the flat earth (position, the biases, the scale factor)."""


def _additive(nom: Nominal) -> np.ndarray:
    return np.concatenate(
        [nom.nav.pos_n, nom.accel_bias, nom.gyro_bias, nom.dvl_bias, nom.dvl_sf[..., None]], axis=-1
    )


def test_a_linear_measurement_is_the_kalman_filter() -> None:
    rng = np.random.default_rng(5)
    batch, m = (2, 3), 4
    nom, P = _nominal(rng, batch), _covariance(rng, batch, 0.05)
    A = rng.normal(size=(m, ADDITIVE.size))
    H = np.zeros(batch + (m, D))
    H[..., ADDITIVE] = A
    z = rng.normal(size=batch + (m,))
    Rm = np.broadcast_to(np.diag(rng.uniform(0.01, 0.1, m)), batch + (m, m)).copy()

    def remeasure(at: Nominal) -> np.ndarray:
        return np.tile(z, (at.dvl_sf.shape[0] // batch[0], 1, 1)) - _additive(at) @ A.T

    nu = z - _additive(nom) @ A.T
    active = np.ones(batch + (m,), bool)
    active[0, 1, 2] = False  # a row not in use keeps what it was given
    H_s, R_s, nu_s = linearize(P, nom, remeasure, (H, Rm, nu, active), geodetic=False)
    np.testing.assert_allclose(H_s, H, atol=1e-9)
    np.testing.assert_allclose(R_s, Rm, atol=1e-9)
    np.testing.assert_allclose(nu_s, nu, atol=1e-9)
    # and so the update is the Kalman filter's
    n = batch[0] * batch[1]
    flat = (P.reshape(n, D, D).copy(), H_s.reshape(n, m, D), R_s.reshape(n, m, m), nu_s.reshape(n, m))
    dx, *_ = correct_batch(*flat, active.reshape(n, m), np.zeros(n, bool), np.inf, 0, 0)
    for i in range(n):
        a = active.reshape(n, m)[i]
        Hi, Pi = H.reshape(n, m, D)[i][a], P.reshape(n, D, D)[i]
        S = Hi @ Pi @ Hi.T + Rm.reshape(n, m, m)[i][np.ix_(a, a)]
        K = Pi @ Hi.T @ np.linalg.inv(S)
        np.testing.assert_allclose(dx[i], K @ nu.reshape(n, m)[i][a], atol=1e-9)
        np.testing.assert_allclose(flat[0][i], Pi - K @ S @ K.T, atol=1e-9)


def _attitude_and_depth(nom: Nominal) -> np.ndarray:
    """The nonlinear measurement: roll, pitch, yaw and the depth of a sensor off the centre."""
    lever_n = np.einsum("...ij,j->...i", nom.nav.C_nb, LEVER_B_M)
    return np.concatenate(
        [euler_from_C_nb(nom.nav.C_nb), nom.nav.pos_n[..., 2:3] + lever_n[..., 2:3]], axis=-1
    )


def _residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.asarray(a - b, dtype=float)
    return np.concatenate([wrap_angle(out[..., :3]), out[..., 3:]], axis=-1)


@pytest.mark.parametrize("geodetic", [False, True])
def test_the_correction_is_filterpy_s_unscented_update(geodetic: bool) -> None:
    rng = np.random.default_rng(11)
    nom, P = _nominal(rng, (1, 1)), _covariance(rng, (1, 1), 0.15)
    if geodetic:
        nom = nom.with_nav(NavState(np.array([[[0.6, 0.3, 40.0]]]), nom.nav.vel_n, nom.nav.C_nb))
    truth = inject(nom, rng.multivariate_normal(np.zeros(D), P[0, 0])[None, None], geodetic)
    Rm = np.diag([1e-4, 1e-4, 4e-4, 0.01])[None, None]
    z = _attitude_and_depth(truth) + rng.multivariate_normal(np.zeros(4), Rm[0, 0])
    nu = _residual(z, _attitude_and_depth(nom))
    H = np.zeros((1, 1, 4, D))  # the estimate's Jacobian, which the unscented filter replaces
    active = np.ones((1, 1, 4), bool)

    def remeasure(at: Nominal) -> np.ndarray:
        return _residual(z, _attitude_and_depth(at))

    H_s, R_s, nu_s = linearize(P, nom, remeasure, (H, Rm, nu, active), geodetic)
    P_post = P.reshape(1, D, D).copy()
    dx, *_ = correct_batch(
        P_post,
        H_s.reshape(1, 4, D),
        R_s.reshape(1, 4, 4),
        nu_s.reshape(1, 4),
        active.reshape(1, 4),
        np.zeros(1, bool),
        np.inf,
        0,
        0,  # no consider states
    )

    def hx(dx_one: np.ndarray) -> np.ndarray:
        return _attitude_and_depth(inject(nom, dx_one[None, None], geodetic))[0, 0]

    points = MerweScaledSigmaPoints(D, alpha=ALPHA, beta=BETA, kappa=KAPPA)
    ukf = UnscentedKalmanFilter(D, 4, 1.0, hx, lambda x, dt: x, points, residual_z=_residual)
    ukf.x, ukf.P, ukf.R = np.zeros(D), P[0, 0].copy(), Rm[0, 0]
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    ukf.update(z[0, 0])
    np.testing.assert_allclose(weights(D)[1], points.Wm, atol=1e-15)
    np.testing.assert_allclose(dx[0], ukf.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(P_post[0], ukf.P, rtol=1e-9, atol=1e-14)
    # and the attitude's curvature matters here: the extended filter's update is another
    H_ekf = np.zeros((4, D))
    for j in range(D):  # the Jacobian at the estimate, by central differences
        e = np.zeros(D)
        e[j] = 1e-7
        H_ekf[:, j] = _residual(hx(e), hx(-e)) / 2e-7
    S = H_ekf @ P[0, 0] @ H_ekf.T + Rm[0, 0]
    dx_ekf = P[0, 0] @ H_ekf.T @ np.linalg.solve(S, nu[0, 0])
    assert np.max(np.abs(dx_ekf - ukf.x)[STATE.att]) > 1e-4


LINEAR = (
    Config()
    .replace("earth", model="flat")
    .replace("trajectory", name="figure8", duration_s=60.0)
    .replace("initial_error", mode="random")
    .replace("run", methods=("lc", "ukf"), aiding=("depth", "usbl"))
    .replace("usbl", interval_s=2.0, latency_s=0.0, lever_arm_b_m=(0.0, 0.0, 0.0))
)
"""Only aiding linear in the error: depth, and USBL fixes of the centre without latency, on the flat earth."""


def test_the_bank_s_ukf_is_its_ekf_on_linear_aiding() -> None:
    results = run_streaming(LINEAR, np.random.default_rng(2), num_runs=3)
    ekf, ukf = results["lc"], results["ukf"]
    assert ukf.updates["usbl"].fused.sum() > 40 and ukf.updates["depth"].fused.sum() > 40
    for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "pos_sigma_m", "nees", "nees_block"):
        np.testing.assert_allclose(getattr(ukf, name), getattr(ekf, name), rtol=1e-9, atol=1e-9, err_msg=name)


def test_the_family_is_one_registry_entry_on_the_20_state_bank() -> None:
    family = FAMILIES["ukf"]
    assert family_of("ukf") is family and family_of("ukf-tc") is family
    assert (
        family.error_state == FAMILIES["eskf"].error_state
        and family.block_dims == FAMILIES["eskf"].block_dims
    )
    assert family.dvl_fusion == {"ukf": "lc", "ukf-tc": "tc"} and not family.in_all


def test_the_cli_runs_it_smoothed_and_in_monte_carlo(tmp_path) -> None:
    args = ["--trajectory", "figure8", "--duration", "60", "--method", "lc,ukf,ukf-tc"]
    assert main(["run", *args, "--smooth", "--json", str(tmp_path / "run.json")]) == 0
    results = json.loads((tmp_path / "run.json").read_text())["results"]
    for method in ("ukf", "ukf-tc"):
        filtered, smoothed = results[method], results[method]["smoothed"]
        assert np.all(np.array(smoothed["pos_sigma_m"]) <= np.array(filtered["pos_sigma_m"]) + 1e-9)
        assert (
            np.array(smoothed["pos_sigma_m"])[len(smoothed["t"]) // 2]
            < np.array(filtered["pos_sigma_m"])[len(filtered["t"]) // 2]
        )
    assert main(["mc", *args, "--runs", "3", "--out", str(tmp_path / "mc")]) == 0
    assert any((tmp_path / "mc").iterdir())
