"""The seabed and the DVL beams that reach it: known answers for the slant-range
geometry, the seeded terrain, the long-range mission's trenches, bottom lock lost exactly at the
range limit."""

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, merge, trajectory_preset
from tauvcore.geo.earth import Earth
from tauvcore.sensors import dvl
from tauvcore.truth import generate
from tauvcore.truth.kinematic import LONGRANGE_OUT_OF_RANGE_S, bathymetry
from tauvcore.truth.seabed import Bathymetry, Trench
from tauvcore.validation import ConfigError


def _longrange() -> Config:
    return from_dict(merge(trajectory_preset("longrange"), {"trajectory": {"name": "longrange"}}))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_flat_seabed_straight_down_and_slanted() -> None:
    bed = Bathymetry(60.0)
    head = np.array([10.0, -5.0, 20.0])
    assert bed.slant_range_m(head, np.array([0.0, 0.0, 1.0]), 1000.0) == pytest.approx(40.0)
    pitch = np.radians(20.0)
    beam = np.array([np.sin(pitch), 0.0, np.cos(pitch)])
    assert bed.slant_range_m(head, beam, 1000.0) == pytest.approx(40.0 / np.cos(pitch))
    assert np.isinf(bed.slant_range_m(head, np.array([1.0, 0.0, 0.0]), 1000.0))       # level: never
    assert np.isinf(bed.slant_range_m(head, np.array([0.0, 0.0, -1.0]), 1000.0))      # up
    assert np.isinf(bed.slant_range_m(np.array([0.0, 0.0, 70.0]), beam, 1000.0))      # below the seabed
    assert np.isinf(bed.slant_range_m(head, beam, 40.0))                              # beyond the limit


def test_sloped_seabed_known_answer_closed_form_and_marched() -> None:
    """A plane deepening 0.2 m per metre north: a beam tilted 30 deg forward from 20 m above the
    seabed meets it at r = h / (cos 30 - 0.2 sin 30); the marching search finds the same."""
    bed = Bathymetry(60.0, slope=(0.2, 0.0))
    head = np.array([0.0, 0.0, 40.0])
    beam = np.array([np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))])
    expected = 20.0 / (np.cos(np.radians(30.0)) - 0.2 * np.sin(np.radians(30.0)))
    assert bed.slant_range_m(head, beam, 1000.0) == pytest.approx(expected, rel=1e-12)
    assert bed._marched(head[None], beam[None], bed.altitude_m(head[None]), 1000.0)[0] == pytest.approx(
        expected, abs=1e-8)
    aft = beam * [-1.0, 1.0, 1.0]                       # looking aft, up the slope: shorter
    assert bed.slant_range_m(head, aft, 1000.0) == pytest.approx(
        20.0 / (np.cos(np.radians(30.0)) + 0.2 * np.sin(np.radians(30.0))), rel=1e-12)


def test_terrain_is_seeded_smooth_and_of_the_stated_relief() -> None:
    a = Bathymetry(100.0, "terrain", seed=3, relief_m=15.0, wavelength_m=300.0)
    b = Bathymetry(100.0, "terrain", seed=3, relief_m=15.0, wavelength_m=300.0)
    c = Bathymetry(100.0, "terrain", seed=4, relief_m=15.0, wavelength_m=300.0)
    n, e = np.meshgrid(np.linspace(-5000, 5000, 201), np.linspace(-5000, 5000, 201))
    da, db, dc = a.depth_m(n, e), b.depth_m(n, e), c.depth_m(n, e)
    np.testing.assert_array_equal(da, db)
    assert np.max(np.abs(da - dc)) > 10.0
    assert np.std(da) == pytest.approx(15.0, rel=0.2) and np.mean(da) == pytest.approx(100.0, abs=3.0)
    # a beam over the terrain: the point found lies on the seabed
    head = np.array([[120.0, 40.0, 30.0]])
    beam = _unit(np.array([[0.3, -0.2, 0.9]]))
    r = a.slant_range_m(head, beam, 500.0)
    hit = head + r[:, None] * beam
    assert a.depth_m(hit[:, 0], hit[:, 1]) == pytest.approx(hit[:, 2], abs=1e-7)
    assert Bathymetry(100.0, "flat", relief_m=15.0).is_plane       # relief only on terrain


def test_trench_walls_and_floor() -> None:
    bed = Bathymetry(110.0, trenches=(Trench(1000.0, 2000.0, 190.0, 200.0),))
    depth = bed.depth_m(np.array([0.0, 900.0, 1000.0, 1500.0, 2000.0, 2100.0, 3000.0]), 0.0)
    np.testing.assert_allclose(depth, [110.0, 110.0, 150.0, 190.0, 150.0, 110.0, 110.0], atol=1e-9)


def test_the_longrange_seabed_is_out_of_range_from_5_to_8_and_15_to_16_minutes() -> None:
    """The paper's Figure 6: the echo sounder's altitude crosses the DVL's 100 m at those times
    (to within the 0.01 s IMU step and the round Earth's drop of the tangent plane)."""
    config = _longrange()
    cfg = config.trajectory
    truth = generate(cfg, Earth(), config.imu.rate_hz)
    altitude = bathymetry(cfg).depth_m(truth.pos_n[:, 0], truth.pos_n[:, 1]) - truth.depth_m
    beyond = altitude > 100.0
    crossings = truth.t_s[np.flatnonzero(np.diff(beyond.astype(int))) + 1]
    np.testing.assert_allclose(crossings, np.ravel(LONGRANGE_OUT_OF_RANGE_S), atol=1.0)
    assert cfg.duration_s == 1440.0 and cfg.speed_mps == pytest.approx(5.1444, abs=1e-4)
    assert config.imu.rate_hz == 100.0 and config.dvl.rate_hz == 5.0


@pytest.mark.parametrize("mode", ["lost", "noisy"])
def test_bottom_lock_is_lost_exactly_beyond_the_range(mode: str) -> None:
    """Every ping of the long-range mission: a beam is available exactly when its slant range is
    within max_altitude / cos(beam pitch) ("lost"), or always, with 5 m/s more noise beyond
    ("noisy", Yoo's eq. 30-32)."""
    config = _longrange()
    cfg_dvl = dvl.DvlConfig(rate_hz=5.0, beyond_range=mode, noise_mps=0.0, bias_mps=0.0, bias_rw_mps_per_sqrt_s=0.0,
                            scale_factor_pct=0.0, scale_factor_rw_pct_per_sqrt_s=0.0)
    truth = generate(config.trajectory, Earth(), config.imu.rate_hz)
    data = dvl.simulate(truth, cfg_dvl, np.random.default_rng(0), seabed=bathymetry(config.trajectory))
    ranges = data.slant_range_m
    inside = np.isfinite(ranges)
    assert np.all(ranges[inside] <= cfg_dvl.max_range_m)
    assert 0.1 < np.mean(~inside) < 0.25                          # 4 of 24 minutes, walls included
    assert len({tuple(row) for row in inside}) >= 3                # beams drop one by one on the walls
    exact = dvl.beam_velocity(cfg_dvl.A_b, truth.vel_b[data.index], truth.omega_nb_b[data.index], cfg_dvl.l_dvl_b,
                              data.scale_factor, data.bias_mps)
    if mode == "lost":
        np.testing.assert_array_equal(data.available, inside)
        np.testing.assert_allclose(data.y_beam_mps[inside], exact[inside], atol=1e-12)
    else:
        assert data.available.all()
        np.testing.assert_allclose(data.y_beam_mps[inside], exact[inside], atol=1e-12)
        assert np.std(data.y_beam_mps[~inside] - exact[~inside]) == pytest.approx(5.0, rel=0.05)


@pytest.mark.parametrize("section, key, value, field", [
    ("dvl", "max_altitude_m", 0.0, "dvl.max_altitude_m"),
    ("dvl", "max_altitude_m", -5.0, "dvl.max_altitude_m"),
    ("dvl", "beyond_range", "vanish", "dvl.beyond_range"),
    ("trajectory", "seabed", "rocky", "trajectory.seabed"),
    ("trajectory", "terrain_relief_m", 5000.0, "trajectory.terrain_relief_m"),
    ("trajectory", "terrain_wavelength_m", float("nan"), "trajectory.terrain_wavelength_m"),
    ("trajectory", "terrain_seed", -1, "trajectory.terrain_seed"),
    ("trajectory", "seabed_depth_m", 20.0, "trajectory.seabed_depth_m"),       # the vehicle starts at 20 m
    ("trajectory", "seabed_depth_m", 12000.0, "trajectory.seabed_depth_m"),    # deeper than the deepest ocean
])
def test_bad_seabed_and_range_settings_name_the_field(section: str, key: str, value: object, field: str) -> None:
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        Config().replace(section, **{key: value})


def _marched_numpy(bed: Bathymetry, head: np.ndarray, d: np.ndarray, max_range_m: float) -> np.ndarray:
    """The march and bisection written plainly in numpy over Bathymetry.depth_m (the reference the
    compiled tauvcore.truth.seabed_kernels.march_into replaced)."""
    out = np.full(head.shape[0], np.inf)
    step = bed._step_m()

    def height(j: int, r: float) -> float:
        p = head[j] + r * d[j]
        return float(bed.depth_m(p[0], p[1])) - p[2]

    for j in range(head.shape[0]):
        if not bed.altitude_m(head[j]) > 0.0:
            continue
        r = 0.0
        while r < max_range_m:
            r_next = min(r + step, max_range_m)
            if height(j, r_next) <= 0.0:
                a, b = r, r_next
                while b - a >= 1e-9:
                    mid = 0.5 * (a + b)
                    a, b = (a, mid) if height(j, mid) <= 0.0 else (mid, b)
                out[j] = b
                break
            r = r_next
    return out


@pytest.mark.parametrize("model", ["terrain", "trenches", "both"])
def test_the_compiled_march_equals_a_plain_numpy_march(model: str) -> None:
    """Rays in every direction from heads over terrain, over trench walls, and both, some beyond
    range and some from below the seabed: the compiled march finds the same ranges (to the
    bisection's 1e-9 m) and the same misses."""
    trenches = (Trench(100.0, 300.0, 250.0, 60.0),) if model != "terrain" else ()
    bed = Bathymetry(80.0, "terrain" if model != "trenches" else "flat", seed=3, relief_m=8.0, wavelength_m=120.0,
                     trenches=trenches)
    rng = np.random.default_rng(11)
    head = np.column_stack([rng.uniform(0.0, 400.0, 300), rng.uniform(-50.0, 50.0, 300), rng.uniform(20.0, 90.0, 300)])
    d = rng.normal(size=(300, 3))
    d[:, 2] = np.abs(d[:, 2]) * rng.choice([1.0, -0.2], 300)     # mostly downward, a few upward
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    fast = bed.slant_range_m(head, d, 150.0)
    slow = _marched_numpy(bed, head, d, 150.0)
    np.testing.assert_array_equal(np.isinf(fast), np.isinf(slow))
    np.testing.assert_allclose(fast[np.isfinite(fast)], slow[np.isfinite(slow)], rtol=0.0, atol=2e-9)
    assert 50 < np.isfinite(fast).sum() < 290 and (bed.altitude_m(head) <= 0.0).any()


def test_a_seabed_above_the_vehicle_is_refused_on_the_command_line_by_name(tmp_path, capsys) -> None:
    """A seabed shallower than the vehicle (here terrain whose ridges reach 20 m: 50 m less three
    times 10 m of relief) would put the vehicle in the bottom: exit status 2, one line naming the
    field and the value, nothing written."""
    from app.cli import main

    cfg = tmp_path / "shallow.toml"
    cfg.write_text('[trajectory]\nseabed = "terrain"\nseabed_depth_m = 50.0\nterrain_relief_m = 10.0\n')
    out = tmp_path / "out.json"
    assert main(["run", "--config", str(cfg), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert "trajectory.seabed_depth_m" in err and "50" in err and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("truth", ["kinematic", "dynamic"])
def test_a_long_figure_eight_levels_off_above_the_seabed(truth: str) -> None:
    """The figure eight descends 0.1 m/s; past MIN_ALTITUDE_M above the seabed (300 s with the
    defaults) it levels off instead of flying into the bottom, so the DVL keeps its beams for the
    whole of a 20-minute mission. The paper's 250 s are untouched (a constant descent)."""
    from tauvcore.truth import TrajectoryConfig
    from tauvcore.truth.kinematic import MIN_ALTITUDE_M, figure8_level_off_s

    cfg = TrajectoryConfig(name="figure8", duration_s=1200.0, truth=truth)
    assert figure8_level_off_s(cfg) == pytest.approx(300.0)
    truth_rec = generate(cfg, Earth(), 20.0)
    altitude = bathymetry(cfg).altitude_m(truth_rec.pos_n)
    assert altitude.min() > MIN_ALTITUDE_M - 0.5
    late = truth_rec.t_s > 320.0
    assert truth_rec.pos_n[late, 2].max() < truth_rec.pos_n[late, 2][0] + 0.5      # no deeper once level
    paper = generate(TrajectoryConfig(name="figure8", duration_s=250.0), Earth(), 20.0)
    never_level = generate(TrajectoryConfig(name="figure8", duration_s=250.0, seabed_depth_m=5000.0), Earth(), 20.0)
    np.testing.assert_array_equal(paper.pos_n, never_level.pos_n)
