"""The spread of a Monte Carlo (app/figures/spread_figures.py): percentiles over runs, the runs
drawn, histograms of final errors and the NEES bands of R runs, with known answers; the figures
checked against the results they draw (hand-built results, and a real 20 s Monte Carlo)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from app.figures.spread_figures import (
    BAND_NAME,
    MAX_RUNS_DRAWN,
    MEDIAN_NAME,
    RUNS_NAME,
    final_errors_figure,
    histogram_bins,
    histogram_counts,
    histogram_edges,
    mean_nees_band,
    nees_blocks_figure,
    percentiles,
    runs_drawn,
    runs_figure,
)
from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import BLOCK_DIMS, SERIES_FIELDS, MethodResult
from tauvcore.engine.simulation import simulate
from tauvcore.eval.consistency import nees_series


def _hand_built(method: str, t_s: np.ndarray, runs: int, scale: float = 1.0) -> MethodResult:
    """A MethodResult whose every series at epoch i of run r is ``scale * (r + 1) * (1 + i)``, and
    whose block NEES are the block's dimension times (r + 1) / runs * 2 (mean over runs: dim (runs + 1) / runs)."""
    T = len(t_s)
    base = scale * np.outer(1.0 + np.arange(T), 1.0 + np.arange(runs))  # (T, R)
    blocks = [b for b in BLOCK_DIMS if b != "full"]
    per_run = 2.0 * (1.0 + np.arange(runs)) / runs  # mean over runs: (runs + 1) / runs
    nees_block = np.stack([np.tile(BLOCK_DIMS[b] * per_run, (T, 1)) for b in blocks], axis=-1)
    return MethodResult(
        method=method, t_s=t_s, **{name: base.copy() for name in SERIES_FIELDS.values()},
        nees_block=nees_block, est_pos_n=np.zeros((T, runs, 3)), diverged=np.zeros(runs, bool),
        diverged_at_s=np.full(runs, np.nan), p_floor_count=np.zeros(runs, int))


# ------------------------------------------------------------------------------------------ known answers

def test_percentiles_of_a_hand_built_array():
    """21 runs holding 0..20 (+ 100 t) at each epoch: the 5th, 50th, 95th percentiles are 1, 10, 19
    (+ 100 t), by linear interpolation between the sorted runs."""
    t = np.arange(4)
    series = 100.0 * t[:, None] + np.random.default_rng(3).permutation(21)[None, :]
    got = percentiles(series)
    assert got.shape == (3, 4)
    np.testing.assert_allclose(got, [100.0 * t + 1.0, 100.0 * t + 10.0, 100.0 * t + 19.0], rtol=0, atol=1e-12)


def test_percentiles_interpolate_and_leave_nan_runs_out():
    series = np.array([[1.0, 2.0, 3.0, 4.0], [np.nan, 10.0, 20.0, 30.0], [np.nan] * 4])
    got = percentiles(series, (0.0, 25.0, 50.0, 100.0))
    np.testing.assert_allclose(got[:, 0], [1.0, 1.75, 2.5, 4.0])
    np.testing.assert_allclose(got[:, 1], [10.0, 15.0, 20.0, 30.0])   # the NaN run left out
    assert np.isnan(got[:, 2]).all()                                   # no finite run: NaN


def test_percentiles_equal_numpy_s_nanpercentile():
    rng = np.random.default_rng(8)
    series = rng.lognormal(size=(50, 17))
    series[rng.random(series.shape) < 0.2] = np.nan
    series[3] = np.nan
    q = (0.0, 5.0, 37.5, 50.0, 95.0, 100.0)
    with np.errstate(all="ignore"), pytest.warns(RuntimeWarning, match="All-NaN"):
        expected = np.nanpercentile(series, q, axis=1)
    np.testing.assert_allclose(percentiles(series, q), expected, rtol=1e-12, equal_nan=True)


def test_percentiles_refuse_a_series_that_is_not_time_by_runs():
    with pytest.raises(ValueError, match="shape"):
        percentiles(np.zeros(5))


def test_histogram_counts_known_answer():
    edges = np.array([0.0, 0.5, 1.0])
    assert histogram_counts(np.array([0.1, 0.2, 0.5, 0.9, 1.0, np.nan]), edges).tolist() == [2, 3]


def test_histogram_edges_linear_log_and_single_value():
    edges, log = histogram_edges(np.array([1.0, 2.0, 3.0, np.nan]), 4)
    assert not log
    np.testing.assert_allclose(edges, [1.0, 1.5, 2.0, 2.5, 3.0])
    edges, log = histogram_edges(np.array([0.01, 0.1, 10.0]), 3)   # spans 3 decades: bins even in log
    assert log
    np.testing.assert_allclose(edges, [0.01, 0.1, 1.0, 10.0])
    edges, log = histogram_edges(np.array([2.0, 2.0]), 2)
    assert not log and edges[0] < 2.0 < edges[-1]
    counts = histogram_counts(np.array([0.01, 0.1, 10.0]), histogram_edges(np.array([0.01, 0.1, 10.0]), 3)[0])
    assert counts.tolist() == [1, 1, 1]


def test_histogram_bins_rice_rule():
    assert [histogram_bins(r) for r in (1, 10, 100, 10000)] == [5, 5, 10, 30]


@pytest.mark.parametrize("dim", [1, 2, 3, 12, 20])
@pytest.mark.parametrize("runs", [1, 10, 100])
@pytest.mark.parametrize("confidence", [0.95, 0.99])
def test_mean_nees_band_is_scipy_chi2_quantiles_over_runs(dim, runs, confidence):
    """R * mean(NEES) of a consistent filter is chi-square with R d degrees of freedom: the band of
    the mean NEES / d is its two-sided quantiles over R d."""
    alpha = 1.0 - confidence
    expected = stats.chi2.ppf([alpha / 2, 1 - alpha / 2], runs * dim) / (runs * dim)
    np.testing.assert_allclose(mean_nees_band(dim, runs, confidence), expected, rtol=1e-9)


def test_the_99_percent_band_holds_the_95_percent_band_and_both_narrow_with_runs():
    for dim in (3, 20):
        lo95, hi95 = mean_nees_band(dim, 10, 0.95)
        lo99, hi99 = mean_nees_band(dim, 10, 0.99)
        assert lo99 < lo95 < 1.0 < hi95 < hi99
        assert mean_nees_band(dim, 100, 0.99)[1] < hi99


@pytest.mark.parametrize("num_runs", [0, 1, 5, 20, 21, 57, 100, 1000])
def test_runs_drawn_are_deterministic_bounded_and_keep_first_and_last(num_runs):
    drawn = runs_drawn(num_runs)
    assert np.array_equal(drawn, runs_drawn(num_runs))
    assert len(drawn) == min(num_runs, MAX_RUNS_DRAWN)
    assert np.all(np.diff(drawn) > 0)
    if num_runs:
        assert drawn[0] == 0 and drawn[-1] == num_runs - 1
    assert len(runs_drawn(num_runs, limit=3)) == min(num_runs, 3)
    with pytest.raises(ValueError, match="limit"):
        runs_drawn(num_runs, limit=0)


# ------------------------------------------------------------------------------------------ figures

def _by_axes(figure, name: str, yaxis: str = "y") -> list:
    return [t for t in figure.data if t.name == name and (t.yaxis or "y") == yaxis]


def test_runs_figure_draws_the_runs_the_median_and_the_band_of_every_run():
    t = np.linspace(0.0, 10.0, 11)
    result = _hand_built("lc", t, runs=21)
    figure = runs_figure("lc", result, max_points=None)
    for field, yaxis in (("vel_err_mps", "y"), ("pos_err_m", "y2")):
        series = getattr(result, field)
        runs = [tr for tr in figure.data if tr.name.startswith("run ") and (tr.yaxis or "y") == yaxis]
        assert [tr.name for tr in runs] == [f"run {r + 1}" for r in runs_drawn(21)]
        for tr in runs:
            np.testing.assert_array_equal(tr.y, series[:, int(tr.name.split()[1]) - 1])
        (median,) = _by_axes(figure, MEDIAN_NAME, yaxis)
        np.testing.assert_allclose(median.y, 11.0 * (1.0 + np.arange(11)))   # runs 1..21 times (1 + i)
        (high,) = _by_axes(figure, BAND_NAME, yaxis)
        (low,) = _by_axes(figure, f"{BAND_NAME} low", yaxis)
        np.testing.assert_allclose(low.y, 2.0 * (1.0 + np.arange(11)))      # 5th of 1..21: 2
        np.testing.assert_allclose(high.y, 20.0 * (1.0 + np.arange(11)))    # 95th: 20
        assert high.fill == "tonexty"
    assert f"{MAX_RUNS_DRAWN} of 21 runs drawn" in figure.layout.title.text
    assert figure.layout.hovermode == "closest"
    legend = [tr.name for tr in figure.data if tr.showlegend is not False]
    assert legend == [BAND_NAME, RUNS_NAME, MEDIAN_NAME]
    (entry,) = [tr for tr in figure.data if tr.name == RUNS_NAME]
    assert list(entry.y) == [None]                                    # a legend entry, no data


def test_runs_figure_decimates_every_trace_and_keeps_the_last_epoch():
    t = np.arange(2000) * 0.1
    figure = runs_figure("tc", _hand_built("tc", t, runs=3), max_points=200)
    for trace in figure.data:
        if trace.name == RUNS_NAME:
            continue
        assert len(trace.x) <= 201 and trace.x[-1] == t[-1]


def test_final_errors_figure_counts_every_run_of_every_method_in_shared_bins():
    t = np.linspace(0.0, 5.0, 6)
    results = {"ins": _hand_built("ins", t, 10, scale=100.0), "lc": _hand_built("lc", t, 10)}
    figure = final_errors_figure(results)
    for k, (field, axis) in enumerate((("vel_err_mps", "x"), ("pos_err_m", "x2"))):
        traces = [tr for tr in figure.data if tr.xaxis == axis]
        assert [tr.name for tr in traces] == ["INS", "LC"]
        edges = np.asarray(traces[0].x[1:])
        assert all(np.array_equal(tr.x, traces[0].x) for tr in traces)
        for tr, method in zip(traces, ("ins", "lc")):
            finals = getattr(results[method], field)[-1]
            assert sum(tr.y) == 10
            np.testing.assert_array_equal(tr.y[1:-1], np.histogram(finals, edges)[0])
        # INS's finals are 100 times LC's: the bins are even in the logarithm, on a log axis
        assert figure.layout["xaxis" if k == 0 else f"xaxis{k + 1}"].type == "log"
    assert figure.layout.meta is None   # no time axis: the page's time cursor and zoom leave it alone
    assert "10 runs" in figure.layout.title.text


def test_nees_blocks_figure_a_panel_per_block_mean_over_runs_and_both_bands():
    t = np.linspace(0.0, 5.0, 6)
    results = {"lc": _hand_built("lc", t, runs=4), "tc": _hand_built("tc", t, runs=4)}
    figure = nees_blocks_figure(results)
    blocks = list(BLOCK_DIMS)
    for k, block in enumerate(blocks):
        yaxis = "y" if k == 0 else f"y{k + 1}"
        layout_axis = figure.layout["yaxis" if k == 0 else f"yaxis{k + 1}"]
        assert layout_axis.type == "log"
        for method in ("LC", "TC"):
            (curve,) = _by_axes(figure, method, yaxis)
            expected = nees_series(results[method.lower()], block).mean(axis=1) / BLOCK_DIMS[block]
            np.testing.assert_allclose(curve.y, expected)
        for confidence, name in ((0.95, "95 % band"), (0.99, "99 % band")):
            (band,) = _by_axes(figure, name, yaxis)
            lo, hi = mean_nees_band(BLOCK_DIMS[block], 4, confidence)
            np.testing.assert_allclose(band.y, [lo, lo, hi, hi])
            assert list(band.x) == [0.0, 5.0, 5.0, 0.0]
    non_full = [b for b in blocks if b != "full"]
    (vel,) = _by_axes(figure, "LC", f"y{blocks.index('vel') + 1}")
    np.testing.assert_allclose(vel.y, 5.0 / 4.0)     # (runs + 1) / runs, known by construction
    assert len(non_full) == len(blocks) - 1


# ------------------------------------------------------------------------------------------ a real Monte Carlo

@pytest.fixture(scope="module")
def monte_carlo() -> dict[str, MethodResult]:
    config = Config().replace("trajectory", duration_s=20.0).replace("run", methods=("ins", "lc", "vkf"))
    sim = simulate(config, np.random.default_rng(5), 4)
    return run(config, sim, np.random.default_rng(6))


def test_the_figures_of_a_real_monte_carlo_equal_their_validated_construction(monte_carlo):
    for fast, checked in (
        (runs_figure("lc", monte_carlo["lc"]), runs_figure("lc", monte_carlo["lc"], validate=True)),
        (final_errors_figure(monte_carlo), final_errors_figure(monte_carlo, validate=True)),
        (nees_blocks_figure(monte_carlo), nees_blocks_figure(monte_carlo, validate=True)),
    ):
        assert json.loads(fast.to_json()) == json.loads(checked.to_json())


def test_a_real_monte_carlo_s_histograms_count_its_four_runs_and_yoo_s_nees_has_its_own_dims(monte_carlo):
    figure = final_errors_figure(monte_carlo)
    velocity = {tr.name: sum(tr.y) for tr in figure.data if tr.xaxis == "x"}
    assert velocity == {"INS": 4, "LC": 4, "VKF": 4}
    nees = nees_blocks_figure(monte_carlo)
    full = {tr.name for tr in nees.data if (tr.yaxis or "y") == "y"}
    assert {"INS", "LC", "VKF", "95 % band (dim 20)", "99 % band (dim 12)"} <= full
