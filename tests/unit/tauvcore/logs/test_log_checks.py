"""Physical plausibility of a log (tauvcore.logs.checks).

Given a short seeded simulation written as a log, when one thing about it is made wrong the way
real logs are wrong (a clock in milliseconds, a gyro in deg/s, a flipped or swapped axis, degrees
under ``_rad``, knots under ``_mps``, altitude as depth), then ``check_plausible`` refuses it with
one LogError naming the file, the column, the row and the value there (checked against the table
written); and the logs as written pass: simulated on every trajectory and earth model with no note
at all, the 13 segments of the real A-KIT data with no error.
"""

from __future__ import annotations

import copy
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest

from tauvcore import logs, units
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs import Log, read_log
from tauvcore.logs import checks as log_checks
from tauvcore.logs.checks import check_plausible
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.validation import MESSAGE_CHARS, LogError, show_path

SEED = 11
DURATION_S = 30.0
REFERENCE_EVERY = 15  # rows of the 150 Hz reference kept in the figure eight made wrong
ROOT = Path(__file__).resolve().parents[4]
AKIT = ROOT.parent / "shared" / "data" / "akit"
IMU_INCREMENTS = ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps")
IMU_RATES = ("gyro_x_rps", "gyro_y_rps", "gyro_z_rps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2")

Tables = dict[str, dict[str, np.ndarray]]


def _simulated(trajectory: str = "figure8", earth: str = "wgs84", seed: int = SEED) -> Tables:
    config = (
        Config().replace("trajectory", name=trajectory, duration_s=DURATION_S).replace("earth", model=earth)
    )
    return simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(seed)))])


@pytest.fixture(scope="module")
def figure8() -> Tables:
    """The figure eight, its reference thinned to 10 Hz (a reference may come at any rate; the
    smaller files keep the tests quick)."""
    tables = _simulated()
    tables["reference"] = {c: v[::REFERENCE_EVERY] for c, v in tables["reference"].items()}
    return tables


@pytest.fixture
def tables(figure8: Tables) -> Tables:
    """A copy of the figure-eight log's tables, for one test to make wrong."""
    return copy.deepcopy(figure8)


def _as_rates(tables: Tables) -> Tables:
    """The IMU as rates (``gyro_*_rps``, ``accel_*_mps2``): each increment over its interval."""
    imu = tables["imu"]
    dt = np.diff(imu["t_s"], prepend=imu["t_s"][0] - (imu["t_s"][1] - imu["t_s"][0]))
    rates = {"t_s": imu["t_s"]}
    for inc, rate in zip(IMU_INCREMENTS, IMU_RATES, strict=True):
        r = imu[inc] / dt
        r[0] = r[1]
        rates[rate] = r
    tables["imu"] = rates
    return tables


def _without_checks_read(directory: Path) -> Log:
    """The log as the reader makes it, whether or not the reader runs the checks itself (they are
    called directly here)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(log_checks, "check_plausible", lambda log, files: [])
        patch.setattr(logs, "check_plausible", lambda log, files: [], raising=False)
        return read_log(directory)


def _checked(directory: Path, tables: Tables, fmt: str = "parquet") -> list[str]:
    """``check_plausible`` on the tables written as a log (Parquet unless said: the quicker)."""
    write_log(directory, tables, fmt)
    log = _without_checks_read(directory)
    return check_plausible(log, {t: directory / f"{t}.{fmt}" for t in tables})


def _refused(directory: Path, tables: Tables, table: str, *fragments: str, fmt: str = "parquet") -> str:
    """The LogError's message, after asserting that it names the table's file, every fragment,
    and a row whose value in the file is the value it quotes."""
    with pytest.raises(LogError) as info:
        _checked(directory, tables, fmt)
    message = str(info.value)
    assert message.startswith(f"{_file(directory, table, fmt)}: "), message
    assert len(message) <= MESSAGE_CHARS, message  # the CLI cuts a longer one
    for fragment in fragments:
        assert fragment in message, message
    quoted = re.search(r"column '(\w+)', row (\d+): (-?[0-9.]+(?:e[-+]?\d+)?)", message)
    assert quoted is not None, message
    column, row, value = quoted.group(1), int(quoted.group(2)), float(quoted.group(3))
    written = tables[table][column][row - 1]
    assert value == pytest.approx(written, rel=1e-5, abs=1e-12), message
    return message


def _file(directory: Path, table: str, fmt: str = "parquet") -> str:
    """A table's file as messages name it."""
    return show_path(str(directory / f"{table}.{fmt}"))


# --------------------------------------------------------------------------------------- valid logs
@pytest.mark.parametrize(
    "trajectory, earth",
    [("straight", "wgs84"), ("figure8", "wgs84"), ("lawnmower", "wgs84"), ("figure8", "flat")],
)
def test_a_simulated_log_passes_without_a_note(tmp_path: Path, trajectory: str, earth: str) -> None:
    assert _checked(tmp_path, _simulated(trajectory, earth)) == []


@pytest.mark.parametrize("as_rates", [False, True])
def test_the_figure_eight_in_csv_passes_without_a_note(
    tmp_path: Path, tables: Tables, as_rates: bool
) -> None:
    assert _checked(tmp_path, _as_rates(tables) if as_rates else tables, "csv") == []


# ------------------------------------------------------------------------------------------- clocks
@pytest.mark.parametrize("factor, unit", [(1e3, "milliseconds"), (1e6, "microseconds")])
def test_imu_times_in_milliseconds_or_microseconds_are_refused(
    tmp_path: Path, tables: Tables, factor: float, unit: str
) -> None:
    """As rates (the increments' own check, gravity over 10 s, would see a 1000-times-slow specific
    force first): the clock is named, not the accelerometer."""
    tables = _as_rates(tables)
    tables["imu"]["t_s"] = tables["imu"]["t_s"] * factor
    message = _refused(tmp_path, tables, "imu", "column 't_s', row 2:", f"times in {unit}?", fmt="csv")
    assert "accel" not in message


@pytest.mark.parametrize("table", ["dvl", "depth", "attitude", "reference"])
def test_a_table_whose_times_are_in_milliseconds_is_refused(
    tmp_path: Path, tables: Tables, table: str
) -> None:
    tables[table]["t_s"] = tables[table]["t_s"] * 1e3
    _refused(tmp_path, tables, table, "column 't_s', row", "outside the IMU's span", "times in milliseconds?")


def test_rows_beyond_the_imus_span_are_noted(tmp_path: Path, tables: Tables) -> None:
    dvl = tables["dvl"]
    late = dvl["t_s"][-1] + np.arange(1.0, 4.0)
    tables["dvl"] = {c: np.concatenate([v, late if c == "t_s" else v[-3:]]) for c, v in dvl.items()}
    notes = _checked(tmp_path, tables)
    assert len(notes) == 1 and notes[0].startswith(f"{_file(tmp_path, 'dvl')}: column 't_s': 3 of"), notes
    assert "left out" in notes[0]


# ------------------------------------------------------------------------------------------ the gyro
def test_a_gyro_in_deg_per_s_under_rps_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables = _as_rates(tables)
    for c in IMU_RATES[:3]:
        tables["imu"][c] = tables["imu"][c] / units.DEG
    message = _refused(tmp_path, tables, "imu", "in deg/s", "57.", fmt="csv")
    assert re.search(r"column 'gyro_[xyz]_rps'", message), message


def test_angle_increments_in_degrees_are_refused(tmp_path: Path, tables: Tables) -> None:
    for c in IMU_INCREMENTS[:3]:
        tables["imu"][c] = tables["imu"][c] / units.DEG
    message = _refused(tmp_path, tables, "imu", "(or degrees) under a radian name")
    assert re.search(r"column 'dtheta_[xyz]_rad'", message), message


def test_a_gyro_axis_with_its_sign_flipped_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables["imu"]["dtheta_z_rad"] = -tables["imu"]["dtheta_z_rad"]
    _refused(tmp_path, tables, "imu", "column 'dtheta_z_rad'", "sign is flipped")


def test_imu_axes_swapped_are_refused(tmp_path: Path, tables: Tables) -> None:
    imu = tables["imu"]
    for a, b in (("dtheta_x_rad", "dtheta_y_rad"), ("dv_x_mps", "dv_y_mps")):
        imu[a], imu[b] = imu[b], imu[a]
    _refused(tmp_path, tables, "imu", "dtheta_x_rad and dtheta_y_rad swapped")


def test_a_gyro_turning_faster_than_an_auv_is_refused_without_an_attitude_to_compare(
    tmp_path: Path, tables: Tables
) -> None:
    """No reference and an attitude table of two rows: nothing to compare the gyro with, but a
    figure eight's 7.6 deg/s read as rad/s is beyond any AUV."""
    del tables["reference"]
    tables["attitude"] = {c: v[:2] for c, v in tables["attitude"].items()}
    for c in IMU_INCREMENTS[:3]:
        tables["imu"][c] = tables["imu"][c] / units.DEG
    message = _refused(tmp_path, tables, "imu", "beyond the 3 rad/s an AUV turns")
    assert re.search(r"column 'dtheta_z_rad'", message), message


def test_too_few_attitude_rows_to_check_the_gyro_are_noted(tmp_path: Path, tables: Tables) -> None:
    del tables["reference"]
    tables["attitude"] = {c: v[:2] for c, v in tables["attitude"].items()}
    notes = _checked(tmp_path, tables)
    assert len(notes) == 1 and notes[0].startswith(f"{_file(tmp_path, 'attitude')}: roll/pitch/yaw"), notes
    assert "too few to check the gyro" in notes[0]


def test_a_log_without_reference_is_checked_against_its_attitude_table(
    tmp_path: Path, tables: Tables
) -> None:
    """The magnetometer's noisy attitude (1-6 deg every 2 s) hides the figure eight's slow roll and
    pitch (noted: not checked) but still tells a flipped yaw gyro."""
    del tables["reference"]
    notes = _checked(tmp_path, copy.deepcopy(tables))
    assert [n.split(": ")[1] for n in notes] == ["column 'dtheta_x_rad'", "column 'dtheta_y_rad'"], notes
    assert all("does not follow the attitude's rotation" in n for n in notes), notes
    tables["imu"]["dtheta_z_rad"] = -tables["imu"]["dtheta_z_rad"]
    _refused(tmp_path, tables, "imu", "column 'dtheta_z_rad'", "sign is flipped")


# ---------------------------------------------------------------------------------- accelerometer
def test_an_accelerometer_z_with_its_sign_flipped_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables["imu"]["dv_z_mps"] = -tables["imu"]["dv_z_mps"]
    with pytest.raises(LogError) as info:
        _checked(tmp_path, tables)
    message = str(info.value)
    assert message.startswith(f"{_file(tmp_path, 'imu')}: column 'dv_z_mps', rows 1-"), message
    assert "the specific force averages (" in message and "dv_z_mps has its sign flipped" in message, message


def test_an_accelerometer_x_with_its_sign_flipped_is_refused(tmp_path: Path, tables: Tables) -> None:
    """A level vehicle's gravity cannot show it; the figure eight's pitch and turns do."""
    tables["imu"]["dv_x_mps"] = -tables["imu"]["dv_x_mps"]
    _refused(tmp_path, tables, "imu", "column 'dv_x_mps'", "sign is flipped")


# ---------------------------------------------------------------------------------------- attitude
@pytest.mark.parametrize("table", ["reference", "attitude"])
def test_an_attitude_in_degrees_under_rad_is_refused(tmp_path: Path, tables: Tables, table: str) -> None:
    for c in ("roll_rad", "pitch_rad", "yaw_rad"):
        tables[table][c] = tables[table][c] / units.DEG
    message = _refused(tmp_path, tables, table, "in degrees under _rad?", fmt="csv")
    assert re.search(r"column '(roll|pitch)_rad', row 1: .* the range of a (roll|pitch)", message), message


def test_a_small_attitude_in_degrees_is_refused_against_the_gyro(tmp_path: Path) -> None:
    """The 6-DOF vehicle on the straight leg rolls and pitches by less than a degree: in degrees
    under _rad its angles stay within range, but they turn 57 times as fast as the gyro."""
    config = Config().replace("trajectory", name="straight", duration_s=DURATION_S, truth="dynamic")
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(SEED)))])
    reference = tables["reference"]
    for c in ("roll_rad", "pitch_rad", "yaw_rad"):
        reference[c] = reference[c] / units.DEG
    with pytest.raises(LogError) as info:
        _checked(tmp_path, tables)
    message = str(info.value)
    quoted = re.match(
        rf"{re.escape(_file(tmp_path, 'reference'))}: columns roll_rad, pitch_rad, yaw_rad, row (\d+): "
        r"(-?[0-9.e+-]+), ",
        message,
    )
    assert quoted is not None, message
    assert float(quoted.group(2)) == pytest.approx(reference["roll_rad"][int(quoted.group(1)) - 1], rel=1e-5)
    assert "times as fast as the gyro" in message and "in degrees under _rad?" in message, message


def test_an_unwrapped_yaw_in_radians_passes(tmp_path: Path, tables: Tables) -> None:
    tables["reference"]["yaw_rad"] = tables["reference"]["yaw_rad"] + 4 * np.pi
    assert _checked(tmp_path, tables) == []


# --------------------------------------------------------------------------------- velocity, depth
@pytest.mark.parametrize(
    "factor, looks", [(1.0 / units.KNOT, "in knots under _mps?"), (-1.0, "sign is flipped")]
)
def test_a_reference_velocity_in_knots_or_flipped_is_refused(
    tmp_path: Path, tables: Tables, factor: float, looks: str
) -> None:
    for c in ("vel_north_mps", "vel_east_mps", "vel_down_mps"):
        tables["reference"][c] = tables["reference"][c] * factor
    _refused(tmp_path, tables, "reference", "column 'vel_north_mps', row", looks)


def test_a_negative_reference_depth_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables["reference"]["depth_m"] = -tables["reference"]["depth_m"]
    _refused(tmp_path, tables, "reference", "column 'depth_m', row 1: -20 m", "altitude given as depth?")


def test_a_depth_table_of_the_opposite_sign_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables["depth"]["depth_m"] = -tables["depth"]["depth_m"]
    _refused(tmp_path, tables, "depth", "column 'depth_m', row 1:", "the reference is at", "sign is flipped")


def test_a_depth_table_off_the_reference_is_noted(tmp_path: Path, tables: Tables) -> None:
    tables["depth"]["depth_m"] = tables["depth"]["depth_m"] + 5.0
    notes = _checked(tmp_path, tables)
    assert len(notes) == 1 and notes[0].startswith(f"{_file(tmp_path, 'depth')}: column 'depth_m'"), notes
    offset = re.search(r"by ([-+][0-9.]+) m", notes[0])
    assert offset is not None and float(offset.group(1)) == pytest.approx(5.0, abs=0.1), notes


# --------------------------------------------------------------------------------------------- DVL
def test_dvl_beams_in_knots_are_refused(tmp_path: Path, tables: Tables) -> None:
    for k in range(1, 5):
        tables["dvl"][f"beam{k}_mps"] = tables["dvl"][f"beam{k}_mps"] / units.KNOT
    _refused(tmp_path, tables, "dvl", "column 'beam1_mps', row", "in knots under _mps?", fmt="csv")


def _as_body(tables: Tables) -> Tables:
    """The DVL as a body velocity: the least squares of its beams (all four return here)."""
    beams = np.column_stack([tables["dvl"][f"beam{k}_mps"] for k in range(1, 5)])
    assert np.isfinite(beams).all()
    vel = np.linalg.lstsq(DvlConfig().A_b, beams.T, rcond=None)[0].T
    tables["dvl"] = {
        "t_s": tables["dvl"]["t_s"],
        "vel_x_mps": vel[:, 0],
        "vel_y_mps": vel[:, 1],
        "vel_z_mps": vel[:, 2],
    }
    return tables


def test_a_dvl_body_velocity_passes_and_its_flipped_sign_is_refused(tmp_path: Path, tables: Tables) -> None:
    tables = _as_body(tables)
    assert _checked(tmp_path, copy.deepcopy(tables)) == []
    tables["dvl"]["vel_x_mps"] = -tables["dvl"]["vel_x_mps"]
    _refused(tmp_path, tables, "dvl", "column 'vel_x_mps', row", "sign is flipped")


# ---------------------------------------------------------------------------------------- real data
def _akit_module():
    spec = importlib.util.spec_from_file_location("akit_to_log", ROOT / "scripts" / "akit_to_log.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not (AKIT / "Trajectory1" / "IMU.csv").exists(), reason="A-KIT data not present")
def test_every_akit_segment_passes(tmp_path: Path) -> None:
    """The 13 converted segments (Parquet: the quicker to write and read): no error on any, and a
    note only on segment 11, whose DVL heave the reference does not follow closely (the notes'
    worst segment: gyro-only attitude 3 deg off over 400 s)."""
    akit = _akit_module()
    noted = {}
    for n in range(1, 14):
        out = tmp_path / f"akit{n}"
        akit.convert(AKIT / f"Trajectory{n}", out, "parquet")
        log = _without_checks_read(out)
        notes = check_plausible(log, {t: out / f"{t}.parquet" for t in ("imu", "dvl", "reference")})
        if notes:
            noted[n] = notes
    assert set(noted) <= {11}, noted
    for note in noted.get(11, []):
        assert note.startswith(
            f"{show_path(str(tmp_path / 'akit11' / 'dvl.parquet'))}: column 'vel_z_mps'"
        ), note
