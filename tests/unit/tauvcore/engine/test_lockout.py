"""Recovery from a lock-out: the velocity reset to the DVL (known answers, the reset's Jacobian
against finite differences, the covariance it leaves), the monitor's reading of a reset, the
study's count, and a run the gate locked out from its first ping that now recovers."""

import numpy as np
import pytest

from tauvcore.config import Config, FilterConfig
from tauvcore.engine.lockout import BeamGeometry, BeamPing, dvl_velocity_reset, reset_jacobian
from tauvcore.engine.monitor import LOCKOUT_UPDATES, RESET_REPEAT_UPDATES, innovation_divergence_s
from tauvcore.eval.study import ChunkSeries, StudyAccumulator, run_chunk
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.validation import ConfigError

A_B = Config().dvl.A_b
L_B = np.array([0.4, -0.05, 0.2])


def _ping(v_b, sf, b, omega_nb_b, available):
    """A noise-free ping of the DVL model (tauvcore.sensors.dvl): (1 + sf) A v + A (omega x l) + b."""
    y = (1.0 + sf) * A_B @ v_b + A_B @ np.cross(omega_nb_b, L_B) + b
    return np.where(available, y, np.nan)


@pytest.fixture
def case():
    rng = np.random.default_rng(7)
    C = C_nb_from_euler(np.array([0.1, -0.05, 2.0]))
    return {
        "C": C,
        "v_true_b": np.array([2.0, 0.1, -0.05]),
        "sf": 0.004,
        "b": rng.normal(0.0, 0.005, 4),
        "bg": rng.normal(0.0, 1e-4, 3),
        "omega": np.array([0.01, -0.02, 0.15]),  # the gyro's body rate relative to n, bias included
        "P": np.diag(rng.uniform(0.5, 2.0, STATE.dim) * 1e-2),
    }


@pytest.mark.parametrize("beams", [(1, 2, 3, 4), (1, 2, 4), (2, 3, 4)])
def test_with_three_or_four_beams_the_velocity_is_the_ping_s(case, beams):
    available = np.isin(np.arange(1, 5), beams)
    y = _ping(case["v_true_b"], case["sf"], case["b"], case["omega"] - case["bg"], available)
    wrong_n = np.array([5.0, -3.0, 1.0])  # kilometres from anywhere, as after a long lock-out
    vel_n, P = dvl_velocity_reset(wrong_n, case["P"], case["C"], (case["sf"], case["b"], case["bg"]), BeamPing(y, available, case["omega"]),
                              BeamGeometry(A_B, L_B, 0.0))
    np.testing.assert_allclose(vel_n, case["C"] @ case["v_true_b"], atol=1e-12)
    np.testing.assert_allclose(P, P.T, atol=0.0)


def test_with_two_beams_the_unseen_component_is_kept(case):
    available = np.array([True, True, False, False])
    y = _ping(case["v_true_b"], case["sf"], case["b"], case["omega"] - case["bg"], available)
    before_b = case["v_true_b"] + np.array([0.8, -0.4, 0.3])
    vel_n, _ = dvl_velocity_reset(case["C"] @ before_b, case["P"], case["C"], (case["sf"], case["b"], case["bg"]), BeamPing(y, available, case["omega"]),
                              BeamGeometry(A_B, L_B, 0.0))
    after_b = case["C"].T @ vel_n
    A2 = A_B[:2]
    np.testing.assert_allclose(A2 @ after_b, A2 @ case["v_true_b"], atol=1e-12)   # what the beams see
    null = np.linalg.svd(A2)[2][-1]                                                 # what they do not
    assert null @ after_b == pytest.approx(null @ before_b, abs=1e-12)
    assert abs(null @ (after_b - case["v_true_b"])) > 0.1


@pytest.mark.parametrize("beams", [(1, 2, 3, 4), (1, 2), (2, 3, 4)])
def test_the_reset_s_jacobian_matches_finite_differences(case, beams):
    """dx+ = J dx: the error after the reset, to first order, for errors of velocity, beam biases,
    scale factor and gyro bias (the ping noise-free)."""
    available = np.isin(np.arange(1, 5), beams)
    C, sf_hat, b_hat, bg_hat = case["C"], case["sf"], case["b"], case["bg"]
    v_hat_b = np.array([1.9, 0.2, 0.02])

    def error_after(dx):
        v_true = v_hat_b + dx[STATE.vel]
        b_true, sf_true, bg_true = b_hat + dx[STATE.b_dvl], sf_hat + dx[STATE.sf_dvl][0], bg_hat + dx[STATE.bg]
        y = _ping(v_true, sf_true, b_true, case["omega"] - bg_true, available)
        vel_n, _ = dvl_velocity_reset(C @ v_hat_b, case["P"], C, (sf_hat, b_hat, bg_hat), BeamPing(y, available, case["omega"]),
                              BeamGeometry(A_B, L_B, 0.0))
        return v_true - C.T @ vel_n

    J = reset_jacobian(v_hat_b, sf_hat, available, A_B, L_B)
    h = 1e-6
    numeric = np.zeros((3, STATE.dim))
    for i in range(STATE.dim):
        e = np.zeros(STATE.dim)
        e[i] = h
        numeric[:, i] = (error_after(e) - error_after(-e)) / (2 * h)
    np.testing.assert_allclose(J[STATE.vel], numeric, atol=1e-8)
    others = np.ones(STATE.dim, bool)
    others[STATE.vel] = False
    np.testing.assert_array_equal(J[others], np.eye(STATE.dim)[others])   # only the velocity is reset


def test_the_covariance_after_the_reset_is_j_p_jt_and_the_ping_s_noise(case):
    available = np.array([True, True, True, False])
    y = _ping(case["v_true_b"], case["sf"], case["b"], case["omega"] - case["bg"], available)
    v_hat_n = case["C"] @ (case["v_true_b"] + 0.3)
    beam_var = 0.042**2
    _, P = dvl_velocity_reset(v_hat_n, case["P"], case["C"], (case["sf"], case["b"], case["bg"]), BeamPing(y, available, case["omega"]),
                              BeamGeometry(A_B, L_B, beam_var))
    J = reset_jacobian(case["C"].T @ v_hat_n, case["sf"], available, A_B, L_B)
    A_pinv = np.linalg.pinv(A_B[available])
    expected = J @ case["P"] @ J.T
    expected[STATE.vel, STATE.vel] += beam_var * A_pinv @ A_pinv.T / (1 + case["sf"]) ** 2
    np.testing.assert_allclose(P, expected, atol=1e-15)


def _monitor(fused, reset, nis=None):
    U = fused.shape[0]
    t = np.arange(1.0, U + 1.0)
    nis = np.where(fused, 3.0, 400.0)[:, None] if nis is None else nis
    return innovation_divergence_s(t, nis, np.full((U, 1), 3), fused[:, None], np.ones((U, 1), bool),
                                   reset=None if reset is None else reset[:, None])[0]


def test_a_reset_explains_the_rejections_before_it_and_the_window_starts_again():
    fused = np.ones(200, bool)
    fused[50:60] = False
    assert 51.0 <= _monitor(fused, None) < 50.0 + LOCKOUT_UPDATES  # the NIS window, before the lock-out
    reset = np.zeros(200, bool)
    reset[59] = True  # the 10th rejection: the velocity reset to it
    assert np.isnan(_monitor(fused, reset))


def test_a_reset_soon_after_another_is_a_lock_out_after_all():
    fused = np.ones(250, bool)
    fused[50:60] = False
    fused[70:80] = False
    reset = np.zeros(250, bool)
    reset[[59, 79]] = True
    assert 79 - 59 <= RESET_REPEAT_UPDATES
    assert _monitor(fused, reset) == 80.0
    fused[70:80], reset[79] = True, False
    fused[170:180], reset[179] = False, True  # 120 updates later: recovered in between
    assert np.isnan(_monitor(fused, reset))


def test_the_setting_is_a_whole_number_within_its_range():
    assert FilterConfig(lockout_reset_updates=0).lockout_reset_updates == 0
    for bad in (-1, 1001, 2.5, True, "10"):
        with pytest.raises(ConfigError, match=r"filter\.lockout_reset_updates must be a whole number"):
            FilterConfig(lockout_reset_updates=bad)


def _paper_run_54(lockout_reset_updates):
    """Run 54 of the paper's study (`tauv reproduce`), LC on the straight line: its initial tilt
    was drawn at 4 sigma, and the gate rejects every ping from the first."""
    config = Config().replace("earth", model="flat").replace("run", methods=("lc",))
    config = config.replace("filter", lockout_reset_updates=lockout_reset_updates)
    return run_chunk(config, config.run.seed, 54, 1)["lc"]


def test_a_run_locked_out_from_its_first_ping_recovers_after_its_reset():
    stuck = _paper_run_54(0)
    assert stuck.diverged[0] and stuck.diverged_at_s[0] == 10.0
    assert stuck.vel_err_mps[-1, 0] > 50.0  # the free INS's drift: the gate never lets the DVL back
    assert not stuck.updates["dvl"].reset.any()
    res = _paper_run_54(10)
    dvl = res.updates["dvl"]
    assert not res.diverged[0]
    np.testing.assert_array_equal(dvl.t_s[dvl.reset[:, 0]], [10.0])  # the 10th rejected ping
    assert not dvl.fused[:10, 0].any() and dvl.fused[10:, 0].all()    # the next one fused, and all after
    assert dvl.test_ratio[10, 0] > 1.0  # beyond the gate: fused because it followed the reset
    assert res.vel_err_mps[-1, 0] < 0.2 and res.pos_err_m[-1, 0] < 60.0


def test_a_study_counts_the_resets_per_method_and_names_the_runs():
    acc = StudyAccumulator(("lc",))
    T = 3
    series = {"lc": {n: np.zeros((T, 2)) for n in _series_names()}}
    acc.add(ChunkSeries(first=0, count=2, t_s=np.arange(T, dtype=float), series=series,
                        diverged={"lc": np.zeros(2, bool)}, resets={"lc": np.array([0, 2])}))
    acc.add(ChunkSeries(first=2, count=2, t_s=np.arange(T, dtype=float), series=series,
                        diverged={"lc": np.zeros(2, bool)}, resets={"lc": np.array([1, 0])}))
    lc = acc.summary()["methods"]["lc"]
    assert lc["lockout_resets"] == 3 and lc["reset_runs"] == [1, 2]


def _series_names():
    from tauvcore.eval.study import ERROR_SERIES, NEES_SERIES, SIGMA_SERIES
    return ERROR_SERIES + SIGMA_SERIES + NEES_SERIES
