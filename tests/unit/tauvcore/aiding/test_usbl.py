"""The USBL source (tauvcore.aiding.usbl): known answers of its fix, its noise against 10,000 draws,
its losses and outliers, the latency, what the gate does with an outlier, and bad input from a
TOML file and a log table. Its H against central differences, its chunk independence and its log
round trip are the plug-in tests of tests/unit/tauvcore/aiding/test_sources.py."""

from __future__ import annotations

import numpy as np
import pytest

from app.cli import main
from tauvcore.aiding.source import SourceData
from tauvcore.aiding.usbl import AXES, SOURCE, UsblConfig
from tauvcore.config import Config, from_dict
from tauvcore.engine.mission import run_streaming
from tauvcore.geo.rotations import mv
from tauvcore.truth import generate
from tauvcore.validation import ConfigError

MISSION = Config().replace("trajectory", name="lawnmower", duration_s=300.0)


def _truth():
    return generate(MISSION.trajectory, MISSION.earth, MISSION.imu.rate_hz)


def _fixes(section: UsblConfig, num_runs: int, seed: int = 0, truth=None) -> tuple[SourceData, np.ndarray]:
    truth = truth if truth is not None else _truth()
    pings = np.arange(150, truth.num_samples, 150)  # one a second
    rngs = {name: np.random.default_rng([seed, i]) for i, name in enumerate(SOURCE.streams)}
    data, _ = SOURCE.simulate_chunk(truth, 0, pings, section, SOURCE.initial_state(section, num_runs, None),
                                    rngs, num_runs, truth.num_samples)
    return data, pings


def test_an_ideal_fix_is_the_transponder_at_ping_time_arriving_latency_later() -> None:
    truth = _truth()
    section = SOURCE.ideal(UsblConfig(latency_s=2.0, lever_arm_b_m=(0.5, -0.2, -0.4)))
    data, pings = _fixes(section, 1, truth=truth)
    lag = 300  # 2 s at 150 Hz
    arrived = pings[pings + lag < truth.num_samples]
    np.testing.assert_array_equal(data.index, arrived + lag)
    np.testing.assert_array_equal(data.t_s, truth.t_s[arrived + lag])
    expected = truth.pos_n[arrived] + mv(truth.C_nb[arrived], np.array([0.5, -0.2, -0.4]))
    np.testing.assert_allclose(data.stacked(AXES)[:, 0], expected, rtol=0, atol=1e-12)


def test_the_noise_is_the_configured_slant_range_law_over_10000_draws() -> None:
    """Far from the transceiver (a few km), sigma = 0.5 m + 1 % of the slant range, per axis: the
    sample variance of 10,000 fixes (33 pings x 300 runs) within 5 % (3.5 sigma of its own spread),
    the axes uncorrelated, the mean zero."""
    truth = _truth()
    section = UsblConfig(noise_fixed_m=0.5, noise_fraction=0.01, transceiver_n_m=(-3000.0, 2000.0, 5.0),
                         dropout_probability=0.0, outlier_probability=0.0, latency_s=0.0)
    data, pings = _fixes(section, 300, truth=truth)
    lever = mv(truth.C_nb[pings], np.asarray(section.lever_arm_b_m))
    true_n = truth.pos_n[pings] + lever
    slant = np.linalg.norm(true_n - np.asarray(section.transceiver_n_m), axis=-1)
    sigma = 0.5 + 0.01 * slant  # (E,) ~ 36 m
    err = (data.stacked(AXES) - true_n[:, None, :]) / sigma[:, None, None]  # (E, R, 3) standard normal
    e = err.reshape(-1, 3)
    assert e.shape[0] >= 9_900
    np.testing.assert_allclose(np.var(e, axis=0), 1.0, atol=0.05)
    np.testing.assert_allclose(np.mean(e, axis=0), 0.0, atol=0.04)
    corr = np.corrcoef(e.T)
    np.testing.assert_allclose(corr[np.triu_indices(3, 1)], 0.0, atol=0.04)


def test_losses_and_outliers_come_at_their_probabilities() -> None:
    section = UsblConfig(dropout_probability=0.2, outlier_probability=0.1, outlier_m=50.0, latency_s=0.0,
                         noise_fixed_m=0.1, noise_fraction=0.0)
    truth = _truth()
    data, pings = _fixes(section, 400, truth=truth)
    fix = data.stacked(AXES)
    lost = np.isnan(fix).all(axis=-1)
    assert np.isnan(fix).any(axis=-1).sum() == lost.sum()  # a lost fix is lost whole
    assert abs(lost.mean() - 0.2) < 0.01  # 11,600 fixes: 3.4 sigma is 0.013
    true_n = truth.pos_n[pings] + mv(truth.C_nb[pings], np.asarray(section.lever_arm_b_m))
    off = np.linalg.norm(fix - true_n[:, None, :], axis=-1)[~lost]
    outliers = off > 10.0
    assert abs(outliers.mean() - 0.1) < 0.01
    np.testing.assert_allclose(off[outliers], 50.0, atol=1.0)  # 50 m in a random direction, plus the noise


def test_the_gate_refuses_the_outliers_and_the_latency_compensation_removes_the_lag() -> None:
    """LC + USBL on the lawnmower (2 m/s), one fix a second, 1 s latency: every outlier (30 m) is
    refused by the gate, every good fix fused; with the latency compensated the innovations have
    no mean along the track, without it they lag the vehicle by v tau (2 m)."""
    base = (MISSION.replace("run", methods=("lc",), aiding=("dvl", "usbl"))
            .replace("usbl", interval_s=1.0, outlier_probability=0.05, dropout_probability=0.0))
    record = run_streaming(base, np.random.default_rng(4))["lc"].updates["usbl"]
    truth = _truth()
    rng = np.random.default_rng(4)
    from tauvcore.engine.source_streams import SourceStream
    from tauvcore.sensors.stream import SensorStreams
    streams = SensorStreams.spawned(rng)
    data = SourceStream(base, rng, 1, truth.num_samples, truth.dt_s, streams).next_chunk(0, truth)["usbl"]
    ping = data.index - 150
    true_n = truth.pos_n[ping] + mv(truth.C_nb[ping], np.asarray(base.section("usbl").lever_arm_b_m))
    outlier = np.linalg.norm(data.stacked(AXES)[:, 0] - true_n, axis=-1) > 10.0
    assert outlier.sum() >= 5
    settled = record.t_s > 30.0
    np.testing.assert_array_equal(record.rejected[outlier & settled, 0], True)
    assert record.fused[~outlier & settled, 0].mean() > 0.98
    track = truth.vel_n[data.index] / np.linalg.norm(truth.vel_n[data.index], axis=-1, keepdims=True)
    along = np.einsum("ij,ij->i", record.innovation[:, 0], track)[~outlier & settled]
    ignored = run_streaming(base.replace("usbl", compensate_latency=False), np.random.default_rng(4))["lc"]
    along_ignored = np.einsum("ij,ij->i", ignored.updates["usbl"].innovation[:, 0], track)[~outlier & settled]
    assert abs(np.mean(along)) < 0.1  # metres
    assert np.mean(along_ignored) < -1.0  # the fix is behind the vehicle's estimate


@pytest.mark.parametrize(
    ("key", "value", "words"),
    [
        ("interval_s", 0.1, "usbl.interval_s"),
        ("latency_s", -1.0, "usbl.latency_s"),
        ("noise_fraction", 0.5, "usbl.noise_fraction"),
        ("transceiver_n_m", [0.0, 0.0, -5.0], "usbl.transceiver_n_m[2]"),
        ("lever_arm_b_m", [0.0, 11.0, 0.0], "usbl.lever_arm_b_m"),
        ("dropout_probability", 1.5, "usbl.dropout_probability"),
        ("compensate_latency", 1, "usbl.compensate_latency"),
    ],
)
def test_a_bad_field_names_itself_and_its_value(key: str, value: object, words: str, tmp_path, capsys) -> None:
    with pytest.raises(ConfigError, match=words.replace("[", r"\[").replace("]", r"\]")):
        from_dict({"usbl": {key: value}})
    path = tmp_path / "bad.toml"
    text = str(value).lower() if not isinstance(value, list) else str(value)
    path.write_text(f"[usbl]\n{key} = {text}\n")
    assert main(["run", "--config", str(path), "--aiding", "dvl,usbl", "--duration", "5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words.split("[")[0] in err[0] and "Traceback" not in err[0]


def test_a_bad_usbl_table_names_the_file_the_column_and_the_row(tmp_path, capsys) -> None:
    from tauvcore.engine.simulation import SimChunk, simulate
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.writer import simulation_tables, write_log

    config = Config().replace("trajectory", name="lawnmower", duration_s=60.0).replace("run", aiding=("dvl", "usbl"))
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(0)))])
    write_log(tmp_path / "good", tables)
    assert main(["replay", str(tmp_path / "good"), "--aiding", "dvl,usbl", "--method", "lc"]) == 0
    assert "usbl" in capsys.readouterr().out
    cases = {
        "missing": ({k: v for k, v in tables["usbl"].items() if k != "east_m"}, "missing column 'east_m'"),
        "infinite": ({**tables["usbl"], "north_m": np.where(np.arange(tables["usbl"]["north_m"].size) == 2,
                                                           np.inf, tables["usbl"]["north_m"])},
                     "column 'north_m', row 3"),
        "too far": ({**tables["usbl"], "down_m": np.full(tables["usbl"]["down_m"].size, 3e7)},
                    "column 'down_m', row 1"),
    }
    for case, (usbl, words) in cases.items():
        directory = tmp_path / case.replace(" ", "_")
        write_log(directory, {**tables, "usbl": usbl})
        with pytest.raises(LogError, match=words):
            read_log(directory)
        assert main(["replay", str(directory), "--aiding", "dvl,usbl"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "usbl.csv" in err[0] and words in err[0]
    # a lost fix (an empty row) is a row without a measurement, not an error
    lost = {**tables["usbl"], **{a: np.where(np.arange(tables["usbl"][a].size) == 1, np.nan, tables["usbl"][a])
                                 for a in AXES}}
    write_log(tmp_path / "lost", {**tables, "usbl": lost})
    log = read_log(tmp_path / "lost")
    assert np.isnan(log.sources["usbl"]["north_m"][1])
