"""The Sensors tab's raw data (app.figures.sensor_view) and its figures (app.figures.sensor_figures): the IMU and
every source of one run as the engine generated them, gathered chunk by chunk the same as whole,
dead beams as gaps with their state, and the figures drawing exactly those numbers."""

import dataclasses

import numpy as np
import pytest

from app.figures.scene import BEAM_OUTAGE, BEAM_RETURNING, BEAM_SWITCHED_OFF
from app.figures.sensor_figures import raw_sensor_figure, sensor_error_figure
from app.figures.sensor_view import (
    BEAM_STATE_CODES,
    MAX_SOURCE_EPOCHS,
    SensorViewBuilder,
    beam_state_codes,
    sensor_view,
)
from tauvcore.aiding.source import SourceData
from tauvcore.config import Config
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.engine.results import sensor_states
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.units import MG

STEP = 20  # 200 Hz IMU, 10 Hz output


def _config(**dvl) -> Config:
    config = Config().replace("trajectory", name="figure8", duration_s=12.0).replace("run", methods=("ins",))
    return config.replace("dvl", **dvl) if dvl else config


def _streamed(config: Config, chunk_s: float, runs: int = 2, run: int = 1):
    builder = SensorViewBuilder(STEP, config.dvl.beam_mask, run=run)
    chunks = []

    def keep(chunk):
        chunks.append(chunk)
        builder.add(chunk)

    run_streaming(config, np.random.default_rng(4), runs, chunk_s=chunk_s, sinks=Sinks(on_sim_chunk=keep))
    return builder.view(), chunks


def test_the_imu_is_the_run_s_own_increments_over_the_sample_interval_at_the_output_epochs() -> None:
    config = _config()
    view, chunks = _streamed(config, chunk_s=3.0)
    dtheta = np.concatenate([c.imu.dtheta_b[:, 1] for c in chunks])
    dv = np.concatenate([c.imu.dv_b[:, 1] for c in chunks])
    t = np.concatenate([c.truth.t_s for c in chunks])
    dt_s = chunks[0].truth.dt_s
    rows = np.arange(STEP, t.size, STEP)  # the output epochs after sample 0 (no increment before it)
    np.testing.assert_array_equal(view["t_s"], t[rows])
    np.testing.assert_array_equal(view["gyro_b_radps"], dtheta[rows] / dt_s)
    np.testing.assert_array_equal(view["accel_b_mps2"], dv[rows] / dt_s)
    assert view["run"] == 1 and view["runs"] == 2
    # a level vehicle's accelerometer reads gravity upward (FRD: -g on z)
    assert np.median(view["accel_b_mps2"][:, 2]) == pytest.approx(-9.8, abs=0.2)


def test_gathered_chunk_by_chunk_the_view_is_the_same_as_in_one_chunk() -> None:
    config = _config()
    small, _ = _streamed(config, chunk_s=2.0)
    large, _ = _streamed(config, chunk_s=12.5)
    np.testing.assert_array_equal(small["t_s"], large["t_s"])
    np.testing.assert_array_equal(small["gyro_b_radps"], large["gyro_b_radps"])
    assert small["sources"].keys() == large["sources"].keys() >= {"dvl", "depth", "mag"}
    for name, source in small["sources"].items():
        other = large["sources"][name]
        np.testing.assert_array_equal(source["t_s"], other["t_s"])
        assert source["columns"].keys() == other["columns"].keys()
        for column, values in source["columns"].items():
            np.testing.assert_array_equal(values, other["columns"][column])


def test_every_source_s_columns_are_the_run_s_values_with_their_units_and_truth() -> None:
    config = _config()
    sim = simulate(config, np.random.default_rng(2), num_runs=3)
    view = sensor_view(SimChunk.whole(sim), STEP, config.dvl.beam_mask, run=2)
    depth = view["sources"]["depth"]
    np.testing.assert_array_equal(depth["t_s"], sim.sources["depth"].t_s)
    np.testing.assert_array_equal(depth["columns"]["depth_m"], sim.sources["depth"].values["depth_m"][:, 2])
    assert depth["units"]["depth_m"] == "m" and depth["label"]
    dvl = view["sources"]["dvl"]
    assert dvl["units"]["beam1_mps"] == "m/s"
    # the simulation knows the DVL's true beam biases; a magnetometer has no truth columns
    assert any(name.startswith("true_beam") for name in dvl["truth"]) and not view["sources"]["mag"]["truth"]


def test_dead_beams_are_gaps_with_their_state_not_zeros() -> None:
    config = _config(beams=(1, 2))
    view, _ = _streamed(config, chunk_s=5.0, runs=1, run=0)
    dvl = view["sources"]["dvl"]
    assert np.isnan(dvl["columns"]["beam3_mps"]).all() and np.isnan(dvl["columns"]["beam4_mps"]).all()
    assert np.isfinite(dvl["columns"]["beam1_mps"]).mean() > 0.9
    states = np.asarray(BEAM_STATE_CODES)[dvl["beam_state"]]
    assert (states[:, 2:] == BEAM_SWITCHED_OFF).all()
    returned = np.isfinite(dvl["columns"]["beam1_mps"])
    assert (states[returned, 0] == BEAM_RETURNING).all() and (states[~returned, 0] == BEAM_OUTAGE).all()
    figure = raw_sensor_figure(view)
    beam3 = next(t for t in figure.data if t.name == "beam3")
    assert np.isnan(np.asarray(beam3.y, float)).all()  # drawn as a gap, not a line at zero


def test_beam_state_codes_known_answers() -> None:
    mask = np.array([True, True, False, True])
    returned = np.array([[True, False, False, True], [False, True, True, False]])
    codes = beam_state_codes(mask, returned)
    names = [[BEAM_STATE_CODES[c] for c in row] for row in codes]
    assert names == [
        [BEAM_RETURNING, BEAM_OUTAGE, BEAM_SWITCHED_OFF, BEAM_RETURNING],
        [BEAM_OUTAGE, BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE],
    ]
    from app.figures.scene import BEAM_WATER
    water = np.array([[True, True, True, False], [True, False, False, False]])
    names = [[BEAM_STATE_CODES[c] for c in row] for row in beam_state_codes(mask, returned, water)]
    assert names == [
        [BEAM_RETURNING, BEAM_WATER, BEAM_SWITCHED_OFF, BEAM_RETURNING],
        [BEAM_WATER, BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE],
    ]


@pytest.mark.parametrize("mode", ["always", "both"])
def test_a_water_tracking_beam_is_water_track_not_lost_or_returning(mode: str) -> None:
    """Every beam water-tracks (``always``: its velocity column holds the water-track, the mode
    columns say so; ``both``: bottom-track in range beside water-track columns of its own, with
    the DVL's range cut to 30 m so that no beam finds the seabed at 40 m): the beam panel names
    the pings' beams water-track."""
    from app.figures.scene import BEAM_WATER
    config = _config(water_track=mode, max_altitude_m=30.0, water_layer_m=10.0)
    view, _ = _streamed(config, chunk_s=5.0, runs=1, run=0)
    states = np.asarray(BEAM_STATE_CODES)[view["sources"]["dvl"]["beam_state"]]
    assert (states == BEAM_WATER).mean() > 0.9, np.unique(states, return_counts=True)
    assert not (states == BEAM_RETURNING).any()


def test_a_long_source_is_thinned_keeping_its_last_epoch() -> None:
    config = _config()
    sim = simulate(config, np.random.default_rng(2))
    n = MAX_SOURCE_EPOCHS * 3 + 7
    t = np.arange(n) * 0.01
    chunk = SimChunk.whole(sim)
    long = SourceData(t_s=t, index=np.arange(n), values={"depth_m": np.arange(n, dtype=float)[:, None]})
    chunk = SimChunk(chunk.k0, chunk.truth, chunk.imu, {"depth": long})
    depth = sensor_view(chunk, STEP, config.dvl.beam_mask)["sources"]["depth"]
    assert depth["t_s"].size <= MAX_SOURCE_EPOCHS + 1 and depth["t_s"][-1] == t[-1]
    np.testing.assert_array_equal(depth["columns"]["depth_m"], np.round(depth["t_s"] / 0.01))  # the same rows


def test_the_raw_figure_draws_the_view_s_numbers_in_display_units_and_validates() -> None:
    config = _config()
    sim = simulate(config, np.random.default_rng(2))
    view = sensor_view(SimChunk.whole(sim), STEP, config.dvl.beam_mask)
    figure = raw_sensor_figure(view)
    validated = raw_sensor_figure(view, validate=True)
    assert figure.to_plotly_json() == validated.to_plotly_json()
    gyro_z = next(t for t in figure.data if t.name == "gyro z")
    np.testing.assert_allclose(gyro_z.y, np.degrees(view["gyro_b_radps"][:, 2]), rtol=1e-12)
    yaw = next(t for t in figure.data if t.name == "yaw")
    np.testing.assert_allclose(yaw.y, np.degrees(view["sources"]["mag"]["columns"]["yaw_rad"]), rtol=1e-12)
    # a truth beside the column it is the truth of; the DVL's true beam biases are not velocities
    altitude_true = next(t for t in figure.data if t.name == "altitude (true)")
    np.testing.assert_array_equal(altitude_true.y, view["sources"]["echo"]["truth"]["true_altitude_m"])
    assert not any(t.name.startswith("true_beam") or t.name.startswith("beam1 (") for t in figure.data)
    labels = " ".join(a.text for a in figure.layout.annotations)
    for source in view["sources"].values():
        assert source["label"] in labels
    assert "Gyro" in labels and "Accelerometer" in labels and "DVL beams" in labels


def test_the_sensor_error_figure_draws_estimate_three_sigma_and_truth_in_data_sheet_units() -> None:
    """LC's estimated accelerometer bias in mg, its +-3-sigma band and its truth; a Yoo 2014
    method's 12-state filter has only the IMU's biases; a log's (NaN truth) draws no truth."""
    config = _config().replace("run", methods=("lc", "ins-dvl"))
    results = run_streaming(config, np.random.default_rng(3), 2, sensor_errors=True)
    lc = results["lc"]
    figure = sensor_error_figure(lc, run=1)
    assert figure.to_plotly_json() == sensor_error_figure(lc, run=1, validate=True).to_plotly_json()
    names = [t.name for t in figure.data]
    col = [s.name for s in sensor_states("lc")].index("ba_x")
    mg = 1.0 / MG
    est = next(t for t in figure.data if t.name == "accelerometer bias x (body) estimate")
    upper = next(t for t in figure.data if t.name == "accelerometer bias x (body) +3 sigma")
    true = next(t for t in figure.data if t.name == "accelerometer bias x (body) true")
    np.testing.assert_allclose(est.y, lc.sensor_est[:, 1, col] * mg, rtol=1e-12)
    np.testing.assert_allclose(upper.y, (lc.sensor_est[:, 1, col] + 3 * lc.sensor_sigma[:, 1, col]) * mg, rtol=1e-12)
    np.testing.assert_allclose(true.y, lc.sensor_true[:, 1, col] * mg, rtol=1e-12)
    assert "DVL scale factor error estimate" in names
    labels = " ".join(a.text for a in figure.layout.annotations)
    assert "[mg]" not in labels and "Accelerometer bias" in labels and "DVL scale factor" in labels
    assert figure.layout.yaxis.title.text == "mg" and figure.layout.yaxis2.title.text == "deg/h"
    yoo = sensor_error_figure(results["ins-dvl"])
    assert {t.name.split(" estimate")[0] for t in yoo.data if t.name.endswith("estimate")} == {
        s.label for s in sensor_states("ins-dvl")} and len(sensor_states("ins-dvl")) == 6
    unknown = dataclasses.replace(lc, sensor_true=np.full_like(lc.sensor_true, np.nan))
    assert not any(t.name.endswith(" true") for t in sensor_error_figure(unknown).data)
    without = dataclasses.replace(lc, sensor_est=None)
    with pytest.raises(ValueError, match="no sensor errors"):
        sensor_error_figure(without)


def test_a_long_mission_s_imu_is_thinned_keeping_its_last_epoch() -> None:
    """Every progress message carries the view: a 10-hour mission's 360,000 output epochs would be
    17 MB each time; at most MAX_SOURCE_EPOCHS of them travel, the last kept."""
    config = _config().replace("trajectory", duration_s=40.0)
    sim = simulate(config, np.random.default_rng(2))
    view = sensor_view(SimChunk.whole(sim), 1, config.dvl.beam_mask)   # every IMU sample an epoch
    rows = np.arange(1, sim.truth.num_samples)
    assert rows.size > MAX_SOURCE_EPOCHS
    assert view["t_s"].size <= MAX_SOURCE_EPOCHS + 1 and view["t_s"][-1] == sim.truth.t_s[-1]
    kept = np.searchsorted(sim.truth.t_s, view["t_s"])
    np.testing.assert_array_equal(view["gyro_b_radps"], sim.imu.dtheta_b[kept, 0] / sim.truth.dt_s)


def test_water_track_both_in_range_marks_lime_beside_every_returning_beam() -> None:
    """``both`` with the seabed in range: every beam bottom-tracks (blue) and water-tracks beside
    it, marked lime just above its row in the beam panel (nothing lime was drawn)."""
    from app.figures.scene import BEAM_COLORS, BEAM_WATER
    from app.figures.sensor_figures import WATER_BESIDE_OFFSET
    config = _config(water_track="both", water_layer_m=10.0)
    view, _ = _streamed(config, chunk_s=5.0, runs=1, run=0)
    dvl = view["sources"]["dvl"]
    states = np.asarray(BEAM_STATE_CODES)[dvl["beam_state"]]
    beside = dvl["water_beside"]
    assert beside is not None and beside.mean() > 0.9 and (states[beside] == BEAM_RETURNING).all()
    fig = raw_sensor_figure(view)
    lime = [d for d in fig.data if d.marker.color == f"rgb{BEAM_COLORS[BEAM_WATER]}"]
    assert [d.name for d in lime] == [f"{BEAM_WATER} (beside bottom-track)"]
    np.testing.assert_allclose(np.unique(np.round(np.asarray(lime[0].y) - WATER_BESIDE_OFFSET, 6)), [1, 2, 3, 4])
    off, _ = _streamed(_config(water_track="off"), chunk_s=5.0, runs=1, run=0)
    assert off["sources"]["dvl"]["water_beside"] is None
