"""Log replay: the format's reader, its errors, and replay against the simulation."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tauvcore.config import METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.replay import log_simulation, replay, replay_config
from tauvcore.logs import LogError, read_log
from tauvcore.logs.writer import simulation_tables, write_log

SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "est_pos_n", "pos_sigma_m",
          "vel_sigma_mps", "att_sigma_deg")


def _config(model: str, duration_s: float = 40.0) -> Config:
    return (Config().replace("trajectory", name="figure8", duration_s=duration_s).replace("earth", model=model)
            .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag")))


@pytest.fixture(scope="module")
def simulated_log(tmp_path_factory: pytest.TempPathFactory) -> tuple:
    config = _config("wgs84")
    rng = np.random.default_rng(5)
    sim = simulate(config, rng)
    ours = run(config, sim, rng)
    directory = tmp_path_factory.mktemp("log")
    write_log(directory, simulation_tables([SimChunk.whole(sim)]), "csv")
    return config, sim, ours, directory


@pytest.mark.parametrize("model, fmt", [("wgs84", "csv"), ("wgs84", "parquet"), ("flat", "csv")])
def test_a_simulated_log_replays_to_the_simulation_to_1e_9(tmp_path: Path, model: str, fmt: str) -> None:
    """Every method, every navigation series and every DVL decision of the replay equal the run on
    the simulation it was written from, at 1e-9 of each series' scale."""
    config = _config(model)
    rng = np.random.default_rng(5)
    sim = simulate(config, rng)
    ours = run(config, sim, rng)
    write_log(tmp_path, simulation_tables([SimChunk.whole(sim)]), fmt)
    # the simulation's filters start off the truth by the initial errors: so must the replay's
    replayed_config, back = replay(config.replace("replay", initial_errors=True), read_log(tmp_path),
                                   np.random.default_rng(5))
    assert replayed_config.imu.rate_hz == pytest.approx(config.imu.rate_hz, rel=1e-12)
    for method in METHODS:
        for name in SERIES:
            a, b = getattr(ours[method], name), getattr(back[method], name)
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * max(np.abs(a).max(), 1e-9), err_msg=f"{method} {name}")
        for block in range(4):       # position, velocity, tilt, heading: what a log can be judged on
            a, b = ours[method].nees_block[..., block], back[method].nees_block[..., block]
            np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9, err_msg=f"{method} NEES block {block}")
        assert np.isnan(back[method].nees).all()                   # the true sensor errors are unknown
        for src, rec in ours[method].updates.items():
            np.testing.assert_array_equal(back[method].updates[src].fused, rec.fused, err_msg=f"{method} {src}")


def test_tauv_replay_reproduces_tauv_run(tmp_path: Path) -> None:
    """End to end: ``tauv run --save-log`` then ``tauv replay`` on that log, JSON against JSON."""
    def cli(*argv: str) -> dict:
        out = tmp_path / f"{argv[0]}.json"
        proc = subprocess.run([sys.executable, "-m", "app.cli", *argv, "--json", str(out)], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        return json.loads(out.read_text())["results"]

    ran = cli("run", "--trajectory", "lawnmower", "--duration", "30", "--method", "ins,lc,tc,elc", "--aiding",
              "dvl,depth", "--save-log", str(tmp_path / "log"))
    replayed = cli("replay", str(tmp_path / "log"), "--method", "ins,lc,tc,elc", "--aiding", "dvl,depth",
                   "--initial-errors")
    for method, series in ran.items():
        for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "nees_pos", "nees_vel"):
            a, b = np.array(series[name], dtype=float), np.array(replayed[method][name], dtype=float)
            np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9 * np.abs(a).max(), err_msg=f"{method} {name}")


def test_beams_dropped_on_replay(simulated_log: tuple) -> None:
    """``--beams 1,2`` on a four-beam log: the replay sees two beams, as the simulation would."""
    config, _, _, directory = simulated_log
    two = config.replace("dvl", beams=(1, 2))
    sim = log_simulation(replay_config(two, read_log(directory)), read_log(directory), np.random.default_rng(0))
    assert not sim.dvl.available[:, 0, 2:].any() and sim.dvl.available[:, 0, :2].all()
    _, results = replay(two, read_log(directory), np.random.default_rng(0))
    assert (results["lc"].updates["dvl"].valid == 0).all()     # LC needs three beams
    assert results["nsv"].updates["dvl"].valid.all()


def test_imu_rates_dvl_body_velocity_and_a_slow_reference(tmp_path: Path, simulated_log: tuple) -> None:
    """The other column choices: IMU rates (trapezoid increments), DVL body velocity (projected
    onto the configured beams), a reference at 1 Hz in degrees (interpolated, exact at its rows)."""
    config, sim, _, _ = simulated_log
    t = sim.truth.t_s
    rates = {"t_s": t, "gyro_x_rps": np.full_like(t, 0.01), "gyro_y_rps": 0.02 * t, "gyro_z_rps": np.zeros_like(t),
             "accel_x_mps2": np.zeros_like(t), "accel_y_mps2": np.zeros_like(t), "accel_z_mps2": np.full_like(t, -9.8)}
    every = int(round(1.0 / sim.truth.dt_s))
    truth = sim.truth
    ref = {"t_s": t[::every], "lat_deg": np.degrees(truth.pos_nav[::every, 0]),
           "lon_deg": np.degrees(truth.pos_nav[::every, 1]), "depth_m": truth.pos_nav[::every, 2],
           "roll_deg": np.degrees(truth.euler[::every, 0]), "pitch_deg": np.degrees(truth.euler[::every, 1]),
           "yaw_deg": np.degrees(truth.euler[::every, 2]), "vel_north_mps": truth.vel_n[::every, 0],
           "vel_east_mps": truth.vel_n[::every, 1], "vel_down_mps": truth.vel_n[::every, 2]}
    body = {"t_s": t[sim.dvl.index], "vel_x_mps": truth.vel_b[sim.dvl.index, 0],
            "vel_y_mps": truth.vel_b[sim.dvl.index, 1], "vel_z_mps": truth.vel_b[sim.dvl.index, 2],
            "valid": (np.arange(sim.dvl.index.size) % 5 != 3).astype(float)}
    write_log(tmp_path, {"imu": rates, "reference": ref, "dvl": body})
    log = read_log(tmp_path)
    dt = sim.truth.dt_s
    np.testing.assert_allclose(log.dtheta_b[1:, 1], 0.02 * 0.5 * (t[1:] + t[:-1]) * dt, rtol=1e-12)
    np.testing.assert_array_equal(log.dtheta_b[0], 0.0)
    cfg = replay_config(config, log)
    replayed = log_simulation(cfg, log, np.random.default_rng(0))
    expected = truth.vel_b[sim.dvl.index] @ cfg.dvl.A_b.T
    kept = body["valid"] == 1.0
    np.testing.assert_allclose(replayed.dvl.y_beam_mps[kept, 0], expected[kept], rtol=1e-12)
    assert np.isnan(replayed.dvl.y_beam_mps[~kept]).all() and not replayed.dvl.available[~kept].any()
    # the reference, at 1 Hz, is interpolated to the IMU: exact at its own rows, close between them
    np.testing.assert_allclose(replayed.truth.pos_nav[::every], truth.pos_nav[::every], rtol=1e-14, atol=0)
    np.testing.assert_allclose(replayed.truth.C_nb[::every], truth.C_nb[::every], rtol=0, atol=1e-14)
    assert np.abs(replayed.truth.pos_n - truth.pos_n).max() < 0.05      # 1 s of a 15 m turn, linearly


def _log_copy(source: Path, target: Path) -> Path:
    shutil.copytree(source, target)
    return target


def _edit_csv(path: Path, row: int, column: str, value: str) -> None:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def _drop_column(path: Path, column: str) -> None:
    lines = [line.split(",") for line in path.read_text().splitlines()]
    j = lines[0].index(column)
    path.write_text("\n".join(",".join(c[:j] + c[j + 1:]) for c in lines) + "\n")


@pytest.mark.parametrize("case, expected", [
    ("missing_column", ["imu.csv", "'dv_y_mps'"]),
    ("unsorted", ["imu.csv", "'t_s'", "row 7", "goes back"]),
    ("duplicated", ["imu.csv", "'t_s'", "row 7", "repeats"]),
    ("nan_row", ["imu.csv", "'dtheta_z_rad'", "row 12", "empty"]),
    ("text", ["depth.csv", "'depth_m'", "row 3", "'deep'"]),
    ("gravity_mg", ["imu.csv", "dv_x_mps", "9.8", "mg"]),
    ("gap", ["imu.csv", "'t_s'", "row 40", "gap", "50"]),
    ("no_reference_nor_attitude", ["no reference.csv or attitude.csv", "starting attitude"]),
    ("local_reference_on_wgs84", ["north_m", "--earth flat"]),
])
def test_bad_logs_name_file_column_and_row(tmp_path: Path, simulated_log: tuple, case: str, expected: list) -> None:
    config, _, _, directory = simulated_log
    log = _log_copy(directory, tmp_path / "log")
    imu = log / "imu.csv"
    if case == "missing_column":
        _drop_column(imu, "dv_y_mps")
    elif case == "unsorted":
        _edit_csv(imu, 7, "t_s", "0.0001")
    elif case == "duplicated":
        t6 = imu.read_text().splitlines()[6].split(",")[0]
        _edit_csv(imu, 7, "t_s", t6)
    elif case == "nan_row":
        _edit_csv(imu, 12, "dtheta_z_rad", "")
    elif case == "text":
        _edit_csv(log / "depth.csv", 3, "depth_m", "deep")
    elif case == "gravity_mg":
        lines = imu.read_text().splitlines()
        header = lines[0].split(",")
        cols = [header.index(c) for c in ("dv_x_mps", "dv_y_mps", "dv_z_mps")]
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            for j in cols:
                cells[j] = repr(float(cells[j]) * 1000.0 / 9.80665)      # in mg
            out.append(",".join(cells))
        imu.write_text("\n".join(out) + "\n")
    elif case == "gap":
        lines = imu.read_text().splitlines()
        imu.write_text("\n".join(lines[:40] + lines[100:]) + "\n")      # 0.4 s at 150 Hz: 60 intervals
    elif case == "no_reference_nor_attitude":
        (log / "reference.csv").unlink()
        (log / "attitude.csv").unlink()
    elif case == "local_reference_on_wgs84":
        ref = log / "reference.csv"
        text = ref.read_text().replace("lat_rad,lon_rad,depth_m", "north_m,east_m,down_m", 1)
        ref.write_text(text)
    with pytest.raises(LogError) as err:
        replay(config, read_log(log), np.random.default_rng(0))
    message = str(err.value)
    for part in expected:
        assert part in message, message
    proc = subprocess.run([sys.executable, "-m", "app.cli", "replay", str(log)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def test_an_irregular_imu_clock_and_a_short_gap_are_resampled(tmp_path: Path, simulated_log: tuple) -> None:
    """Dropped samples (a 5-sample hole) and jittered time stamps: the IMU is put back on a
    constant rate by interpolating its cumulative increments, the reader says so, nothing measured
    is lost but the end of the last interval, and the replay's errors move by centimetres."""
    config, _, _, directory = simulated_log
    log_dir = _log_copy(directory, tmp_path / "log")
    imu = log_dir / "imu.csv"
    lines = imu.read_text().splitlines()
    header, rows = lines[0], [line.split(",") for line in lines[1:]]
    rng = np.random.default_rng(2)
    for cells in rows[1:-1]:
        cells[0] = repr(float(cells[0]) + rng.uniform(-0.2, 0.2) / 150.0)     # +-20 % of an interval
    hole = rows[300:305]
    rows = rows[:300] + rows[305:]
    # the increments of the dropped rows are gone from the record: the next row's covers the hole
    for j in range(1, 7):
        rows[300][j] = repr(float(rows[300][j]) + sum(float(r[j]) for r in hole))
    imu.write_text(header + "\n" + "\n".join(",".join(c) for c in rows) + "\n")
    clean, jittered = read_log(directory), read_log(log_dir)
    assert jittered.notes and "resampled" in jittered.notes[0] and "imu.csv" in jittered.notes[0]
    assert abs(jittered.imu_t_s.size - clean.imu_t_s.size) <= 1
    np.testing.assert_allclose(np.diff(jittered.imu_t_s), clean.dt_s, rtol=1e-4)
    # nothing measured is lost but the part of the last interval past the grid's end
    np.testing.assert_allclose(jittered.dv_b.sum(axis=0), clean.dv_b.sum(axis=0), rtol=0,
                               atol=2 * np.abs(clean.dv_b).max())
    offset = config.replace("replay", initial_errors=True)   # both start off the reference alike
    _, a = replay(offset, clean, np.random.default_rng(0))
    _, b = replay(offset, jittered, np.random.default_rng(0))
    for method in ("ins", "lc", "tc"):
        # time stamps 20 % of an interval off move the rates they are given by that much: the
        # errors (2-4 m here) change by centimetres
        assert np.abs(a[method].pos_err_m - b[method].pos_err_m).max() < 0.15, method


def test_a_log_without_reference_starts_from_its_own_sensors(tmp_path: Path, simulated_log: tuple) -> None:
    """No reference: the filters start from the attitude sensor's first row, the first DVL
    velocity and the configured origin; the estimate is there, the errors are unknown (NaN)."""
    config, sim, ours, directory = simulated_log
    log_dir = _log_copy(directory, tmp_path / "log")
    (log_dir / "reference.csv").unlink()
    log = read_log(log_dir)
    assert log.ref_t_s is None
    _, back = replay(config, log, np.random.default_rng(0))
    for method in ("ins", "lc", "tc"):
        r = back[method]
        # no truth, no error: not even the zero at the start the filters were put on
        assert np.isnan(r.pos_err_m).all() and np.isnan(r.nees_block).all() and np.isfinite(r.est_pos_n).all()
    # LC, DVL-aided from a magnetometer start, stays within metres of the truth it never saw
    truth_end = sim.truth.pos_n[-1]
    assert np.linalg.norm(back["lc"].est_pos_n[-1, 0] - truth_end) < 10.0
    # the start: the attitude sensor's first row and the origin at the first depth
    first = back["lc"].est_pos_n[0, 0]
    assert first[:2] == pytest.approx([0.0, 0.0], abs=1e-6) and first[2] == pytest.approx(log.sources["depth"]["depth_m"][0], abs=1e-6)


def _cli(*argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "app.cli", *argv], capture_output=True, text=True, timeout=120)


def test_a_replay_starts_on_the_reference_unless_told_otherwise(simulated_log: tuple) -> None:
    """By default the filters start on the reference's first row (zero error at t = 0) with the
    initial errors as their sigmas; ``replay.initial_errors`` puts them off it as the simulation
    was (its first error is the initial offset's norm, 2 m in each axis: 3.46 m)."""
    config, _, ours, directory = simulated_log
    log = read_log(directory)
    on, back = replay(config, log, np.random.default_rng(5))
    assert on.run.ideal and not on.replay.initial_errors
    for method in ("ins", "lc"):
        assert back[method].pos_err_m[0, 0] == pytest.approx(0.0, abs=1e-9)
        assert back[method].pos_sigma_m[0, 0] == pytest.approx(ours[method].pos_sigma_m[0, 0], rel=1e-12)
    off, back = replay(config.replace("replay", initial_errors=True), log, np.random.default_rng(5))
    assert not off.run.ideal
    assert back["lc"].pos_err_m[0, 0] == pytest.approx(np.sqrt(12.0), rel=1e-6)


def test_the_log_s_own_configuration_is_applied_under_config_and_flags(tmp_path: Path, simulated_log: tuple) -> None:
    """``DIR/log.toml`` sets the replay's configuration; ``--config`` and the flags win over it;
    ``--no-log-config`` leaves it out; the header and the JSON say which applied."""
    _, _, _, directory = simulated_log
    log_dir = _log_copy(directory, tmp_path / "log")
    (log_dir / "log.toml").write_text("[dvl]\nlever_arm_m = [0.5, 0.0, 0.2]\nnoise_mps = 0.05\n")
    over = tmp_path / "over.toml"
    over.write_text("[dvl]\nnoise_mps = 0.06\n")

    def replayed(*argv: str) -> tuple[dict, list[str]]:
        out = tmp_path / "r.json"
        proc = _cli("replay", str(log_dir), "--method", "ins,lc", "--json", str(out), *argv)
        assert proc.returncode == 0, proc.stderr
        return json.loads(out.read_text()), proc.stdout.splitlines()

    doc, lines = replayed()
    assert doc["config"]["dvl"]["lever_arm_m"] == [0.5, 0.0, 0.2] and doc["config"]["dvl"]["noise_mps"] == 0.05
    assert doc["log"]["config_file"] == str(log_dir / "log.toml")
    assert "dvl.lever_arm_m, dvl.noise_mps" in lines[1] and lines[2].startswith("start: on the reference")
    doc, lines = replayed("--config", str(over), "--beams", "1,2,3")
    assert doc["config"]["dvl"]["lever_arm_m"] == [0.5, 0.0, 0.2] and doc["config"]["dvl"]["noise_mps"] == 0.06
    assert doc["config"]["dvl"]["beams"] == [1, 2, 3] and "--config" in lines[1] and "--beams" in lines[1]
    doc, lines = replayed("--no-log-config")
    assert doc["config"]["dvl"]["lever_arm_m"] == list(Config().dvl.lever_arm_m) and doc["log"]["config_file"] is None
    assert "ignored (--no-log-config)" in lines[1]
    doc, lines = replayed("--initial-errors")
    assert doc["config"]["replay"]["initial_errors"] and "plus the fixed initial errors" in lines[2]


@pytest.mark.parametrize("content, expected", [
    ("[dvl]\nlever_arm = 1\n", "unknown key dvl.lever_arm"),
    ("[dvl\n", "malformed TOML"),
    ("[dvl]\nnoise_mps = -1.0\n", "dvl.noise_mps"),
])
def test_a_bad_log_configuration_is_named(tmp_path: Path, simulated_log: tuple, content: str, expected: str) -> None:
    """A log's own configuration that cannot be used: one line naming the file and what is wrong."""
    _, _, _, directory = simulated_log
    log_dir = _log_copy(directory, tmp_path / "log")
    (log_dir / "log.toml").write_text(content)
    proc = _cli("replay", str(log_dir))
    assert proc.returncode == 2 and proc.stdout == "" and "Traceback" not in proc.stderr
    line, = proc.stderr.strip().splitlines()
    assert "log.toml" in line and expected in line and "the log's configuration" in line


def test_a_vendor_s_raw_layout_gets_the_converter_named(tmp_path: Path) -> None:
    """A folder in A-KIT's own layout (IMU.csv, DVL.csv, GT.csv) replayed or served as it is:
    one line naming the converter, not only "no imu.csv"."""
    raw = tmp_path / "segments" / "Trajectory1"
    raw.mkdir(parents=True)
    for name in ("IMU.csv", "DVL.csv", "GT.csv"):
        (raw / name).write_text("time,x\n0,0\n")
    for argv in (("replay", str(raw)), ("serve", "--logs", str(tmp_path / "segments"))):
        proc = _cli(*argv)
        assert proc.returncode == 2 and "Traceback" not in proc.stderr
        line, = proc.stderr.strip().splitlines()
        assert "IMU.csv, DVL.csv, GT.csv" in line and "scripts/akit_to_log.py" in line, line
