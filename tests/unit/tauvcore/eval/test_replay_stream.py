"""`tauv replay` reduced chunk by chunk: the banks fed a log's chunks give the numbers of the whole log
at once (tauvcore.engine.mission.run_chunked), and the command prints and writes (--json) what it
did when it held the whole results (the oracle below: the command as it was)."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from app import cli
from app.commands.outputs import write_json_atomic
from app.commands.replay_log import replay_layers
from app.commands.values import resolve_config
from app.reports.payload import run_payload
from app.reports.tables import summary_table
from tauvcore.config import Config
from tauvcore.engine import mission
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval import replay as replay_module
from tauvcore.eval.judging import judged
from tauvcore.eval.replay import LogRows, log_config, prepare, prepare_rows, start_description
from tauvcore.logs import CONFIG_FILE, read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.validation import show_path

METHODS = ("ins", "lc", "tc", "nsv", "elc", "iekf", "ins-dvl", "vkf")
SERIES = ("t_s", "pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "nees", "nees_block",
          "est_pos_n", "est_vel_n", "est_euler_rad", "pos_sigma_m", "vel_sigma_mps", "att_sigma_deg")


@pytest.fixture(scope="module")
def awkward_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 40 s simulated log whose DVL starts at 12 s (after the first chunk would end) and whose
    echo sounder and RPM are read between the IMU samples the chunks start at (read at their
    latest epoch, a chunk must see the one before it), with its own configuration file."""
    config = (Config().replace("trajectory", name="figure8", duration_s=40.0)
              .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag")))
    sim = simulate(config, np.random.default_rng(5))
    tables = simulation_tables([SimChunk.whole(sim)])
    late = tables["dvl"]["t_s"] >= 12.0
    tables["dvl"] = {name: values[late] for name, values in tables["dvl"].items()}
    for table in ("echo", "rpm"):
        tables[table]["t_s"] = tables[table]["t_s"] + 0.1
    directory = tmp_path_factory.mktemp("awkward") / "log"
    write_log(directory, tables, "csv", config_toml="[dvl]\nnoise_mps = 0.012\n")
    return directory


@pytest.fixture(scope="module")
def slow_reference_log(awkward_log: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The awkward log with its reference at 1 Hz and ending at 38 s: interpolated between rows
    that chunks cut through, and held after its last row."""
    tables = {name: _csv_columns(awkward_log / f"{name}.csv")
              for name in ("imu", "reference", "dvl", "depth", "attitude", "echo", "rpm")}
    tables["reference"] = {name: values[:5701:150] for name, values in tables["reference"].items()}
    directory = tmp_path_factory.mktemp("slow") / "log"
    write_log(directory, tables, "csv")
    return directory


def _prepared(directory: Path, rows: bool = False, **run) -> tuple:
    """The replay's configuration, the log as a whole simulation (prepare) or as its rows made chunk
    by chunk (prepare_rows), the log and the generator the filters draw from next."""
    config = Config().replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"), **run)
    log = read_log(directory)
    rng = np.random.default_rng(4)
    config, sim = (prepare_rows if rows else prepare)(config.replace("replay", initial_errors=True), log, rng)
    return config, sim, log, rng


@pytest.mark.parametrize("chunk_s", [1.37, 10.0])
@pytest.mark.parametrize("rpm_fallback, rows, reference", [(False, False, "imu rate"), (True, False, "imu rate"),
                                                            (False, True, "imu rate"), (True, True, "imu rate"),
                                                            (False, True, "1 Hz")])
def test_the_chunks_results_are_the_whole_log_s(awkward_log, slow_reference_log, chunk_s, rpm_fallback, rows,
                                                reference) -> None:
    """The banks fed the chunks of the whole simulation, or of the log's rows made chunk by chunk
    (LogRows), give the whole simulation's numbers: bit for bit with a reference at the IMU's rate;
    between the rows of a slower one the interpolated attitude may differ in its last bit
    (exp_so3 takes its series or its sines by the largest angle of what it is given), so there
    to 1e-9 of each series' scale."""
    log_dir = awkward_log if reference == "imu rate" else slow_reference_log
    config, sim, _, rng = _prepared(log_dir, rpm_fallback=rpm_fallback)
    whole = mission.run(config, sim, rng)
    config_rows, source, _, rng = _prepared(log_dir, rows=rows, rpm_fallback=rpm_fallback)
    assert config_rows == config and isinstance(source, LogRows) == rows
    parts: list[dict] = []
    mission.run_chunked(config, source, rng, parts.append, chunk_s=chunk_s)
    assert len(parts) == (22 if chunk_s == 1.37 else 4)     # the first chunk reaches past the first ping (12 s)
    assert sim.dvl.index[0] > round(chunk_s * config.imu.rate_hz)
    def same(a, b, what):
        if reference == "imu rate":
            np.testing.assert_array_equal(a, b, err_msg=what)
        else:
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * max(np.nanmax(np.abs(b), initial=0.0), 1e-9),
                                       err_msg=what)

    for m in METHODS:
        for name in SERIES:
            same(np.concatenate([getattr(p[m], name) for p in parts]), getattr(whole[m], name), f"{m} {name}")
        for src, rec in whole[m].updates.items():
            for f in ("t_s", "nis", "nis_dof", "fused", "rejected", "valid"):
                same(np.concatenate([getattr(p[m].updates[src], f) for p in parts if src in p[m].updates]),
                     getattr(rec, f), f"{m} {src} {f}")
        for f in ("diverged", "diverged_at_s", "p_floor_count"):
            np.testing.assert_array_equal(getattr(parts[-1][m], f), getattr(whole[m], f), err_msg=f"{m} {f}")


def test_a_last_chunk_of_one_epoch_and_the_yoo_bank_s_verdict_so_far(tmp_path) -> None:
    """A 40 s log in 10 s chunks ends with a chunk of one sample (one output epoch); Yoo's bank,
    whose full NEES a log cannot give (no true sensor errors), does not take that for a diverged
    filter, and the last chunk's verdict so far is the whole log's."""
    config = Config().replace("trajectory", name="figure8", duration_s=40.0).replace("run", methods=("ins-dvl", "vkf"))
    write_log(tmp_path, simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(1)))]))
    config, sim, _, rng = _prepared(tmp_path)
    config = config.replace("run", methods=("lc", "ins-dvl", "vkf"))
    whole = mission.run(config, sim, rng)
    _, rows, _, rng = _prepared(tmp_path, rows=True)
    parts: list[dict] = []
    mission.run_chunked(config, rows, rng, parts.append)
    assert [p["vkf"].t_s.size for p in parts] == [100, 100, 100, 100, 1]   # 10 Hz output epochs
    for m in ("lc", "ins-dvl", "vkf"):
        np.testing.assert_array_equal(np.concatenate([p[m].pos_err_m for p in parts]), whole[m].pos_err_m)
        for f in ("diverged", "diverged_at_s"):
            np.testing.assert_array_equal(getattr(parts[-1][m], f), getattr(whole[m], f), err_msg=f"{m} {f}")
    assert np.isnan(whole["vkf"].nees).all()
    assert all(np.isnan(whole[m].diverged_at_s[0]) for m in ("lc", "ins-dvl", "vkf"))


def _replay_as_it_was(argv: list[str], json_path: Path) -> tuple[str, str]:
    """The command as it was before it reduced chunk by chunk: the whole results held, judged,
    then run_payload (--json) and summary_table; its stdout and stderr (the oracle)."""
    args = cli.build_parser().parse_args(cli.attach_dash_values(["replay", *argv]))
    log_raw, log_config_path = ({}, None) if args.no_log_config else log_config(args.log)
    config = resolve_config(args, under=log_raw)
    imu_errors = IMU_PROFILES[args.imu_errors] if args.imu_errors is not None else None
    log = read_log(args.log)
    rng = np.random.default_rng(config.run.seed)
    imu_tuning = config.imu if imu_errors is not None and args.imu is not None else None
    config, sim = prepare(config, log, rng, imu_errors, imu_tuning)
    results = judged(log, mission.run(config, sim, rng))
    err = "".join(f"tauv: note: {note}\n" for note in log.notes)
    source = {
        "directory": str(args.log),
        "config_file": log_config_path,
        "configuration": replay_layers(args, log_raw, log_config_path),
        "start": start_description(config, log),
        "reference": config.reference.describe(log.ref_t_s is not None),
        "notes": list(log.notes),
    }
    if imu_errors is not None:
        source["imu"] = (f"IMU: the log's with the errors of {args.imu_errors} added (drawn from seed "
                         f"{config.run.seed}); the filters tuned for {args.imu or args.imu_errors}")
    write_json_atomic(str(json_path), run_payload(config, results, log=source))
    start = source["start"] + ("" if config.replay.initial_errors else " (--initial-errors: start off it)")
    preamble = ["configuration: " + " < ".join(source["configuration"]), start, source["reference"]]
    preamble += [source["imu"]] if "imu" in source else []
    table = summary_table(results, config, 0.0, source=f"log {show_path(str(args.log))}", preamble=preamble)
    return table + "\n", err


def _assert_same(a, b, exact: bool, path="") -> None:
    """Equal documents: the same keys and numbers (the consistency, summed chunk by chunk, to 1e-9;
    the rest exactly, or to 1e-9 unless ``exact``)."""
    assert type(a) is type(b) or {type(a), type(b)} <= {int, float}, path
    if isinstance(a, dict):
        assert list(a) == list(b), path
        for k in a:
            _assert_same(a[k], b[k], exact, f"{path}/{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            _assert_same(x, y, exact, f"{path}[{k}]")
    elif isinstance(a, float) and ("/consistency/" in path or not exact):
        assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12), (path, a, b)
    else:
        assert a == b, (path, a, b)


def _without_reference(awkward_log: Path, target: Path) -> Path:
    """The log without its reference (nothing to judge: errors and NEES NaN) and with a jittered
    IMU clock (the reader resamples it and says so: a note)."""
    log = read_log(awkward_log)
    tables = {"imu": {}}
    t = log.imu_t_s.copy()
    t[1:-1] += np.random.default_rng(2).uniform(-0.2, 0.2, t.size - 2) * log.dt_s
    tables["imu"] = {"t_s": t, **{f"dtheta_{a}_rad": log.dtheta_b[:, i] for i, a in enumerate("xyz")},
                     **{f"dv_{a}_mps": log.dv_b[:, i] for i, a in enumerate("xyz")}}
    for table in ("dvl", "depth", "attitude", "echo", "rpm"):
        tables[table] = _csv_columns(awkward_log / f"{table}.csv")
    write_log(target, tables, "csv")
    assert read_log(target).notes and read_log(target).ref_t_s is None
    return target


def _csv_columns(path: Path) -> dict[str, np.ndarray]:
    header = path.read_text().splitlines()[0].split(",")
    data = np.genfromtxt(path, delimiter=",", skip_header=1, ndmin=2)
    return {name: data[:, j] for j, name in enumerate(header)}


@pytest.mark.parametrize("case", ["reference", "odd chunks", "no reference", "slow reference"])
def test_tauv_replay_prints_and_writes_what_it_did_holding_the_whole_results(capsys, tmp_path, monkeypatch,
                                                                              awkward_log, slow_reference_log,
                                                                              case) -> None:
    """The printed table and the notes the same to the character (but the wall time), the --json
    document the same keys and numbers: every series exactly (to 1e-9 with a reference slower than
    the IMU: see above), the consistency to 1e-9."""
    log_dir = slow_reference_log if case == "slow reference" else awkward_log
    argv = ["--method", ",".join(METHODS), "--aiding", "dvl,depth,mag", "--initial-errors"]
    if case == "odd chunks":
        monkeypatch.setattr(mission, "STREAM_CHUNK_S", 1.37)
        argv = ["--method", "lc,vkf", "--rpm-fallback", "--seed", "3"]
    if case == "no reference":
        log_dir = _without_reference(awkward_log, tmp_path / "no_reference")
        argv = ["--method", "ins,lc,tc,ins-dvl", "--aiding", "dvl,depth,mag", "--imu-errors", "yoo-table1"]
    chunked: list = []
    real = replay_module.replay_chunked

    def counting(config, sim, log, rng, on_chunk, *args, **kwargs):
        def each(results):
            chunked.append(len(results))
            on_chunk(results)
        real(config, sim, log, rng, each, *args, **kwargs)

    monkeypatch.setattr(replay_module, "replay_chunked", counting)
    assert cli.main(["replay", str(log_dir), *argv, "--json", str(tmp_path / "streamed.json")]) == 0
    out, err = capsys.readouterr()
    assert len(chunked) == (22 if case == "odd chunks" else 4)
    expected_out, expected_err = _replay_as_it_was([str(log_dir), *argv], tmp_path / "whole.json")
    assert re.sub(r"\(\d+\.\d s wall\)", "(0.0 s wall)", out) == expected_out
    assert err == expected_err
    a = json.loads((tmp_path / "whole.json").read_text())
    b = json.loads((tmp_path / "streamed.json").read_text())
    assert list(b) == ["config", "log", "results"]
    if case == "reference":
        assert b["log"]["config_file"] == str(awkward_log / CONFIG_FILE)
        assert b["config"]["dvl"]["noise_mps"] == 0.012
    if case == "no reference":
        assert b["log"]["notes"] and all(v is None for v in b["results"]["lc"]["pos_err_m"])
    for method in a["results"]:  # the NIS sources may come in another order: compare them by name
        a["results"][method]["nis"] = dict(sorted(a["results"][method]["nis"].items()))
        b["results"][method]["nis"] = dict(sorted(b["results"][method]["nis"].items()))
    _assert_same(a, b, exact=case != "slow reference")
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".tauv-")) == []  # no spool left


def test_replay_layers_name_only_configuration_flags() -> None:
    """The configuration line names the flags that configure, not the command's own arguments."""
    args = cli.build_parser().parse_args(
        cli.attach_dash_values(["replay", "some-log", "--method", "lc", "--json", "out.json"]))
    assert replay_layers(args, {}, None) == ["defaults", "flags --method"]
    bare = cli.build_parser().parse_args(cli.attach_dash_values(["replay", "some-log"]))
    assert replay_layers(bare, {}, None) == ["defaults"]
