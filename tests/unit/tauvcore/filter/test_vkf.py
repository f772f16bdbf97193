"""The velocity Kalman filter of Yoo 2014 eq. 20-29 (tauvcore.filter.vkf): the product's compiled
step (tauvcore.filter.families.yoo.model_kernels.vkf_step, what both banks run) and the numpy reference
(vkf_reference.py, beside this file) equal the plain filterpy loop, known answers of the filter,
of eq. 27-28 and of the switch (eq. 29), and the config's messages."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tauvcore.filter.vkf import VkfConfig
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.validation import ConfigError
from tests.unit.tauvcore.filter import vkf_reference as vkf

DEG = math.pi / 180.0


# ----------------------------------------------------------------------------- batched == filterpy

def _seeded_runs(rng: np.random.Generator, cfg: VkfConfig, num_steps: int,
                 num_runs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """RPM levels drawn per run (500-1000 rpm, a new level every 30 s, plus 2 rpm of jitter), a
    truth that follows the filter's own model, DVL noise of R, a gap of 30-60 s at a different
    time in every run and 10 % random dropouts; z NaN where the DVL has no lock."""
    steps_per_level = int(round(30.0 / cfg.step_s))
    levels = rng.uniform(500.0, 1000.0, (num_steps // steps_per_level + 1, num_runs))
    rpm = np.repeat(levels, steps_per_level, axis=0)[:num_steps] + rng.normal(0.0, 2.0, (num_steps, num_runs))
    x = cfg.x0 + rng.standard_normal((num_runs, 3)) * np.sqrt(np.diag(cfg.P0))
    z = np.empty((num_steps, num_runs))
    for k in range(num_steps):
        x = np.einsum("rij,rj->ri", vkf.transition(rpm[k]), x) + rng.standard_normal((num_runs, 3)) * np.sqrt(
            np.diag(cfg.Q))
        z[k] = x[:, 0] + rng.normal(0.0, cfg.dvl_forward_noise_mps, num_runs)
    k = np.arange(num_steps)[:, None]
    start = rng.integers(0, num_steps // 2, num_runs)
    length = rng.integers(int(30 / cfg.step_s), int(60 / cfg.step_s), num_runs)
    valid = ~((k >= start) & (k < start + length)) & (rng.random((num_steps, num_runs)) >= 0.1)
    return rpm, np.where(valid, z, np.nan), valid


@pytest.fixture(scope="module", params=[VkfConfig(), VkfConfig(forward_speed="norm", step_s=1.0, v_noise_mps=0.0,
                                                                dvl_forward_noise_mps=0.3)],
                ids=["defaults", "1Hz-noV-noise"])
def batch_and_reference(request: pytest.FixtureRequest) -> tuple:
    cfg = request.param
    rng = np.random.default_rng(20140903)
    rpm, z, valid = _seeded_runs(rng, cfg, num_steps=1200, num_runs=4)
    ours = vkf.run_vkf_batch(rpm, z, valid, cfg)
    refs = [vkf.vkf_filterpy(rpm[:, r], z[:, r], valid[:, r], cfg) for r in range(rpm.shape[1])]
    return ours, refs, valid, cfg, rpm, z


def test_batched_equals_filterpy_to_1e9(batch_and_reference: tuple) -> None:
    ours, refs, valid = batch_and_reference[:3]
    for r, ref in enumerate(refs):
        sig = np.sqrt(np.diagonal(ref.P, axis1=-2, axis2=-1))                       # (K, 3)
        # x relative to its own size or, near zero, to its sigma; P as correlation-scaled entries
        dx = np.abs(ours.x[:, r] - ref.x) / np.maximum(np.abs(ref.x), sig)
        dP = np.abs(ours.P[:, r] - ref.P) / (sig[:, :, None] * sig[:, None, :])
        assert dx.max() <= 1e-9 and dP.max() <= 1e-9, (r, dx.max(), dP.max())
        upd = valid[:, r]
        assert np.array_equal(np.isnan(ref.innovation), ~upd) and np.array_equal(np.isnan(ours.innovation[:, r]), ~upd)
        dy = np.abs(ours.innovation[upd, r] - ref.innovation[upd]) / np.sqrt(ref.innovation_var[upd])
        dS = np.abs(ours.innovation_var[upd, r] / ref.innovation_var[upd] - 1.0)
        assert dy.max() <= 1e-9 and dS.max() <= 1e-9
    # the comparison is not empty: gaps and updates in every run, and the filter learned something
    assert valid.any(axis=0).all() and (~valid).sum(axis=0).min() >= 100
    assert (ours.P[-1, :, 1, 1] < 0.1 * ours.P[0, :, 1, 1]).all()


def test_the_compiled_step_equals_filterpy_to_1e9(batch_and_reference: tuple) -> None:
    """yoo_kernels.vkf_step, stepped as the banks step it (the DVL chosen, its speed fused where
    valid), gives filterpy's posteriors to 1e-9 at every step of every run, and the switch's
    answers: the DVL chosen where it is valid, an RPM read at every step."""
    from tauvcore.filter.families.yoo.model_kernels import vkf_step

    cfg = batch_and_reference[3]
    refs, valid, rpm, z = batch_and_reference[1], batch_and_reference[2], batch_and_reference[4], batch_and_reference[5]
    Q = np.ascontiguousarray(cfg.Q)
    for r, ref in enumerate(refs):
        x, P = cfg.x0.astype(float).copy(), np.array(cfg.P0, dtype=float)
        for k in range(rpm.shape[0]):
            use_rpm, have_rpm = vkf_step(x, P, float(rpm[k, r]), 0.0, float(z[k, r]), bool(valid[k, r]), Q, cfg.R,
                                         cfg.switch_altitude_m)
            assert have_rpm and use_rpm == (not valid[k, r])
            sig = np.sqrt(np.diag(ref.P[k]))
            assert np.all(np.abs(x - ref.x[k]) <= 1e-9 * np.maximum(np.abs(ref.x[k]), sig)), (r, k)
            assert np.all(np.abs(P - ref.P[k]) <= 1e-9 * np.outer(sig, sig)), (r, k)


def test_batched_covariance_stays_symmetric_positive_definite(batch_and_reference: tuple) -> None:
    ours = batch_and_reference[0]
    assert np.array_equal(ours.P, ours.P.swapaxes(-1, -2))
    assert (np.linalg.eigvalsh(ours.P) > 0).all()
    nis = ours.nis[np.isfinite(ours.nis)]
    assert 0.8 < nis.mean() < 1.2           # consistent data (the model's own truth): E[NIS] = 1


def test_vkf_filterpy_refuses_a_batch_and_bad_inputs() -> None:
    cfg = VkfConfig()
    with pytest.raises(ValueError, match="one run"):
        vkf.vkf_filterpy(np.ones((3, 2)), np.ones((3, 2)), np.ones((3, 2), bool), cfg)
    with pytest.raises(ValueError, match="finite wherever"):
        vkf.run_vkf_batch(np.ones((3, 2)), np.full((3, 2), np.nan), np.ones((3, 2), bool), cfg)


# ----------------------------------------------------------------------------- known answers

def test_transition_and_noise_are_eq_24_and_the_stated_densities() -> None:
    np.testing.assert_array_equal(vkf.transition(750.0), [[0, 750, -1], [0, 1, 0], [0, 0, 1]])
    cfg = VkfConfig(step_s=0.5, v_noise_mps=0.03, sf_rw_mps_per_rpm_per_sqrt_s=2e-6, b_rw_mps_per_sqrt_s=4e-4)
    np.testing.assert_allclose(np.diag(cfg.Q), [0.03 ** 2, 4e-12 * 0.5, 1.6e-7 * 0.5], rtol=1e-15)
    assert cfg.R == pytest.approx(0.087 ** 2)


SF_TRUE, B_TRUE = 0.0027, 0.25       # within 0.5 and 0.9 sigma of the default prior (0.0025, 0)


def _noise_free(rpm_levels: tuple[float, ...], seconds_each: float) -> tuple[VkfConfig, np.ndarray, vkf.VkfRun]:
    """z = rpm sf - b exactly (eq. 20), constant sf and b; the filter with no process noise and
    a small R (it must not be zero: S = P_VV + R)."""
    cfg = VkfConfig(v_noise_mps=0.0, sf_rw_mps_per_rpm_per_sqrt_s=0.0, b_rw_mps_per_sqrt_s=0.0,
                    dvl_forward_noise_mps=0.01)
    rpm = np.repeat(rpm_levels, int(round(seconds_each / cfg.step_s)))[:, None]
    z = rpm * SF_TRUE - B_TRUE
    return cfg, rpm, vkf.run_vkf_batch(rpm, z, np.ones(rpm.shape, bool), cfg)


def test_noise_free_two_rpm_levels_converge_to_the_truth() -> None:
    """60 s at 600 rpm then 60 s at 900 rpm. Without noise the estimate is the Bayesian posterior
    mean, whose only error is the prior's pull ``P_post P0^-1 (x0 - x_true)``: with 300 pings per
    level and R = (0.01 m/s)^2, sigma_sf ~ 0.01 sqrt(2/300) / 300 = 2.7e-6, so the pull on the
    5e-4 prior error is ~ (2.7e-6 / 1e-3)^2 5e-4 = 4e-9 m/s/rpm; on b ~ 1e-6 m/s. The bounds
    below are 25x those."""
    cfg, rpm, out = _noise_free((600.0, 900.0), 60.0)
    assert abs(out.x[-1, 0, 1] - SF_TRUE) < 1e-7
    assert abs(out.x[-1, 0, 2] - B_TRUE) < 2.5e-5
    assert abs(out.x[-1, 0, 0] - (900.0 * SF_TRUE - B_TRUE)) < 2.5e-5
    # and the filter knows it: both sigmas far below their prior
    assert np.sqrt(out.P[-1, 0, 1, 1]) < 1e-2 * cfg.initial_sf_sigma_mps_per_rpm
    assert np.sqrt(out.P[-1, 0, 2, 2]) < 1e-2 * cfg.initial_b_sigma_mps


def test_constant_rpm_learns_only_the_speed_and_stays_well_behaved() -> None:
    """One RPM level c: only ``c sf - b`` is observed. The posterior tends to the prior projected
    onto that line in P0's metric, ``theta0 + P0 h (h^T P0 h)^-1 (V - h^T theta0)``, h = [c, -1],
    and sf's sigma to ``sigma_sf0 sqrt(sigma_b0^2 / (c^2 sigma_sf0^2 + sigma_b0^2))`` (0.447 of
    its prior here), not to zero. P stays symmetric, its sf-b block positive definite; the whole P
    is singular here (no process noise: V = c sf - b exactly), positive semi-definite to
    round-off."""
    cfg, rpm, out = _noise_free((600.0,), 120.0)
    c = 600.0
    h = np.array([c, -1.0])
    theta0, P0 = cfg.x0[1:], cfg.P0[1:, 1:]
    V = c * SF_TRUE - B_TRUE
    expected = theta0 + P0 @ h * (V - h @ theta0) / (h @ P0 @ h)
    # finite-N remainder: the prior keeps a weight R / (N h^T P0 h) = 1e-4 / (600 x 0.45) ~ 4e-7
    np.testing.assert_allclose(out.x[-1, 0, 1:], expected, rtol=1e-5)
    assert abs(out.x[-1, 0, 0] - V) < 1e-5
    assert abs(out.x[-1, 0, 1] - SF_TRUE) > 1e-4            # sf itself NOT found: unobservable
    s0, b0 = cfg.initial_sf_sigma_mps_per_rpm, cfg.initial_b_sigma_mps
    limit = s0 * math.sqrt(b0 ** 2 / (c ** 2 * s0 ** 2 + b0 ** 2))
    assert np.sqrt(out.P[-1, 0, 1, 1]) == pytest.approx(limit, rel=1e-4)
    P = out.P[:, 0]
    assert np.array_equal(P, P.swapaxes(-1, -2))
    assert (np.linalg.eigvalsh(P[:, 1:, 1:]) > 0).all()
    eig = np.linalg.eigvalsh(P)
    assert (eig >= -1e-12 * eig[:, -1:]).all()
    u = np.array([1.0, -c, 1.0])                       # the direction V - (c sf - b): known exactly
    assert (np.abs(np.einsum("i,kij,j->k", u, P, u)) <= 1e-12 * eig[:, -1]).all()


def test_no_dvl_keeps_sf_and_b_and_converts_the_rpm() -> None:
    """Without bottom lock the filter only predicts: sf and b stay at their last value ("the
    finally assumed value") and V follows the RPM through eq. 20."""
    cfg, rpm, out = _noise_free((600.0, 900.0), 60.0)
    rpm2 = np.concatenate([rpm, np.full((50, 1), 750.0)])
    z2 = np.concatenate([rpm * SF_TRUE - B_TRUE, np.full((50, 1), np.nan)])
    valid = np.isfinite(z2)
    out2 = vkf.run_vkf_batch(rpm2, z2, valid, cfg)
    sf, b = out2.x[len(rpm) - 1, 0, 1:]
    np.testing.assert_array_equal(out2.x[len(rpm):, 0, 1], sf)
    np.testing.assert_array_equal(out2.x[len(rpm):, 0, 2], b)
    np.testing.assert_allclose(out2.x[len(rpm):, 0, 0], 750.0 * sf - b, rtol=1e-15)
    assert np.isnan(out2.innovation[len(rpm):]).all()


# ----------------------------------------------------------------------------- eq. 21, 27-28, 29

def test_forward_speed_body_x_and_the_papers_norm() -> None:
    v_n = np.array([0.3, 2.0, 0.1])
    C = C_nb_from_euler(np.array([0.0, 0.0, 90 * DEG]))             # heading east, level
    assert vkf.dvl_forward_speed(v_n, C, VkfConfig()) == pytest.approx(2.0, abs=1e-15)
    assert vkf.dvl_forward_speed(v_n, C, VkfConfig(forward_speed="norm")) == pytest.approx(math.sqrt(4.1))
    # any attitude: body x of C_nb^T v_n; batch shapes (K, R)
    rng = np.random.default_rng(7)
    euler = rng.uniform(-1.0, 1.0, (5, 4, 3))
    v = rng.normal(0.0, 2.0, (5, 4, 3))
    C = C_nb_from_euler(euler)
    expected = np.einsum("krji,krj->kri", C, v)[..., 0]
    np.testing.assert_allclose(vkf.dvl_forward_speed(v, C, VkfConfig()), expected, atol=1e-14)


def test_rpm_velocity_level_heading_90_deg_is_east() -> None:
    x = np.array([2.0, 0.006, 0.1])
    v = vkf.rpm_velocity_n(x, C_nb_from_euler(np.array([0.0, 0.0, 90 * DEG])))
    np.testing.assert_allclose(v, [0.0, 2.0, 0.0], atol=1e-15)


@pytest.mark.parametrize("roll_deg", [0.0, 40.0])
def test_rpm_velocity_nose_down_goes_down_and_roll_does_not_matter(roll_deg: float) -> None:
    x = np.array([2.0, 0.006, 0.1])
    down = vkf.rpm_velocity_n(x, C_nb_from_euler(np.array([roll_deg * DEG, -30 * DEG, 0.0])))
    np.testing.assert_allclose(down, [2.0 * math.cos(30 * DEG), 0.0, 1.0], atol=1e-15)     # +down
    up = vkf.rpm_velocity_n(x, C_nb_from_euler(np.array([roll_deg * DEG, 30 * DEG, 0.0])))
    np.testing.assert_allclose(up, [2.0 * math.cos(30 * DEG), 0.0, -1.0], atol=1e-15)


def test_rpm_velocity_is_eq_28_first_column_batched() -> None:
    rng = np.random.default_rng(28)
    phi, theta, psi = rng.uniform(-1.5, 1.5, (3, 6, 2))
    x = np.stack([rng.uniform(0.0, 5.0, (6, 2)), np.full((6, 2), 0.006), np.zeros((6, 2))], axis=-1)
    C = C_nb_from_euler(np.stack([phi, theta, psi], axis=-1))
    c11, c21, c31 = np.cos(theta) * np.cos(psi), np.cos(theta) * np.sin(psi), -np.sin(theta)
    expected = x[..., :1] * np.stack([c11, c21, c31], axis=-1)
    np.testing.assert_allclose(vkf.rpm_velocity_n(x, C), expected, atol=1e-14)


def test_switch_at_above_below_alpha_and_without_bottom() -> None:
    cfg = VkfConfig(switch_altitude_m=100.0)
    altitude = np.array([20.0, 99.999, 100.0, np.nextafter(100.0, 200.0), 150.0, np.nan])
    v_rpm = np.tile([1.0, 2.0, 3.0], (6, 1))
    v_dvl = np.tile([-1.0, -2.0, -3.0], (6, 1))
    out = vkf.switched_velocity_n(altitude, v_rpm, v_dvl, cfg)
    use_rpm = np.array([False, False, False, True, True, True])     # ES > alpha, NaN = no bottom = too high
    np.testing.assert_array_equal(out, np.where(use_rpm[:, None], v_rpm, v_dvl))
    np.testing.assert_array_equal(vkf.rpm_selected(altitude, cfg), use_rpm)
    # the DVL's NaN (no lock) never leaks where the RPM velocity is used; the threshold is the config's
    out = vkf.switched_velocity_n(np.array([150.0, 150.0]), np.ones((2, 3)), np.full((2, 3), np.nan),
                                  VkfConfig(switch_altitude_m=160.0))
    assert np.isnan(out).all()
    out = vkf.switched_velocity_n(np.array([150.0, np.nan]), np.ones((2, 3)), np.full((2, 3), np.nan), cfg)
    np.testing.assert_array_equal(out, np.ones((2, 3)))


def test_switch_broadcasts_over_time_and_runs() -> None:
    cfg = VkfConfig()
    altitude = np.array([[50.0, 120.0], [np.nan, 80.0], [100.0, 101.0]])   # (K=3, R=2)
    v_rpm, v_dvl = np.ones((3, 2, 3)), np.zeros((3, 2, 3))
    out = vkf.switched_velocity_n(altitude, v_rpm, v_dvl, cfg)
    np.testing.assert_array_equal(out[..., 0], [[0, 1], [1, 0], [0, 1]])


# ----------------------------------------------------------------------------- config

@pytest.mark.parametrize("value, shown", [(-5.0, "-5.0"), (float("nan"), "nan"), (0.0, "0.0"), (float("inf"), "inf"),
                                          (12000.0, "12000.0"), (True, "True"), ("100", "'100'")])
def test_switch_altitude_is_refused_unless_positive_and_finite(value: object, shown: str) -> None:
    with pytest.raises(ConfigError) as err:
        VkfConfig(switch_altitude_m=value)
    assert "vkf.switch_altitude_m" in str(err.value) and shown in str(err.value), str(err.value)


@pytest.mark.parametrize("field, value", [
    ("initial_sf_mps_per_rpm", float("nan")), ("initial_sf_sigma_mps_per_rpm", 0.0),
    ("initial_sf_sigma_mps_per_rpm", -1e-3), ("initial_b_mps", float("inf")), ("initial_b_sigma_mps", 0.0),
    ("initial_v_mps", float("nan")), ("initial_v_sigma_mps", -1.0), ("step_s", 0.0), ("step_s", 61.0),
    ("v_noise_mps", -0.01), ("sf_rw_mps_per_rpm_per_sqrt_s", float("nan")), ("b_rw_mps_per_sqrt_s", -1e-4),
    ("dvl_forward_noise_mps", 0.0), ("dvl_forward_noise_mps", float("nan")), ("forward_speed", "speed"),
    ("forward_speed", None),
])
def test_every_field_is_validated_with_its_name_and_value(field: str, value: object) -> None:
    with pytest.raises(ConfigError) as err:
        VkfConfig(**{field: value})
    message = str(err.value)
    assert f"vkf.{field} " in message and repr(value) in message, message


def test_defaults_and_legal_edges_are_accepted() -> None:
    cfg = VkfConfig()
    assert cfg.switch_altitude_m == 100.0 and cfg.forward_speed == "body_x"
    VkfConfig(switch_altitude_m=1e-3, initial_v_sigma_mps=0.0, v_noise_mps=0.0, sf_rw_mps_per_rpm_per_sqrt_s=0.0,
              b_rw_mps_per_sqrt_s=0.0, step_s=60.0, forward_speed="norm", initial_sf_mps_per_rpm=-0.001)
