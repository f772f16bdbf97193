"""The log reader's refusals (tauvcore.logs): every log that cannot be used is one LogError naming
the file, the column, the row (data rows from 1) and the value, never another exception or a
numpy warning; values beyond physics are refused as they are read; reading costs at most about
the table's size in memory."""

from __future__ import annotations

import errno
import os
import shutil
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.logs import LogError, find_logs, read_log
from tauvcore.logs.table_io import read_table
from tauvcore.logs.writer import simulation_tables, write_log

ROOT = Path(__file__).resolve().parents[4]


@pytest.fixture(scope="module")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A valid log (20 s of the figure eight on WGS-84, CSV): IMU increments, DVL beams, depth,
    attitude and a geodetic reference, angles in radians."""
    config = Config().replace("trajectory", name="figure8", duration_s=20.0).replace("earth", model="wgs84")
    sim = simulate(config, np.random.default_rng(3))
    directory = tmp_path_factory.mktemp("base")
    write_log(directory, simulation_tables([SimChunk.whole(sim)]), "csv")
    return directory


@pytest.fixture
def log(base: Path, tmp_path: Path) -> Path:
    """A copy of the base log to spoil."""
    return Path(shutil.copytree(base, tmp_path / "log"))


def _refusal(directory: Path) -> str:
    """The message of the one LogError read_log raises for ``directory`` (any other exception or
    a numpy RuntimeWarning fails the test); one line of at most about 400 characters."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(LogError) as err:
            read_log(directory)
    message = str(err.value)
    assert "\n" not in message and len(message) <= 480, message
    return message


def _assert_names(message: str, *parts: str) -> None:
    for part in parts:
        assert part in message, f"{part!r} not in {message!r}"


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def _set_cell(path: Path, row: int, column: str, text: str) -> None:
    """Data row ``row`` (from 1) of ``column`` in a CSV table written as ``text``."""
    lines = _lines(path)
    j = lines[0].split(",").index(column)
    cells = lines[row].split(",")
    cells[j] = text
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")


def _big_table(path: Path, rows: int, edit: tuple[int, str] | None = None) -> None:
    """A valid IMU table of ``rows`` rows at 100 Hz (several of the reader's 1 MiB blocks for
    20,000 rows); ``edit``: (data row, the line written there instead)."""
    header = "t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps"
    body = [f"{k / 100.0!r},1.2345678901234567e-05,-2.345678901234567e-05,3.4567890123456789e-05,"
            f"0.0012345678901234567,-0.0023456789012345678,-0.098066500000000001" for k in range(rows)]
    if edit is not None:
        body[edit[0] - 1] = edit[1]
    path.write_text(header + "\n" + "\n".join(body) + "\n", encoding="utf-8", errors="surrogateescape")


# ------------------------------------------------------------------------------------ structure
@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_duplicated_column_is_named_with_both_positions(log: Path, fmt: str) -> None:
    imu = log / "imu.csv"
    lines = _lines(imu)
    header = lines[0].split(",")
    j = header.index("dv_y_mps")
    lines = [f"{line},{line.split(',')[j]}" for line in lines]
    imu.write_text("\n".join(lines) + "\n")
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.csv as pcsv
        import pyarrow.parquet as pq

        names = header + ["dv_y_mps"]
        table = pcsv.read_csv(imu, read_options=pcsv.ReadOptions(skip_rows=1, column_names=[f"c{i}" for i in
                                                                                          range(len(names))]))
        pq.write_table(pa.Table.from_arrays(table.columns, names=names), log / "imu.parquet")
        imu.unlink()
    message = _refusal(log)
    _assert_names(message, f"imu.{fmt}", "'dv_y_mps'", f"columns {j + 1} and {len(header) + 1}")


@pytest.mark.parametrize("where", ["header", "cell"])
def test_a_byte_that_is_not_utf8_is_shown_escaped(log: Path, where: str) -> None:
    imu = log / "imu.csv"
    data = imu.read_bytes()
    if where == "header":
        head, rest = data.split(b"\n", 1)
        lines = [line + b",1.0" for line in rest.rstrip(b"\n").split(b"\n")]
        imu.write_bytes(head + b",temp_\xb0c\n" + b"\n".join(lines) + b"\n")
        expected = ["imu.csv", "header", f"column {head.count(b',') + 2}", "temp_\\xb0c", "must be UTF-8"]
    else:
        lines = data.split(b"\n")
        j = lines[0].split(b",").index(b"dv_x_mps")
        cells = lines[7].split(b",")
        cells[j] = cells[j][:4] + b"\xe9"
        lines[7] = b",".join(cells)
        imu.write_bytes(b"\n".join(lines))
        expected = ["imu.csv", "'dv_x_mps'", "row 7", "\\xe9", "must be UTF-8"]
    _assert_names(_refusal(log), *expected)


@pytest.mark.parametrize("edit, expected", [
    ("1_000", ["'dtheta_y_rad'", "row 15001", "'1_000'", "not a number"]),     # Python reads it, Arrow does not
    ("caf\udce9", ["'dtheta_y_rad'", "row 15001", "b'caf\\xe9'", "must be UTF-8"]),
    ("short", ["row 15001", "6 cells", "the header has 7"]),
    ("long", ["row 15001", "8 cells", "the header has 7"]),
])
def test_a_bad_cell_far_into_a_table_is_named_by_its_row(tmp_path: Path, edit: str, expected: list) -> None:
    """Rows counted across the reader's blocks: row 15,001 of 20,000 is in the third block."""
    good = "150.0,0.0,0.0,0.0,0.0,0.0,-0.0980665"
    line = {"short": good.rsplit(",", 1)[0], "long": good + ",0.0"}.get(edit, f"150.0,0.0,{edit},0.0,0.0,0.0,0.0")
    path = tmp_path / "imu.csv"
    _big_table(path, 20_000, (15_001, line))
    assert path.stat().st_size > 2 << 20
    with pytest.raises(LogError) as err:
        read_table(path)
    _assert_names(str(err.value), "imu.csv", *expected)


def test_what_a_missing_cell_holds_is_said(log: Path) -> None:
    """Empty, 'N/A', 'nan' and 'NaN' are four different things in the file: the message says which."""
    imu = log / "imu.csv"
    original = imu.read_text()
    for text, said in [("", "row 12: empty"), ("N/A", "row 12: 'N/A'"), ("nan", "row 12: 'nan'"),
                       ("NaN", "row 12: 'NaN'"), ("1e999", "row 12: '1e999'")]:
        imu.write_text(original)
        _set_cell(imu, 12, "dtheta_z_rad", text)
        _assert_names(_refusal(log), "imu.csv", "column 'dtheta_z_rad'", said)


def test_a_parquet_null_and_a_nan_are_told_apart(log: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    columns = read_table(log / "depth.csv")
    (log / "depth.csv").unlink()
    for value, said in [(None, "row 2: empty (null)"), (float("nan"), "row 2: NaN")]:
        depth: list[float | None] = [float(v) for v in columns["depth_m"]]
        depth[1] = value
        pq.write_table(pa.table({"t_s": columns["t_s"], "depth_m": pa.array(depth, pa.float64())}),
                       log / "depth.parquet")
        _assert_names(_refusal(log), "depth.parquet", "column 'depth_m'", said)


def test_dvl_beams_may_be_missing_but_not_infinite(log: Path) -> None:
    """Empty, NaN or N/A in a beam column: that beam did not return on that ping; a number
    beyond the float range is refused as the file writes it."""
    dvl = log / "dvl.csv"
    expected = read_log(log).dvl_beams_mps
    assert expected is not None
    for row, column, text in [(3, "beam2_mps", ""), (4, "beam3_mps", "nan"), (5, "beam1_mps", "N/A")]:
        _set_cell(dvl, row, column, text)
        expected[row - 1, int(column[4]) - 1] = np.nan
    beams = read_log(log).dvl_beams_mps
    assert beams is not None
    np.testing.assert_array_equal(beams, expected)          # NaN where not returned, the rest as it was
    _set_cell(dvl, 6, "beam4_mps", "1e999")
    _assert_names(_refusal(log), "dvl.csv", "column 'beam4_mps'", "row 6: '1e999'")


@pytest.mark.parametrize("table, column", [("reference", "roll_rad"), ("reference", "lat_rad"),
                                           ("attitude", "yaw_rad"), ("attitude", "pitch_deg")])
def test_an_angle_column_is_named_as_the_file_has_it(log: Path, table: str, column: str) -> None:
    path = log / f"{table}.csv"
    if column.endswith("_deg"):
        path.write_text(path.read_text().replace(column.replace("_deg", "_rad"), column, 1))
    _set_cell(path, 3, column, "")
    _assert_names(_refusal(log), f"{table}.csv", f"column {column!r}", "row 3: empty")


def test_an_angle_in_degrees_and_radians_at_once_is_refused(log: Path) -> None:
    att = log / "attitude.csv"
    lines = _lines(att)
    att.write_text("\n".join([lines[0] + ",roll_deg"] + [line + ",0.0" for line in lines[1:]]) + "\n")
    _assert_names(_refusal(log), "attitude.csv", "'roll_rad'", "'roll_deg'", "keep one")


@pytest.mark.parametrize("how", ["short", "long"])
def test_a_row_with_too_few_or_too_many_cells_is_named(log: Path, how: str) -> None:
    imu = log / "imu.csv"
    lines = _lines(imu)
    lines[12] = lines[12].rsplit(",", 1)[0] if how == "short" else lines[12] + ",0.5"
    imu.write_text("\n".join(lines) + "\n")
    found = 6 if how == "short" else 8
    _assert_names(_refusal(log), "imu.csv", "row 12", f"{found} cells where the header has 7")


@pytest.mark.parametrize("table", ["imu", "dvl"])
@pytest.mark.parametrize("kind, said", [("loop", "is a symbolic link loop"),
                                        ("dangling", "is a dangling symbolic link to 'moved.csv'"),
                                        ("directory", "is a directory, not a file")])
def test_a_table_that_is_not_a_file_says_what_it_is(log: Path, table: str, kind: str, said: str) -> None:
    """Not "no imu.csv"; and an optional table that is not a file is not silently left out."""
    path = log / f"{table}.csv"
    path.unlink()
    if kind == "loop":
        os.symlink(path.name, path)
    elif kind == "dangling":
        os.symlink("moved.csv", path)
    else:
        path.mkdir()
    _assert_names(_refusal(log), f"{table}.csv", said)


def test_find_logs_lists_a_log_whose_imu_table_is_not_a_file(base: Path, tmp_path: Path) -> None:
    """Choosing such a log gives read_log's message; a directory with no imu entry is no log."""
    for name in ("good", "imu_dir", "loop", "dangling"):
        shutil.copytree(base, tmp_path / name)
    (tmp_path / "imu_dir" / "imu.csv").unlink()
    (tmp_path / "imu_dir" / "imu.csv").mkdir()
    (tmp_path / "loop" / "imu.csv").unlink()
    os.symlink("imu.csv", tmp_path / "loop" / "imu.csv")
    (tmp_path / "dangling" / "imu.csv").unlink()
    os.symlink("gone.csv", tmp_path / "dangling" / "imu.csv")
    (tmp_path / "notes").mkdir()
    logs = find_logs(tmp_path)
    assert list(logs) == ["dangling", "good", "imu_dir", "loop"]
    assert "is a directory, not a file" in _refusal(Path(logs["imu_dir"]))


def test_find_logs_leaves_out_a_subdirectory_it_cannot_search(base: Path, tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """A subdirectory without search permission (simulated: the suite may run as root, who may
    search anything): its entries cannot be looked at; it is left out, the others listed."""
    shutil.copytree(base, tmp_path / "good")
    shutil.copytree(base, tmp_path / "locked")
    stat, lstat = os.stat, os.lstat

    def refused(real):
        def call(path, *args, **kwargs):
            if Path(os.fsdecode(path)).parent.name == "locked":
                raise PermissionError(errno.EACCES, "Permission denied", os.fsdecode(path))
            return real(path, *args, **kwargs)
        return call

    monkeypatch.setattr(os, "stat", refused(stat))
    monkeypatch.setattr(os, "lstat", refused(lstat))
    assert find_logs(tmp_path) == {"good": str(tmp_path / "good")}


# ---------------------------------------------------------------------------------------- cells
@pytest.mark.parametrize("table, column, row, text, bound", [
    ("reference", "lat_rad", 4, repr(95.11 * np.pi / 180.0), "no latitude"),
    ("reference", "lon_rad", 4, "3.5", "no longitude"),
    ("reference", "depth_m", 5, "-1e300", "outside [-100, 12000] m"),
    ("reference", "vel_east_mps", 6, "31.0", "beyond +-30 m/s"),
    ("reference", "yaw_rad", 6, "1e300", "no attitude angle"),
    ("imu", "dtheta_x_rad", 9, "1e300", "beyond +-1 rad"),
    ("imu", "dv_z_mps", 9, "-1e300", "beyond +-50 m/s"),
    ("imu", "t_s", 3001, "1e300", "more than any clock counts"),
    ("depth", "depth_m", 2, "13000.0", "outside [-100, 12000] m, deeper than the ocean"),
    ("dvl", "beam3_mps", 2, "1e300", "beyond +-30 m/s"),
    ("attitude", "roll_rad", 2, "-1e300", "no attitude angle"),
])
def test_a_value_beyond_physics_is_refused_as_it_is_read(log: Path, table: str, column: str, row: int,
                                                         text: str, bound: str) -> None:
    _set_cell(log / f"{table}.csv", row, column, text)
    _assert_names(_refusal(log), f"{table}.csv", f"column {column!r}", f"row {row}: {float(text)!r}", bound)


@pytest.mark.parametrize("column, text, bound", [("gyro_y_rps", "25.0", "beyond +-20 rad/s"),
                                                 ("accel_x_mps2", "1e300", "beyond +-500 m/s^2")])
def test_imu_rates_beyond_physics_are_refused(log: Path, column: str, text: str, bound: str) -> None:
    inc = read_table(log / "imu.csv")
    dt = float(np.median(np.diff(inc["t_s"])))
    rates = {"t_s": inc["t_s"]}
    for axis in "xyz":
        rates[f"gyro_{axis}_rps"] = inc[f"dtheta_{axis}_rad"] / dt
        rates[f"accel_{axis}_mps2"] = inc[f"dv_{axis}_mps"] / dt
    (log / "imu.csv").unlink()
    write_log(log, {"imu": rates})
    _set_cell(log / "imu.csv", 7, column, text)
    _assert_names(_refusal(log), "imu.csv", f"column {column!r}", f"row 7: {float(text)!r}", bound)


def test_a_dvl_body_velocity_beyond_physics_and_its_valid_column(log: Path) -> None:
    """``valid`` as 1/0, 1.0/0.0 or true/false in any case, mixed; another word is named; a
    body velocity of 40 m/s is refused."""
    t = read_table(log / "dvl.csv")["t_s"]
    words = ["1", "TRUE", "0.0", " false", "1.0", "True", "0"]
    rows = [f"{float(t[k])!r},1.0,0.0,0.1,{words[k % len(words)]}" for k in range(t.size)]
    dvl = log / "dvl.csv"
    dvl.write_text("t_s,vel_x_mps,vel_y_mps,vel_z_mps,valid\n" + "\n".join(rows) + "\n")
    valid = read_table(dvl)["valid"]
    np.testing.assert_array_equal(valid[:7], [1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0])
    _set_cell(dvl, 3, "vel_y_mps", "40.0")
    _assert_names(_refusal(log), "dvl.csv", "column 'vel_y_mps'", "row 3: 40.0", "beyond +-30 m/s")
    _set_cell(dvl, 3, "vel_y_mps", "0.0")
    _set_cell(dvl, 4, "valid", "yes")
    _assert_names(_refusal(log), "dvl.csv", "column 'valid'", "row 4: 'yes' is not 0, 1, true or false")


def test_an_imu_sampled_every_20_s_gives_no_numpy_warning(tmp_path: Path) -> None:
    """The gravity check's first 10 s hold no interval of such a log: it takes the first one."""
    t = np.arange(5) * 20.0
    zero = np.zeros_like(t)
    write_log(tmp_path, {"imu": {"t_s": t, "gyro_x_rps": zero, "gyro_y_rps": zero, "gyro_z_rps": zero,
                                 "accel_x_mps2": zero, "accel_y_mps2": zero, "accel_z_mps2": zero - 9.81},
                         "attitude": {"t_s": t, "roll_rad": zero, "pitch_rad": zero, "yaw_rad": zero}})
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            read_log(tmp_path)
        except LogError as exc:  # an IMU this slow may be refused, by name
            assert "imu.csv" in str(exc)


# --------------------------------------------------------------------------------------- memory
def test_reading_a_csv_table_costs_about_its_size_in_memory(tmp_path: Path) -> None:
    """A 43 MB IMU table read in a fresh process: the peak resident memory grows by less than
    1.5 times the file's size (0.8-1.1 times: the arrays, 0.4, and the reader's blocks; the
    whole Arrow table held beside the arrays cost 2.5 times)."""
    path = tmp_path / "imu.csv"
    _big_table(path, 300_000)
    size = path.stat().st_size
    assert size > 40e6
    _big_table(tmp_path / "small.csv", 10)
    script = textwrap.dedent(f"""
        from pathlib import Path
        from tauvcore.logs.table_io import read_table

        def peak():
            for line in open("/proc/self/status"):
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) * 1024

        read_table(Path({str(tmp_path / "small.csv")!r}))  # every module loaded
        before = peak()
        columns = read_table(Path({str(path)!r}))
        assert len(columns["t_s"]) == 300_000
        print(peak() - before)
    """)
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=ROOT,
                          check=False)
    assert proc.returncode == 0, proc.stderr
    growth = int(proc.stdout)
    assert growth < 1.5 * size, f"{growth / 1e6:.0f} MB of memory to read a {size / 1e6:.0f} MB table"
