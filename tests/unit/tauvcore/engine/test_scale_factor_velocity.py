"""The DVL scale factor's column of H at an averaged body velocity (tauvcore.engine.scale_factor):
the rows it rewrites and the ones it leaves, the average's known answers, and the bank using it."""

import math

import numpy as np
import pytest

from tauvcore.aiding.dvl_extended import MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC
from tauvcore.config import Config, FilterConfig
from tauvcore.engine.mission import run
from tauvcore.engine.results import SENSOR_STATES
from tauvcore.engine.scale_factor import VelocityAverage, body_velocity, scale_factor_rows
from tauvcore.engine.simulation import simulate
from tauvcore.filter.kernels.dvl_kernels import lc_jacobian_batch, partial_sensor_row_into, tc_jacobian_batch
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.validation import ConfigError

A_B = np.asarray(Config().dvl.A_b, dtype=float)
L_B = np.array([0.6, 0.0, 0.15])
W_IE = np.array([6.1e-5, 0.0, -3.9e-5])
SF = STATE.sf_dvl.start


@pytest.fixture
def bank():
    """Two methods x three runs: attitudes, velocities, scale factors and both kernels' rows."""
    rng = np.random.default_rng(3)
    C = np.stack([C_nb_from_euler(rng.normal(0.0, [0.1, 0.1, 2.0])) for _ in range(6)])
    vel_n = rng.normal(0.0, 1.5, (6, 3))
    sf = rng.normal(0.0, 0.01, 6)
    A_pinv = np.broadcast_to(np.linalg.pinv(A_B), (6, 3, 4)).copy()
    H = np.zeros((6, 4, STATE.dim))
    H[:, :3] = lc_jacobian_batch(C, vel_n, sf, A_pinv, W_IE, L_B)
    H_tc = tc_jacobian_batch(A_B, C, vel_n, sf, W_IE, L_B)
    H[3:] = H_tc[3:]                      # filters 3-5 tightly coupled: four beam rows
    # filter 2 a two-beam construction: velocity rows with the compensated beams' weights c
    c = rng.normal(0.0, 0.5, (3, 4))
    H[2] = 0.0
    for k in range(3):
        partial_sensor_row_into(c[k], A_B, C[2].T @ vel_n[2], sf[2], H[2, k])
        H[2, k, STATE.vel.start + k] = 1.0
    return {"C": C.reshape(2, 3, 3, 3), "vel_n": vel_n.reshape(2, 3, 3), "sf": sf.reshape(2, 3),
            "H": H.reshape(2, 3, 4, STATE.dim), "c": c}


MODES = np.array([[MODE_LC, MODE_LC, MODE_PARTIAL], [MODE_TC, MODE_COAST, MODE_TC]])


def test_at_the_current_estimate_the_rows_are_the_kernels(bank):
    H = bank["H"].copy()
    scale_factor_rows(H, MODES, A_B, body_velocity(bank["C"], bank["vel_n"]))
    np.testing.assert_allclose(H, bank["H"], rtol=0.0, atol=1e-14)


def test_the_column_is_the_reference_velocity_seen_by_each_row(bank):
    H = bank["H"].copy()
    v_ref = np.random.default_rng(4).normal(0.0, 2.0, (2, 3, 3))
    scale_factor_rows(H, MODES, A_B, v_ref)
    # loosely coupled: the velocity itself; tightly coupled: its projection on each beam;
    # two beams: the construction's weights on the beams' share, over 1 + SF_hat
    np.testing.assert_allclose(H[0, 0, :3, SF], v_ref[0, 0], rtol=1e-13)
    np.testing.assert_allclose(H[0, 1, :3, SF], v_ref[0, 1], rtol=1e-13)
    np.testing.assert_allclose(H[1, 0, :, SF], A_B @ v_ref[1, 0], rtol=1e-14)
    np.testing.assert_allclose(H[1, 2, :, SF], A_B @ v_ref[1, 2], rtol=1e-14)
    np.testing.assert_allclose(H[0, 2, :3, SF], bank["c"] @ A_B @ v_ref[0, 2] / (1.0 + bank["sf"][0, 2]), rtol=1e-13)
    # a coasting filter is left as it was, and so is every other column
    np.testing.assert_array_equal(H[1, 1], bank["H"][1, 1])
    other = np.arange(STATE.dim) != SF
    np.testing.assert_array_equal(H[..., other], bank["H"][..., other])


def test_the_average_is_exponential_in_time_and_restarts_after_a_reset():
    avg = VelocityAverage(300.0)
    v0 = np.array([[[2.0, 0.0, 0.0], [1.0, 0.5, 0.0]]])
    np.testing.assert_array_equal(avg.reference(v0), v0)        # the first ping: the estimate itself
    avg.update(v0, 1.0, np.zeros((1, 2), bool))
    v1 = v0 + np.array([0.3, -0.2, 0.1])
    avg.update(v1, 31.0, np.array([[False, True]]))
    w = 1.0 - math.exp(-30.0 / 300.0)
    np.testing.assert_allclose(avg.v_ref_b[0, 0], v0[0, 0] + w * np.array([0.3, -0.2, 0.1]), rtol=1e-15)
    np.testing.assert_array_equal(avg.v_ref_b[0, 1], v1[0, 1])   # reset: restarted at the new velocity
    for k in range(2, 40):                                      # a constant velocity: the average converges
        avg.update(v1, 31.0 + 300.0 * k, np.zeros((1, 2), bool))
    np.testing.assert_allclose(avg.v_ref_b, v1, rtol=1e-12)


@pytest.mark.parametrize("bad", [-1.0, 86401.0, float("nan"), "300"])
def test_a_time_constant_out_of_range_is_refused(bad):
    with pytest.raises(ConfigError, match=r"filter\.scale_factor_velocity_tau_s"):
        FilterConfig(scale_factor_velocity_tau_s=bad)


def _lc_straight(tau_s: float) -> dict:
    config = (Config().replace("trajectory", name="straight", duration_s=1800.0)
              .replace("imu", rate_hz=50.0).replace("filter", output_rate_hz=1.0, scale_factor_velocity_tau_s=tau_s)
              .replace("run", methods=("lc", "tc"), aiding=("dvl", "depth", "mag")))
    rng = np.random.default_rng(11)
    return run(config, simulate(config, rng, 2), rng, sensor_errors=True)


def test_the_bank_evaluates_the_column_at_the_average():
    """Against the plain EKF on the same pings: the same until the estimate leaves the average, then
    the scale factor no longer follows the velocity estimate's noise."""
    plain, averaged = _lc_straight(0.0), _lc_straight(300.0)
    sf_col = [s.name for s in SENSOR_STATES].index("sf_dvl")
    for method in ("lc", "tc"):
        a, b = plain[method], averaged[method]
        np.testing.assert_array_equal(a.t_s, b.t_s)
        # the first ping's column is the estimate in both: the first record after it agrees
        np.testing.assert_allclose(b.sensor_est[1, :, sf_col], a.sensor_est[1, :, sf_col], rtol=0.0, atol=1e-6)
        drift_plain = a.sensor_est[-1, :, sf_col] - a.sensor_est[600, :, sf_col]
        drift_avg = b.sensor_est[-1, :, sf_col] - b.sensor_est[600, :, sf_col]
        assert np.all(drift_plain < -2e-3)                       # the plain EKF's scale factor slides down
        assert np.all(np.abs(drift_avg) < 0.5 * np.abs(drift_plain))
