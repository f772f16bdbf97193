"""Truth and sensors chunk by chunk (streaming): the chunks are the whole mission's numbers.

- truth chunks of any size concatenate to ``generate`` (bit for bit in practice; 1e-12 asserted);
- with spawned streams, sensors cut into chunks of any size are the same data, bit for bit (the IMU
  of SensorStream, the DVL of its source in tauvcore.engine.source_streams);
- with a single generator and one whole-mission chunk, exactly ``tauvcore.engine.simulation.simulate``'s draws;
- a list of per-run streams gives each run what it gets alone;
- a chunk without aiding epochs yields empty records of the right shapes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore.aiding import dvl_beams
from tauvcore.config import Config
from tauvcore.engine.simulation import simulate
from tauvcore.engine.source_streams import SourceStream
from tauvcore.geo.earth import Earth
from tauvcore.sensors import dvl, imu
from tauvcore.sensors.dvl import Outage
from tauvcore.sensors.stream import SensorStream, SensorStreams
from tauvcore.sensors.timing import epoch_indices
from tauvcore.truth import TRAJECTORIES, TrajectoryConfig, generate
from tauvcore.truth.kinematic import TruthStream, generate_chunk

RATE_HZ = 150.0
TRUTH_FIELDS = ("t_s", "pos_n", "vel_n", "vel_b", "C_nb", "euler", "omega_nb_b", "omega_ib_b", "f_b",
                "dtheta_ib_b", "dv_b")
# rates that are not divisors of the IMU rate, dropout and an outage: every epoch and draw path
SENSORS = (imu.ImuConfig(),
           dvl.DvlConfig(rate_hz=3.0, dropout_probability=0.2, outages=(Outage((2,), 5.0, 9.0),)))


def _concat(records: list) -> dict[str, np.ndarray]:
    """Fields of a list of records joined along time (``name``/``earth``/``step_s`` and fields that
    are None, the kinematic truth's ``vehicle``, left out)."""
    return {f.name: np.concatenate([getattr(r, f.name) for r in records])
            for f in dataclasses.fields(records[0])
            if f.name not in ("name", "earth", "step_s") and getattr(records[0], f.name) is not None}


def _assert_same(got: dict, expected: object) -> None:
    for name, value in got.items():
        np.testing.assert_array_equal(value, getattr(expected, name), err_msg=name)


def _stream_sensors(trajectory: TrajectoryConfig, streams: SensorStreams | list[SensorStreams], num_runs: int,
                    chunk_samples: int, sensors: tuple = SENSORS) -> list[dict[str, np.ndarray]]:
    """The IMU's output (SensorStream) and the DVL's pings (the DVL source of SourceStream, from the
    same streams) over the mission, generated chunk by chunk, joined along time."""
    truth = TruthStream(trajectory, Earth(), RATE_HZ, chunk_samples)
    stream = SensorStream(sensors[0], streams, num_runs, truth.num_samples, truth.dt_s)
    config = Config(trajectory=trajectory, imu=sensors[0], dvl=sensors[1])
    sources = SourceStream(config, np.random.default_rng(0), num_runs, truth.num_samples, truth.dt_s, streams)
    parts: list[list] = [[], []]
    for k0, chunk in truth:
        parts[0].append(stream.next_chunk(k0, chunk))
        parts[1].append(dvl_beams.pings(sources.next_chunk(k0, chunk)["dvl"], num_runs))
    return [_concat(p) for p in parts]


# ------------------------------------------------------------------------------------------ truth

@pytest.mark.parametrize("name", TRAJECTORIES)
@pytest.mark.parametrize("model", ["flat", "wgs84"])
def test_truth_chunks_concatenate_to_the_whole_mission(name: str, model: str) -> None:
    cfg = TrajectoryConfig(name=name, duration_s=60.0)
    earth = Earth(model=model)
    whole = generate(cfg, earth, RATE_HZ)
    for chunk_samples in (7, 150, 1000, whole.num_samples + 5):
        stream = TruthStream(cfg, earth, RATE_HZ, chunk_samples)
        assert stream.num_samples == whole.num_samples and stream.dt_s == whole.dt_s
        chunks = list(stream)
        assert len(chunks) == len(stream) == -(-whole.num_samples // chunk_samples)
        assert [k0 for k0, _ in chunks] == list(range(0, whole.num_samples, chunk_samples))
        for k0, chunk in chunks:
            assert chunk.dt_s == whole.dt_s                         # exact, not t_s[1] - t_s[0]
            assert chunk.t_s[0] == whole.t_s[k0]                    # the mission's times
        joined = _concat([c for _, c in chunks])
        for f in TRUTH_FIELDS:
            np.testing.assert_allclose(joined[f], getattr(whole, f), rtol=0, atol=1e-12,
                                       err_msg=f"{name} {chunk_samples} {f}")
        np.testing.assert_array_equal(joined["pos_nav"], whole.pos_nav)     # integrated sample after sample


def test_truth_chunks_of_one_sample_work_too() -> None:
    cfg = TrajectoryConfig(name="lawnmower", duration_s=1.0)
    whole = generate(cfg, Earth(), RATE_HZ)
    joined = _concat([c for _, c in TruthStream(cfg, Earth(), RATE_HZ, 1)])
    for f in TRUTH_FIELDS:
        np.testing.assert_allclose(joined[f], getattr(whole, f), rtol=0, atol=1e-12, err_msg=f)


def test_generate_chunk_continues_from_the_position_sum_it_is_given() -> None:
    cfg = TrajectoryConfig(name="figure8", duration_s=20.0)
    whole = generate(cfg, Earth(), RATE_HZ)
    first, travelled_n = generate_chunk(cfg, Earth(), RATE_HZ, 0, 1000)
    second, _ = generate_chunk(cfg, Earth(), RATE_HZ, 1000, 1700, travelled_n)
    np.testing.assert_allclose(first.pos_n[-1], whole.pos_n[999], rtol=0, atol=1e-12)
    np.testing.assert_allclose(second.pos_n, whole.pos_n[1000:1700], rtol=0, atol=1e-12)
    np.testing.assert_allclose(second.dv_b, whole.dv_b[1000:1700], rtol=0, atol=1e-12)
    assert np.all(np.abs(second.dv_b[0]) > 0)                       # only the mission's row 0 is zero
    with pytest.raises(ValueError, match="travelled_n"):
        generate_chunk(cfg, Earth(), RATE_HZ, 1000, 1700)
    with pytest.raises(ValueError, match="within the mission"):
        generate_chunk(cfg, Earth(), RATE_HZ, 2000, whole.num_samples + 1, travelled_n)
    with pytest.raises(ValueError, match="chunk_samples"):
        TruthStream(cfg, Earth(), RATE_HZ, 0)


# ------------------------------------------------------------------------------------------ sensors

def test_spawned_streams_do_not_depend_on_the_chunk_size() -> None:
    trajectory = TrajectoryConfig(name="figure8", duration_s=40.0)
    reference = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(5)), 2, 10**6)
    for chunk_samples in (7, 150, 1000):
        got = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(5)), 2, chunk_samples)
        for ref_rec, rec in zip(reference, got, strict=True):
            for name in ref_rec:
                np.testing.assert_array_equal(rec[name], ref_rec[name], err_msg=f"{chunk_samples} {name}")
    whole = generate(trajectory, Earth(), RATE_HZ)
    for record, config in zip(reference[1:], SENSORS[1:], strict=True):       # the whole mission's epochs
        np.testing.assert_array_equal(record["index"], epoch_indices(whole, config.rate_hz))
    imu_data, dvl_data = reference[0], reference[1]
    assert imu_data["dv_b"].shape == (whole.num_samples, 2, 3)
    assert not np.array_equal(imu_data["accel_bias"][:, 0], imu_data["accel_bias"][:, 1])   # runs differ
    assert np.all(np.diff(dvl_data["bias_mps"], axis=0) != 0)                 # the walk steps every ping
    assert 0 < np.mean(~dvl_data["available"]) < 0.5                          # dropout and outage drawn


def test_imu_axis_errors_do_not_depend_on_the_chunk_size() -> None:
    trajectory = TrajectoryConfig(name="figure8", duration_s=10.0)
    sensors = (dataclasses.replace(SENSORS[0], accel_scale_factor_ppm=300.0, gyro_misalignment_mrad=0.5),) + SENSORS[1:]
    reference = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(6)), 2, 10**6, sensors)
    plain = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(6)), 2, 10**6)
    assert not np.array_equal(reference[0]["dv_b"], plain[0]["dv_b"])
    np.testing.assert_array_equal(reference[1]["bias_mps"], plain[1]["bias_mps"])      # other streams untouched
    for chunk_samples in (7, 400):
        got = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(6)), 2, chunk_samples, sensors)
        for name in reference[0]:
            np.testing.assert_array_equal(got[0][name], reference[0][name], err_msg=f"{chunk_samples} {name}")


def test_spawned_streams_keep_sensors_independent() -> None:
    """Turning the DVL dropout off changes no other stream's numbers (a shared generator would)."""
    trajectory = TrajectoryConfig(name="straight", duration_s=20.0)
    no_dropout = (SENSORS[0], dataclasses.replace(SENSORS[1], dropout_probability=0.0)) + SENSORS[2:]
    a = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(8)), 1, 500)
    b = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(8)), 1, 500, no_dropout)
    for name in a[0]:
        np.testing.assert_array_equal(a[0][name], b[0][name], err_msg=name)
    np.testing.assert_array_equal(a[1]["bias_mps"], b[1]["bias_mps"])
    assert not np.array_equal(a[1]["available"], b[1]["available"])
    streams = SensorStreams.spawned(np.random.default_rng(8))          # each walk starts from its own stream
    imu_cfg, dvl_cfg = SENSORS[0], SENSORS[1]
    first = {"accel": streams.accel_bias.standard_normal((1, 3)) * imu_cfg.accel_bias_mps2,
             "gyro": streams.gyro_bias.standard_normal((1, 3)) * imu_cfg.gyro_bias_rps,
             "dvl": streams.dvl_bias.standard_normal((1, 4)) * dvl_cfg.bias_mps}
    np.testing.assert_array_equal(a[0]["accel_bias"][0], first["accel"])
    np.testing.assert_array_equal(a[0]["gyro_bias"][0], first["gyro"])
    np.testing.assert_array_equal(a[1]["bias_mps"][0], first["dvl"])


def test_single_stream_one_chunk_is_the_runner_simulation() -> None:
    config = Config().replace("trajectory", name="lawnmower", duration_s=30.0).replace("dvl", dropout_probability=0.1)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    rng_old, rng_new = np.random.default_rng(21), np.random.default_rng(21)
    sim = simulate(config, rng_old, 3, truth=truth)
    record = SensorStream(config.imu, SensorStreams.single(rng_new), 3, truth.num_samples, truth.dt_s).next_chunk(0, truth)
    _assert_same({f.name: getattr(record, f.name) for f in dataclasses.fields(record)}, sim.imu)
    # then the sources aboard: the DVL, the depth and the magnetometer from the same generator, the
    # echo sounder and the RPM from its first child
    extra, plugins = rng_new.spawn(2)
    aboard = dataclasses.replace(SensorStreams.single(rng_new), echo_sounder=extra, rpm_scale_factor=extra,
                                 rpm_bias=extra, rpm_noise=extra)
    sources = SourceStream(config, plugins, 3, truth.num_samples, truth.dt_s, aboard).next_chunk(0, truth)
    assert set(sources) == set(sim.sources) == {"dvl", "depth", "mag", "echo", "rpm"}
    for name in sources:
        _assert_same({"t_s": sources[name].t_s, "index": sources[name].index}, sim.sources[name])
        for column, values in {**sources[name].values, **sources[name].truth}.items():
            expected = {**sim.sources[name].values, **sim.sources[name].truth}[column]
            np.testing.assert_array_equal(values, expected, err_msg=f"{name}.{column}")
    np.testing.assert_array_equal(rng_new.standard_normal(5), rng_old.standard_normal(5))   # same draws consumed


def test_per_run_streams_give_each_run_its_own_data() -> None:
    trajectory = TrajectoryConfig(name="lawnmower", duration_s=30.0)
    seeds = (3, 4, 5)
    together = _stream_sensors(trajectory, [SensorStreams.spawned(np.random.default_rng(s)) for s in seeds],
                               len(seeds), 150)
    for r, seed in enumerate(seeds):
        alone = _stream_sensors(trajectory, SensorStreams.spawned(np.random.default_rng(seed)), 1, 1000)
        for rec_together, rec_alone in zip(together, alone, strict=True):
            for name, value in rec_alone.items():
                if name in ("t_s", "index"):
                    np.testing.assert_array_equal(rec_together[name], value)
                else:
                    np.testing.assert_array_equal(rec_together[name][:, r], value[:, 0], err_msg=name)


def test_per_run_single_streams_repeat_the_runner_run_by_run() -> None:
    """As a study draws today: run r's sensors from its own generator, one run at a time."""
    config = Config().replace("trajectory", name="figure8", duration_s=15.0)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    streams = [SensorStreams.single(np.random.default_rng(s)) for s in (1, 2)]
    imu_data = SensorStream(config.imu, streams, 2, truth.num_samples, truth.dt_s).next_chunk(0, truth)
    sources = SourceStream(config, np.random.default_rng(0), 2, truth.num_samples, truth.dt_s, streams)
    records = (imu_data, dvl_beams.pings(sources.next_chunk(0, truth)["dvl"], 2))
    for r, seed in enumerate((1, 2)):
        sim = simulate(config, np.random.default_rng(seed), 1, truth=truth)
        for record, expected in zip(records, (sim.imu, sim.dvl), strict=True):
            for f in dataclasses.fields(record):
                value = getattr(record, f.name)
                if value is not None and f.name not in ("t_s", "index", "slant_range_m"):  # per ping: every run's
                    value = value[:, r:r + 1]
                np.testing.assert_array_equal(value, getattr(expected, f.name), err_msg=f.name)


def test_a_chunk_without_aiding_epochs_yields_empty_records() -> None:
    trajectory = TrajectoryConfig(name="straight", duration_s=10.0)
    truth = TruthStream(trajectory, Earth(), RATE_HZ, 100)               # first ping at sample 150
    streams = SensorStreams.spawned(np.random.default_rng(0))
    stream = SensorStream(imu.ImuConfig(), streams, 2, truth.num_samples, truth.dt_s)
    sources = SourceStream(Config(trajectory=trajectory), np.random.default_rng(0), 2, truth.num_samples, truth.dt_s,
                           streams)
    k0, chunk = next(iter(truth))
    imu_data, dvl_data = stream.next_chunk(k0, chunk), dvl_beams.pings(sources.next_chunk(k0, chunk)["dvl"], 2)
    assert imu_data.dv_b.shape == (100, 2, 3) and np.all(imu_data.dv_b[0] == 0)
    assert dvl_data.index.shape == dvl_data.t_s.shape == (0,)
    assert dvl_data.y_beam_mps.shape == dvl_data.available.shape == dvl_data.bias_mps.shape == (0, 2, 4)
    assert dvl_data.scale_factor.shape == (0, 2)
    with pytest.raises(ValueError, match="in order"):
        stream.next_chunk(200, chunk)                                    # samples 100-199 skipped


@pytest.mark.parametrize("shape, run_axis", [((3,), 0), ((3, 4), 0), ((5, 3), 1), ((5, 3, 4), 1)])
def test_per_run_draws_are_each_generator_s_own_draws(shape, run_axis) -> None:
    """timing.standard_normal / uniform with one generator per run: run r's slice is what its
    generator draws alone for that slice's shape (the run's numbers do not depend on the others)."""
    from tauvcore.sensors.timing import standard_normal, uniform

    R = shape[run_axis]
    each = shape[:run_axis] + shape[run_axis + 1:]
    for draw, method in ((standard_normal, "standard_normal"), (uniform, "random")):
        got = draw([np.random.default_rng(10 + r) for r in range(R)], shape, run_axis)
        assert got.shape == shape
        for r in range(R):
            own = getattr(np.random.default_rng(10 + r), method)(each if each else None)
            np.testing.assert_array_equal(np.take(got, r, axis=run_axis), own)
    with pytest.raises(ValueError, match="2 generators"):
        standard_normal([np.random.default_rng(0)] * 2, shape, run_axis)
