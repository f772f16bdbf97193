"""Every aiding source of the registry (tauvcore.aiding.sources: the depth, the magnetometer, the
USBL), through the one interface the engine, the configuration and the log reader and writer use:

- its H against central differences of its own innovation, ``-(nu(x (+) eps e_j) - nu(x (-) eps
  e_j)) / 2 eps``, at a state off the truth, on the flat earth and on WGS-84;
- its simulation does not depend on how the mission is cut into chunks, nor on whether the runs
  are drawn as a batch or one generator each (run r of a batch of per-run generators is the run a
  batch of one draws);
- its section round-trips through TOML and leaves the built-in sections' defaults alone;
- its log table round-trips (``tauv run --save-log`` -> ``tauv replay``) to the last digit, lost
  measurements (NaN) included, and the replay fuses it;
- the registry refuses a module without a source.
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.aiding import dvl_beams
from tauvcore.aiding.sources import FUSED, SOURCES, load
from tauvcore.config import SOURCE_SECTIONS, Config, from_dict, to_dict
from tauvcore.engine.mission import run, run_streaming
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.engine.source_streams import SourceStream
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import exp_so3
from tauvcore.sensors.stream import SensorStreams
from tauvcore.truth import generate, truth_stream

NAMES = sorted(SOURCES)
FUSED_NAMES = sorted(FUSED)  # those with a measurement model (the others: data Yoo's methods read)
EPS = 1e-4  # large enough that a position step moves latitude by far more than its rounding


def _source_stream(config: Config, rng, num_runs: int, num_samples: int, dt_s: float) -> SourceStream:
    """The sources' stream as tauvcore.engine.mission.run_streaming makes it: the sensor streams
    spawned from each generator first, then the sources' own children."""
    streams = (
        SensorStreams.spawned(rng) if isinstance(rng, np.random.Generator) else [SensorStreams.spawned(g) for g in rng]
    )
    return SourceStream(config, rng, num_runs, num_samples, dt_s, streams)


def _config(name: str, earth: str = "flat", duration_s: float = 120.0) -> Config:
    return (
        Config()
        .replace("trajectory", name="lawnmower", duration_s=duration_s)
        .replace("earth", model=earth)
        .replace("run", methods=("ins", "lc"), aiding=("dvl", name) if SOURCES[name].fused else ("dvl",))
    )


def _epoch_with_data(name: str, config: Config):
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    data = _source_stream(config, np.random.default_rng(5), 2, truth.num_samples, truth.dt_s).next_chunk(0, truth)[name]
    values = np.stack(list(data.values.values()), axis=-1)
    j = int(np.flatnonzero(np.isfinite(values).all(axis=(1, 2)))[len(data.index) // 2])
    return truth, data, j


def _nominal_near(truth, k: int, rng: np.random.Generator, batch: tuple[int, ...]) -> Nominal:
    """The truth at sample k, off by a few metres, a few degrees and a few dm/s."""
    C = exp_so3(rng.normal(0.0, 0.03, batch + (3,))) @ truth.C_nb[k]
    pos = truth.pos_nav[k] + rng.normal(0.0, 1.0, batch + (3,)) * (
        np.array([1e-6, 1e-6, 1.0]) if truth.earth.geodetic else 1.0
    )
    vel_n = truth.vel_n[k] + rng.normal(0.0, 0.2, batch + (3,))
    return Nominal(
        nav=NavState(pos_n=pos, vel_n=vel_n, C_nb=C),
        accel_bias=np.zeros(batch + (3,)),
        gyro_bias=np.zeros(batch + (3,)),
        dvl_bias=np.zeros(batch + (4,)),
        dvl_sf=np.zeros(batch),
    )


@pytest.mark.parametrize("earth", ["flat", "wgs84"])
@pytest.mark.parametrize("name", FUSED_NAMES)
def test_H_matches_central_differences_of_the_innovation(name: str, earth: str) -> None:
    config = _config(name, earth)
    truth, data, j = _epoch_with_data(name, config)
    source = SOURCES[name]
    model = source.model(config.section(source.section_name), config)
    geodetic = config.earth.geodetic
    nom = _nominal_near(truth, int(data.index[j]), np.random.default_rng(1), (3, 2))
    meas = model.measure(nom, data, j)
    assert meas.valid.all()
    # on WGS-84 the innovation is resolved in the estimate's NED frame, which turns as the estimate
    # moves: H is exact to |nu| / R_earth (1e-6 for metres of innovation)
    atol = 1e-5 if geodetic else 1e-6
    H_fd = np.zeros_like(meas.H)
    for i in range(STATE.dim):
        dx = np.zeros((3, 2, STATE.dim))
        dx[..., i] = EPS
        plus = model.measure(inject(nom, dx, geodetic), data, j).innovation
        minus = model.measure(inject(nom, -dx, geodetic), data, j).innovation
        H_fd[..., i] = -(plus - minus) / (2 * EPS)
    for block in STATE.names:
        sl = getattr(STATE, block)
        np.testing.assert_allclose(meas.H[..., sl], H_fd[..., sl], rtol=0, atol=atol, err_msg=f"{name}: H[{block}]")
        if block not in source.observes:  # what it declares is all its H weighs (Yoo's bank relies on it)
            assert not meas.H[..., sl].any() and np.abs(H_fd[..., sl]).max() <= atol, f"{name}: H[{block}]"


@pytest.mark.parametrize("name", NAMES)
def test_one_epoch_s_row_is_that_epoch_of_the_stacked_columns(name: str) -> None:
    _, data, j = _epoch_with_data(name, _config(name))
    columns = list(data.values)
    for k in (0, j, len(data.index) - 1):
        np.testing.assert_array_equal(data.row(columns, k), data.stacked(columns)[k])
    assert data.row(columns, j).shape == (2, len(columns))


@pytest.mark.parametrize("name", NAMES)
def test_the_simulation_does_not_depend_on_the_chunks_or_the_batch(name: str) -> None:
    config = _config(name, duration_s=200.0)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    K, dt = truth.num_samples, truth.dt_s

    def chunked(size: int, rng) -> dict[str, np.ndarray]:
        stream = _source_stream(config, rng, 3, K, dt)
        parts = [stream.next_chunk(k0, part)[name]
                 for k0, part in truth_stream(config.trajectory, config.earth, config.imu.rate_hz, size)]
        index = np.concatenate([p.index for p in parts])
        columns = {**parts[0].values, **parts[0].truth}
        return {"index": index, **{c: np.concatenate([{**p.values, **p.truth}[c] for p in parts]) for c in columns}}

    whole = chunked(K, np.random.default_rng(3))
    for size in (1500, 977):
        cut = chunked(size, np.random.default_rng(3))
        assert cut.keys() == whole.keys()
        for key in whole:
            np.testing.assert_array_equal(cut[key], whole[key], err_msg=f"{name}: {key}, chunks of {size}")
    # per-run generators: run r is the run a batch of one draws from the same generator
    runs = [np.random.default_rng(s) for s in (11, 12, 13)]
    batch = chunked(1500, runs)
    for r, seed in enumerate((11, 12, 13)):
        stream = _source_stream(config, [np.random.default_rng(seed)], 1, K, dt)
        alone = stream.next_chunk(0, truth)[name]
        for column, values in {**alone.values, **alone.truth}.items():
            np.testing.assert_array_equal(batch[column][:, r], values[:, 0], err_msg=f"{name}: run {r}")


@pytest.mark.parametrize("name", NAMES)
def test_its_section_round_trips_and_leaves_the_rest_alone(name: str) -> None:
    config = Config()
    data = to_dict(config)
    section_name = SOURCES[name].section_name
    assert section_name in data  # its own [section_name] section
    assert from_dict(data) == config
    section = config.section(section_name)
    assert config.replace(section_name, **{}).section(section_name) == section
    plain = {k: v for k, v in data.items() if k not in SOURCE_SECTIONS}
    assert to_dict(from_dict(plain)) == data


def _log_table(log, name: str) -> dict:
    """Source ``name``'s table as the log reader read it (the DVL's, which has two forms, in the
    log's own fields)."""
    if name != "dvl":
        return log.sources[name]
    beams = dict(zip(dvl_beams.BEAMS, log.dvl_beams_mps.T, strict=True))
    return {"t_s": log.dvl_t_s, **beams, **log.dvl_truth}


@pytest.mark.parametrize("name", NAMES)
def test_its_log_table_round_trips_and_the_replay_fuses_it(name: str, tmp_path) -> None:
    from tauvcore.eval.replay import prepare
    from tauvcore.logs import read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = _config(name, duration_s=90.0)
    sim = simulate(config, np.random.default_rng(2), 1)
    tables = simulation_tables([SimChunk.whole(sim)])
    assert SOURCES[name].table in tables
    write_log(tmp_path / "log", tables)
    log = read_log(tmp_path / "log")
    table = _log_table(log, name)
    np.testing.assert_array_equal(table["t_s"], sim.sources[name].t_s)
    for column, values in {**sim.sources[name].values, **sim.sources[name].truth}.items():
        np.testing.assert_array_equal(table[column], values[:, 0], err_msg=column)
    replay_config, replay_sim = prepare(config, log, np.random.default_rng(0))
    np.testing.assert_array_equal(replay_sim.sources[name].index, sim.sources[name].index)
    for part in ("values", "truth"):
        for column, values in getattr(sim.sources[name], part).items():
            np.testing.assert_array_equal(getattr(replay_sim.sources[name], part)[column], values, err_msg=column)
    if SOURCES[name].fused:
        results = run(replay_config, replay_sim, np.random.default_rng(0))
        record = results["lc"].updates[name]
        assert record.fused.any() and name not in results["ins"].updates


@pytest.mark.parametrize("name", FUSED_NAMES)
def test_the_streaming_engine_fuses_every_epoch_of_the_source(name: str) -> None:
    """run_streaming fuses the source at each of its epochs, with the data its streams draw (the
    children of the run's generator after the built-in sensors')."""
    config = _config(name)
    results = run_streaming(config, np.random.default_rng(0), 2)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    rng = np.random.default_rng(0)
    data = _source_stream(config, rng, 2, truth.num_samples, truth.dt_s).next_chunk(0, truth)[name]
    record = results["lc"].updates[name]
    np.testing.assert_array_equal(record.t_s, data.t_s)
    values = np.stack(list(data.values.values()), axis=-1)
    have = np.isfinite(values).all(axis=-1)
    np.testing.assert_array_equal(record.valid, have)
    np.testing.assert_array_equal(record.z[have], values[have])
    assert name not in results["ins"].updates  # the standalone INS takes no aiding


def test_the_registry_refuses_a_module_without_a_source() -> None:
    with pytest.raises(TypeError, match="must define SOURCE"):
        load(("cv",))  # a fusion method's module, not a source's


@pytest.mark.parametrize("name", FUSED_NAMES)
def test_a_replay_that_aids_with_a_source_the_log_lacks_is_refused_naming_the_table(name: str, tmp_path, capsys) -> None:
    from app.cli import main
    from tauvcore.eval.replay import prepare
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="lawnmower", duration_s=30.0)
    table = SOURCES[name].table
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(0)))])
    tables.pop(table, None)  # a source aboard is in every simulation's log
    write_log(tmp_path / "log", tables)
    with pytest.raises(LogError, match=f"names {name}, but the log has no {table}.csv or {table}.parquet"):
        prepare(config.replace("run", aiding=("dvl", name)), read_log(tmp_path / "log"), np.random.default_rng(0))
    assert main(["replay", str(tmp_path / "log"), "--aiding", f"dvl,{name}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"no {table}.csv" in err[0]


@pytest.mark.parametrize("name", FUSED_NAMES)
def test_yoos_methods_fuse_the_source_if_their_states_can_and_the_run_table_says_which_not(name: str) -> None:
    """Yoo 2014's 12-state filter has no position state and its velocity error is in NED: it fuses
    a source whose H weighs only its attitude and biases (the magnetometer), no other."""
    from app.reports.tables import summary_table
    from tauvcore.engine.yoo_sources import takes

    config = _config(name, duration_s=30.0).replace("run", methods=("lc", "vkf"))
    results = run_streaming(config, np.random.default_rng(0))
    assert name in results["lc"].updates
    assert (name in results["vkf"].updates) == takes(SOURCES[name]) == (set(SOURCES[name].observes) <= {"att", "ba", "bg"})
    table = summary_table(results, config, 1.0)
    assert (f"they do not fuse {name} (no position state)" in table) == (not takes(SOURCES[name]))


@pytest.mark.parametrize("name", sorted(n for n, s in SOURCES.items() if not s.fused and not s.methods_fuse))
def test_a_source_that_is_data_for_a_method_has_no_place_in_run_aiding(name: str) -> None:
    from tauvcore.validation import ConfigError

    with pytest.raises(ConfigError, match=f"run.aiding must be one of .*got '{name}'"):
        Config().replace("run", aiding=("dvl", name))
    with pytest.raises(TypeError, match="no model"):
        SOURCES[name].model(Config().section(SOURCES[name].section_name), Config())


def test_a_log_without_truth_columns_reads_them_as_nan(tmp_path) -> None:
    """A recorded log's RPM table has only ``t_s`` and ``propeller_rpm``: the RPM model's truth reads
    as NaN, and the replay's VKF trace has no truth to judge its scale factor against."""
    from tauvcore.aiding.propeller_rpm import RPM, TRUE_SCALE_FACTOR
    from tauvcore.eval.replay import prepare
    from tauvcore.logs import read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="lawnmower", duration_s=30.0).replace("run", methods=("vkf",))
    sim = simulate(config, np.random.default_rng(0))
    tables = simulation_tables([SimChunk.whole(sim)])
    tables["rpm"] = {"t_s": tables["rpm"]["t_s"], RPM: tables["rpm"][RPM]}
    write_log(tmp_path / "log", tables)
    log = read_log(tmp_path / "log")
    assert np.isnan(log.sources["rpm"][TRUE_SCALE_FACTOR]).all()
    np.testing.assert_array_equal(log.sources["rpm"][RPM], sim.sources["rpm"].values[RPM][:, 0])
    replay_config, replay_sim = prepare(config, log, np.random.default_rng(0))
    trace = run(replay_config, replay_sim, np.random.default_rng(0))["vkf"].vkf_trace
    assert trace is not None and np.isnan(trace["sf_true"]).all() and np.isfinite(trace["x"]).all()


@pytest.mark.parametrize("missing", ["rpm", "echo"])
@pytest.mark.parametrize("what", ["vkf", "rpm_fallback"])
def test_a_replay_of_the_velocity_filter_without_its_tables_is_refused_naming_the_table(
    missing: str, what: str, tmp_path, capsys
) -> None:
    from app.cli import main
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="lawnmower", duration_s=30.0)
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(0)))])
    tables.pop(SOURCES[missing].table)
    write_log(tmp_path / "log", tables)
    flags = ["--method", "vkf"] if what == "vkf" else ["--method", "lc", "--rpm-fallback"]
    assert main(["replay", str(tmp_path / "log"), *flags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"no {SOURCES[missing].table}.csv or {SOURCES[missing].table}.parquet" in err[0], err


@pytest.mark.parametrize("table, column, value, words", [
    ("rpm", "propeller_rpm", np.nan, "column 'propeller_rpm', row 3"),   # an empty RPM cell is no reading
    ("rpm", "propeller_rpm", 1e9, "column 'propeller_rpm', row 3"),
    ("rpm", "true_scale_factor_mps_per_rpm", 5.0, "column 'true_scale_factor_mps_per_rpm', row 3"),
    ("echo", "altitude_m", np.inf, "column 'altitude_m', row 3"),
    ("echo", "true_altitude_m", 1e6, "column 'true_altitude_m', row 3"),
])
def test_a_bad_cell_of_the_velocity_filter_s_tables_names_the_file_the_column_and_the_row(
    table: str, column: str, value: float, words: str, tmp_path, capsys
) -> None:
    """Every column of a source's table is checked, its truth columns where the table has them;
    the replay exits 2 with one line, whatever the methods (the log is read whole)."""
    from app.cli import main
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="lawnmower", duration_s=30.0)
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(0)))])
    cells = tables[table][column].copy()
    cells[2] = value
    write_log(tmp_path / "log", {**tables, table: {**tables[table], column: cells}})
    with pytest.raises(LogError, match=words):
        read_log(tmp_path / "log")
    assert main(["replay", str(tmp_path / "log"), "--method", "vkf"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{table}.csv" in err[0] and words in err[0], err


def _rate_setting(name: str):
    from tauvcore.validation import settings

    return {key: s for key, _, s in settings(SOURCES[name].config_type)}.get("rate_hz")


# the sources whose rate may exceed the slowest IMU's 50 Hz (the DVL's stops at 25 Hz, a USBL's at 2 Hz)
CAN_OUTRUN_THE_IMU = [n for n in NAMES if (r := _rate_setting(n)) is not None and r.high is not None and r.high > 50.0]


@pytest.mark.parametrize("name", CAN_OUTRUN_THE_IMU)
def test_a_source_faster_than_the_imu_is_refused_naming_its_rate(name: str) -> None:
    """Every epoch falls on an IMU sample: a source's rate above the IMU's is refused, whichever
    source it is (the configuration reads every source's rate from the registry)."""
    from tauvcore.config import from_dict
    from tauvcore.validation import ConfigError

    section, high = SOURCES[name].section_name, _rate_setting(name).high
    with pytest.raises(ConfigError, match=rf"^{section}\.rate_hz must not exceed imu\.rate_hz \(50 Hz\)"):
        from_dict({"imu": {"rate_hz": 50.0}, section: {"rate_hz": high}})


def test_some_source_can_outrun_the_imu() -> None:
    assert {"depth", "mag", "echo"} <= set(CAN_OUTRUN_THE_IMU)
