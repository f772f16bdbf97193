"""The Series tab's catalogue (app.figures.series_catalog) and figures (app.figures.series_figures):
every recorded series by a name carrying its unit, each the run's own numbers, drawn as picked."""

import numpy as np
import plotly.graph_objects as go
import pytest

from app.dashboard.session_series import format_xy, parse_xy, split_names
from app.dashboard.truth_view import truth_view
from app.figures.sensor_view import sensor_view
from app.figures.series_catalog import Catalog, Series, unit_of
from app.figures.series_figures import MAX_POINTS, paired, series_time_figure, series_xy_figure
from tauvcore.config import Config
from tauvcore.engine.mission import run as run_mission
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.consistency import nees_series

STEP = 20  # 200 Hz IMU, 10 Hz output


@pytest.fixture(scope="module")
def config() -> Config:
    return (
        Config()
        .replace("trajectory", name="figure8", duration_s=20.0)
        .replace("run", methods=("ins", "lc", "tc"), aiding=("dvl", "depth", "mag"))
    )


@pytest.fixture(scope="module")
def sim(config):
    return simulate(config, np.random.default_rng(3), num_runs=2)


@pytest.fixture(scope="module")
def results(config, sim):
    return run_mission(config, sim, np.random.default_rng(4), sensor_errors=True)


@pytest.fixture(scope="module")
def catalog(config, sim, results) -> Catalog:
    view = sensor_view(SimChunk.whole(sim), STEP, config.dvl.beam_mask, run=1)
    return Catalog(results, view, truth_view(config, STEP))


def test_every_name_carries_its_unit():
    assert unit_of("lc/vel_err_mps") == "m/s"
    assert unit_of("lc/dvl/innovation_1_mps_sigma") == "m/s"
    assert unit_of("sensors/imu/accel_x_mps2") == "m/s^2"
    assert unit_of("sensors/imu/gyro_z_radps") == "rad/s"
    assert unit_of("lc/est_yaw_deg") == "deg"
    assert unit_of("truth/north_m") == "m"
    assert unit_of("lc/nees") == "-"


def test_the_catalogue_holds_each_method_s_series_updates_sensors_and_truth(catalog, results):
    names = set(catalog.names)
    for method in results:
        assert {f"{method}/vel_err_mps", f"{method}/pos_sigma_m", f"{method}/nees", f"{method}/nees_pos"} <= names
        assert {f"{method}/est_north_m", f"{method}/est_vel_east_mps", f"{method}/est_yaw_deg"} <= names
    assert {"lc/dvl/innovation_1_mps", "lc/dvl/innovation_1_mps_sigma", "lc/dvl/nis", "lc/dvl/rejected"} <= names
    assert {"tc/dvl/innovation_4_mps", "lc/depth/innovation_depth_m", "lc/mag/innovation_yaw_rad"} <= names
    assert "ins/dvl/nis" not in names  # the free INS fuses nothing
    assert {"sensors/imu/gyro_x_radps", "sensors/dvl/beam1_mps", "sensors/depth/depth_m"} <= names
    assert {"truth/north_m", "truth/yaw_deg", "truth/altitude_m"} <= names
    assert catalog.runs == 2


def test_each_series_is_the_run_s_own_numbers(catalog, results):
    lc = results["lc"]
    s = catalog.series("lc/vel_err_mps", run=1)
    assert s.unit == "m/s"
    np.testing.assert_array_equal(s.t_s, lc.t_s)
    np.testing.assert_array_equal(s.value, lc.vel_err_mps[:, 1])
    np.testing.assert_array_equal(catalog.series("lc/est_east_m", run=0).value, lc.est_pos_n[:, 0, 1])
    np.testing.assert_allclose(catalog.series("lc/est_yaw_deg", run=1).value, np.degrees(lc.est_euler_rad[:, 1, 2]))
    np.testing.assert_array_equal(catalog.series("lc/nees_vel", run=1).value, nees_series(lc, "vel")[:, 1])
    dvl = lc.updates["dvl"]
    inn = catalog.series("lc/dvl/innovation_2_mps", run=1)
    np.testing.assert_array_equal(inn.t_s, dvl.t_s)
    np.testing.assert_array_equal(inn.value, dvl.innovation[:, 1, 1])
    np.testing.assert_allclose(
        catalog.series("lc/dvl/innovation_2_mps_sigma", run=1).value, np.sqrt(dvl.innovation_var[:, 1, 1])
    )
    np.testing.assert_array_equal(catalog.series("lc/dvl/rejected", run=0).value, dvl.rejected[:, 0].astype(float))


def test_the_truth_s_euler_angles_are_those_of_its_attitude(catalog, config):
    tv = truth_view(config, STEP)
    yaw = np.radians(catalog.series("truth/yaw_deg").value)
    # the yaw is the heading of the body's x axis in the level plane
    np.testing.assert_allclose(np.cos(yaw), tv["C_nb"][:, 0, 0] / np.hypot(tv["C_nb"][:, 0, 0], tv["C_nb"][:, 1, 0]))
    np.testing.assert_array_equal(catalog.series("truth/east_m").value, tv["pos_n"][:, 1])


def test_an_unknown_name_is_refused_naming_it(catalog):
    with pytest.raises(KeyError, match="lc/nope"):
        catalog.series("lc/nope")


def test_the_time_plot_has_one_panel_per_unit_on_one_time_axis(catalog):
    picks = [catalog.series(n) for n in ("lc/vel_err_mps", "tc/vel_err_mps", "lc/pos_err_m")]
    fig = series_time_figure(picks)
    assert [t.name for t in fig.data] == ["lc/vel_err_mps", "tc/vel_err_mps", "lc/pos_err_m"]
    assert [t.yaxis for t in fig.data] == ["y", "y", "y2"]
    assert fig.layout.yaxis.title.text == "m/s" and fig.layout.yaxis2.title.text == "m"
    assert fig.layout.xaxis2.matches == "x"
    np.testing.assert_array_equal(fig.data[2].y, picks[2].value)


def test_a_long_series_is_drawn_with_at_most_max_points_the_last_kept():
    t = np.arange(10 * MAX_POINTS) * 0.1
    s = Series("a/b_m", "m", t, np.sin(t))
    trace = series_time_figure([s]).data[0]
    assert len(trace.x) <= MAX_POINTS and trace.x[-1] == t[-1]


def test_the_xy_plot_reads_y_at_x_s_epochs():
    x = Series("x_m", "m", np.array([0.0, 1.0, 2.0, 3.0]), np.array([10.0, 11.0, 12.0, 13.0]))
    y = Series("y_m", "m", np.array([0.5, 2.5]), np.array([0.0, 4.0]))
    xv, yv = paired(x, y)
    np.testing.assert_array_equal(xv, [11.0, 12.0])  # X's epochs 1 s and 2 s lie within Y's
    np.testing.assert_allclose(yv, [1.0, 3.0])
    same = Series("z_m", "m", x.t_s, x.value * 2)
    np.testing.assert_array_equal(paired(x, same)[1], x.value * 2)
    assert series_xy_figure(x, [y]).layout.yaxis.scaleanchor == "x"  # metres against metres: equal scales
    assert series_xy_figure(x, [Series("v_mps", "m/s", x.t_s, x.value)]).layout.yaxis.scaleanchor is None


def test_the_track_of_a_method_as_xy_is_its_east_against_north(catalog, results):
    fig = series_xy_figure(catalog.series("lc/est_east_m"), [catalog.series("lc/est_north_m")])
    np.testing.assert_array_equal(fig.data[0].x, results["lc"].est_pos_n[:, 0, 1])
    np.testing.assert_array_equal(fig.data[0].y, results["lc"].est_pos_n[:, 0, 0])


def test_nothing_picked_shows_how_to_pick():
    assert "Add to time plot" in series_time_figure([]).layout.annotations[0].text
    assert "X axis" in series_xy_figure(None, []).layout.annotations[0].text


def test_the_pick_lists_read_and_write_their_text():
    assert split_names(" lc/a_m, ,tc/b_m,lc/a_m ") == ["lc/a_m", "tc/b_m"]
    assert parse_xy("lc/est_east_m; lc/est_north_m, tc/est_north_m") == (
        "lc/est_east_m",
        ["lc/est_north_m", "tc/est_north_m"],
    )
    assert parse_xy("") == (None, [])
    assert format_xy("x_m", ["y_m"]) == "x_m; y_m" and format_xy(None, []) == ""


def test_the_figures_validate_as_plotly_figures(catalog):
    picks = [catalog.series(n) for n in ("lc/vel_err_mps", "lc/dvl/nis", "truth/altitude_m")]
    go.Figure(series_time_figure(picks).to_dict())
    go.Figure(series_xy_figure(catalog.series("truth/east_m"), [catalog.series("truth/north_m")]).to_dict())
