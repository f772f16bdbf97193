"""Consistency records: the block NEES, the tilt/heading split and the summaries.

Known answers: the one-solve block NEES equals one NEES per block; a run's records equal the
NEES computed by hand from its final state; summaries of synthetic chi-square series land on 1
and inside the band, of inflated series outside it.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import BLOCK_DIMS, UpdateRecord
from tauvcore.engine.simulation import simulate
from tauvcore.eval.consistency import (
    method_consistency,
    nees_band,
    nees_series,
    summarise_nees,
    summarise_nis,
)
from tauvcore.filter.layout import NEES_BLOCKS, STATE
from tauvcore.filter.statistics import block_nees, nees


def _block_of_state() -> np.ndarray:
    out = np.full(STATE.dim, -1)
    for b, ix in enumerate(NEES_BLOCKS.values()):
        out[list(ix)] = b
    return out


def test_the_blocks_partition_the_state_and_split_attitude_into_tilt_and_heading():
    assert (_block_of_state() >= 0).all()
    assert sum(len(ix) for ix in NEES_BLOCKS.values()) == STATE.dim
    att = list(range(STATE.att.start, STATE.att.stop))
    assert list(NEES_BLOCKS["tilt"]) == att[:2] and list(NEES_BLOCKS["heading"]) == att[2:]
    assert BLOCK_DIMS == {"full": 20, "pos": 3, "vel": 3, "tilt": 2, "heading": 1, "sensor": 11}


def test_block_nees_equals_one_nees_per_block():
    rng = np.random.default_rng(801)
    A = rng.standard_normal((6, 4, 20, 20))
    P = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(20)
    dx = rng.standard_normal((6, 4, 20))
    fast = block_nees(dx, P, _block_of_state(), len(NEES_BLOCKS))
    for b, ix in enumerate(NEES_BLOCKS.values()):
        ix = np.asarray(ix)
        slow = nees(dx[..., ix], P[..., ix[:, None], ix])
        np.testing.assert_allclose(fast[..., b], slow, rtol=1e-9, atol=0)


def test_block_nees_is_nan_only_in_the_block_that_is_not_finite():
    """Each block uses its own marginal (one Cholesky factorisation per block): a NaN in the
    position variance spoils the position block and the full NEES, not the other blocks."""
    rng = np.random.default_rng(802)
    A = rng.standard_normal((3, 20, 20))
    P = A @ np.swapaxes(A, -1, -2) + np.eye(20)
    dx = rng.standard_normal((3, 20))
    P[1, 0, 0] = np.nan
    out = block_nees(dx, P, _block_of_state(), len(NEES_BLOCKS))
    pos = list(NEES_BLOCKS).index("pos")
    assert np.isnan(out[1, pos]) and np.isfinite(np.delete(out[1], pos)).all()
    assert np.isfinite(out[[0, 2]]).all()
    assert np.isnan(nees(dx, P)[1]) and np.isfinite(nees(dx, P)[[0, 2]]).all()


@pytest.fixture(scope="module")
def lawnmower_run():
    config = (Config().replace("trajectory", name="lawnmower", duration_s=40.0).replace("dvl", beams=(1, 2))
              .replace("run", methods=("ins", "tc", "nsv"), seed=4).replace("initial_error", mode="random"))
    rng = np.random.default_rng(4)
    return run(config, simulate(config, rng, 3), rng)


def test_tilt_and_heading_make_up_the_attitude_norm(lawnmower_run):
    for r in lawnmower_run.values():
        np.testing.assert_allclose(np.hypot(r.tilt_err_deg, r.heading_err_deg), r.att_err_deg, rtol=1e-12)
        np.testing.assert_allclose(np.hypot(r.tilt_sigma_deg, r.heading_sigma_deg), r.att_sigma_deg, rtol=1e-12)
        assert r.nees_block.shape == r.nees.shape + (len(NEES_BLOCKS),)


def test_nees_series_picks_the_block(lawnmower_run):
    r = lawnmower_run["tc"]
    assert nees_series(r, "full") is r.nees
    np.testing.assert_array_equal(nees_series(r, "heading"), r.nees_block[..., 3])


def test_summaries_of_a_consistent_series_land_on_one_and_in_the_band():
    rng = np.random.default_rng(803)
    for dim in (1, 3, 20):
        series = rng.chisquare(dim, size=(2000, 20))
        s = summarise_nees(series, dim, "x")
        assert s.per_dim == pytest.approx(1.0, abs=0.02)
        assert s.in_band > 0.97
        lo, hi = nees_band(dim, 20)
        assert lo < 1.0 < hi
        inflated = summarise_nees(10.0 * series, dim)
        assert inflated.per_dim == pytest.approx(10.0, rel=0.02) and inflated.in_band < 0.01


def test_a_nan_epoch_counts_as_outside_the_band_and_is_left_out_of_the_mean():
    series = np.ones((10, 2)) * 3.0
    series[4, 1] = np.nan
    s = summarise_nees(series, 3)
    assert s.per_dim == pytest.approx(1.0) and s.in_band == pytest.approx(0.9)


def test_nis_summary_counts_only_updates_with_a_measurement():
    rng = np.random.default_rng(804)
    U, R = 500, 4
    dof = np.full((U, R), 3)
    dof[::5] = 0
    nis = rng.chisquare(3, size=(U, R))
    valid = np.ones((U, R), bool)
    valid[1::7] = False
    zeros = np.zeros((U, R))
    rec = UpdateRecord(t_s=np.arange(U, dtype=float), z=zeros[..., None], innovation=zeros[..., None],
                       innovation_var=zeros[..., None], test_ratio=zeros, fused=valid, rejected=~valid, valid=valid,
                       fused_rows=valid[..., None], rejected_rows=~valid[..., None], nis=nis, nis_dof=dof,
                       unusable=np.zeros((U, R), bool))
    s = summarise_nis(rec, "dvl")
    used = valid & (dof > 0)
    assert s.count == used.sum()
    assert s.per_dof == pytest.approx(nis[used].sum() / dof[used].sum(), rel=1e-12)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 3)
    assert s.in_band == pytest.approx(np.mean((nis[used] >= lo) & (nis[used] <= hi)), rel=1e-12)


def test_method_consistency_has_every_block_and_every_source(lawnmower_run):
    c = method_consistency(lawnmower_run["tc"])
    assert set(c.nees) == set(BLOCK_DIMS) and set(c.nis) == {"dvl"}
    assert method_consistency(lawnmower_run["ins"]).nis == {}
    assert c.nees["full"].per_dim == pytest.approx(np.mean(lawnmower_run["tc"].nees) / 20, rel=1e-12)


def test_the_chi_square_quantiles_equal_scipy_stats():
    """metrics.chi2_ppf / chi2_isf replace scipy.stats.chi2 (whose import costs 0.3 s per command)."""
    from tauvcore.filter.statistics import chi2_isf, chi2_ppf

    dof = np.array([1, 2, 3, 11, 20, 90, 400, 2000])
    for q in (0.005, 0.5, 0.995):
        np.testing.assert_allclose(chi2_ppf(q, dof), stats.chi2.ppf(q, dof), rtol=1e-12)
    for p in (1e-6, 1e-6 / 11, 0.005):
        np.testing.assert_allclose(chi2_isf(p, dof), stats.chi2.isf(p, dof), rtol=1e-12)
