"""The DVL as a registry source (tauvcore.aiding.dvl_beams): simulated by the source stream as the
other sensors aboard, its beams and true errors written to a log and read back, and what only a
simulation knows of it (its true errors) never reaching a filter."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore.aiding import dvl_beams
from tauvcore.aiding.sources import AIDING, FUSED, SOURCES
from tauvcore.config import Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.sensors import dvl
from tauvcore.sensors.timing import epoch_indices
from tauvcore.truth.kinematic import bathymetry
from tauvcore.validation import ConfigError, settings


def test_the_dvl_is_a_source_aboard_that_its_methods_fuse() -> None:
    source = SOURCES["dvl"]
    assert source.aboard and not source.fused and source.methods_fuse
    assert list(SOURCES)[0] == "dvl"  # drawn first of the sources aboard, right after the IMU
    assert AIDING == ("dvl", *FUSED)  # run.aiding names it; the engine's update does not fuse it
    assert [c.name for c in source.columns] == list(dvl_beams.BEAMS)


def test_the_source_draws_what_the_dvl_s_own_simulation_draws() -> None:
    """simulate() draws the DVL from the run's generator right after the IMU, as
    tauvcore.sensors.dvl.simulate does when given that generator at that point."""
    config = Config().replace("trajectory", name="lawnmower", duration_s=40.0).replace(
        "dvl", dropout_probability=0.2, beams=(1, 2, 4)
    )
    sim = simulate(config, np.random.default_rng(3), 2)
    rng = np.random.default_rng(3)
    from tauvcore.sensors import imu

    imu.simulate(sim.truth, config.imu, rng, 2)
    own = dvl.simulate(sim.truth, config.dvl, rng, 2, bathymetry(config.trajectory))
    np.testing.assert_array_equal(sim.dvl.index, epoch_indices(sim.truth, config.dvl.rate_hz))
    for name in ("t_s", "index", "y_beam_mps", "available", "bias_mps", "scale_factor"):
        np.testing.assert_array_equal(getattr(sim.dvl, name), getattr(own, name), err_msg=name)
    assert not sim.dvl.available[..., 2].any() and 0 < (~sim.dvl.available).mean() < 0.6


def test_a_log_without_the_true_errors_replays_to_the_same_estimates(tmp_path) -> None:
    """A recorded log's DVL table has only its beams: the true errors read as NaN, and every
    estimate of the replay is what it is with them (they are for the records, never the filter)."""
    from tauvcore.eval.replay import prepare
    from tauvcore.logs import read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="figure8", duration_s=40.0).replace(
        "run", methods=("ins", "lc", "tc", "nsv")
    )
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(1)))])
    assert set(tables["dvl"]) == {"t_s", *dvl_beams.BEAMS, *dvl_beams.TRUE_BIASES, dvl_beams.TRUE_SCALE_FACTOR}
    write_log(tmp_path / "with", tables)
    tables["dvl"] = {n: tables["dvl"][n] for n in ("t_s", *dvl_beams.BEAMS)}
    write_log(tmp_path / "without", tables)
    results = {}
    for name in ("with", "without"):
        log = read_log(tmp_path / name)
        replay_config, sim = prepare(config.replace("dvl", beams=(1, 2)), log, np.random.default_rng(0))
        results[name] = run(replay_config, sim, np.random.default_rng(0))
        truth = sim.sources["dvl"].truth
        assert set(truth) == {*dvl_beams.TRUE_BIASES, dvl_beams.TRUE_SCALE_FACTOR}
        assert np.isnan(truth[dvl_beams.TRUE_SCALE_FACTOR]).all() == (name == "without")
        assert not sim.dvl.available[..., 2:].any()  # the configured beams, applied to logged beams
    for method, a in results["with"].items():
        b = results["without"][method]
        np.testing.assert_array_equal(a.est_pos_n, b.est_pos_n, err_msg=method)
        np.testing.assert_array_equal(a.vel_err_mps, b.vel_err_mps, err_msg=method)
        for src, rec in a.updates.items():
            np.testing.assert_array_equal(rec.innovation, b.updates[src].innovation, err_msg=f"{method} {src}")


def test_every_field_of_the_dvl_section_declares_its_setting() -> None:
    declared = {name: s for name, _, s in settings(dvl.DvlConfig)}
    assert list(declared) == [f.name for f in dataclasses.fields(dvl.DvlConfig)]
    for name, s in declared.items():
        if s.low is None:
            continue
        for bad in (s.low - 1.0, s.high * 2.0 + 1.0):
            with pytest.raises(ConfigError, match=rf"^dvl\.{name} must be within [\[(]{s.low:g}, {s.high:g}\], got "):
                dvl.DvlConfig(**{name: bad})
    with pytest.raises(ConfigError, match=r"dvl\.lever_arm_m\[0\] must be within \[-10, 10\]"):
        dvl.DvlConfig(lever_arm_m=(11.0, 0.0, 0.0))
    with pytest.raises(ConfigError, match="dvl.beyond_range must be one of lost, noisy"):
        dvl.DvlConfig(beyond_range="gone")


def test_a_true_error_column_with_an_empty_cell_is_refused_naming_the_file_column_and_row(tmp_path) -> None:
    """The true errors are optional as columns, but a log that has one has it at every ping."""
    from tauvcore.logs import read_log
    from tauvcore.logs.writer import simulation_tables, write_log
    from tauvcore.validation import LogError

    config = Config().replace("trajectory", name="figure8", duration_s=20.0)
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(0)))])
    tables["dvl"][dvl_beams.TRUE_SCALE_FACTOR][4] = np.nan
    write_log(tmp_path / "log", tables)
    with pytest.raises(LogError, match=r"dvl\.csv.*'true_scale_factor'.*row 5"):
        read_log(tmp_path / "log")


def test_a_50_hz_log_whose_stamps_round_is_read_at_50_hz(tmp_path) -> None:
    """Time stamps 1000 s into a clock carry their float's rounding: the median interval is not
    exactly 0.02 s, and the replay takes the IMU at 50 Hz (the lowest rate allowed), not at
    49.99999999999996 Hz (refused)."""
    from tauvcore.eval.replay import replay_config
    from tauvcore.logs import read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="straight", duration_s=20.0).replace("imu", rate_hz=50.0)
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(1)))])
    for table in tables.values():
        table["t_s"] = table["t_s"] + 1000.3
    write_log(tmp_path / "log", tables)
    log = read_log(tmp_path / "log")
    assert 1.0 / log.dt_s != 50.0   # the stamps' rounding
    assert replay_config(config, log).imu.rate_hz == 50.0
