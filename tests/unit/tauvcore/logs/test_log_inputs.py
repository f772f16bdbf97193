"""A log's cells and units that read well yet are wrong, each refused in one line naming the file,
the column, the row and the value: a cut-short IMU, a 'no echo' code or a written 'nan' where the
format's empty cell means no reading, attitude in radians under _deg, a gyro in deg/s on a log that
does not turn."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.cli import main


def _save(root: Path, name: str, trajectory: str) -> Path:
    assert main(["run", "--trajectory", trajectory, "--duration", "60", "--method", "ins",
                 "--save-log", str(root / name)]) == 0
    return root / name


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("logs")
    return {"figure8": _save(root, "figure8", "figure8"), "straight": _save(root, "straight", "straight")}


def _rows(path: Path) -> tuple[list[str], list[list[str]]]:
    lines = path.read_text().splitlines()
    return lines[0].split(","), [line.split(",") for line in lines[1:]]


def _write(path: Path, header: list[str], rows: list[list[str]]) -> None:
    path.write_text("\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n")


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # short relative names in the messages


def _copy(logs: dict[str, Path], which: str, tmp_path: Path) -> Path:
    shutil.copytree(logs[which], tmp_path / which)
    return Path(which)


def _refused(capsys, log: Path, *parts: str) -> str:
    code = main(["replay", str(log), "--method", "ins"])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tauv: error: "), err
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]


def test_an_imu_of_three_rows_is_blamed_on_the_imu(capsys, logs, tmp_path) -> None:
    """It was blamed on dvl.csv ("outside the IMU's span ... times in microseconds?")."""
    log = _copy(logs, "figure8", tmp_path)
    header, rows = _rows(log / "imu.csv")
    _write(log / "imu.csv", header, rows[:3])
    _refused(capsys, log, "imu.csv': 3 rows (", "at least 151 needed (1 s of IMU)")


@pytest.mark.parametrize("cell, shown", [("-1", "-1.0 is outside [-0.5, 12000] m"),
                                         ("N/A", "'N/A' is not a number"), ("nan", "'nan' is not a number")])
def test_an_echo_altitude_that_is_no_reading_is_refused(capsys, logs, tmp_path, cell, shown) -> None:
    log = _copy(logs, "figure8", tmp_path)
    header, rows = _rows(log / "echo.csv")
    rows[2][header.index("altitude_m")] = cell
    _write(log / "echo.csv", header, rows)
    _refused(capsys, log, "echo.csv': column 'altitude_m', row 3: ", shown)


def test_an_empty_echo_altitude_is_no_echo(capsys, logs, tmp_path) -> None:
    log = _copy(logs, "figure8", tmp_path)
    header, rows = _rows(log / "echo.csv")
    rows[2][header.index("altitude_m")] = ""
    _write(log / "echo.csv", header, rows)
    assert main(["replay", str(log), "--method", "ins"]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("cell", ["nan", "NaN"])
def test_a_water_track_mode_of_nan_is_refused(capsys, logs, tmp_path, cell) -> None:
    """The format allows 1, 0 or empty."""
    log = _copy(logs, "figure8", tmp_path)
    header, rows = _rows(log / "dvl.csv")
    header += [f"beam{k}_water_track" for k in range(1, 5)]
    rows = [row + ["0", "0", "0", ""] for row in rows]
    rows[3][header.index("beam2_water_track")] = cell
    _write(log / "dvl.csv", header, rows)
    _refused(capsys, log, "dvl.csv': column 'beam2_water_track', row 4: ", f"'{cell}' is not a number",
             "1, 0 or an empty cell")


@pytest.mark.parametrize("table", ["attitude.csv", "reference.csv"])
def test_attitude_in_radians_under_deg_is_refused(capsys, logs, tmp_path, table) -> None:
    """The attitude table's was accepted; the reference's was blamed on the gyro."""
    log = _copy(logs, "figure8", tmp_path)
    header, rows = _rows(log / table)
    header = [c.replace("_rad", "_deg") if c in ("roll_rad", "pitch_rad", "yaw_rad") else c for c in header]
    _write(log / table, header, rows)
    _refused(capsys, log, f"{table}': column 'roll_deg', row ", "the accelerometer's gravity tilts the vehicle",
             "radians under _deg? Name the columns _rad, or give degrees")


def test_a_gyro_in_deg_per_s_on_a_log_that_does_not_turn_is_refused(capsys, logs, tmp_path) -> None:
    """Three notes and exit 0 before (and LC then diverged): the earth's rate shows the unit."""
    log = _copy(logs, "straight", tmp_path)
    header, rows = _rows(log / "imu.csv")
    for axis in "xyz":
        j = header.index(f"dtheta_{axis}_rad")
        for row in rows:
            row[j] = repr(float(row[j]) * 180.0 / np.pi)
    _write(log / "imu.csv", header, rows)
    _refused(capsys, log, "imu.csv': column 'dtheta_", "times the earth's rate and the reference's turn",
             "in deg/s (or degrees) under a radian name?")


@pytest.mark.parametrize("which", ["figure8", "straight"])
def test_the_logs_as_written_replay(capsys, logs, which) -> None:
    assert main(["replay", str(logs[which]), "--method", "ins"]) == 0, capsys.readouterr().err
