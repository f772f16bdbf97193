"""Plotly figures of run results (app/figures/shared.py and the figure modules on it: app/figures/error_figures.py,
app/figures/innovation_figures.py, app/figures/vehicle_figures.py) and the Results tab's tables (app/reports/markdown_tables.py),
checked against the MethodResult they draw.

Every figure is a pure function of the results, so each test runs the real pipeline once
(20 s straight run, seeded, module-scoped fixtures) and compares what the figure holds (trace
names, x, y, colours, axis settings) with the numbers computed here from the MethodResult.
"""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from app.figures.error_figures import (
    elc_choice_figure,
    error_figure,
    nees_figure,
    overlay_figure,
)
from app.figures.log_axes import LOG_SPAN
from app.figures.shared import (
    METHOD_COLORS,
    TRUTH_COLOR,
)
from app.figures.vehicle_figures import (
    ALTITUDE_NAME,
    DVL_LIMIT_NAME,
    FIN_COLORS,
    FIN_NAMES,
    RPM_NAME,
    SWITCH_NAME,
    VKF_B_NAME,
    VKF_SF_NAME,
    actuator_figure,
    altitude_figure,
    intervals_above,
    vkf_figure,
)
from app.reports.markdown_tables import (
    CONSISTENCY_COLUMNS,
    CONSISTENCY_HEADING,
    COUNTS_HEADING,
    ERROR_COLUMNS,
    RMS_COLUMNS,
    RMS_HEADING,
    RUNS_COLUMNS,
    summary_markdown,
    summary_rows,
)
from tauvcore.aiding.dvl_extended import MODE_COAST, MODE_LC, MODE_PARTIAL
from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.config import RUN_METHODS, Config, from_dict, merge, trajectory_preset
from tauvcore.engine.mission import run
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.engine.simulation import simulate
from tauvcore.eval.consistency import method_consistency, nees_band
from tauvcore.filter.families import FAMILIES
from tauvcore.filter.layout import NEES_BLOCKS
from tauvcore.sensors.dvl import Outage

DURATION_S = 20.0
METHODS_UNDER_TEST = ("ins", "tc", "nsv")
NAMES = ("INS", "TC", "NSV")
QUANTITY_FIELDS = {   # quantity -> (error field, sigma field, unit in the title)
    "vel": ("vel_err_mps", "vel_sigma_mps", "[m/s]"),
    "att": ("att_err_deg", "att_sigma_deg", "[deg]"),
    "tilt": ("tilt_err_deg", "tilt_sigma_deg", "[deg]"),
    "heading": ("heading_err_deg", "heading_sigma_deg", "[deg]"),
    "pos": ("pos_err_m", "pos_sigma_m", "[m]"),
}
AXES = ("surge", "sway", "heave")
LC_NAME = "LC (3-4 beams)"


def _short_config(**run_changes: object) -> Config:
    return Config().replace("trajectory", duration_s=DURATION_S).replace("run", **run_changes)


def _methods_config() -> Config:
    """Beams 3-4 lost for 5-15 s: with four beams TC and NSV (LC then) give the same errors."""
    return _short_config(methods=METHODS_UNDER_TEST).replace(
        "dvl", outages=(Outage(beams=(3, 4), start_s=5.0, end_s=15.0),))


def _results(config: Config, num_runs: int, seed: int) -> dict[str, MethodResult]:
    sim = simulate(config, np.random.default_rng(seed), num_runs)
    return run(config, sim, np.random.default_rng(seed + 1))


@pytest.fixture(scope="module")
def single() -> dict[str, MethodResult]:
    return _results(_methods_config(), 1, seed=11)


@pytest.fixture(scope="module")
def monte_carlo() -> dict[str, MethodResult]:
    return _results(_methods_config(), 3, seed=21)


@pytest.fixture(scope="module")
def elc_two_beams() -> MethodResult:
    config = _short_config(methods=("elc",)).replace("dvl", beams=(1, 2))
    return _results(config, 1, seed=31)["elc"]


@pytest.fixture(scope="module")
def elc_four_beams() -> MethodResult:
    return _results(_short_config(methods=("elc",)), 1, seed=41)["elc"]


@pytest.fixture(scope="module")
def elc_mixed() -> MethodResult:
    """LC, partial (beams 3-4 lost) and coast (beams 2-4 lost) epochs in one run."""
    config = _short_config(methods=("elc",)).replace(
        "dvl", outages=(Outage(beams=(3, 4), start_s=4.0, end_s=10.0), Outage(beams=(2, 3, 4), start_s=12.0, end_s=15.0)))
    return _results(config, 1, seed=51)["elc"]


def _rms_over_runs(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(np.square(x), axis=1))


def _by_name(fig) -> dict[str, object]:
    names = [t.name for t in fig.data]
    assert len(names) == len(set(names)), f"duplicate trace names {names}"
    return {t.name: t for t in fig.data}


def _hex_rgb(color: str) -> tuple[int, int, int]:
    return tuple(int(color[i:i + 2], 16) for i in (1, 3, 5))


# ------------------------------------------------------------------------------------------ preconditions

def test_fixture_series_differ_between_methods_and_quantities(single):
    """The trace checks below could not tell series apart if the series were equal."""
    for q, (err, sigma, _) in QUANTITY_FIELDS.items():
        curves = [getattr(single[m], err)[:, 0] for m in METHODS_UNDER_TEST]
        for i in range(len(curves)):
            for j in range(i + 1, len(curves)):
                assert not np.allclose(curves[i], curves[j]), (q, METHODS_UNDER_TEST[i], METHODS_UNDER_TEST[j])
        assert not np.allclose(getattr(single["tc"], err), getattr(single["tc"], sigma)), q
    tc = single["tc"]
    assert not np.allclose(tc.vel_err_mps, tc.pos_err_m) and not np.allclose(tc.vel_err_mps, tc.att_err_deg)
    assert not np.allclose(tc.tilt_err_deg, tc.heading_err_deg) and not np.allclose(tc.tilt_err_deg, tc.att_err_deg)
    for block in NEES_BLOCKS:             # the block choice draws a different series every time
        assert not np.allclose(tc.nees, tc.nees_block[..., list(NEES_BLOCKS).index(block)]), block


# ------------------------------------------------------------------------------------------ error_figure

@pytest.mark.parametrize("quantity", list(QUANTITY_FIELDS))
def test_error_figure_single_run_one_trace_per_method(single, quantity):
    err_field, _, _ = QUANTITY_FIELDS[quantity]
    fig = error_figure(single, quantity=quantity)
    assert [t.name for t in fig.data] == list(NAMES)
    for method, trace in zip(METHODS_UNDER_TEST, fig.data):
        res = single[method]
        np.testing.assert_array_equal(np.asarray(trace.x), res.t_s)
        np.testing.assert_array_equal(np.asarray(trace.y), getattr(res, err_field)[:, 0])


@pytest.mark.parametrize("quantity", list(QUANTITY_FIELDS))
def test_error_figure_sigma_band_per_method(single, quantity):
    err_field, sigma_field, _ = QUANTITY_FIELDS[quantity]
    fig = error_figure(single, quantity=quantity, show_sigma=True)
    traces = _by_name(fig)
    assert set(traces) == set(NAMES) | {f"{n} 1-sigma" for n in NAMES}
    for method, name in zip(METHODS_UNDER_TEST, NAMES):
        res = single[method]
        band, curve = traces[f"{name} 1-sigma"], traces[name]
        np.testing.assert_array_equal(np.asarray(band.x), res.t_s)
        np.testing.assert_array_equal(np.asarray(band.y), getattr(res, sigma_field)[:, 0])
        np.testing.assert_array_equal(np.asarray(curve.y), getattr(res, err_field)[:, 0])
        # the band is shaded in the method's own colour
        rgba = re.fullmatch(r"rgba\((\d+),(\d+),(\d+),([0-9.]+)\)", band.fillcolor.replace(" ", ""))
        assert rgba is not None, band.fillcolor
        assert tuple(int(g) for g in rgba.groups()[:3]) == _hex_rgb(METHOD_COLORS[method])
        assert 0.0 < float(rgba.group(4)) < 1.0


def test_error_figure_without_sigma_has_no_band(single):
    fig = error_figure(single, show_sigma=False)
    assert not any("sigma" in t.name for t in fig.data)


@pytest.mark.parametrize("log_y, axis_type", [(True, "log"), (False, "linear")])
def test_error_figure_log_axis(single, log_y, axis_type):
    assert error_figure(single, log_y=log_y).layout.yaxis.type == axis_type


@pytest.mark.parametrize("quantity", list(QUANTITY_FIELDS))
@pytest.mark.parametrize("show_sigma", [False, True])
def test_error_figure_auto_log_only_where_the_values_span_decades(single, monte_carlo, quantity, show_sigma):
    """A log axis over 1.0-1.2 deg (heading) has no ticks and flattens the curves: "auto" is log
    exactly when the drawn values span more than LOG_SPAN."""
    for results in (single, monte_carlo):
        fig = error_figure(results, quantity, show_sigma=show_sigma, log_y="auto")
        values = np.concatenate([np.asarray(t.y, dtype=float) for t in fig.data])
        values = values[np.isfinite(values) & (values > 0)]
        wide = values.max() > LOG_SPAN * values.min()
        assert fig.layout.yaxis.type == ("log" if wide else "linear"), (quantity, values.min(), values.max())


def test_error_figure_auto_log_for_velocity_linear_for_heading(single):
    """The cases that motivated "auto": the INS velocity error grows by decades, heading barely moves."""
    heading = single["tc"].heading_err_deg
    assert heading.max() < LOG_SPAN * heading.min()
    assert error_figure(single, "vel", log_y="auto").layout.yaxis.type == "log"
    assert error_figure({"tc": single["tc"]}, "heading", log_y="auto").layout.yaxis.type == "linear"
    with pytest.raises(ValueError, match="'sometimes'"):
        error_figure(single, log_y="sometimes")


def test_error_figure_unknown_quantity_names_it(single):
    with pytest.raises(ValueError, match="'speed'"):
        error_figure(single, quantity="speed")


@pytest.mark.parametrize("quantity", list(QUANTITY_FIELDS))
def test_error_figure_monte_carlo_is_rms_over_runs(monte_carlo, quantity):
    err_field, sigma_field, _ = QUANTITY_FIELDS[quantity]
    fig = error_figure(monte_carlo, quantity=quantity, show_sigma=True)
    traces = _by_name(fig)
    for method, name in zip(METHODS_UNDER_TEST, NAMES):
        res = monte_carlo[method]
        err = getattr(res, err_field)
        assert err.shape[1] == 3
        assert not np.allclose(err[:, 0], err[:, 1])      # runs differ, so RMS is not run 0
        np.testing.assert_allclose(np.asarray(traces[name].y), _rms_over_runs(err), rtol=1e-12, atol=0)
        np.testing.assert_allclose(np.asarray(traces[f"{name} 1-sigma"].y), _rms_over_runs(getattr(res, sigma_field)),
                                   rtol=1e-12, atol=0)
        np.testing.assert_array_equal(np.asarray(traces[name].x), res.t_s)
    assert "RMS of 3 runs" in fig.layout.title.text


def test_error_figure_tilt_and_heading_split_the_attitude_norm(single):
    """tilt^2 + heading^2 = norm^2 at every epoch: the two plots split what the norm plot shows."""
    for method in METHODS_UNDER_TEST:
        tilt = np.asarray(error_figure(single, "tilt").data[METHODS_UNDER_TEST.index(method)].y)
        heading = np.asarray(error_figure(single, "heading").data[METHODS_UNDER_TEST.index(method)].y)
        norm = np.asarray(error_figure(single, "att").data[METHODS_UNDER_TEST.index(method)].y)
        np.testing.assert_allclose(np.hypot(tilt, heading), norm, rtol=1e-9, atol=1e-12)


def test_error_figure_colours_are_the_method_colours(single):
    fig = error_figure(single, show_sigma=True)
    traces = _by_name(fig)
    for method, name in zip(METHODS_UNDER_TEST, NAMES):
        assert traces[name].line.color == METHOD_COLORS[method]


def test_every_method_has_its_own_colour():
    """Both papers' methods (Yoo 2014's INS-DVL and VKF too) and the registered ones, each its own colour."""
    assert set(RUN_METHODS) <= set(METHOD_COLORS) and "cv" in RUN_METHODS
    colours = [METHOD_COLORS[m] for m in RUN_METHODS]
    assert len(set(colours)) == len(colours)
    for c in colours:
        assert re.fullmatch(r"#[0-9a-fA-F]{6}", c), c


@pytest.mark.parametrize("quantity", list(QUANTITY_FIELDS))
def test_error_figure_title_has_the_unit(single, quantity):
    title = error_figure(single, quantity=quantity).layout.title.text
    assert QUANTITY_FIELDS[quantity][2] in title
    assert "RMS" not in title                              # one run: the curves are that run's errors


# ------------------------------------------------------------------------------------------ elc_choice_figure

def _markers_per_axis(fig) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {a: [] for a in AXES}
    for t in fig.data:
        assert t.mode == "markers"
        ys = set(t.y)
        assert len(ys) == 1 and ys <= set(AXES), t.y      # one trace draws one axis
        out[t.y[0]].extend(np.asarray(t.x).tolist())
    return out


def test_elc_choice_two_beams_marks_every_partial_epoch(elc_two_beams):
    dvl = elc_two_beams.updates["dvl"]
    mode, choice = dvl.mode[:, 0], dvl.elc_choice[:, 0, :]
    partial = mode == MODE_PARTIAL
    assert partial.all() and partial.sum() == len(dvl.t_s) > 0        # beams 1-2 only: every ping partial
    assert (choice[partial] >= 0).all()                                # and every axis measured
    fig = elc_choice_figure(elc_two_beams)
    markers = _markers_per_axis(fig)
    for axis_name in AXES:
        assert len(markers[axis_name]) == int(partial.sum())
        assert sorted(markers[axis_name]) == sorted(dvl.t_s[partial].tolist())
    assert LC_NAME not in {t.name for t in fig.data}
    assert list(fig.layout.yaxis.categoryarray) and set(fig.layout.yaxis.categoryarray) == set(AXES)


def test_elc_choice_traces_follow_the_recorded_choice(elc_two_beams):
    """Each candidate's markers on an axis sit exactly at the epochs where that axis chose it."""
    dvl = elc_two_beams.updates["dvl"]
    mode, choice = dvl.mode[:, 0], dvl.elc_choice[:, 0, :]
    fig = elc_choice_figure(elc_two_beams)
    drawn = {(t.name, t.y[0]): np.asarray(t.x) for t in fig.data}
    expected = {}
    for a, axis_name in enumerate(AXES):
        for code, cand in enumerate(CANDIDATES):
            hit = (choice[:, a] == code) & (mode == MODE_PARTIAL)
            if hit.any():
                expected[(cand.upper(), axis_name)] = dvl.t_s[hit]
    assert len({name for name, _ in expected}) >= 2                     # the run exercises several candidates
    assert set(drawn) == set(expected)
    for key, t in expected.items():
        np.testing.assert_array_equal(drawn[key], t)
    for trace in fig.data:
        assert trace.marker.color == METHOD_COLORS[trace.name.lower()]
    # one legend entry per candidate, however many axes it appears on
    shown = [t.name for t in fig.data if t.showlegend]
    assert sorted(shown) == sorted({name for name, _ in expected})


def test_elc_choice_four_beams_is_lc_at_every_epoch(elc_four_beams):
    dvl = elc_four_beams.updates["dvl"]
    assert (dvl.mode[:, 0] == MODE_LC).all()
    fig = elc_choice_figure(elc_four_beams)
    assert {t.name for t in fig.data} == {LC_NAME}
    markers = _markers_per_axis(fig)
    for axis_name in AXES:
        np.testing.assert_array_equal(markers[axis_name], dvl.t_s)
    for trace in fig.data:
        assert trace.marker.color == METHOD_COLORS["lc"]
    assert sum(bool(t.showlegend) for t in fig.data) == 1


def test_elc_choice_mixed_run_marks_partial_and_lc_never_coast(elc_mixed):
    dvl = elc_mixed.updates["dvl"]
    mode = dvl.mode[:, 0]
    assert {MODE_LC, MODE_PARTIAL, MODE_COAST} <= set(mode.tolist())
    fig = elc_choice_figure(elc_mixed)
    for axis_name in AXES:
        lc_x = np.concatenate([np.asarray(t.x) for t in fig.data if t.name == LC_NAME and t.y[0] == axis_name])
        partial_x = np.concatenate([np.asarray(t.x) for t in fig.data if t.name != LC_NAME and t.y[0] == axis_name])
        np.testing.assert_array_equal(np.sort(lc_x), dvl.t_s[mode == MODE_LC])
        np.testing.assert_array_equal(np.sort(partial_x), dvl.t_s[mode == MODE_PARTIAL])
        assert not np.isin(dvl.t_s[mode == MODE_COAST], np.concatenate([lc_x, partial_x])).any()


def test_elc_choice_without_dvl_updates_is_empty(single):
    assert "dvl" not in single["ins"].updates
    assert len(elc_choice_figure(single["ins"]).data) == 0


# ------------------------------------------------------------------------------------------ nees_figure

BAND, REFERENCE = "99 % band", "1 = consistent"


def _block_series(res: MethodResult, block: str) -> np.ndarray:
    """The (T, R) NEES of a block, read from the result's own arrays."""
    return res.nees if block == "full" else res.nees_block[..., list(NEES_BLOCKS).index(block)]


@pytest.mark.parametrize("block", list(BLOCK_DIMS))
@pytest.mark.parametrize("fixture, runs", [("single", 1), ("monte_carlo", 3)])
def test_nees_figure_traces_are_the_run_averaged_nees_per_dim(request, fixture, runs, block):
    results = request.getfixturevalue(fixture)
    dim = BLOCK_DIMS[block]
    fig = nees_figure(results, block=block)
    traces = _by_name(fig)
    assert set(traces) == set(NAMES) | {BAND, REFERENCE}
    for method, name in zip(METHODS_UNDER_TEST, NAMES):
        res = results[method]
        series = _block_series(res, block)
        assert series.shape == (len(res.t_s), runs)
        np.testing.assert_array_equal(np.asarray(traces[name].x), res.t_s)
        np.testing.assert_allclose(np.asarray(traces[name].y), series.mean(axis=1) / dim, rtol=1e-12, atol=0)
        assert traces[name].line.color == METHOD_COLORS[method]
    assert f"dim {dim}" in fig.layout.title.text and "NEES/dim" in fig.layout.title.text
    assert fig.layout.yaxis.type == "log"
    assert "1 = consistent" in fig.layout.yaxis.title.text


@pytest.mark.parametrize("block", list(BLOCK_DIMS))
@pytest.mark.parametrize("fixture, runs", [("single", 1), ("monte_carlo", 3)])
def test_nees_figure_band_is_the_two_sided_99_percent_band(request, fixture, runs, block):
    """The shaded band spans the run time between the chi-square bounds of the run-averaged NEES
    divided by dim (worked values: dim 20 with one run, chi2(20) 0.5 % and 99.5 % = 7.434, 39.997)."""
    results = request.getfixturevalue(fixture)
    dim = BLOCK_DIMS[block]
    band = _by_name(nees_figure(results, block=block))[BAND]
    lo, hi = nees_band(dim, runs)
    assert 0.0 < lo < 1.0 < hi
    np.testing.assert_allclose(np.asarray(band.y), [lo, lo, hi, hi], rtol=1e-12)
    t = results["tc"].t_s
    np.testing.assert_array_equal(np.asarray(band.x), [t[0], t[-1], t[-1], t[0]])
    assert band.fill == "toself" and band.line.dash == "dash"
    reference = _by_name(nees_figure(results, block=block))[REFERENCE]
    np.testing.assert_array_equal(np.asarray(reference.y), [1.0, 1.0])
    if block == "full" and runs == 1:
        np.testing.assert_allclose([lo, hi], [7.4338 / 20, 39.9968 / 20], rtol=1e-4)


def test_nees_figure_band_narrows_with_runs(single, monte_carlo):
    one = _by_name(nees_figure(single, "vel"))[BAND].y
    three = _by_name(nees_figure(monte_carlo, "vel"))[BAND].y
    assert one[0] < three[0] < 1.0 < three[2] < one[2]
    assert "mean of 3 runs" in nees_figure(monte_carlo).layout.title.text


def test_nees_figure_block_choice_changes_the_curves_and_the_title(single):
    curves = {block: np.asarray(_by_name(nees_figure(single, block))["TC"].y) for block in BLOCK_DIMS}
    titles = {block: nees_figure(single, block).layout.title.text for block in BLOCK_DIMS}
    assert len(set(titles.values())) == len(BLOCK_DIMS)
    assert "velocity" in titles["vel"] and "heading" in titles["heading"] and "full state" in titles["full"]
    for a in BLOCK_DIMS:
        for b in BLOCK_DIMS:
            if a < b:
                assert not np.allclose(curves[a], curves[b]), (a, b)
    assert nees_figure(single).layout.title.text == titles["full"]            # the default block


def test_nees_figure_unknown_block_names_it(single):
    with pytest.raises(ValueError, match="'attitude'"):
        nees_figure(single, block="attitude")


def test_nees_figure_diverged_run_is_a_gap_not_a_number(monte_carlo):
    """A run whose NEES is not finite (a diverged filter) leaves a gap (NaN), never an infinity."""
    res = monte_carlo["tc"]
    nees = res.nees.copy()
    nees[5:9, 1] = np.inf
    nees[12, 2] = np.nan
    y = np.asarray(_by_name(nees_figure({"tc": dataclasses.replace(res, nees=nees)}))["TC"].y)
    assert np.flatnonzero(np.isnan(y)).tolist() == [5, 6, 7, 8, 12]
    assert not np.isinf(y).any()


def test_nees_figure_decimates_like_the_error_plots(monte_carlo):
    fig = nees_figure(monte_carlo, max_points=50)
    t = monte_carlo["tc"].t_s
    x = np.asarray(_by_name(fig)["TC"].x)
    assert len(x) <= 51 and x[-1] == t[-1]
    np.testing.assert_array_equal(np.asarray(_by_name(fig)[BAND].x)[:2], [t[0], t[-1]])


def test_fast_nees_figure_equals_plotly_validated_construction(single, monte_carlo):
    for results in (single, monte_carlo):
        for block in BLOCK_DIMS:
            fast, checked = nees_figure(results, block), nees_figure(results, block, validate=True)
            assert json.loads(fast.to_json()) == json.loads(checked.to_json())


# ------------------------------------------------------------------------------------------ summary

def _expected_row(res: MethodResult) -> dict[str, float]:
    out = {}
    for key, field in (("vel", "vel_err_mps"), ("att", "att_err_deg"), ("pos", "pos_err_m")):
        err = getattr(res, field)                                   # (T, R)
        unit = field.rsplit("_", 1)[1]
        out[f"{key}_final_{unit}"] = float(np.sqrt(np.mean(err[-1] ** 2)))
        out[f"{key}_rms_{unit}"] = float(np.sqrt(np.mean(err ** 2)))  # RMS over runs then time = over both
    out["tilt_rms_deg"] = float(np.sqrt(np.mean(res.tilt_err_deg ** 2)))
    out["heading_rms_deg"] = float(np.sqrt(np.mean(res.heading_err_deg ** 2)))
    return out


CONSISTENCY_KEYS = ("nees_dim", "nees_per_dim", "nees_in_band", "vel_nees_per_dim", "dvl_nis_per_dof")


def _expected_consistency(res: MethodResult) -> dict[str, float]:
    c = method_consistency(res)
    return {"nees_dim": c.nees["full"].dim, "nees_per_dim": c.nees["full"].per_dim, "nees_in_band": c.nees["full"].in_band,
            "vel_nees_per_dim": c.nees["vel"].per_dim,
            "dvl_nis_per_dof": c.nis["dvl"].per_dof if "dvl" in c.nis else float("nan")}


@pytest.mark.parametrize("fixture", ["single", "monte_carlo"])
def test_summary_rows_final_and_rms(request, fixture):
    results = request.getfixturevalue(fixture)
    rows = summary_rows(results)
    assert [r["method"] for r in rows] == list(NAMES)
    for method, row in zip(METHODS_UNDER_TEST, rows):
        expected = _expected_row(results[method])
        assert set(row) == (set(expected) | set(CONSISTENCY_KEYS)
                            | {"method", "runs", "diverged_runs", "diverged_first_s", "p_floor_count",
                               "counts", "dvl_resets"})
        for key, value in expected.items():
            assert row[key] == pytest.approx(value, rel=1e-12), key
        # a healthy default run: nothing flagged, P never repaired
        assert row["runs"] == results[method].vel_err_mps.shape[1]
        assert row["diverged_runs"] == 0 and np.isnan(row["diverged_first_s"]) and row["p_floor_count"] == 0


def test_summary_rows_single_run_final_is_last_epoch(single):
    res = single["tc"]
    row = summary_rows({"tc": res})[0]
    assert row["vel_final_mps"] == res.vel_err_mps[-1, 0]
    assert row["pos_final_m"] == res.pos_err_m[-1, 0]
    assert row["att_final_deg"] == res.att_err_deg[-1, 0]


@pytest.mark.parametrize("fixture", ["single", "monte_carlo"])
def test_summary_rows_consistency_is_method_consistency(request, fixture):
    """The new columns are tauvcore.eval.consistency's numbers, NaN kept as NaN (INS: no DVL)."""
    results = request.getfixturevalue(fixture)
    for method, row in zip(METHODS_UNDER_TEST, summary_rows(results)):
        expected = _expected_consistency(results[method])
        for key in CONSISTENCY_KEYS:
            if np.isnan(expected[key]):
                assert np.isnan(row[key]), (method, key)
            else:
                assert row[key] == expected[key], (method, key)
    ins, tc = summary_rows(results)[0], summary_rows(results)[1]
    assert np.isnan(ins["dvl_nis_per_dof"])                         # INS has no DVL update
    assert 0.2 < tc["nees_per_dim"] < 5 and 0.0 < tc["nees_in_band"] <= 1.0 and 0.2 < tc["dvl_nis_per_dof"] < 5


ERRORS_HEADER = ("| method | vel final [m/s] | vel RMS [m/s] | att final [deg] | pos final [m] | tilt RMS [deg] "
                 "| heading RMS [deg] |")
CONSISTENCY_HEADER = "| method | states | NEES/dim (in 99 % band) | vel NEES/dim | DVL NIS/dof | monitor |"


def _tables(markdown: str) -> tuple[list[str], list[str]]:
    """The errors table's and the consistency table's lines (header, rule, one line per method)."""
    lines = markdown.splitlines()
    cut = lines.index(CONSISTENCY_HEADING)
    assert lines[cut - 1] == lines[cut + 1] == ""
    rest = lines[cut + 2:]
    end = rest.index("") if "" in rest else len(rest)           # a Monte Carlo's runs table follows
    return lines[:cut - 1], rest[:end]


def _table_rows(markdown: str) -> tuple[list[str], list[list[str]]]:
    """Header and body cells of both tables side by side, one row per method (columns 0-6: the
    errors table, 7-11: the consistency table after its method column, 12: P floors if shown)."""
    errors, consistency = _tables(markdown)
    assert len(errors) == len(consistency)
    header = _cells(errors[0]) + _cells(consistency[0])[1:]
    rows = []
    for e, c in zip(errors[2:], consistency[2:]):
        assert _cells(e)[0] == _cells(c)[0]                        # the same method on both lines
        rows.append(_cells(e) + _cells(c)[1:])
    return header, rows


def _ratio_value(text: str) -> float:
    return float(text.split(" (")[0])


@pytest.mark.parametrize("fixture", ["single", "monte_carlo"])
def test_summary_markdown_table(request, fixture):
    results = request.getfixturevalue(fixture)
    errors, consistency = _tables(summary_markdown(results))
    assert errors[0] == ERRORS_HEADER and errors[1] == "|" + "---|" * 7
    assert consistency[0] == CONSISTENCY_HEADER and consistency[1] == "|" + "---|" * 6
    header, body = _table_rows(summary_markdown(results))
    assert tuple(header) == ERROR_COLUMNS + CONSISTENCY_COLUMNS[1:]
    assert len(body) == len(METHODS_UNDER_TEST)
    for method, name, cells in zip(METHODS_UNDER_TEST, NAMES, body):
        assert len(cells) == 12
        assert cells[0] == name
        assert cells[7] == str(BLOCK_DIMS["full"])                   # the 20-state filter
        assert cells[11] == "ok"
        exp = _expected_row(results[method])
        assert float(cells[1]) == pytest.approx(exp["vel_final_mps"], abs=0.5e-4)
        assert float(cells[2]) == pytest.approx(exp["vel_rms_mps"], abs=0.5e-4)
        assert float(cells[3]) == pytest.approx(exp["att_final_deg"], abs=0.5e-3)
        assert float(cells[4]) == pytest.approx(exp["pos_final_m"], abs=0.5e-2)
        assert float(cells[5]) == pytest.approx(exp["tilt_rms_deg"], abs=0.5e-3)
        assert float(cells[6]) == pytest.approx(exp["heading_rms_deg"], abs=0.5e-3)
        c = _expected_consistency(results[method])
        nees_cell = re.fullmatch(r"([0-9.e+-]+) \((\d+) %\)", cells[8])
        assert nees_cell is not None, cells[8]
        assert float(nees_cell.group(1)) == pytest.approx(c["nees_per_dim"], rel=0.01, abs=0.005)
        assert int(nees_cell.group(2)) == round(100 * c["nees_in_band"])
        assert _ratio_value(cells[9]) == pytest.approx(c["vel_nees_per_dim"], rel=0.01, abs=0.005)
        if np.isnan(c["dvl_nis_per_dof"]):
            assert cells[10] == "-"
        else:
            assert _ratio_value(cells[10]) == pytest.approx(c["dvl_nis_per_dof"], rel=0.01, abs=0.005)
    assert body[0][10] == "-"                                        # INS: no DVL NIS


def test_a_monte_carlo_shows_its_spread_and_its_flagged_runs(single, monte_carlo):
    """Over the runs: RMS, median and 95th percentile of the final errors, the monitor's flagged
    runs and the RMS without them; nothing of it for a single run."""
    assert "Over the" not in summary_markdown(single)
    res = monte_carlo["tc"]
    flagged = np.zeros(res.diverged.size, dtype=bool)
    flagged[0] = True
    vel = res.vel_err_mps.copy()
    vel[-1, 0] = 99.0                                                    # one run locked out
    results = {"tc": dataclasses.replace(res, diverged=flagged, vel_err_mps=vel)}
    markdown = summary_markdown(results)
    lines = markdown.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(f"**Over the {flagged.size} runs**"))
    assert _cells(lines[start + 2]) == list(RUNS_COLUMNS)
    cells = _cells(lines[start + 4])
    rms_, median, p95 = (float(x) for x in cells[1].split(" / "))
    finals = vel[-1]
    assert rms_ == pytest.approx(np.sqrt(np.mean(finals**2)), abs=0.5e-4)
    assert median == pytest.approx(np.median(finals), abs=0.5e-4)
    assert p95 == pytest.approx(np.percentile(finals, 95.0), abs=0.5e-4)
    assert cells[3] == f"1 of {flagged.size}"
    without = float(cells[4].split(" / ")[0])
    assert without == pytest.approx(np.sqrt(np.mean(finals[1:] ** 2)), abs=0.5e-4) and without < 1.0


def test_summary_markdown_shows_nan_as_a_dash(single):
    """A diverged filter's NaN errors and NEES read "-", never "nan"."""
    res = single["tc"]
    nan = np.full_like(res.vel_err_mps, np.nan)
    broken = dataclasses.replace(res, vel_err_mps=nan, nees=nan, nees_block=np.full_like(res.nees_block, np.nan))
    cells = _table_rows(summary_markdown({"tc": broken}))[1][0]
    assert cells[1] == cells[2] == cells[8] == cells[9] == "-"
    assert "nan" not in summary_markdown({"tc": broken}).lower()


@pytest.mark.parametrize("per_dim, shown", [(1.004, "1.00"), (21.66, "21.66"), (2820.4, "2820"), (0.0123, "0.012")])
def test_summary_markdown_ratio_reads_near_one_and_in_the_thousands(single, per_dim, shown):
    res = single["tc"]
    dim = BLOCK_DIMS["vel"]
    vel_ix = list(NEES_BLOCKS).index("vel")
    nees_block = res.nees_block.copy()
    nees_block[..., vel_ix] = per_dim * dim
    cells = _table_rows(summary_markdown({"tc": dataclasses.replace(res, nees_block=nees_block)}))[1][0]
    assert cells[9] == shown


def _flagged(res: MethodResult, at_s: list[float], floors: list[int]) -> MethodResult:
    """The same result with the divergence monitor's and the P floor's records set as given."""
    at = np.array(at_s, dtype=float)
    return dataclasses.replace(res, diverged=~np.isnan(at), diverged_at_s=at, p_floor_count=np.array(floors))


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def test_summary_marks_a_diverged_single_run_with_its_time(single):
    results = {"ins": single["ins"], "tc": _flagged(single["tc"], [12.3456], [0]), "nsv": single["nsv"]}
    rows = summary_rows(results)
    assert [r["diverged_runs"] for r in rows] == [0, 1, 0]
    assert rows[1]["diverged_first_s"] == 12.3456
    header, body = _table_rows(summary_markdown(results))
    assert "P floors" not in header                        # no repair anywhere: no column
    assert [cells[11] for cells in body] == ["ok", "diverged at 12.3 s", "ok"]


def test_summary_counts_diverged_monte_carlo_runs_and_the_first_time(monte_carlo):
    results = {"tc": _flagged(monte_carlo["tc"], [np.nan, 80.0, 41.25], [0, 0, 0]), "nsv": monte_carlo["nsv"]}
    row = summary_rows(results)[0]
    assert (row["runs"], row["diverged_runs"], row["diverged_first_s"]) == (3, 2, 41.25)
    cells = _table_rows(summary_markdown(results))[1][0]
    assert cells[11] == "2 of 3 runs, first diverged at 41.2 s"


def test_summary_shows_p_floor_column_only_when_a_repair_happened(monte_carlo):
    results = {"tc": _flagged(monte_carlo["tc"], [np.nan] * 3, [2, 0, 5]), "nsv": monte_carlo["nsv"]}
    assert summary_rows(results)[0]["p_floor_count"] == 7
    errors, consistency = _tables(summary_markdown(results))
    assert consistency[0].endswith("| monitor | P floors |") and consistency[1] == "|" + "---|" * 7
    assert "P floors" not in errors[0]
    body = _table_rows(summary_markdown(results))[1]
    assert [cells[12] for cells in body] == ["7", "0"]
    assert [cells[11] for cells in body] == ["ok", "ok"]


@pytest.mark.parametrize("show_sigma", [False, True])
@pytest.mark.parametrize("log_y", [False, True])
def test_fast_error_figure_equals_plotly_validated_construction(single, monte_carlo, show_sigma, log_y):
    """The live plots skip plotly's validation; what they send must be what validation gives."""
    for results in (single, monte_carlo):
        for quantity in QUANTITY_FIELDS:
            fast = error_figure(results, quantity, show_sigma=show_sigma, log_y=log_y)
            checked = error_figure(results, quantity, show_sigma=show_sigma, log_y=log_y, validate=True)
            assert json.loads(fast.to_json()) == json.loads(checked.to_json())
            fast = error_figure(results, quantity, show_sigma=show_sigma, log_y="auto")
            checked = error_figure(results, quantity, show_sigma=show_sigma, log_y="auto", validate=True)
            assert json.loads(fast.to_json()) == json.loads(checked.to_json())
            assert json.loads(fast.to_json())["layout"]["template"]["layout"]["plot_bgcolor"] == "white"


def test_fast_elc_figure_equals_plotly_validated_construction(elc_two_beams, elc_four_beams, elc_mixed):
    for result in (elc_two_beams, elc_four_beams, elc_mixed):
        fast, checked = elc_choice_figure(result), elc_choice_figure(result, validate=True)
        assert json.loads(fast.to_json()) == json.loads(checked.to_json())


def test_the_study_report_figure_is_plotly_s_validated_figure() -> None:
    """app.reports.study_report builds its traces as dicts on make_subplots' grid without validation; the
    result must be the figure plotly builds and validates (traces on their axes, log axes, NaN
    gaps as None)."""
    import json

    from app.reports.study_report import trajectory_figure

    rng = np.random.default_rng(0)
    T = 40
    names = ("vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg")
    summary = {"t_s": list(np.arange(T) * 0.1), "num_runs": 4,
               "methods": {m: {"rms": {n: list(np.abs(rng.normal(size=T))) for n in names},
                               "mean_nees": {"nees": list(20 * np.abs(rng.normal(size=T)))}}
                           for m in ("ins", "lc", "elc")}}
    summary["methods"]["lc"]["rms"]["vel_err_mps"][3] = float("nan")
    fast = json.loads(trajectory_figure("figure8", summary).to_json())
    checked = json.loads(trajectory_figure("figure8", summary, validate=True).to_json())
    assert fast == checked
    assert fast["data"][1]["y"][3] is None and fast["layout"]["yaxis"]["type"] == "log"
    assert {d["yaxis"] for d in fast["data"]} == {"y", "y2", "y3", "y4", "y5"}


# ------------------------------------------------------------------------------------------ actuators

@pytest.fixture(scope="module")
def dynamic_view() -> dict[str, np.ndarray]:
    """The worker's truth view of a short dynamic figure eight (fins and propeller at 10 Hz)."""
    from app.dashboard.truth_view import truth_view
    config = Config().replace("trajectory", name="figure8", duration_s=5.0, truth="dynamic")
    return truth_view(config, int(round(config.imu.rate_hz / config.filter.output_rate_hz)))


def test_actuator_figure_fins_in_degrees_and_propeller_against_time(dynamic_view):
    """Four fin traces (deg) on the top panel, the propeller [rpm] on the bottom one, one time axis."""
    tv = dynamic_view
    fig = actuator_figure(tv["t_s"], tv["fin_angles_rad"], tv["propeller_rpm"])
    traces = _by_name(fig)
    assert list(traces) == [*FIN_NAMES, "propeller"]
    for k, name in enumerate(FIN_NAMES):
        np.testing.assert_array_equal(np.asarray(traces[name].x), tv["t_s"])
        np.testing.assert_allclose(np.asarray(traces[name].y), tv["fin_angles_rad"][:, k] * 180.0 / np.pi,
                                   rtol=1e-12, atol=0)
        assert (traces[name].xaxis, traces[name].yaxis) == ("x", "y")
        assert traces[name].line.color == FIN_COLORS[k]
    np.testing.assert_array_equal(np.asarray(traces["propeller"].x), tv["t_s"])
    np.testing.assert_array_equal(np.asarray(traces["propeller"].y), tv["propeller_rpm"])
    assert (traces["propeller"].xaxis, traces["propeller"].yaxis) == ("x2", "y2")
    # degrees, not radians: the figure eight's turns need more than a degree of fin
    assert np.max(np.abs(np.asarray(traces[FIN_NAMES[0]].y))) > 1.0
    layout = fig.layout
    assert layout.xaxis2.ticksuffix == " s" and layout.xaxis.matches == "x2"   # the unit on the time ticks
    assert "[deg]" in layout.yaxis.title.text and "[rpm]" in layout.yaxis2.title.text
    # the two panels do not overlap
    assert layout.yaxis2.domain[1] < layout.yaxis.domain[0]


def test_actuator_figure_known_answer():
    t = np.array([0.0, 0.1, 0.2])
    fins = np.radians([[0.0, 1.0, -2.0, 3.0], [10.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -25.0]])
    fig = actuator_figure(t, fins, np.array([900.0, 910.0, 920.0]))
    traces = _by_name(fig)
    np.testing.assert_allclose(np.asarray(traces[FIN_NAMES[0]].y), [0.0, 10.0, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(traces[FIN_NAMES[3]].y), [3.0, 0.0, -25.0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(traces["propeller"].y), [900.0, 910.0, 920.0])


def test_actuator_figure_decimates_and_keeps_the_last_sample():
    t = np.arange(2001) * 0.1
    fins = np.column_stack([np.sin(t), np.cos(t), -np.sin(t), -np.cos(t)]) * 0.2
    fig = actuator_figure(t, fins, 900.0 + t, max_points=100)
    for trace in fig.data:
        x = np.asarray(trace.x)
        assert len(x) <= 101 and x[-1] == t[-1]


def test_actuator_figure_refuses_mismatched_arrays():
    with pytest.raises(ValueError, match="fin_angles_rad \\(T, 4\\)"):
        actuator_figure(np.zeros(3), np.zeros((3, 3)), np.zeros(3))


def test_fast_actuator_figure_equals_plotly_validated_construction(dynamic_view):
    tv = dynamic_view
    fast = actuator_figure(tv["t_s"], tv["fin_angles_rad"], tv["propeller_rpm"])
    checked = actuator_figure(tv["t_s"], tv["fin_angles_rad"], tv["propeller_rpm"], validate=True)
    assert json.loads(fast.to_json()) == json.loads(checked.to_json())



# ------------------------------------------------------------------------------------------ altitude

@pytest.fixture(scope="module")
def longrange_view() -> dict[str, np.ndarray]:
    """The worker's truth view of the paper's long-range mission (24 min, 10 Hz)."""
    from app.dashboard.truth_view import truth_view
    from tauvcore.config import from_dict, merge, trajectory_preset
    config = from_dict(merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange"}}))
    return truth_view(config, int(round(config.imu.rate_hz / config.filter.output_rate_hz)))


def _shaded_spans(trace) -> list[tuple[float, float]]:
    """(start, end) of each rectangle of a "toself" trace of rectangles separated by None."""
    x = list(trace.x)
    spans, corners = [], []
    for value in x + [None]:
        if value is None:
            if corners:
                spans.append((min(corners), max(corners)))
            corners = []
        else:
            corners.append(value)
    return spans


def test_intervals_above_known_answer():
    """Crossings by linear interpolation; a stretch open at either end runs to that end; NaN is not above."""
    t = np.arange(11.0)
    np.testing.assert_allclose(intervals_above(t, np.array([0, 1, 2, 3, 4, 5, 4, 3, 2, 1, 0.0]), 2.5),
                               [[2.5, 7.5]], rtol=0, atol=1e-12)
    np.testing.assert_allclose(intervals_above(t, np.array([3, 3, 0, 0, 0, 0, 0, 0, np.nan, 3, 3.0]), 1.0),
                               [[0.0, 1.0 + 2.0 / 3.0], [9.0, 10.0]], rtol=0, atol=1e-12)
    assert intervals_above(t, np.zeros(11), 2.5).shape == (0, 2)
    np.testing.assert_array_equal(intervals_above(t, np.full(11, 5.0), 2.5), [[0.0, 10.0]])


def test_altitude_figure_shades_the_longrange_trenches(longrange_view):
    """Given the long-range mission, the altitude curve is the truth view's, the DVL limit and the
    VKF switch are horizontal lines at their values, and the stretches above the switch are shaded:
    5-8 and 15-16 minutes (Yoo 2014 section 3), to the output epoch."""
    tv = longrange_view
    config = Config()
    fig = altitude_figure(tv["t_s"], tv["altitude_m"], config.dvl.max_altitude_m, config.vkf.switch_altitude_m)
    traces = _by_name(fig)
    assert set(traces) == {ALTITUDE_NAME, DVL_LIMIT_NAME, SWITCH_NAME, RPM_NAME}
    alt_x, alt_y = np.asarray(traces[ALTITUDE_NAME].x), np.asarray(traces[ALTITUDE_NAME].y)
    assert len(alt_x) <= 601 and alt_x[-1] == tv["t_s"][-1]
    np.testing.assert_array_equal(alt_y, np.interp(alt_x, tv["t_s"], tv["altitude_m"]))
    assert alt_y.min() == pytest.approx(60.0) and alt_y.max() == pytest.approx(140.0)
    for name, level in ((DVL_LIMIT_NAME, config.dvl.max_altitude_m), (SWITCH_NAME, config.vkf.switch_altitude_m)):
        np.testing.assert_array_equal(traces[name].y, [level, level])
        np.testing.assert_array_equal(traces[name].x, [0.0, tv["t_s"][-1]])
    spans = _shaded_spans(traces[RPM_NAME])
    np.testing.assert_allclose(spans, [(300.0, 480.0), (900.0, 960.0)], rtol=0, atol=0.1)
    assert traces[RPM_NAME].fill == "toself"
    lo, hi = fig.layout.yaxis.range
    assert lo <= 0.0 and hi > 140.0                                 # the shading spans the plot's height
    assert min(v for v in traces[RPM_NAME].y if v is not None) == lo
    assert max(v for v in traces[RPM_NAME].y if v is not None) == hi


def test_altitude_figure_follows_the_thresholds():
    """The shading is where the altitude exceeds the VKF switch, not the DVL's limit."""
    t = np.arange(101.0)
    alt = 50.0 + t                                                    # 50 m to 150 m
    fig = altitude_figure(t, alt, dvl_max_altitude_m=100.0, switch_altitude_m=80.0)
    np.testing.assert_allclose(_shaded_spans(_by_name(fig)[RPM_NAME]), [(30.0, 100.0)], rtol=0, atol=1e-12)
    assert "100 m" in fig.layout.title.text and "80 m" in fig.layout.title.text
    # never above the switch: no shading trace
    low = altitude_figure(t, np.full(101, 60.0), 100.0, 100.0)
    assert RPM_NAME not in _by_name(low)


def test_altitude_figure_refuses_mismatched_arrays():
    with pytest.raises(ValueError, match="altitude_m \\(T,\\)"):
        altitude_figure(np.zeros(3), np.zeros(4), 100.0, 100.0)


def test_fast_altitude_figure_equals_plotly_validated_construction(longrange_view):
    tv = longrange_view
    fast = altitude_figure(tv["t_s"], tv["altitude_m"], 100.0, 100.0)
    checked = altitude_figure(tv["t_s"], tv["altitude_m"], 100.0, 100.0, validate=True)
    assert json.loads(fast.to_json()) == json.loads(checked.to_json())


# ------------------------------------------------------------------------------------------ Yoo 2014's methods

YOO_DURATION_S = 330.0
"""The long-range mission's first 330 s: its first trench (above the VKF's switch) from about 300 s."""


@pytest.fixture(scope="module")
def yoo() -> dict[str, MethodResult]:
    """LC (with the RPM fallback) beside Yoo 2014's INS-DVL and VKF over the first trench."""
    config = from_dict(merge(trajectory_preset("longrange"), {
        "trajectory": {"name": "longrange", "duration_s": YOO_DURATION_S},
        "run": {"methods": ["lc", "ins-dvl", "vkf"], "rpm_fallback": True}}))
    return _results(config, 1, seed=61)


def test_yoo_fixture_has_the_12_state_filter_s_dims_and_no_position_state(yoo):
    assert list(yoo) == ["lc", "ins-dvl", "vkf"]
    assert yoo["lc"].block_dims is None and "rpm" in yoo["lc"].updates
    for method in ("ins-dvl", "vkf"):
        res = yoo[method]
        assert res.block_dims == FAMILIES["yoo"].block_dims
        assert np.isnan(res.pos_sigma_m).all() and np.isnan(_block_series(res, "pos")).all()
        assert np.isfinite(res.nees).all() and np.isfinite(res.pos_err_m).all()
    assert yoo["vkf"].vkf_trace is not None and yoo["ins-dvl"].vkf_trace is None


@pytest.mark.parametrize("block", list(BLOCK_DIMS))
def test_nees_figure_divides_each_method_s_nees_by_its_own_dim(yoo, block):
    """Given LC (20 states) beside INS-DVL and VKF (12), each curve is the method's NEES over its own
    dimension; where the dimensions differ there is one 99 % band per dimension, and the title
    names both."""
    fig = nees_figure(yoo, block=block, max_points=None)
    traces = _by_name(fig)
    for method in yoo:
        dim = (yoo[method].block_dims or BLOCK_DIMS)[block]
        y = np.asarray(traces[method.upper()].y, dtype=float)
        expected = _block_series(yoo[method], block)[:, 0] / dim
        np.testing.assert_allclose(y, expected, rtol=1e-12, atol=0)
        assert traces[method.upper()].line.color == METHOD_COLORS[method]
    dims = [BLOCK_DIMS[block], FAMILIES["yoo"].block_dims[block]]
    if dims[0] == dims[1]:
        assert BAND in traces and f"dim {dims[0]}" in fig.layout.title.text
    else:
        for dim in dims:
            band = traces[f"{BAND} (dim {dim})"]
            np.testing.assert_allclose(np.asarray(band.y), np.repeat(nees_band(dim, 1), 2), rtol=1e-12)
        assert f"(dim {dims[0]}; INS-DVL, VKF dim {dims[1]})" in fig.layout.title.text
    if block == "pos":                                   # no position state: no curve at all
        assert np.isnan(np.asarray(traces["VKF"].y, dtype=float)).all()


def test_error_figure_has_no_position_band_for_yoo_s_methods(yoo):
    """The 12-state filter has no position sigma (NaN): its position error is drawn, its band is
    not; its velocity band is."""
    pos = _by_name(error_figure(yoo, "pos", show_sigma=True, log_y="auto", max_points=None))
    assert set(pos) == {"LC", "LC 1-sigma", "INS-DVL", "VKF"}
    np.testing.assert_array_equal(np.asarray(pos["VKF"].y), yoo["vkf"].pos_err_m[:, 0])
    vel = _by_name(error_figure(yoo, "vel", show_sigma=True))
    assert {"INS-DVL 1-sigma", "VKF 1-sigma"} <= set(vel)


def test_summary_shows_each_method_s_own_state_count_and_nees(yoo):
    """The Results consistency table: 20 states for LC, 12 for INS-DVL and VKF, each NEES/dim over
    its own dimension (method_consistency); no "nan" anywhere."""
    markdown = summary_markdown(yoo)
    assert "nan" not in markdown.lower()
    _, body = _table_rows(markdown)
    assert [cells[0] for cells in body] == ["LC", "INS-DVL", "VKF"]
    assert [cells[7] for cells in body] == ["20", "12", "12"]
    for method, cells in zip(yoo, body):
        c = _expected_consistency(yoo[method])
        assert _ratio_value(cells[8]) == pytest.approx(c["nees_per_dim"], rel=0.01, abs=0.005)
        assert np.isfinite(c["dvl_nis_per_dof"]) and cells[10] != "-"
    rows = summary_rows(yoo)
    assert [r["nees_dim"] for r in rows] == [20, 12, 12]


def _vkf_trace(U: int = 10, R: int = 1, in_use: tuple[int, ...] = (3, 4, 5), truth: bool = True) -> dict:
    """A VKF trace with known numbers: pings every second, sf 2e-3 + 1e-5 k [m/s per rpm], b 0.1 - 0.01 k [m/s]."""
    t = np.arange(U, dtype=float)
    x = np.zeros((U, R, 3))
    x[..., 0] = 5.0
    x[..., 1] = (2e-3 + 1e-5 * t)[:, None] + 1e-4 * np.arange(R)
    x[..., 2] = (0.1 - 0.01 * t)[:, None]
    sigma = np.empty((U, R, 3))
    sigma[..., 0], sigma[..., 1], sigma[..., 2] = 0.05, 2e-5, 0.02
    rpm = np.zeros((U, R), bool)
    rpm[list(in_use)] = True
    nan = np.full((U, R), np.nan)
    return {"t_s": t, "x": x, "sigma": sigma, "sf_true": np.full((U, R), 2.05e-3) if truth else nan,
            "b_true": np.full((U, R), 0.05) if truth else nan, "rpm_in_use": rpm, "altitude_m": np.full((U, R), 90.0)}


def test_vkf_figure_known_answer():
    """Scale factor in mm/s per rpm on top, bias in m/s below, each with its 1-sigma band (a closed
    polygon est + sigma forward, est - sigma back), the truth dashed, and the pings with the RPM in
    use shaded on both panels from crossing to crossing (2.5 to 5.5 s)."""
    trace = _vkf_trace()
    fig = vkf_figure(trace)
    traces = _by_name(fig)
    assert set(traces) == {VKF_SF_NAME, f"{VKF_SF_NAME} 1-sigma", f"{VKF_SF_NAME} (true)", VKF_B_NAME,
                           f"{VKF_B_NAME} 1-sigma", f"{VKF_B_NAME} (true)", RPM_NAME, f"{RPM_NAME} (bias)"}
    t = trace["t_s"]
    for name, k, scale, axis in ((VKF_SF_NAME, 1, 1e3, "y"), (VKF_B_NAME, 2, 1.0, "y2")):
        est, sig = scale * trace["x"][:, 0, k], scale * trace["sigma"][:, 0, k]
        np.testing.assert_array_equal(np.asarray(traces[name].x), t)
        np.testing.assert_allclose(np.asarray(traces[name].y), est, rtol=1e-12)
        band = traces[f"{name} 1-sigma"]
        np.testing.assert_array_equal(np.asarray(band.x), np.r_[t, t[::-1]])
        np.testing.assert_allclose(np.asarray(band.y), np.r_[est + sig, (est - sig)[::-1]], rtol=1e-12)
        assert band.fill == "toself" and band.yaxis == axis and traces[name].yaxis == axis
        assert band.showlegend is False and band.legendgroup == traces[name].legendgroup      # one legend entry
        true = traces[f"{name} (true)"]
        assert true.line.dash == "dash" and true.line.color == TRUTH_COLOR
        np.testing.assert_allclose(np.asarray(true.y), scale * trace[f"{'sf' if k == 1 else 'b'}_true"][:, 0])
        lo, hi = (fig.layout.yaxis if k == 1 else fig.layout.yaxis2).range
        assert lo < min(est - sig) and hi > max(est + sig)            # the band fits in the panel
    assert traces[VKF_SF_NAME].line.color == METHOD_COLORS["vkf"]
    np.testing.assert_allclose(_shaded_spans(traces[RPM_NAME]), [(2.5, 5.5)], rtol=0, atol=1e-12)
    np.testing.assert_allclose(_shaded_spans(traces[f"{RPM_NAME} (bias)"]), [(2.5, 5.5)], rtol=0, atol=1e-12)
    assert traces[RPM_NAME].showlegend and not traces[f"{RPM_NAME} (bias)"].showlegend
    assert fig.layout.yaxis.title.text == "sf [mm/s per rpm]" and fig.layout.yaxis2.title.text == "b [m/s]"
    assert fig.layout.title.text == "VKF: propeller scale factor and bias"


def test_vkf_figure_without_truth_or_rpm_has_neither_trace():
    """The dynamic truth has no RPM model (truth NaN); a mission within the DVL's range never uses the RPM."""
    traces = _by_name(vkf_figure(_vkf_trace(in_use=(), truth=False)))
    assert set(traces) == {VKF_SF_NAME, f"{VKF_SF_NAME} 1-sigma", VKF_B_NAME, f"{VKF_B_NAME} 1-sigma"}


def test_vkf_figure_draws_the_chosen_run_and_names_it():
    trace = _vkf_trace(R=3)
    fig = vkf_figure(trace, run=2)
    np.testing.assert_allclose(np.asarray(_by_name(fig)[VKF_SF_NAME].y), 1e3 * trace["x"][:, 2, 1], rtol=1e-12)
    assert fig.layout.title.text.endswith("(run 3 of 3)")
    with pytest.raises(ValueError, match="run must be within \\[0, 2\\], got 3"):
        vkf_figure(trace, run=3)


def test_vkf_figure_refuses_mismatched_arrays():
    trace = _vkf_trace()
    with pytest.raises(ValueError, match="x and sigma \\(U, R, 3\\)"):
        vkf_figure({**trace, "sigma": trace["sigma"][:-1]})


def test_vkf_figure_of_the_longrange_trench(yoo):
    """Given the first 330 s of the long-range mission, the VKF's figure shades the stretch over
    the trench (from about 300 s to the end), the truth lies within 3 sigma of the learned scale
    factor and bias at the end, and the curves are decimated with the last ping kept."""
    trace = yoo["vkf"].vkf_trace
    fig = vkf_figure(trace, max_points=300)
    traces = _by_name(fig)
    (start, end), = _shaded_spans(traces[RPM_NAME])
    assert 290.0 < start < 305.0 and end == pytest.approx(YOO_DURATION_S)
    x = np.asarray(traces[VKF_SF_NAME].x)
    assert len(x) <= 301 and x[-1] == trace["t_s"][-1]
    for k, key in ((1, "sf_true"), (2, "b_true")):
        assert abs(trace["x"][-1, 0, k] - trace[key][-1, 0]) < 3 * trace["sigma"][-1, 0, k], key
    fast, checked = vkf_figure(trace), vkf_figure(trace, validate=True)
    assert json.loads(fast.to_json()) == json.loads(checked.to_json())


def test_fast_figures_of_yoo_s_methods_equal_plotly_validated_construction(yoo):
    for block in BLOCK_DIMS:
        assert json.loads(nees_figure(yoo, block).to_json()) == json.loads(nees_figure(yoo, block, validate=True).to_json())
    for quantity in QUANTITY_FIELDS:
        fast = error_figure(yoo, quantity, show_sigma=True, log_y="auto")
        checked = error_figure(yoo, quantity, show_sigma=True, log_y="auto", validate=True)
        assert json.loads(fast.to_json()) == json.loads(checked.to_json())


# ------------------------------------------------------------------------------------------ workbench
from app.figures.error_figures import (  # noqa: E402
    RUN_DASHES,
    compare_figure,
    components_figure,
    error_components,
)
from app.figures.innovation_figures import (  # noqa: E402
    BAND_SUFFIX,
    REJECTED_SUFFIX,
    innovation_figure,
    innovation_sources,
)
from app.figures.shared import (  # noqa: E402
    CURSOR_NAME,
    cursor_shape,
    with_cursor,
)
from app.reports.markdown_tables import (  # noqa: E402
    compare_markdown,
    config_diff_markdown,
    config_differences,
    identical_methods,
    identical_note,
    rms_markdown,
)
from app.reports.settings_text import flat_config  # noqa: E402
from tauvcore.geo.rotations import euler_from_C_nb, wrap_angle  # noqa: E402


@pytest.fixture(scope="module")
def four_beams() -> tuple[Config, object, dict[str, MethodResult]]:
    """All four beams: LC, ELC and NSV fuse alike; TC fuses beams; the truth kept for components."""
    config = _short_config(methods=("ins", "lc", "tc", "elc", "nsv"))
    sim = simulate(config, np.random.default_rng(61), 1)
    return config, sim.truth, run(config, sim, np.random.default_rng(62))


def test_error_components_are_estimate_minus_truth(four_beams):
    """Known case: at the output epochs, position is est - truth per NED axis, attitude the
    difference of the Euler angles (heading wrapped), and the body velocity's norm is the
    runner's own velocity error norm."""
    _, truth, results = four_beams
    for method, res in results.items():
        comp = error_components(res, truth.t_s, truth.pos_n, truth.C_nb, truth.vel_n)
        k = np.searchsorted(truth.t_s, res.t_s)
        np.testing.assert_allclose(truth.t_s[k], res.t_s, atol=1e-9)
        np.testing.assert_array_equal(comp["pos"], res.est_pos_n - truth.pos_n[k][:, None, :])
        d = res.est_euler_rad - euler_from_C_nb(truth.C_nb[k])[:, None, :]
        d[..., 2] = wrap_angle(d[..., 2])
        np.testing.assert_allclose(comp["att"], np.degrees(d), atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(comp["vel"], axis=-1), res.vel_err_mps, atol=1e-9)
        np.testing.assert_allclose(np.linalg.norm(comp["pos"], axis=-1), res.pos_err_m, atol=1e-5)
        # without the truth's velocity: the central difference of its positions, close
        approx = error_components(res, truth.t_s[k], truth.pos_n[k], truth.C_nb[k])["vel"]
        np.testing.assert_allclose(approx, comp["vel"], atol=1e-3)


def test_error_components_of_a_synthetic_offset():
    """Truth at rest, level, heading north; the estimate 1 m north, 0.1 m/s east, 2 deg heading
    right: the components are exactly these, in the body frame for velocity."""
    T = 5
    t = np.arange(T, dtype=float)
    res = MethodResult(
        method="lc", t_s=t, vel_err_mps=np.zeros((T, 1)), att_err_deg=np.zeros((T, 1)), pos_err_m=np.zeros((T, 1)),
        vel_sigma_mps=np.zeros((T, 1)), att_sigma_deg=np.zeros((T, 1)), pos_sigma_m=np.zeros((T, 1)),
        nees=np.zeros((T, 1)), tilt_err_deg=np.zeros((T, 1)), heading_err_deg=np.zeros((T, 1)),
        tilt_sigma_deg=np.zeros((T, 1)), heading_sigma_deg=np.zeros((T, 1)), nees_block=np.zeros((T, 1, 6)),
        est_pos_n=np.tile([1.0, 0.0, 0.0], (T, 1, 1)), diverged=np.zeros(1, bool), diverged_at_s=np.full(1, np.nan),
        p_floor_count=np.zeros(1, int), est_vel_n=np.tile([0.0, 0.1, 0.0], (T, 1, 1)),
        est_euler_rad=np.tile([0.0, 0.0, np.radians(2.0)], (T, 1, 1)))
    comp = error_components(res, t, np.zeros((T, 3)), np.tile(np.eye(3), (T, 1, 1)), np.zeros((T, 3)))
    np.testing.assert_allclose(comp["pos"][:, 0], np.tile([1.0, 0.0, 0.0], (T, 1)))
    np.testing.assert_allclose(comp["att"][:, 0], np.tile([0.0, 0.0, 2.0], (T, 1)), atol=1e-12)
    c, s = np.cos(np.radians(2.0)), np.sin(np.radians(2.0))
    np.testing.assert_allclose(comp["vel"][:, 0], np.tile([0.1 * s, 0.1 * c, 0.0], (T, 1)), atol=1e-12)


@pytest.mark.parametrize("quantity", ["pos", "vel", "att"])
def test_components_figure_three_panels_per_method(four_beams, quantity):
    _, truth, results = four_beams
    comps = {m: error_components(r, truth.t_s, truth.pos_n, truth.C_nb, truth.vel_n) for m, r in results.items()}
    fig = components_figure(results, comps, quantity, max_points=None)
    assert len(fig.data) == 3 * len(results)
    for method, res in results.items():
        traces = [d for d in fig.data if d.name == method.upper()]
        assert [d.yaxis for d in traces] == ["y", "y2", "y3"]
        assert sum(bool(d.showlegend) for d in traces) == 1
        for k, d in enumerate(traces):
            np.testing.assert_array_equal(d.y, comps[method][quantity][:, 0, k])
            assert d.line.color == METHOD_COLORS[method]
    with_check = components_figure(results, comps, quantity, validate=True)
    assert json.loads(with_check.to_json()) == json.loads(components_figure(results, comps, quantity).to_json())


def test_identical_methods_four_beams_partial_methods_are_lc(four_beams):
    _, _, results = four_beams
    same = identical_methods(results)
    assert same == {"elc": "lc", "nsv": "lc"}           # TC fuses beams, not the LC velocity: its own numbers
    note = identical_note(same)
    assert "ELC and NSV give exactly the results of LC (with 3-4 beams returning, the partial-beam" in note
    assert identical_note({}) == ""


def test_the_identical_note_gives_each_group_its_own_reason():
    """Two beams: LC equals the INS because it coasts, not because of the partial-beam methods;
    ELC equals NSV because the selector took NSV's axes."""
    note = identical_note({"lc": "ins", "elc": "nsv"})
    assert "LC gives exactly the results of INS (LC coasts: fewer than three beams give it no velocity" in note
    assert "ELC gives exactly the results of NSV (the ELC selector took NSV's axes on every ping)" in note
    assert "partial-beam methods fuse as LC" not in note


def test_identical_methods_two_beams_none(single):
    assert identical_methods(single) == {}


def _with_rejections(res: MethodResult, rows: list[tuple[int, int]]) -> MethodResult:
    dvl = res.updates["dvl"]
    rejected_rows = np.zeros_like(dvl.rejected_rows)
    for u, k in rows:
        rejected_rows[u, 0, k] = True
    updates = {**res.updates, "dvl": dataclasses.replace(dvl, rejected_rows=rejected_rows,
                                                         rejected=rejected_rows.any(axis=2))}
    return dataclasses.replace(res, updates=updates)


def test_innovation_figure_envelopes_and_rejected_markers(four_beams):
    _, _, results = four_beams
    lc = _with_rejections(results["lc"], [(2, 0), (5, 0), (5, 2)])
    drawn = {"ins": results["ins"], "lc": lc, "tc": results["tc"]}
    assert innovation_sources(drawn) == ("dvl",)
    fig = innovation_figure(drawn, "dvl", max_points=None)
    # one quantity per panel: LC's body axes first (y, y2, y3), then TC's beams (y4 to y7)
    titles = [fig.layout[f"yaxis{'' if i == 1 else i}"].title.text for i in range(1, 8)]
    assert titles == ["surge", "sway", "heave", "beam 1", "beam 2", "beam 3", "beam 4"]
    assert {d.yaxis for d in fig.data if d.name.startswith("LC")} == {"y", "y2", "y3"}
    assert {d.yaxis for d in fig.data if d.name.startswith("TC")} == {"y4", "y5", "y6", "y7"}
    for method, m in (("lc", 3), ("tc", 4)):
        dvl = drawn[method].updates["dvl"]
        lines = [d for d in fig.data if d.name == method.upper()]
        bands = [d for d in fig.data if d.name == method.upper() + BAND_SUFFIX]
        assert len(lines) == len(bands) == m
        for k in range(m):
            np.testing.assert_array_equal(lines[k].x, dvl.t_s)
            np.testing.assert_array_equal(lines[k].y, dvl.innovation[:, 0, k])
            env = 3.0 * np.sqrt(dvl.innovation_var[:, 0, k])
            np.testing.assert_allclose(bands[k].y, np.r_[env, -env[::-1]])
            np.testing.assert_array_equal(bands[k].x, np.r_[dvl.t_s, dvl.t_s[::-1]])
    assert not any(d.name.startswith("INS") for d in fig.data)          # no DVL updates
    marks = [d for d in fig.data if d.name == "LC" + REJECTED_SUFFIX]
    t = lc.updates["dvl"].t_s
    assert [(list(d.x), d.yaxis) for d in marks] == [([t[2], t[5]], "y"), ([t[5]], "y3")]
    np.testing.assert_array_equal(marks[0].y, lc.updates["dvl"].innovation[[2, 5], 0, 0])
    assert sum(bool(d.showlegend) for d in marks) == 1
    assert not any(d.name == "TC" + REJECTED_SUFFIX for d in fig.data)
    checked = innovation_figure(drawn, "dvl", validate=True)
    assert json.loads(checked.to_json()) == json.loads(innovation_figure(drawn, "dvl").to_json())


def test_a_beam_that_did_not_return_is_a_gap_not_a_zero_innovation(single):
    """Beams 3-4 lost for 5-15 s: TC's rows 3 and 4 have no variance there and an innovation of 0
    as a placeholder; the figure leaves them empty (NaN), line and band, and draws them elsewhere."""
    tc = single["tc"]
    dvl = tc.updates["dvl"]
    lost = ~dvl.beams_available[:, 0, 2] & dvl.valid[:, 0]         # a ping, but beams 3-4 silent
    assert lost.any() and (dvl.beams_available[:, 0, 2] & dvl.valid[:, 0]).any()
    assert np.array_equal(dvl.beams_available[:, 0, 2], dvl.beams_available[:, 0, 3])
    assert np.all(dvl.innovation[lost, 0, 2:] == 0.0) and np.all(np.isnan(dvl.innovation_var[lost, 0, 2:]))
    fig = innovation_figure({"tc": tc}, "dvl", max_points=None)
    lines = [d for d in fig.data if d.name == "TC"]
    bands = [d for d in fig.data if d.name == "TC" + BAND_SUFFIX]
    for k in (2, 3):
        returned = dvl.beams_available[:, 0, k] & dvl.valid[:, 0]
        y = np.asarray(lines[k].y, dtype=float)
        assert np.all(np.isnan(y[lost])) and np.all(np.isfinite(y[returned])), k
        env = np.asarray(bands[k].y, dtype=float)[: dvl.t_s.size]
        assert np.all(np.isnan(env[lost])) and np.all(np.isfinite(env[returned])), k


def test_cursor_is_a_vertical_line_at_the_time(single):
    fig = with_cursor(error_figure(single, "vel"), 7.5)
    (shape,) = fig.layout.shapes
    assert shape.name == CURSOR_NAME and shape.x0 == shape.x1 == 7.5 and (shape.y0, shape.y1) == (0.0, 1.0)
    assert shape.yref == "paper" and cursor_shape(3.0)["x0"] == 3.0
    assert with_cursor(fig, None).layout.shapes == ()


def test_summary_rms_and_dvl_counts_table(four_beams):
    _, _, results = four_beams
    lines = rms_markdown(results).splitlines()
    assert lines[0] == RMS_HEADING
    start = 2
    assert lines[start] == "| " + " | ".join(RMS_COLUMNS) + " |"
    end = lines.index("", start)
    body = {cells[0]: cells for cells in (_cells(line) for line in lines[start + 2:end])}
    exp = _expected_row(results["tc"])
    assert float(body["TC"][2]) == pytest.approx(exp["att_rms_deg"], abs=0.5e-3)
    assert float(body["TC"][5]) == pytest.approx(exp["pos_rms_m"], abs=0.5e-2)
    # below it the updates per source: the DVL's bottom-track its own column, INS without any
    assert lines[end + 1] == COUNTS_HEADING
    head = _cells(lines[end + 3])
    assert head == ["method", "DVL bottom-track", "coasted"]
    counts = {cells[0]: cells for cells in (_cells(line) for line in lines[end + 5:])}
    assert counts["INS"][1:] == ["-", "-"]
    dvl = results["tc"].updates["dvl"]
    fused = int(dvl.fused.sum())
    rejected = int((dvl.valid & ~dvl.fused).sum())
    assert counts["TC"][1] == f"{fused} / {rejected} / {dvl.fused.size - fused - rejected}" and fused > 0
    assert counts["TC"][2] == f"{int((~dvl.fused).sum())} of {dvl.fused.size}"


def test_compare_figure_one_dash_per_run_method_colours_kept(single, four_beams):
    runs = [("run 1", single), ("run 2", four_beams[2])]
    fig = compare_figure(runs, "vel", max_points=None)
    assert len(fig.data) == len(single) + len(four_beams[2])
    for n, (label, results) in enumerate(runs):
        for method, res in results.items():
            (trace,) = [d for d in fig.data if d.name == f"{method.upper()} ({label})"]
            assert trace.line.dash == RUN_DASHES[n] and trace.line.color == METHOD_COLORS[method]
            np.testing.assert_array_equal(trace.y, res.vel_err_mps[:, 0])
    checked = compare_figure(runs, "vel", validate=True)
    assert json.loads(checked.to_json()) == json.loads(compare_figure(runs, "vel").to_json())
    table = compare_markdown(runs).splitlines()
    assert [_cells(line)[:2] for line in table[2:4]] == [["INS", "run 1"], ["INS", "run 2"]]
    assert len(table) == 2 + len(single) + len(four_beams[2])


def test_config_diff_names_the_changed_fields():
    a = _short_config(methods=("lc",))
    b = a.replace("dvl", noise_mps=0.02).replace("run", methods=("lc", "tc"))
    flat_a, flat_b = flat_config(a, 1), flat_config(b, 3)
    assert flat_a["dvl.noise_mps"] == a.dvl.noise_mps and flat_a["runs"] == 1
    assert config_differences([flat_a, flat_b]) == {"dvl.noise_mps": [a.dvl.noise_mps, 0.02],
                                                    "run.methods": [["lc"], ["lc", "tc"]], "runs": [1, 3]}
    table = config_diff_markdown(["run 1", "run 2"], [flat_a, flat_b]).splitlines()
    assert table[2] == "| setting | run 1 | run 2 |"
    assert f"| DVL noise | {a.dvl.noise_mps:g} m/s | 0.02 m/s |" in table and "| methods | LC | LC TC |" in table
    assert "the same" in config_diff_markdown(["run 1", "run 2"], [flat_a, flat_a])


def test_overlay_figure_draws_each_run_s_nees_in_its_line_style(single, four_beams):
    """The NEES of two kept runs overlaid: each method's curve of each run, in its colour and the
    run's line style, its data unchanged; the 99 % band and the reference line drawn once."""
    first, second = nees_figure(single, "vel"), nees_figure(four_beams[2], "vel")
    fig = overlay_figure([("run 1", first), ("run 2", second)])
    by_name = {d.name: d for d in fig.data}
    for label, source, dash in (("run 1", first, "solid"), ("run 2", second, "dash")):
        for trace in source.data:
            if trace.name.lower() in METHOD_COLORS:
                drawn = by_name[f"{trace.name} ({label})"]
                assert drawn.line.dash == dash and drawn.line.color == METHOD_COLORS[trace.name.lower()]
                np.testing.assert_array_equal(np.asarray(drawn.y, float), np.asarray(trace.y, float))
    others = [d.name for d in fig.data if "(run" not in d.name]
    assert others == [d.name for d in first.data if d.name.lower() not in METHOD_COLORS]
    assert fig.layout.title.text.endswith(": run 1 solid, run 2 dash")
    with pytest.raises(ValueError, match="at least one run"):
        overlay_figure([])
