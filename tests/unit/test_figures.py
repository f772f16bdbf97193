"""Plotly figures of run results (app/figures.py), checked against the MethodResult they draw.

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

from app.figures import (
    METHOD_COLORS,
    elc_choice_figure,
    error_figure,
    summary_markdown,
    summary_rows,
)
from tauvcore.aiding.dvl_extended import MODE_COAST, MODE_LC, MODE_PARTIAL
from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.config import METHODS, Config
from tauvcore.eval.runner import MethodResult, run, simulate
from tauvcore.sensors.dvl import Outage

DURATION_S = 20.0
METHODS_UNDER_TEST = ("ins", "tc", "nsv")
NAMES = ("INS", "TC", "NSV")
QUANTITY_FIELDS = {   # quantity -> (error field, sigma field, unit in the title)
    "vel": ("vel_err_mps", "vel_sigma_mps", "[m/s]"),
    "att": ("att_err_deg", "att_sigma_deg", "[deg]"),
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


def test_error_figure_colours_are_the_method_colours(single):
    fig = error_figure(single, show_sigma=True)
    traces = _by_name(fig)
    for method, name in zip(METHODS_UNDER_TEST, NAMES):
        assert traces[name].line.color == METHOD_COLORS[method]


def test_every_method_has_its_own_colour():
    assert set(METHODS) <= set(METHOD_COLORS)
    colours = [METHOD_COLORS[m] for m in METHODS]
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


# ------------------------------------------------------------------------------------------ summary

def _expected_row(res: MethodResult) -> dict[str, float]:
    out = {}
    for key, field in (("vel", "vel_err_mps"), ("att", "att_err_deg"), ("pos", "pos_err_m")):
        err = getattr(res, field)                                   # (T, R)
        unit = field.rsplit("_", 1)[1]
        out[f"{key}_final_{unit}"] = float(np.sqrt(np.mean(err[-1] ** 2)))
        out[f"{key}_rms_{unit}"] = float(np.sqrt(np.mean(err ** 2)))  # RMS over runs then time = over both
    return out


@pytest.mark.parametrize("fixture", ["single", "monte_carlo"])
def test_summary_rows_final_and_rms(request, fixture):
    results = request.getfixturevalue(fixture)
    rows = summary_rows(results)
    assert [r["method"] for r in rows] == list(NAMES)
    for method, row in zip(METHODS_UNDER_TEST, rows):
        expected = _expected_row(results[method])
        assert set(row) == set(expected) | {"method", "runs", "diverged_runs", "diverged_first_s", "p_floor_count"}
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
def test_summary_markdown_table(request, fixture):
    results = request.getfixturevalue(fixture)
    lines = summary_markdown(results).splitlines()
    assert lines[0] == ("| method | vel final [m/s] | vel RMS [m/s] | att final [deg] | pos final [m] "
                        "| monitor |")
    assert lines[1] == "|---|---|---|---|---|---|"
    body = lines[2:]
    assert len(body) == len(METHODS_UNDER_TEST)
    for method, name, line in zip(METHODS_UNDER_TEST, NAMES, body):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        assert len(cells) == 6
        assert cells[0] == name
        assert cells[5] == "ok"
        exp = _expected_row(results[method])
        assert float(cells[1]) == pytest.approx(exp["vel_final_mps"], abs=0.5e-4)
        assert float(cells[2]) == pytest.approx(exp["vel_rms_mps"], abs=0.5e-4)
        assert float(cells[3]) == pytest.approx(exp["att_final_deg"], abs=0.5e-3)
        assert float(cells[4]) == pytest.approx(exp["pos_final_m"], abs=0.5e-2)


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
    lines = summary_markdown(results).splitlines()
    assert "P floors" not in lines[0]                      # no repair anywhere: no column
    assert [_cells(line)[5] for line in lines[2:]] == ["ok", "diverged at 12.3 s", "ok"]


def test_summary_counts_diverged_monte_carlo_runs_and_the_first_time(monte_carlo):
    results = {"tc": _flagged(monte_carlo["tc"], [np.nan, 80.0, 41.25], [0, 0, 0]), "nsv": monte_carlo["nsv"]}
    row = summary_rows(results)[0]
    assert (row["runs"], row["diverged_runs"], row["diverged_first_s"]) == (3, 2, 41.25)
    cells = _cells(summary_markdown(results).splitlines()[2])
    assert cells[5] == "2 of 3 runs, first diverged at 41.2 s"


def test_summary_shows_p_floor_column_only_when_a_repair_happened(monte_carlo):
    results = {"tc": _flagged(monte_carlo["tc"], [np.nan] * 3, [2, 0, 5]), "nsv": monte_carlo["nsv"]}
    assert summary_rows(results)[0]["p_floor_count"] == 7
    lines = summary_markdown(results).splitlines()
    assert lines[0].endswith("| monitor | P floors |")
    assert lines[1] == "|---|---|---|---|---|---|---|"
    assert [_cells(line)[6] for line in lines[2:]] == ["7", "0"]
    assert [_cells(line)[5] for line in lines[2:]] == ["ok", "ok"]


@pytest.mark.parametrize("show_sigma", [False, True])
@pytest.mark.parametrize("log_y", [False, True])
def test_fast_error_figure_equals_plotly_validated_construction(single, monte_carlo, show_sigma, log_y):
    """The live plots skip plotly's validation; what they send must be what validation gives."""
    for results in (single, monte_carlo):
        for quantity in ("vel", "att", "pos"):
            fast = error_figure(results, quantity, show_sigma=show_sigma, log_y=log_y)
            checked = error_figure(results, quantity, show_sigma=show_sigma, log_y=log_y, validate=True)
            assert json.loads(fast.to_json()) == json.loads(checked.to_json())
            assert json.loads(fast.to_json())["layout"]["template"]["layout"]["plot_bgcolor"] == "white"


def test_fast_elc_figure_equals_plotly_validated_construction(elc_two_beams, elc_four_beams, elc_mixed):
    for result in (elc_two_beams, elc_four_beams, elc_mixed):
        fast, checked = elc_choice_figure(result), elc_choice_figure(result, validate=True)
        assert json.loads(fast.to_json()) == json.loads(checked.to_json())
