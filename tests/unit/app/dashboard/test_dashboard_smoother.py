"""The smoother in the dashboard: the worker's smoothed results are run_streaming's, a long run's
smoothed bins hold numpy's extremes of the full-rate smoothed series, the Smoothed boxes draw the
smoothed traces (and nothing without them), the tables and the JSON download carry them, the
Smoother's controls are checked like the others, and the budget counts the smoother (no browser)."""

from __future__ import annotations

import dataclasses
import json
import threading
import warnings

import numpy as np
import pytest

from app.dashboard import budget, truth_view, worker
from app.dashboard import control_checks as validation
from app.dashboard.export import FinishedRun, results_json
from app.dashboard.inputs import (
    SMOOTHER,
    SMOOTHER_MB,
    InputError,
    config_from_controls,
    smoother_mb_from_controls,
)
from app.dashboard.session_plots import has_smoothed
from app.figures.error_figures import error_figure, nees_figure, smoothed_name
from app.figures.shared import method_color
from app.reports.markdown_tables import SMOOTHED_HEADING, smoothed_markdown
from tauvcore.config import Config, to_dict
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import MethodResult
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.envelope import (
    RUN_CURVES,
    DecimatedResult,
    curve_key,
    epochs_per_bin,
    nees_curve,
    run_curve,
)
from tauvcore.eval.study import run_rng
from tests.unit.app.dashboard.test_session_inputs import DEFAULTS

METHODS = ("ins", "lc", "tc", "vkf")


def _config(duration_s: float = 20.0, methods: tuple[str, ...] = METHODS) -> Config:
    return Config().replace("trajectory", duration_s=duration_s).replace("run", methods=methods)


class _Messages:
    def __init__(self) -> None:
        self.seen: list[tuple] = []

    def put(self, message: tuple) -> None:
        assert message[0] != "error", message
        self.seen.append(message)


def _done(config: Config, runs: int = 1, smooth_mb: float | None = 256.0) -> dict[str, MethodResult]:
    messages = _Messages()
    worker.run_worker(to_dict(config), runs, messages, threading.Event(), smooth_mb=smooth_mb)
    kind, results, stopped = messages.seen[-1]
    assert kind == "done" and not stopped
    assert all(m[0] != "progress" or all(r.smoothed is None for r in m[2].values()) for m in messages.seen)
    return results


@pytest.fixture(scope="module")
def short() -> tuple[Config, dict[str, MethodResult]]:
    config = _config()
    return config, _done(config)


def test_the_worker_sends_run_streaming_s_smoothed_results(short) -> None:
    config, results = short
    direct = run_streaming(
        config,
        np.random.default_rng(config.run.seed),
        1,
        sensor_errors=budget.records_sensor_errors(config, 1, budget.DEFAULT_BUDGET_BYTES, 256.0),
        smooth=SmoothOptions(),
    )
    for method in ("ins", "lc", "tc", "vkf"):
        got, want = results[method].smoothed, direct[method].smoothed
        assert got is not None and want is not None and len(got.t_s) == len(results[method].t_s)
        for f in dataclasses.fields(MethodResult):
            a, b = getattr(got, f.name), getattr(want, f.name)
            if isinstance(a, np.ndarray):
                np.testing.assert_allclose(a, b, rtol=0, atol=1e-9, err_msg=f"{method}.{f.name}")
    # the smoother knows more than the filter: its velocity RMS is below the filter's
    lc = results["lc"]
    assert lc.smoothed is not None
    assert float(np.sqrt(np.mean(lc.smoothed.vel_err_mps**2))) < float(np.sqrt(np.mean(lc.vel_err_mps**2)))


def test_without_the_smoother_no_smoothed_results() -> None:
    results = _done(_config(5.0, ("lc",)), smooth_mb=None)
    assert results["lc"].smoothed is None and not has_smoothed(results)


def _names(figure) -> list[str]:
    return [t.name for t in figure.data]


@pytest.mark.parametrize("quantity", ["vel", "tilt", "heading", "pos"])
def test_the_smoothed_box_draws_a_dashed_trace_per_method(short, quantity: str) -> None:
    _, results = short
    off = error_figure(results, quantity, show_sigma=True)
    assert not any("smoothed" in n for n in _names(off))
    on = error_figure(results, quantity, show_sigma=True, smoothed=True, validate=True)
    by_name = {t.name: t for t in on.data}
    for method in ("ins", "lc", "tc", "vkf"):
        trace = by_name[smoothed_name(method)]
        assert trace.name == f"{method.upper()} smoothed"
        assert trace.line.color == method_color(method) and trace.line.dash == "dash"
        # no position sigma: the standalone INS's is not drawn, Yoo 2014's filter has no position state
        assert f"{method.upper()} smoothed 1-sigma" in by_name or quantity == "pos" and method in ("ins", "vkf")
    assert len(on.data) == len(off.data) + len([n for n in _names(on) if "smoothed" in n])


@pytest.mark.parametrize("block", ["full", "vel", "heading"])
def test_the_smoothed_nees_box_draws_the_smoothed_nees_per_block(short, block: str) -> None:
    _, results = short
    off = nees_figure(results, block)
    on = nees_figure(results, block, smoothed=True, validate=True)
    assert not any("smoothed" in n for n in _names(off))
    trace = {t.name: t for t in on.data}["LC smoothed"]
    sm = results["lc"].smoothed
    assert sm is not None
    dim = 20 if block == "full" else {"vel": 3, "heading": 1}[block]
    np.testing.assert_allclose(np.asarray(trace.y, dtype=float), nees_curve(sm, block) / dim, equal_nan=True)
    assert "VKF smoothed" in _names(on)


def test_the_tables_and_the_json_carry_the_smoothed_results(short) -> None:
    config, results = short
    table = smoothed_markdown(results)
    assert table.startswith(SMOOTHED_HEADING) and "| LC |" in table and "| VKF |" in table
    assert smoothed_markdown({m: dataclasses.replace(r, smoothed=None) for m, r in results.items()}) == ""
    doc = json.loads(results_json(FinishedRun(config, results)))
    lc = doc["results"]["lc"]["smoothed"]
    sm = results["lc"].smoothed
    assert sm is not None
    np.testing.assert_allclose(lc["vel_err_mps"], sm.vel_err_mps[:, 0], rtol=0, atol=1e-12)
    assert set(lc["consistency"]["nees"]) == {"full", "pos", "vel", "tilt", "heading", "sensor"}
    assert "vel_err_mps" in doc["results"]["vkf"]["smoothed"]


K = 7  # epochs per bin: a short run forced into bins


def _extreme(values: np.ndarray, f) -> np.ndarray:
    T = len(values)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.stack([f(values[b : b + K], axis=0) for b in range(0, T, K)])


@pytest.mark.parametrize("runs", [1, 2])
def test_a_long_run_s_smoothed_bins_hold_numpy_s_extremes(monkeypatch: pytest.MonkeyPatch, runs: int) -> None:
    config = _config(30.0, ("ins", "lc", "vkf"))
    T = budget.output_epochs(config)
    monkeypatch.setattr(truth_view, "epochs_per_bin", lambda T: epochs_per_bin(T, -(-T // K)))
    assert truth_view.decimation(config)[1] == K
    binned = _done(config, runs)
    full = run_streaming(
        config.replace("initial_error", mode="random") if runs > 1 else config,
        # a Monte Carlo's runs each from the study's generator (app.dashboard.worker.run_worker)
        [run_rng(config.run.seed, i) for i in range(runs)] if runs > 1 else np.random.default_rng(config.run.seed),
        runs,
        sensor_errors=budget.records_sensor_errors(config, runs, budget.DEFAULT_BUDGET_BYTES, 256.0),
        smooth=SmoothOptions(),
    )
    for method in ("ins", "lc", "vkf"):
        sm, ref = binned[method].smoothed, full[method].smoothed
        assert isinstance(sm, DecimatedResult) and ref is not None and len(sm.t_s) == -(-T // K)
        np.testing.assert_allclose(sm.t_s, ref.t_s[K - 1 :: K].tolist() + ([ref.t_s[-1]] if T % K else []))
        for name in RUN_CURVES:
            curve = run_curve(getattr(ref, name))
            np.testing.assert_allclose(sm.low[name], _extreme(curve, np.nanmin), rtol=0, atol=1e-9, equal_nan=True)
            np.testing.assert_allclose(sm.high[name], _extreme(curve, np.nanmax), rtol=0, atol=1e-9, equal_nan=True)
        for block in ("full", "vel", "tilt"):
            curve = nees_curve(ref, block)
            key = curve_key(block)
            np.testing.assert_allclose(sm.low[key], _extreme(curve, np.nanmin), rtol=0, atol=1e-9, equal_nan=True)
            np.testing.assert_allclose(sm.high[key], _extreme(curve, np.nanmax), rtol=0, atol=1e-9, equal_nan=True)
        assert sm.summary is not None
        whole = float(np.sqrt(np.mean(run_curve(ref.vel_err_mps) ** 2)))
        assert sm.summary.rms_all_runs["vel_err_mps"] == pytest.approx(whole, abs=1e-9)
    figure = error_figure(binned, "vel", smoothed=True, validate=True)
    assert "LC smoothed" in _names(figure) and any(n.startswith("LC smoothed curve max in") for n in _names(figure))
    assert "| LC |" in smoothed_markdown(binned)


def test_a_bad_smoother_memory_is_named_not_raised() -> None:
    for typed in ("abc", "0", "-5", "1e9", ""):
        c = dataclasses.replace(DEFAULTS, smoother=True, smoother_mb=typed)
        with pytest.raises(InputError, match=r"^Smoother memory \[MB\]"):
            config_from_controls(c)
        assert SMOOTHER_MB in validation.problems(c)
    c = dataclasses.replace(DEFAULTS, smoother=True, smoother_mb="64")
    assert smoother_mb_from_controls(c) == 64.0 and not validation.problems(c)
    assert smoother_mb_from_controls(dataclasses.replace(c, smoother=False)) is None


def test_the_smoother_with_only_yoo_s_methods_is_taken() -> None:
    c = dataclasses.replace(DEFAULTS, methods=("vkf",), smoother=True)
    assert SMOOTHER not in validation.problems(c) and smoother_mb_from_controls(c) is not None


def test_the_budget_counts_the_smoother() -> None:
    config = Config()
    without = budget.estimate_run(config, 1, smooth_mb=None)
    with_it = budget.estimate_run(config, 1, smooth_mb=256.0)
    assert with_it.total_bytes > without.total_bytes and with_it.results_bytes > without.results_bytes
    small = budget.estimate_run(config, 20, smooth_mb=16.0)
    large = budget.estimate_run(config, 20, smooth_mb=1024.0)
    assert small.worker_peak_bytes < large.worker_peak_bytes  # the tape beyond its memory is on disk
    yoo = config.replace("run", methods=("vkf",))
    assert budget.estimate_run(yoo, 1, smooth_mb=256.0).total_bytes > budget.estimate_run(yoo, 1).total_bytes


def test_the_html_report_carries_the_smoothed_table_and_curves(short) -> None:
    from app.dashboard.export import report_html

    config, results = short
    page = report_html(FinishedRun(config, results), max_points=200)
    assert "Smoothed</strong>" in page or "<b>Smoothed</b>" in page
    assert "LC smoothed" in page
