"""The horizontal position covariance record (MethodResult.pos_cov_ne_m2: P_NN, P_NE, P_EE [m^2]):
the bank's own P block at the last epoch, on both earths; with P_DD it adds up to pos_sigma_m^2;
the smoother's is no larger than the filter's; Yoo 2014's family (no position state) has none; it
follows the chunking as every other per-epoch record does."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine import filter_bank
from tauvcore.engine.mission import Banks, run, run_streaming
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.filter.layout import STATE
from tauvcore.sensors.dvl import Outage

POS = STATE.pos.start


def _config(duration_s: float, methods: tuple[str, ...], model: str = "wgs84") -> Config:
    config = Config().replace("trajectory", name="figure8", duration_s=duration_s)
    config = config.replace("earth", model=model).replace("initial_error", mode="random")
    return config.replace("run", methods=methods, aiding=("dvl", "depth"), seed=2)


@pytest.mark.parametrize("model", ["wgs84", "flat"])
def test_the_last_epoch_is_the_banks_p_block_and_adds_up_to_the_position_sigma(model: str) -> None:
    """At the last sample (an output epoch) the record is the bank's P[pos, pos] north-east block
    after the run; with P_DD of that P, ``P_NN + P_EE + P_DD = pos_sigma_m^2``; at every epoch
    the horizontal part is at most the whole, and the block is a covariance (positive)."""
    methods = ("ins", "lc", "tc", "vkf")
    config = _config(12.0, methods, model)
    rng = np.random.default_rng(5)
    sim = simulate(config, rng, 3)
    banks = Banks(config, 3, sim.truth.num_samples, sim.truth.dt_s, rng)
    banks.feed(SimChunk.whole(sim))
    results = banks.results()
    first = banks.banks[0]
    assert isinstance(first, filter_bank.FilterBank)
    for m, method in enumerate(first.methods):
        r = results[method]
        cov = r.pos_cov_ne_m2
        assert cov is not None and cov.shape == (r.t_s.size, 3, 3), method
        assert r.t_s[-1] == sim.truth.t_s[-1]
        P = first.P[m]  # (R, d, d)
        expected = np.stack([P[:, POS, POS], P[:, POS, POS + 1], P[:, POS + 1, POS + 1]], axis=-1)
        np.testing.assert_array_equal(cov[-1], expected, err_msg=method)
        total = cov[-1, :, 0] + cov[-1, :, 2] + P[:, POS + 2, POS + 2]
        np.testing.assert_allclose(total, r.pos_sigma_m[-1] ** 2, rtol=1e-12, err_msg=method)
        assert np.all(cov[..., 0] + cov[..., 2] <= r.pos_sigma_m**2 * (1 + 1e-12)), method
        assert np.all(cov[..., 0] > 0) and np.all(cov[..., 2] > 0), method
        assert np.all(cov[..., 0] * cov[..., 2] - cov[..., 1] ** 2 > 0), method
        assert np.any(cov[..., 1] != 0.0), method  # the figure eight turns: north and east correlate


def test_yoo_methods_have_no_position_state_and_no_record() -> None:
    results = run_streaming(_config(6.0, ("vkf", "ins-dvl", "lc")), np.random.default_rng(1), num_runs=1)
    assert results["vkf"].pos_cov_ne_m2 is None and results["ins-dvl"].pos_cov_ne_m2 is None
    assert np.all(np.isnan(results["vkf"].pos_sigma_m))
    assert results["lc"].pos_cov_ne_m2 is not None


def test_the_record_does_not_depend_on_the_chunk_size() -> None:
    config = _config(12.0, ("ins", "lc", "tc"))
    a = run_streaming(config, np.random.default_rng(6), num_runs=2, chunk_s=2.0)
    b = run_streaming(config, np.random.default_rng(6), num_runs=2, chunk_s=10.0)
    for method in ("ins", "lc", "tc"):
        x, y = a[method].pos_cov_ne_m2, b[method].pos_cov_ne_m2
        assert x is not None and y is not None
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=0.0, err_msg=method)
        assert x.shape[0] == a[method].t_s.size


def test_the_smoothed_covariance_is_no_larger_than_the_filtered() -> None:
    """Over a DVL outage the smoother's horizontal covariance is at most the filter's (the
    difference, filtered - smoothed, positive semi-definite), smaller in the outage, equal
    at the last epoch; its trace with P_DD is the smoothed pos_sigma_m^2."""
    config = _config(120.0, ("ins", "lc", "tc"))
    config = config.replace("dvl", outages=(Outage(beams=(1, 2, 3, 4), start_s=40.0, end_s=80.0),))
    sim = simulate(config, np.random.default_rng(1), 2)
    results = run(config, sim, np.random.default_rng(2), smooth=SmoothOptions())
    for method in ("lc", "tc"):
        f = results[method]
        s = f.smoothed
        assert s is not None and s.pos_cov_ne_m2 is not None and f.pos_cov_ne_m2 is not None
        cf, cs = f.pos_cov_ne_m2, s.pos_cov_ne_m2
        assert cs.shape == cf.shape
        d = cf - cs
        tol = 1e-9 * cf[..., [0, 2]].max()
        trace, det = d[..., 0] + d[..., 2], d[..., 0] * d[..., 2] - d[..., 1] ** 2
        assert np.all(d[..., 0] >= -tol) and np.all(d[..., 2] >= -tol), method
        assert np.all(trace >= -tol) and np.all(det >= -tol * np.abs(trace).max()), method
        np.testing.assert_allclose(cs[-1], cf[-1], rtol=1e-9, err_msg=method)
        mid = np.searchsorted(f.t_s, 60.0)
        assert np.all(cs[mid, :, 0] < 0.9 * cf[mid, :, 0]) and np.all(cs[mid, :, 2] < 0.9 * cf[mid, :, 2]), method
        assert np.all(cs[..., 0] + cs[..., 2] <= s.pos_sigma_m**2 * (1 + 1e-9)), method
