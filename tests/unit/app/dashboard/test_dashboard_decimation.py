"""A long dashboard run reduced to time bins (tauvcore.eval.envelope, app.dashboard.worker): each bin's
minimum and maximum are numpy's over the full-rate series, the summary is the whole series', a
short run is sent as it was computed, and the results do not grow with the mission."""

from __future__ import annotations

import pickle
import threading
import warnings

import numpy as np
import pytest

from app.dashboard import budget, truth_view, worker
from app.figures.error_figures import compare_figure, error_figure, nees_figure
from app.figures.innovation_figures import innovation_figure
from app.figures.sensor_figures import sensor_error_figure
from app.reports.markdown_tables import (
    dvl_resets,
    result_counts,
    rms_markdown,
    summary_markdown,
    summary_rows,
)
from app.reports.tables import summary_table
from tauvcore.config import Config, to_dict
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.engine.results import MethodResult
from tauvcore.eval.envelope import (
    RUN_CURVES,
    SERIES,
    DecimatedResult,
    DecimatedUpdates,
    EnvelopeReducer,
    curve_key,
    epochs_per_bin,
    nees_curve,
    run_curve,
)
from tauvcore.eval.running import summarise

K = 7  # epochs per bin: a short run forced to decimate
METHODS = ("ins", "lc", "tc", "elc", "vkf")


def _config(duration_s: float = 40.0, methods: tuple[str, ...] = METHODS) -> Config:
    return (
        Config()
        .replace("trajectory", duration_s=duration_s)
        .replace("run", methods=methods)
        .replace("dvl", beams=(1, 2, 3), dropout_probability=0.2)
    )


@pytest.fixture(scope="module", params=[1, 3], ids=["1 run", "3 runs"])
def pair(request: pytest.FixtureRequest) -> tuple[dict[str, MethodResult], dict[str, DecimatedResult], int]:
    """The same mission's full-rate results and its bins of K epochs."""
    runs = request.param
    config = _config()
    T = budget.output_epochs(config)
    full = run_streaming(config, np.random.default_rng(3), runs, sensor_errors=True)
    reducer = EnvelopeReducer(T, 0.1, K)
    run_streaming(config, np.random.default_rng(3), runs, keep=False, sensor_errors=True, sinks=Sinks(on_chunk=reducer.add))
    return full, reducer.results(), T


def _bins(T: int) -> list[slice]:
    return [slice(b, min(b + K, T)) for b in range(0, T, K)]


def _extreme(values: np.ndarray, bins: list, f) -> np.ndarray:
    """``f`` (numpy's nanmin or nanmax) of each bin of ``values``, NaN where a bin has none."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN bin (a row never measured)
        return np.stack([f(values[b], axis=0) for b in bins])


def test_each_bin_holds_its_last_epoch_and_the_extremes_of_every_plotted_curve(pair) -> None:
    full, binned, T = pair
    bins = _bins(T)
    last = np.array([b.stop - 1 for b in bins])
    assert last[-1] == T - 1  # the mission's last epoch is a bin's last: final values are exact
    for method, f in full.items():
        d = binned[method]
        assert isinstance(d, DecimatedResult) and d.epochs_per_bin == K and d.bin_s == pytest.approx(0.7)
        np.testing.assert_array_equal(d.t_s, f.t_s[last])
        for name in (*SERIES, "nees_block", "est_pos_n", "est_vel_n", "est_euler_rad", "sensor_est"):
            np.testing.assert_array_equal(getattr(d, name), getattr(f, name)[last], err_msg=name)
        for name in RUN_CURVES:
            curve = run_curve(getattr(f, name))
            np.testing.assert_allclose(d.low[name], _extreme(curve, bins, np.nanmin), atol=1e-9, err_msg=name)
            np.testing.assert_allclose(d.high[name], _extreme(curve, bins, np.nanmax), atol=1e-9, err_msg=name)
        for block in f.block_dims or {"full": 0, "vel": 0, "sensor": 0}:
            curve = nees_curve(f, block)
            np.testing.assert_allclose(d.low[curve_key(block)], _extreme(curve, bins, np.nanmin), atol=1e-9)
            np.testing.assert_allclose(d.high[curve_key(block)], _extreme(curve, bins, np.nanmax), atol=1e-9)
        for name in ("sensor_est", "sensor_sigma", "sensor_true"):
            values = getattr(f, name)
            np.testing.assert_allclose(d.low[name], _extreme(values, bins, np.nanmin), atol=1e-9, err_msg=name)
            np.testing.assert_allclose(d.high[name], _extreme(values, bins, np.nanmax), atol=1e-9, err_msg=name)
        np.testing.assert_array_equal(d.diverged_at_s, f.diverged_at_s)
        np.testing.assert_array_equal(d.p_floor_count, f.p_floor_count)


def test_each_update_bin_holds_its_last_update_and_the_innovations_extremes(pair) -> None:
    full, binned, T = pair
    for method, f in full.items():
        assert set(binned[method].updates) == set(f.updates)
        for source, record in f.updates.items():
            d = binned[method].updates[source]
            assert isinstance(d, DecimatedUpdates)
            which = np.floor(record.t_s / 0.7 + 1e-9).astype(int)
            groups = [np.flatnonzero(which == b) for b in np.unique(which)]
            last = np.array([g[-1] for g in groups])
            np.testing.assert_array_equal(d.t_s, record.t_s[last])
            for name in ("innovation", "innovation_var", "valid", "rejected_rows", "nis", "nis_dof", "beams_available"):
                if getattr(record, name) is not None:
                    np.testing.assert_array_equal(getattr(d, name), getattr(record, name)[last], err_msg=name)
            measured = record.valid[..., None] & np.isfinite(record.innovation_var)
            nu = np.where(measured, record.innovation, np.nan)
            with np.errstate(invalid="ignore"):
                sigma3 = np.where(measured, 3.0 * np.sqrt(record.innovation_var), np.nan)
            np.testing.assert_allclose(d.innovation_low, _extreme(nu, groups, np.nanmin), atol=1e-9)
            np.testing.assert_allclose(d.innovation_high, _extreme(nu, groups, np.nanmax), atol=1e-9)
            np.testing.assert_allclose(d.sigma3_high, _extreme(sigma3, groups, np.nanmax), atol=1e-9)
            rejected = record.rejected_rows & measured
            for j, g in enumerate(groups):
                hit = rejected[g]
                expect = np.full(hit.shape[1:], np.nan)
                for i in range(len(g)):
                    expect = np.where(hit[i], record.innovation[g[i]], expect)
                np.testing.assert_array_equal(d.rejected_innovation[j], expect)
        if f.vkf_trace is not None:
            np.testing.assert_array_equal(binned[method].vkf_trace["t_s"][-1], f.vkf_trace["t_s"][-1])


def test_the_tables_of_a_decimated_run_are_the_full_series_to_1e_9(pair) -> None:
    """RMS, consistency, DVL counts and the monitor's verdict come from running sums over every
    epoch and update (tauvcore.eval.running), not from the bins."""
    full, binned, _ = pair
    expected, got = summary_rows(full), summary_rows(binned)
    for e, g in zip(expected, got, strict=True):
        assert e.keys() == g.keys()
        for key, value in e.items():
            if isinstance(value, float):
                assert g[key] == pytest.approx(value, rel=1e-9, abs=1e-12, nan_ok=True), key
            else:
                assert g[key] == value, key
    for method, f in full.items():
        assert result_counts(binned[method]) == result_counts(f)
        assert dvl_resets(binned[method]) == dvl_resets(f)
        whole = summarise({method: f})[method]
        summary = binned[method].summary
        assert summary is not None
        for name, value in whole.rms.items():
            assert summary.rms[name] == pytest.approx(value, rel=1e-9, nan_ok=True)
            assert summary.rms_all_runs[name] == pytest.approx(
                float(np.sqrt(np.mean(np.square(getattr(f, name))))), rel=1e-9, nan_ok=True
            )
    config = _config()
    table = summary_table(binned, config, 1.0)
    assert table.splitlines()[2:] == summary_table(full, config, 1.0).splitlines()[2:]


def _traces(figure) -> dict[str, dict]:
    return {t.name: {"x": np.asarray(t.x), "y": np.asarray(t.y, dtype=float), "fill": t.fill} for t in figure.data}


def test_the_plots_draw_a_min_max_band_under_each_curve(pair) -> None:
    full, binned, _ = pair
    error_figure(binned, "pos", show_sigma=True, validate=True)  # plotly accepts every trace
    figure = error_figure(binned, "pos")
    assert "curve's min\u2013max within each 0.7 s bin" in figure.layout.title.text
    traces = _traces(figure)
    for method in METHODS:
        lo, hi = traces[f"{method.upper()} curve min in 0.7 s bin"], traces[f"{method.upper()} curve max in 0.7 s bin"]
        line = traces[method.upper()]
        assert hi["fill"] == "tonexty" and lo["fill"] is None
        assert np.all(lo["y"] <= line["y"] + 1e-12) and np.all(line["y"] <= hi["y"] + 1e-12)
    # merged further to at most about max_points: still the extremes of the full-rate curve
    hi = _traces(error_figure(binned, "pos", max_points=5))["LC curve max in 0.7 s bin"]
    assert len(hi["y"]) <= 6 and hi["x"][-1] == full["lc"].t_s[-1]
    assert hi["y"].max() == pytest.approx(float(np.nanmax(run_curve(full["lc"].pos_err_m))), rel=1e-12)
    nees_figure(binned, "vel", validate=True)
    assert _traces(nees_figure(binned, "vel"))["TC curve max in 0.7 s bin"]["fill"] == "tonexty"
    innovation_figure(binned, "dvl", validate=True)
    innovations = innovation_figure(binned, "dvl")
    assert "TC curve max in 0.7 s bin" in _traces(innovations)
    assert "curve's min\u2013max within each 0.7 s bin" in innovations.layout.title.text
    sensor_error_figure(binned["lc"], validate=True)
    assert any(n.endswith("estimate curve max in 0.7 s bin") for n in _traces(sensor_error_figure(binned["lc"])))
    compare_figure([("run 1", binned), ("run 2", full)], "vel", validate=True)
    assert "LC (run 1) curve max in 0.7 s bin" in _traces(compare_figure([("run 1", binned), ("run 2", full)], "vel"))
    assert "Consistency" in summary_markdown(binned) and "DVL bottom-track" in rms_markdown(binned)


class _Messages:
    def __init__(self) -> None:
        self.seen: list[tuple] = []

    def put(self, message: tuple) -> None:
        assert message[0] != "error", message
        self.seen.append(message)


def _worker(config: Config, runs: int = 1) -> list[tuple]:
    messages = _Messages()
    worker.run_worker(to_dict(config), runs, messages, threading.Event())
    return messages.seen


def test_a_short_run_is_sent_as_it_was_computed() -> None:
    """Output epochs within SCREEN_BINS: the worker's results are run_streaming's, byte for byte."""
    config = _config(20.0, ("ins", "lc", "tc"))
    assert truth_view.decimation(config)[1] == 1
    done = _worker(config)[-1]
    assert done[0] == "done"
    direct = run_streaming(
        config,
        np.random.default_rng(config.run.seed),
        1,
        sensor_errors=budget.records_sensor_errors(config, 1, budget.DEFAULT_BUDGET_BYTES),
    )
    assert all(type(r) is MethodResult for r in done[1].values())
    assert pickle.dumps(done[1]) == pickle.dumps(direct)


def test_a_long_run_s_results_are_bounded_by_the_bins(monkeypatch: pytest.MonkeyPatch) -> None:
    """With 40 bins at most, a mission twice as long sends results of about the same size, its
    truth view at the bins' epochs (so the components' truth is each bin's own)."""
    monkeypatch.setattr(truth_view, "epochs_per_bin", lambda T: epochs_per_bin(T, 40))
    sizes = {}
    for duration_s in (60.0, 120.0):
        config = _config(duration_s, ("ins", "lc")).replace("imu", rate_hz=50.0)
        messages = _worker(config, 2)
        kind, results, stopped = messages[-1]
        assert kind == "done" and not stopped
        truth = messages[0][1]
        for r in results.values():
            assert isinstance(r, DecimatedResult) and len(r.t_s) <= 40
            assert r.t_s[-1] == pytest.approx(duration_s)
            assert set(np.round(r.t_s, 6)) <= set(np.round(truth["t_s"], 6))
            assert r.summary is not None and r.summary.rms_all_runs["pos_err_m"] > 0
        assert truth["vel_n"].shape == (len(truth["t_s"]), 3) and len(truth["t_s"]) <= 41
        assert all(m[0] != "progress" or isinstance(next(iter(m[2].values())), DecimatedResult) for m in messages)
        sizes[duration_s] = len(pickle.dumps(results))
    assert sizes[120.0] < 1.3 * sizes[60.0]


def test_the_budget_accepts_a_10_hour_mission_of_the_default_methods() -> None:
    from app.dashboard.control_table import DEFAULT_METHODS

    config = Config().replace("trajectory", duration_s=36000.0).replace("run", methods=DEFAULT_METHODS)
    estimate = budget.estimate_run(config, 1)
    assert budget.over_budget_message(estimate, budget.DEFAULT_BUDGET_BYTES) is None
    assert truth_view.decimation(config)[:2] == (360001, 91)
    assert budget.kept_epochs(config) == 3957


def test_a_binned_run_keeps_each_bin_s_last_estimate_of_the_sources_states() -> None:
    """With current states (the DVL's water-track on every beam), every method's bins carry the
    current's estimate, 1-sigma and truth at each bin's last epoch, and its labels: the Sensors
    tab draws them for a long mission too."""
    config = (_config(methods=("lc", "vkf")).replace("trajectory", current_n_mps=(0.1, 0.2, 0.0))
              .replace("dvl", water_track="always", current_states="random-walk"))
    T = budget.output_epochs(config)
    full = run_streaming(config, np.random.default_rng(3), 2)
    reducer = EnvelopeReducer(T, 0.1, K)
    run_streaming(config, np.random.default_rng(3), 2, keep=False, sinks=Sinks(on_chunk=reducer.add))
    last = np.array([b.stop - 1 for b in _bins(T)])
    for method, f in full.items():
        d = reducer.results()[method]
        assert d.state_labels == f.state_labels == ("current_north_mps", "current_east_mps")
        for name in ("state_est", "state_sigma", "state_true"):
            np.testing.assert_array_equal(getattr(d, name), getattr(f, name)[last], err_msg=f"{method} {name}")
