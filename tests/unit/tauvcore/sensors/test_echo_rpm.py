"""The echo sounder and the propeller RPM sensor: known answers, chunk invariance (as the registry's
sources, tauvcore.aiding.echo_altitude and propeller_rpm), bad input naming the field."""

import dataclasses

import numpy as np
import pytest

from tauvcore.aiding import echo_altitude, propeller_rpm
from tauvcore.config import Config
from tauvcore.engine.simulation import simulate
from tauvcore.engine.source_streams import SourceStream
from tauvcore.geo.earth import Earth
from tauvcore.sensors import echosounder, rpm
from tauvcore.sensors.stream import SensorStreams
from tauvcore.truth import TrajectoryConfig, generate
from tauvcore.truth.kinematic import TruthStream, bathymetry
from tauvcore.truth.seabed import Bathymetry
from tauvcore.validation import ConfigError

RATE_HZ = 150.0


def test_echo_sounder_measures_the_altitude_and_nothing_beyond_its_range() -> None:
    truth = generate(TrajectoryConfig(name="figure8", duration_s=60.0), Earth(model="flat"), RATE_HZ)
    bed = Bathymetry(60.0)
    ideal = echosounder.simulate(truth, echosounder.EchoSounderConfig().ideal(), bed, np.random.default_rng(0))
    np.testing.assert_allclose(ideal.altitude_m, 60.0 - truth.depth_m[ideal.index], atol=1e-12)
    assert ideal.t_s[0] == pytest.approx(0.2)                                  # 5 Hz
    short = echosounder.simulate(truth, echosounder.EchoSounderConfig(max_range_m=38.0), bed,
                                 np.random.default_rng(0))
    assert np.all(np.isnan(short.altitude_m[short.true_altitude_m > 38.0]))
    assert np.all(np.isfinite(short.altitude_m[short.true_altitude_m <= 38.0]))
    noisy = echosounder.simulate(truth, echosounder.EchoSounderConfig(noise_m=0.5), bed, np.random.default_rng(1), 40)
    assert np.std(noisy.altitude_m - noisy.true_altitude_m[:, None]) == pytest.approx(0.5, rel=0.03)


def test_rpm_of_the_kinematic_truth_inverts_eq_20() -> None:
    """Without noise or walks: ``rpm = (u + b) / sf`` with the nominal sf and b (2 m/s is 871 rpm)."""
    truth = generate(TrajectoryConfig(name="lawnmower", duration_s=60.0), Earth(), RATE_HZ)
    cfg = rpm.RpmConfig().ideal()
    data = rpm.simulate(truth, cfg, np.random.default_rng(0))
    np.testing.assert_allclose(data.rpm * cfg.mps_per_rpm - cfg.bias_mps, truth.vel_b[data.index, 0], atol=1e-12)
    assert data.rpm[0] == pytest.approx((2.0 + 0.05) / 2.3525e-3)
    np.testing.assert_array_equal(data.scale_factor, cfg.mps_per_rpm)


def test_rpm_measures_the_speed_through_the_water_with_its_noise_over_10000_draws() -> None:
    """In a 0.4 m/s current from ahead-right that varies and shears, ``rpm sf - b`` is the surge
    through the water (over ground less the current's body-x part), not over ground; the reading
    less the propeller's true rpm has the configured variance, from 10,000 draws (a chi-square
    band at 99.9 %: 1 +- 3.29 sqrt(2 / n))."""
    trajectory = TrajectoryConfig(name="lawnmower", duration_s=60.0, current_n_mps=(-0.3, -0.25, 0.0),
                                  current_shear_ne_per_s=(0.005, 0.0), current_variation_mps=0.05,
                                  current_variation_period_s=60.0)
    truth = generate(trajectory, Earth(), RATE_HZ)
    cfg = rpm.RpmConfig().ideal()
    data = rpm.simulate(truth, cfg, np.random.default_rng(0))
    rows = data.index
    water = truth.vel_b[rows] - np.einsum("kji,kj->ki", truth.C_nb[rows], truth.current_n_mps[rows])
    np.testing.assert_allclose(data.rpm * cfg.mps_per_rpm - cfg.bias_mps, water[:, 0], atol=1e-12)
    assert np.min(np.abs(water[:, 0] - truth.vel_b[rows, 0])) > 0.1        # over ground is not it
    noisy = rpm.simulate(truth, rpm.RpmConfig(noise_rpm=3.0, scale_factor_rw_per_sqrt_s=0.0,
                                              bias_rw_mps_per_sqrt_s=0.0),
                         np.random.default_rng(1), num_runs=334)
    err = (noisy.rpm - noisy.true_rpm).ravel()[:10_000]
    assert err.size == 10_000
    np.testing.assert_allclose(noisy.true_rpm[:, 0] * cfg.mps_per_rpm - cfg.bias_mps, water[:, 0], atol=1e-9)
    assert abs(np.mean(err)) < 3.29 * 3.0 / np.sqrt(err.size)
    assert abs(np.var(err) / 9.0 - 1.0) < 3.29 * np.sqrt(2.0 / err.size)


def test_rpm_of_the_dynamic_truth_is_the_thrusters() -> None:
    truth = generate(TrajectoryConfig(name="figure8", duration_s=20.0, truth="dynamic"), Earth(), RATE_HZ)
    data = rpm.simulate(truth, rpm.RpmConfig(noise_rpm=0.0), np.random.default_rng(0))
    np.testing.assert_array_equal(data.rpm, truth.vehicle.propeller_rpm[data.index])
    assert np.all(np.isnan(data.scale_factor)) and np.all(np.isnan(data.bias_mps))


def test_rpm_walks_and_noise_do_not_depend_on_the_chunk_size() -> None:
    """sf and b walk from their own streams and the noise from a third, the echo sounder from a fourth
    (the sources' streams of SensorStreams): chunks of 7 samples give the numbers of one chunk, run by
    run; the walks move (sf by ~0.4 % in an hour)."""
    trajectory = TrajectoryConfig(name="longrange", duration_s=120.0, speed_mps=5.0, depth_m=50.0,
                                  seabed_depth_m=110.0)
    config = dataclasses.replace(Config(), trajectory=trajectory)
    joined = []
    for chunk_samples in (7, 100_000):
        truth = TruthStream(trajectory, Earth(), config.imu.rate_hz, chunk_samples)
        streams = SensorStreams.spawned(np.random.default_rng(5))
        stream = SourceStream(config, np.random.default_rng(6), 3, truth.num_samples, truth.dt_s, streams)
        parts = [stream.next_chunk(k0, c) for k0, c in truth]
        joined.append({name: np.concatenate([{**p[source].values, **p[source].truth}[name] for p in parts])
                       for source, names in (("rpm", (propeller_rpm.RPM, propeller_rpm.TRUE_SCALE_FACTOR,
                                                       propeller_rpm.TRUE_BIAS)),
                                             ("echo", (echo_altitude.ALTITUDE,)))
                       for name in names})
    for name, value in joined[0].items():
        np.testing.assert_array_equal(value, joined[1][name], err_msg=name)
    assert np.ptp(joined[0][propeller_rpm.TRUE_BIAS]) > 1e-3
    assert joined[0][propeller_rpm.RPM].shape[1] == 3 and np.isfinite(joined[0][echo_altitude.ALTITUDE]).all()


def test_the_sources_draw_what_the_sensors_own_simulations_draw() -> None:
    """A whole-mission simulation's echo and RPM sources are tauvcore.sensors.echosounder.simulate and
    rpm.simulate from the generator both share (the first child of the simulation's): the registry
    moved them, their numbers did not change."""
    trajectory = TrajectoryConfig(name="longrange", duration_s=60.0, speed_mps=5.0, depth_m=50.0,
                                  seabed_depth_m=110.0)
    config = dataclasses.replace(Config(), trajectory=trajectory)
    sim = simulate(config, np.random.default_rng(3), 2)
    extra, _ = np.random.default_rng(3).spawn(2)
    echo = echosounder.simulate(sim.truth, config.echo_sounder, bathymetry(trajectory), extra, 2)
    speed = rpm.simulate(sim.truth, config.rpm, extra, 2)
    np.testing.assert_array_equal(sim.sources["echo"].values[echo_altitude.ALTITUDE], echo.altitude_m)
    np.testing.assert_array_equal(sim.sources["echo"].index, echo.index)
    np.testing.assert_array_equal(sim.sources["rpm"].values[propeller_rpm.RPM], speed.rpm)
    np.testing.assert_array_equal(sim.sources["rpm"].truth[propeller_rpm.TRUE_SCALE_FACTOR], speed.scale_factor)
    np.testing.assert_array_equal(sim.sources["rpm"].truth[propeller_rpm.TRUE_BIAS], speed.bias_mps)


@pytest.mark.parametrize("section, key, value, field", [
    ("rpm", "noise_rpm", -1.0, "rpm.noise_rpm"),
    ("rpm", "noise_rpm", float("nan"), "rpm.noise_rpm"),
    ("rpm", "mps_per_rpm", 0.0, "rpm.mps_per_rpm"),
    ("echo_sounder", "max_range_m", 0.0, "echo_sounder.max_range_m"),
    ("echo_sounder", "noise_m", -0.1, "echo_sounder.noise_m"),
    ("vkf", "switch_altitude_m", -5.0, "vkf.switch_altitude_m"),
    ("vkf", "switch_altitude_m", float("nan"), "vkf.switch_altitude_m"),
])
def test_bad_sensor_settings_name_the_field(section: str, key: str, value: float, field: str) -> None:
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        Config().replace(section, **{key: value})


def test_the_new_sensors_rates_may_not_exceed_the_imus() -> None:
    with pytest.raises(ConfigError, match=r"rpm\.rate_hz"):
        dataclasses.replace(Config().replace("imu", rate_hz=50.0), rpm=rpm.RpmConfig(rate_hz=60.0))
