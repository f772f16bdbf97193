"""The current states in Yoo 2014's filter (tauvcore.engine.yoo_velocity, tauvcore.engine.yoo_bank).

- The NED velocity aid's H (over ground, through the water, and the RPM velocity the VKF learned
  with a current estimate) against central finite differences of its model, every block.
- Current states on but never observed leave every number of ``ins-dvl`` and ``vkf`` as it was
  (to 1e-9): the compiled 12-state loop against the numpy methods that carry the states.
- Water-track beyond bottom range estimates the current, chunks of any size as one.
- The smoother estimates them from the whole mission, and leaves them uncoupled when unobserved.
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run, run_streaming
from tauvcore.engine.simulation import simulate
from tauvcore.engine.source_streams import layout_of
from tauvcore.engine.yoo_velocity import added_states
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.families.yoo.model_kernels import NA
from tauvcore.geo.rotations import exp_so3
from tests.unit.tauvcore.engine.yoo_reference import velocity_H

EPS = 1e-6


def _longrange(duration_s: float, methods=("ins-dvl", "vkf"), current=(0.0, 0.3, 0.0), **dvl) -> Config:
    raw = merge(trajectory_preset("longrange"),
                {"trajectory": {"name": "longrange", "duration_s": duration_s, "current_n_mps": list(current)},
                 "run": {"methods": list(methods), "aiding": ["dvl", "depth", "mag"]}})
    return from_dict(raw).replace("dvl", **dvl).replace("initial_error", mode="random")


@pytest.mark.parametrize("case", ["ground", "water", "learned"])
@pytest.mark.parametrize("seed", range(3))
def test_the_velocity_aid_s_H_matches_finite_differences(case: str, seed: int) -> None:
    """``z = C_est u_b`` with ``u_b`` the velocity over ground, through the water, or the VKF's
    through the water with the current estimate's error along its learning axis: the true ``z``
    of an error ``dx = [dv, rho, ..., dc]`` is ``exp(-[rho x]) (v - c) + x (c - c_l) . a``; H's
    velocity, attitude and current columns are its central differences, the consider columns
    the ``Hc`` handed in."""
    rng = np.random.default_rng(500 + seed)
    config = _longrange(10.0, water_track="beyond_range", current_states="random-walk")
    added = added_states(config, layout_of(config))
    assert added.dim == NA + 2 and added.current == slice(NA, NA + 2)
    B = 4
    v = rng.normal(0.0, 1.5, (B, 3))
    c = np.zeros((B, 3))
    c[:, :2] = rng.normal(0.0, 0.4, (B, 2))
    C = exp_so3(rng.normal(0.0, 0.8, (B, 3)))
    x_n = C[:, :, 0]
    a_n = exp_so3(rng.normal(0.0, 0.3, (B, 3)))[:, :, 0]
    c_l = np.zeros((B, 3))
    c_l[:, :2] = rng.normal(0.0, 0.4, (B, 2))
    water = None if case == "ground" else np.ones(B, bool)
    learned = (x_n, a_n, c_l) if case == "learned" else None
    Hc = rng.normal(0.0, 1.0, (B, 3, 5))

    def z_of(dx: np.ndarray) -> np.ndarray:
        v_t = v + dx[:, yoo.VEL]
        rot = exp_so3(-dx[:, yoo.ATT])  # C_est C_true^T
        c_t = c.copy()
        c_t[:, :2] += dx[:, NA : NA + 2]
        u = v_t - (c_t if water is not None else 0.0)
        z = np.einsum("bij,bj->bi", rot, u)
        if learned is not None:
            z += x_n * np.einsum("bj,bj->b", c_t - c_l, a_n)[:, None]
        return z

    h, H = velocity_H(v, c, Hc, water, added, learned)
    np.testing.assert_allclose(h, z_of(np.zeros((B, added.dim))), rtol=0, atol=1e-12)
    fd = np.zeros_like(H)
    for j in list(range(yoo.DIM)) + [NA, NA + 1]:
        e = np.zeros((B, added.dim))
        e[:, j] = EPS
        fd[..., j] = (z_of(e) - z_of(-e)) / (2 * EPS)
    for name, cols in (("vel", yoo.VEL), ("att", yoo.ATT), ("biases", slice(6, 12)), ("current", slice(NA, NA + 2))):
        np.testing.assert_allclose(H[..., cols], fd[..., cols], rtol=0, atol=1e-7, err_msg=name)
    np.testing.assert_array_equal(H[..., yoo.DIM : NA], Hc)
    if case == "ground":
        assert not H[..., NA:].any()


def test_current_states_never_observed_leave_yoo_s_numbers_as_they_were() -> None:
    """Without water-track and before the first trench (the VKF takes the DVL throughout) nothing
    measures the current: ``ins-dvl`` and ``vkf`` with the states (the numpy methods) equal them
    without (the compiled loop) to 1e-9, every series and update; only the full NEES, over 14
    states, differs."""
    base = _longrange(200.0)
    with_states = base.replace("dvl", current_states="random-walk")
    rng = np.random.default_rng(5)
    sim = simulate(base, rng, 2)
    a = run(base, sim, np.random.default_rng(9))
    b = run(with_states, sim, np.random.default_rng(9))
    for method in base.run.methods:
        for field in ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "est_pos_n"):
            np.testing.assert_allclose(getattr(b[method], field), getattr(a[method], field), rtol=0, atol=1e-9,
                                       err_msg=f"{method} {field}")
        np.testing.assert_allclose(b[method].nees_block[..., :5], a[method].nees_block, rtol=1e-9, atol=1e-9)
        up_a, up_b = a[method].updates["dvl"], b[method].updates["dvl"]
        np.testing.assert_allclose(up_b.innovation, up_a.innovation, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(up_b.fused, up_a.fused)
        assert b[method].block_dims is not None and b[method].block_dims["current"] == 2
        assert b[method].block_dims["full"] == 14 and a[method].block_dims["full"] == 12
        assert b[method].state_labels == ("current_north_mps", "current_east_mps")


def test_water_track_beyond_range_estimates_the_current_in_chunks_as_in_one() -> None:
    """Over the first trench (300-480 s) the DVL water-tracks: both methods fuse it (source
    "water"), the current's 1-sigma falls from 0.5 m/s to below 0.1 with its error inside
    3 sigma, and chunks of any size give the
    numbers of one chunk."""
    config = _longrange(420.0, water_track="beyond_range", current_states="random-walk",
                        current_walk_mps_per_sqrt_s=1e-4, current_sigma_mps=0.5)
    whole = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=1000.0)
    chunked = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=37.3)
    for method in ("ins-dvl", "vkf"):
        r = whole[method]
        water = r.updates["water"]
        assert water.fused.any() and water.t_s[water.fused.any(axis=-1)].min() > 290.0
        assert r.state_est is not None and r.state_true is not None and r.state_sigma is not None
        err = np.abs(r.state_est[-1] - r.state_true[-1])
        sigma = r.state_sigma[-1]
        assert sigma.max() < 0.1 and (err < 3.0 * sigma).all(), (method, err, sigma)  # prior 0.5 m/s
        np.testing.assert_allclose(chunked[method].vel_err_mps, r.vel_err_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(chunked[method].state_est, r.state_est, rtol=0, atol=1e-9)
        np.testing.assert_allclose(chunked[method].nees_block, r.nees_block, rtol=1e-9, atol=1e-9)


def test_yoo_s_smoother_estimates_the_current_from_the_whole_mission() -> None:
    """INS-DVL and VKF smoothed with the current as Gauss-Markov states, water-track beyond bottom
    range (the first trench, 300-420 s): the smoothed current is the filtered one at the last
    epoch, its sigma nowhere above the filter's; before the trench, where the filter had only its
    prior, the smoother knows it from the trench (sigma below 0.1 m/s, the error within 3 sigma);
    and with the states unobserved (no water-track) every smoothed number of the 12 states equals
    the smoothed run without them to 1e-9."""
    from tauvcore.engine.smoothing import SmoothOptions
    config = _longrange(420.0, water_track="beyond_range", current_states="gauss-markov", current_sigma_mps=0.5,
                        current_tau_s=3600.0)
    sim = simulate(config, np.random.default_rng(6), 2)
    results = run(config, sim, np.random.default_rng(7), smooth=SmoothOptions())
    for method in ("ins-dvl", "vkf"):
        f = results[method]
        sm = f.smoothed
        assert sm is not None and sm.state_est is not None and f.state_est is not None
        assert sm.state_sigma is not None and f.state_sigma is not None and sm.state_true is not None
        assert sm.block_dims is not None and sm.block_dims["current"] == 2
        np.testing.assert_array_equal(sm.state_est[-1], f.state_est[-1])
        assert np.all(sm.state_sigma <= f.state_sigma * (1 + 1e-9))
        before = np.flatnonzero(sm.t_s < 290.0)[-1]
        err = np.abs(sm.state_est[before] - sm.state_true[before])
        assert np.all(sm.state_sigma[before] < 0.1) and np.all(err < 3 * sm.state_sigma[before]), (method, err)
        assert np.all(f.state_sigma[before] > 0.4)  # the filter's: its prior
    base = _longrange(200.0)
    sim = simulate(base, np.random.default_rng(5), 2)
    a = run(base, sim, np.random.default_rng(9), smooth=SmoothOptions())
    b = run(base.replace("dvl", current_states="gauss-markov"), sim, np.random.default_rng(9), smooth=SmoothOptions())
    for method in base.run.methods:
        sa, sb = a[method].smoothed, b[method].smoothed
        assert sa is not None and sb is not None
        for field in ("vel_err_mps", "att_err_deg", "vel_sigma_mps", "att_sigma_deg", "est_vel_n"):
            np.testing.assert_allclose(getattr(sb, field), getattr(sa, field), rtol=0, atol=1e-9, err_msg=field)
        np.testing.assert_allclose(sb.nees_block[..., :5], sa.nees_block, rtol=1e-9, atol=1e-9)
