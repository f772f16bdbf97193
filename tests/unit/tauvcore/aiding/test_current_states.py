"""The error state grows by the states a source adds: the DVL's current (north, east), which its
water-track beams observe (tauvcore.aiding.dvl_water, tauvcore.filter.layout.Layout).

- The water-track beams' H against central finite differences of their model, every block.
- The covariance step with the current block equals the dense ``Phi P Phi^T + Qd`` of the 20
  states beside a Gauss-Markov or random-walk block.
- Current states on but never observed (no water-track) leave every other number as it was (to
  1e-9): the block is exactly uncoupled.
- Chunks of any size give the numbers of one chunk.
- With water-track, the current is estimated and the filter knows its error.
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.aiding.dvl_water import CURRENT_BLOCK, WaterTrack
from tauvcore.config import Config
from tauvcore.engine.mission import run, run_streaming
from tauvcore.engine.simulation import simulate
from tauvcore.engine.source_streams import layout_of
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.layout import STATE, Layout, NavState, StateBlock
from tauvcore.geo.rotations import exp_so3
from tauvcore.sensors.dvl import DvlConfig

EPS = 1e-6
CURRENT = Layout((StateBlock(CURRENT_BLOCK, ("current_north_mps", "current_east_mps"), (0.5, 0.5),
                             (-1e-3, -1e-3), (2e-4, 2e-4)),))


def _nominal(rng: np.random.Generator, batch: tuple[int, ...] = (3,)) -> Nominal:
    C = exp_so3(rng.normal(0.0, 0.5, batch + (3,)))
    return Nominal(
        NavState(rng.normal(0.0, 10.0, batch + (3,)), rng.normal(0.0, 2.0, batch + (3,)), C),
        rng.normal(0.0, 1e-3, batch + (3,)),
        rng.normal(0.0, 1e-4, batch + (3,)),
        rng.normal(0.0, 0.01, batch + (4,)),
        rng.normal(0.0, 0.01, batch),
        rng.normal(0.0, 0.4, batch + (2,)),
    )


@pytest.mark.parametrize("seed", range(4))
def test_water_track_H_matches_finite_differences_of_its_model(seed: int) -> None:
    rng = np.random.default_rng(300 + seed)
    model = WaterTrack(DvlConfig(water_track="always"), CURRENT.slice_of(CURRENT_BLOCK), CURRENT.dim)
    nom = _nominal(rng)
    setup = model.prepare(rng.normal(0.0, 1.0, 4), np.array([True, True, False, True]),
                          rng.normal(0.0, 0.2, 3), (3,))
    H = model.jacobian(nom, setup)
    assert H.shape == (3, 4, CURRENT.dim)
    fd = np.zeros_like(H)
    for j in range(CURRENT.dim):
        e = np.zeros(CURRENT.dim)
        e[j] = EPS
        fd[..., j] = (model.predict(inject(nom, e), setup) - model.predict(inject(nom, -e), setup)) / (2 * EPS)
    fd = np.where(setup.active[..., None], fd, H)  # a beam that did not return has no row
    for name in (*STATE.names, CURRENT_BLOCK):
        cols = CURRENT.slice_of(name) if name == CURRENT_BLOCK else getattr(STATE, name)
        np.testing.assert_allclose(H[..., cols], fd[..., cols], rtol=0, atol=1e-7, err_msg=f"H columns {name}")
    assert np.abs(H[..., CURRENT.slice_of(CURRENT_BLOCK)]).max() > 0.5   # the current is seen
    # without a current the model is the bottom-track beam's
    still = Nominal(nom.nav, nom.accel_bias, nom.gyro_bias, nom.dvl_bias, nom.dvl_sf, np.zeros((3, 2)))
    v_head = nom.vel_b * (1.0 + nom.dvl_sf[..., None]) + np.cross(setup.omega_b - nom.gyro_bias,
                                                                    model.config.l_dvl_b)
    expected = np.where(setup.active, v_head @ model.config.A_b.T + nom.dvl_bias, 0.0)
    np.testing.assert_allclose(model.predict(still, setup), expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("rate", [-1e-3, 0.0])
def test_the_covariance_step_carries_the_current_block_exactly(rate: float) -> None:
    """propagate_bank over 22 states: the 20 as over 20 (bit for bit), the cross block
    ``Phi_20 P_2c phi``, the current block ``phi^2 P_cc + q (1 - phi^2) / (-2 rate)`` (``q dt``
    for a random walk): the dense step of the block-diagonal transition."""
    from tauvcore.filter.kernels.error_model_kernels import propagate_bank
    from tauvcore.geo.earth import Earth
    from tauvcore.ins.error_model import F_matrix, G_matrix, discretise
    rng = np.random.default_rng(7)
    M, R, dt, d = 1, 2, 0.1, STATE.dim + 2
    earth = Earth()
    C = exp_so3(rng.normal(0.0, 1.0, (M, R, 3)))
    vel_n = rng.normal(0.0, 2.0, (M, R, 3))
    bg = rng.normal(0.0, 1e-3, (M, R, 3))
    dtheta_sum = rng.normal(0.0, 0.05, (R, 3))
    q = rng.uniform(1e-8, 1e-2, 17)
    A = rng.normal(size=(M, R, d, d))
    P = A @ np.swapaxes(A, -1, -2) + d * np.eye(d)
    rates, qc = np.array([rate, rate]), np.array([3e-4, 5e-4])
    args = (np.ascontiguousarray(earth.g_n), np.ascontiguousarray(earth.omega_ie_n), q, False, np.zeros((0, R, 9, 15)))
    full, base = P.copy(), np.ascontiguousarray(P[..., :20, :20])
    propagate_bank(full, np.zeros(vel_n.shape), np.ascontiguousarray(C), vel_n, bg, dtheta_sum, dt, *args, rates, qc)
    propagate_bank(base, np.zeros(vel_n.shape), np.ascontiguousarray(C), vel_n, bg, dtheta_sum, dt, *args,
                   np.zeros(0), np.zeros(0))
    np.testing.assert_array_equal(full[..., :20, :20], base)
    vel_b = np.einsum("mrji,mrj->mri", C, vel_n)
    Phi, _ = discretise(F_matrix(C, vel_b, dtheta_sum[None] / dt - bg, earth), G_matrix(C, vel_b), q, dt)
    phi = np.exp(rate * dt)
    np.testing.assert_allclose(full[..., :20, 20:], Phi @ P[..., :20, 20:] * phi, rtol=1e-12, atol=1e-12)
    qd = qc * dt if rate == 0.0 else qc * (1.0 - phi**2) / (-2.0 * rate)
    np.testing.assert_allclose(full[..., 20:, 20:], phi**2 * P[..., 20:, 20:] + np.diag(qd), rtol=1e-13, atol=0)
    np.testing.assert_array_equal(full, np.swapaxes(full, -1, -2))


def _config(**dvl) -> Config:
    return (Config().replace("trajectory", name="lawnmower", duration_s=120.0, current_n_mps=(0.2, -0.25, 0.0))
            .replace("dvl", **dvl).replace("initial_error", mode="random")
            .replace("run", methods=("ins", "lc", "tc", "nsv", "iekf"), aiding=("dvl", "depth", "mag"), seed=3))


def test_current_states_never_observed_leave_every_other_number_as_it_was() -> None:
    """Without water-track nothing measures the current: its block stays uncoupled (no F, no H
    across), so every error, sigma and update equals the run without the states to 1e-9; only
    the full NEES, over 22 states, differs."""
    base = _config()
    with_states = base.replace("dvl", current_states="random-walk")
    assert layout_of(base).dim == 20 and layout_of(with_states).dim == 22
    rng = np.random.default_rng(5)
    sim = simulate(base, rng, 3)
    a = run(base, sim, np.random.default_rng(9))
    b = run(with_states, sim, np.random.default_rng(9))
    for method in base.run.methods:
        for field in ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "pos_sigma_m", "est_pos_n"):
            np.testing.assert_allclose(getattr(b[method], field), getattr(a[method], field), rtol=0, atol=1e-9,
                                       err_msg=f"{method} {field}")
        np.testing.assert_allclose(b[method].nees_block[..., :5], a[method].nees_block, rtol=1e-9, atol=1e-9)
        assert b[method].block_dims is not None and b[method].block_dims["current"] == 2
        assert a[method].block_dims is None


def test_water_track_estimates_the_current_in_chunks_as_in_one() -> None:
    """Water-track on every beam (bottom-track off) with the current states: the current's error
    shrinks from its prior; the water-track beams are recorded as the source "water"; chunks of
    any size give the same numbers."""
    config = _config(water_track="always", current_states="gauss-markov", current_sigma_mps=0.5)
    whole = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=1000.0)
    chunked = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=1.37)
    for method in ("lc", "tc", "iekf"):
        r = whole[method]
        assert "water" in r.updates and r.updates["water"].fused.any()
        assert "dvl" not in r.updates or not r.updates["dvl"].fused.any()
        np.testing.assert_allclose(chunked[method].vel_err_mps, r.vel_err_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(chunked[method].nees_block, r.nees_block, rtol=1e-9, atol=1e-9)


def test_the_smoother_leaves_unobserved_current_states_uncoupled() -> None:
    """The smoother over 22 states, the current never observed: every smoothed number of the 20
    equals the smoothed run without the states to 1e-9."""
    from tauvcore.engine.smoothing import SmoothOptions
    base = _config()
    with_states = base.replace("dvl", current_states="gauss-markov")
    sim = simulate(base, np.random.default_rng(5), 2)
    a = run(base, sim, np.random.default_rng(9), smooth=SmoothOptions())
    b = run(with_states, sim, np.random.default_rng(9), smooth=SmoothOptions())
    for method in ("lc", "tc", "iekf"):
        sa, sb = a[method].smoothed, b[method].smoothed
        assert sa is not None and sb is not None
        for field in ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "pos_sigma_m", "est_pos_n"):
            np.testing.assert_allclose(getattr(sb, field), getattr(sa, field), rtol=0, atol=1e-9,
                                       err_msg=f"{method} {field}")
        np.testing.assert_allclose(sb.nees_block[..., :5], sa.nees_block, rtol=1e-9, atol=1e-9)
        assert sb.block_dims is not None and sb.block_dims["current"] == 2


@pytest.mark.parametrize("model", ["gauss-markov", "random-walk"])
def test_the_smoother_estimates_the_current_from_the_whole_mission(model: str) -> None:
    """Water-track on every beam: the smoothed current is the filtered one at the last epoch
    (exactly), its 1-sigma nowhere above the filter's, and at the start, where the filter had
    only its prior (0.5 m/s), the smoothed error is within 3 sigma of a sigma under 0.15 m/s."""
    from tauvcore.engine.smoothing import SmoothOptions
    config = _config(water_track="always", current_states=model, current_sigma_mps=0.5)
    sim = simulate(config, np.random.default_rng(6), 2)
    results = run(config, sim, np.random.default_rng(7), smooth=SmoothOptions())
    for method in ("lc", "tc", "iekf"):
        f = results[method]
        sm = f.smoothed
        assert sm is not None and sm.state_est is not None and f.state_est is not None
        assert sm.state_sigma is not None and f.state_sigma is not None and sm.state_true is not None
        assert sm.state_labels == f.state_labels == ("current_north_mps", "current_east_mps")
        np.testing.assert_array_equal(sm.state_est[-1], f.state_est[-1])
        assert np.all(sm.state_sigma <= f.state_sigma * (1 + 1e-9))
        np.testing.assert_array_equal(sm.state_true, f.state_true)
        err0 = np.abs(sm.state_est[0] - sm.state_true[0])
        assert np.all(sm.state_sigma[0] < 0.15) and np.all(err0 < 3 * sm.state_sigma[0]), (method, err0)
        assert np.all(np.abs(f.state_est[0] - f.state_true[0]) > 0.15)  # the filter's: its prior


@pytest.mark.parametrize("seed", range(3))
def test_the_rpm_velocity_through_the_water_H_matches_finite_differences(seed: int) -> None:
    """``--rpm-fallback`` with the current as states: the propeller's velocity is through the
    water, ``h = [(1 + SF) v_b1 + A+_1 . b, v_b2, v_b3] - C^T c``, its surge plus ``(c - c_l) . a``
    (what the VKF learned along its axis ``a`` with the estimate ``c_l``); H against central
    differences of h over every state, the current's columns included."""
    from tauvcore.engine.dvl_fusion import rpm_measurement
    rng = np.random.default_rng(400 + seed)
    A_pinv = np.linalg.pinv(DvlConfig().A_b)
    cols = CURRENT.slice_of(CURRENT_BLOCK)
    a_n = np.r_[np.cos(0.3 + seed), np.sin(0.3 + seed), 0.0]
    c_l = np.r_[0.2 * rng.standard_normal(2), 0.0]

    def h_of(nom: Nominal) -> np.ndarray:
        c_n = np.concatenate([nom.extra, np.zeros((3, 1))], axis=-1)
        current = (nom.nav.C_nb, c_n, cols, CURRENT.dim, a_n, c_l)
        return rpm_measurement(nom.vel_b, nom.dvl_sf, nom.dvl_bias, A_pinv, current)[0]

    nom = _nominal(rng)
    c_n = np.concatenate([nom.extra, np.zeros((3, 1))], axis=-1)
    current = (nom.nav.C_nb, c_n, cols, CURRENT.dim, a_n, c_l)
    _, H = rpm_measurement(nom.vel_b, nom.dvl_sf, nom.dvl_bias, A_pinv, current)
    assert np.abs(H[..., 0, cols] + nom.nav.C_nb[..., :2, 0] - a_n[:2]).max() < 1e-12
    fd = np.zeros_like(H)
    for j in range(CURRENT.dim):
        e = np.zeros(CURRENT.dim)
        e[j] = EPS
        fd[..., j] = (h_of(inject(nom, e)) - h_of(inject(nom, -e))) / (2 * EPS)
    for name in (*STATE.names, CURRENT_BLOCK):
        c = cols if name == CURRENT_BLOCK else getattr(STATE, name)
        np.testing.assert_allclose(H[..., c], fd[..., c], rtol=0, atol=1e-7, err_msg=f"H columns {name}")
    still = rpm_measurement(nom.vel_b, nom.dvl_sf, nom.dvl_bias, A_pinv)
    back = h_of(nom) + np.einsum("kji,kj->ki", nom.nav.C_nb, c_n)
    back[:, 0] -= (c_n - c_l) @ a_n
    np.testing.assert_allclose(back, still[0], atol=1e-12)
