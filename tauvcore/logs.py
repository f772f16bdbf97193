"""Recorded sensor logs: the format, a validating reader, and a writer for simulated missions.

A log is a directory with one table per sensor, each a CSV file (a header line, then one row
per sample) or a Parquet file, ``<table>.csv`` or ``<table>.parquet``. Every table has a time
column ``t_s`` [s] (one clock for all tables, strictly increasing). Units and frames are in the
column names, as everywhere in tauvcore (b: body forward-right-down; NED: north-east-down).

``imu`` (required), at a nominal constant rate (an irregular clock or holes of up to
:data:`MAX_GAP_STEPS` intervals are resampled onto a constant rate and noted), either

- increments over the interval ending at the row, ``dtheta_x_rad``, ``dtheta_y_rad``,
  ``dtheta_z_rad``, ``dv_x_mps``, ``dv_y_mps``, ``dv_z_mps`` (the first row's are not used), or
- rates at the row's time, ``gyro_x_rps``, ``gyro_y_rps``, ``gyro_z_rps``, ``accel_x_mps2``,
  ``accel_y_mps2``, ``accel_z_mps2`` (integrated over each interval by the trapezoid rule).

``dvl`` (optional), either the beam velocities ``beam1_mps`` .. ``beam4_mps`` along the
configured Janus beams (empty or NaN: the beam did not return), or a body-frame velocity
``vel_x_mps``, ``vel_y_mps``, ``vel_z_mps`` with an optional ``valid`` (1/0, or true/false),
which is projected onto the configured beams (``[dvl]`` of the configuration), so beams can be
dropped synthetically (``--beams``, ``--outage``) as on simulated data.

``depth`` (optional): ``depth_m``. ``attitude`` (optional, a magnetometer/AHRS attitude):
``roll``, ``pitch``, ``yaw`` each as ``_deg`` or ``_rad``.

``reference`` (optional: its first row is the filters' starting point, and errors are computed
against it; without it the filters start from the log's own sensors, see
tauvcore.eval.replay, and no error can be computed): position as ``lat`` and ``lon`` (``_deg`` or ``_rad``) with ``depth_m``, or as
``north_m``, ``east_m``, ``down_m`` from the sea-surface point above the mission origin
(``[earth] latitude_deg, longitude_deg``); attitude ``roll``, ``pitch``, ``yaw`` (``_deg`` or
``_rad``); NED velocity ``vel_north_mps``, ``vel_east_mps``, ``vel_down_mps``. It may be
sampled at any rate: it is interpolated to the IMU's times (linearly; attitude along the
shortest rotation). With a geodetic reference the mission origin is its first point.

Aiding epochs are taken at the IMU sample nearest in time; rows outside the IMU's time span are
left out. A CSV table is UTF-8 text, its header naming each column once; every cell is a number
(empty only where a table allows it: a DVL beam that did not return, a body velocity marked
invalid), within what the physics allows (a latitude within 90 deg, a DVL velocity within
:data:`MAX_SPEED_MPS`, ...: the bounds below). Every problem is reported as one
:class:`LogError` naming the file, the column and the row (data rows count from 1, the header
not included) and the value.
"""

from __future__ import annotations

import dataclasses
import errno
import os
import stat
import typing
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.aiding.source import AidingSource
from tauvcore.aiding.sources import SOURCES
from tauvcore.log_record import Log
from tauvcore.validation import LogError, one_line, show, show_path

if typing.TYPE_CHECKING:
    import pyarrow as pa

TABLES = ("imu", "dvl", "depth", "attitude", "reference")
"""The built-in tables; a plug-in source's is named after it (tauvcore.aiding.sources)."""
IMU_INCREMENTS = ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps")
IMU_RATES = ("gyro_x_rps", "gyro_y_rps", "gyro_z_rps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2")
DVL_BEAMS = ("beam1_mps", "beam2_mps", "beam3_mps", "beam4_mps")
DVL_BODY = ("vel_x_mps", "vel_y_mps", "vel_z_mps")
REF_VEL = ("vel_north_mps", "vel_east_mps", "vel_down_mps")
REF_LOCAL = ("north_m", "east_m", "down_m")
TIME_JITTER = 0.01
"""Largest relative departure of an IMU interval from the log's median interval (1 %) taken as
it is; beyond it (an irregular clock, dropped samples) the IMU is resampled onto a constant
rate (:func:`_resample`) and the reader says so in :attr:`Log.notes`."""
MAX_GAP_STEPS = 50
"""Longest hole in the IMU record the resampling bridges, in intervals of the log (0.5 s at
100 Hz); a longer one is refused: the INS would fly blind through it."""
GRAVITY_BAND_MPS2 = (5.0, 15.0)
"""Average specific-force magnitude an IMU log must show over its first 10 s (a vehicle at sea
feels gravity, 9.8 m/s^2): outside it the accelerometer columns are in other units (mg, mm/s^2,
g) or are not specific force."""
CONFIG_FILE = "log.toml"
"""The configuration a log carries with it, in its directory (the DVL's lever arm and geometry,
the sensors' tuning: partial TOML as for ``--config``). ``tauv replay`` and the dashboard lay
it under ``--config`` and the flags (or the dashboard's controls); the A-KIT converter writes one."""
MAX_LOG_BYTES = 4 << 30
"""Largest table read [bytes] (4 GiB; ten hours at 1 kHz in CSV is about 1.5 GB), as a file and as
the float64 arrays it becomes (8 bytes a value). Reading a table holds those arrays and a few
blocks of the file (of CSV, :data:`_CSV_BLOCK_BYTES`; of Parquet, one column). A CSV of
full-precision numbers (about 22 bytes a value) becomes arrays of 0.4 times its size: a 216 MB
IMU table is read at a peak of 168 MB resident, 78 MB of it the arrays and 58 MB Python and
the libraries. So the cap costs at most 4 GiB of arrays (for a 4 GiB CSV of full-precision
numbers, about 1.6 GiB), and :func:`read_log` holds about twice the IMU table's arrays while it
makes its increments."""
MAX_TIME_S = 1e20
"""Largest time stamp [s] (3e12 years): more than any clock counts, in seconds or in the
nanoseconds since 1970 (1.8e18) a time stamp in other units may be; beyond it the differences
between rows overflow."""
MAX_DTHETA_RAD = 1.0
"""Largest angle increment of one IMU sample [rad] (57 deg: 100 rad/s at 100 Hz, 10 rad/s at
10 Hz, beyond what a vehicle at sea turns); a larger one is in degrees or no measurement."""
MAX_DV_MPS = 50.0
"""Largest velocity increment of one IMU sample [m/s] (5 g over a 1 s sample, far more at a
usual rate); a larger one is in other units or no measurement."""
MAX_GYRO_RPS = 20.0
"""Largest angular rate [rad/s] (1150 deg/s, the range of a MEMS gyro beyond any vehicle at sea);
a larger one is in deg/s or no measurement."""
MAX_ACCEL_MPS2 = 500.0
"""Largest specific force [m/s^2] (50 g, the range of a wide-range MEMS accelerometer; a vehicle
at sea feels about 1 g); a larger one is in mg or mm/s^2, or no measurement."""
DEPTH_RANGE_M = (-100.0, 12_000.0)
"""Depths [m] a log may hold (positive down): the deepest ocean is 10,935 m (Challenger Deep);
up to 100 m above the surface allows for a vehicle on deck, a crane, a pressure sensor's offset."""
MAX_SPEED_MPS = 30.0
"""Largest velocity component [m/s] of a DVL beam, a DVL body velocity or the reference (58 kn:
more than the fastest torpedo; a survey vehicle moves at 1-3 m/s); a larger one is in other
units (mm/s, cm/s) or no measurement."""
MAX_LOCAL_M = 2.0e7
"""Largest north or east distance [m] of a local reference from the mission origin: half the
earth's circumference, as far as any point of the earth is."""
LATITUDE_MAX_DEG = 90.0
"""Largest latitude, north or south [deg] (the poles; pi/2 in ``lat_rad``)."""
LONGITUDE_MAX_DEG = 180.0
"""Largest longitude, east or west [deg] (pi in ``lon_rad``): -180 to 180, east positive."""
MAX_ANGLE_RAD = 1.0e4
"""Largest roll, pitch or yaw [rad] (1600 turns: an unwrapped heading over any mission stays well
within); a larger one is no angle (a time stamp, a sentinel such as 1e300), and beyond 1e15 rad
float64 cannot even hold its sine."""


def _bounds() -> dict[str, tuple[float, float, str, str]]:
    """Each column's physical bounds: (low, high, unit, what a value beyond them is, in words)."""
    speed = "faster than a vehicle under water moves"
    depth = (*DEPTH_RANGE_M, "m", "deeper than the ocean, or high above it")
    table: dict[str, tuple[float, float, str, str]] = {"depth_m": depth, "down_m": depth}
    for names, bound, unit, what in (
        (("t_s",), MAX_TIME_S, "s", "more than any clock counts"),
        (IMU_INCREMENTS[:3], MAX_DTHETA_RAD, "rad", "more than an IMU turns in one sample"),
        (IMU_INCREMENTS[3:], MAX_DV_MPS, "m/s", "more than an IMU's velocity changes in one sample"),
        (IMU_RATES[:3], MAX_GYRO_RPS, "rad/s", "faster than a vehicle at sea turns"),
        (IMU_RATES[3:], MAX_ACCEL_MPS2, "m/s^2", "more than a vehicle at sea feels"),
        (DVL_BEAMS + DVL_BODY + REF_VEL, MAX_SPEED_MPS, "m/s", speed),
        (REF_LOCAL[:2], MAX_LOCAL_M, "m", "farther than any point of the earth is"),
    ):
        table.update(dict.fromkeys(names, (-bound, bound, unit, what)))
    angles = [
        ("lat", LATITUDE_MAX_DEG, "no latitude (the poles are at 90 deg)"),
        ("lon", LONGITUDE_MAX_DEG, "no longitude (-180 to 180 deg, east positive; from 0-360: subtract 360)"),
    ] + [(n, MAX_ANGLE_RAD / units.DEG, "no attitude angle") for n in ("roll", "pitch", "yaw")]
    for name, bound_deg, what in angles:
        table[f"{name}_deg"] = (-bound_deg, bound_deg, "deg", what)
        table[f"{name}_rad"] = (-bound_deg * units.DEG, bound_deg * units.DEG, "rad", what)
    return table


_BOUNDS = _bounds()
"""Each column's physical bounds (low, high, unit, what a value beyond them is, in words), checked
as a table is read (:func:`_within`)."""


# ---------------------------------------------------------------------------------------- reading
_CSV_BLOCK_BYTES = 1 << 18
"""Bytes of a CSV table parsed at a time (256 KiB, about 2000 rows), and the longest line it may
have: pyarrow's reader holds some tens of blocks beside the arrays (with its default block,
1 MiB, reading a 43 MB table cost 50 MB more, and was no faster)."""


def _file_problem(path: Path) -> str | None:
    """Why the directory entry ``path`` is not a table that can be read, in words (a directory, a
    dangling symbolic link, a loop, a pipe); None for a regular file or a link to one."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        if os.path.islink(path):
            if exc.errno == errno.ELOOP:
                return "is a symbolic link loop"
            if exc.errno in (errno.ENOENT, errno.ENOTDIR):
                try:
                    return f"is a dangling symbolic link to {show_path(os.readlink(path))}"
                except OSError:
                    return "is a dangling symbolic link"
        if exc.errno == errno.ENOENT:
            return "does not exist"
        return f"cannot be opened: {exc.strerror or exc}"
    if stat.S_ISDIR(mode):
        return "is a directory, not a file"
    if not stat.S_ISREG(mode):
        return "is not a regular file (a pipe, a socket or a device)"
    return None


def _table_path(directory: Path, table: str) -> Path | None:
    """The file of ``table`` in ``directory`` (None: the log has no such table). Any entry of the
    name counts, so a directory, a dangling symbolic link or a loop named ``imu.csv`` is a
    LogError saying so, not a missing table; as are both a CSV and a Parquet file."""
    found = [p for p in (directory / f"{table}.csv", directory / f"{table}.parquet") if os.path.lexists(p)]
    if len(found) > 1:
        raise LogError(f"{show_path(str(directory))}: both {table}.csv and {table}.parquet; keep one")
    if not found:
        return None
    problem = _file_problem(found[0])
    if problem is not None:
        raise LogError(f"{show_path(str(found[0]))}: {problem}")
    return found[0]


def _read_table(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV or Parquet table as float64 arrays (K,), NaN where a cell is empty
    (``valid`` may also be true/false, or boolean in Parquet); LogError naming the file, and where
    there is one the column, row and value, for anything that cannot be read.

    A CSV table is parsed one block at a time (pyarrow's streaming reader, every column typed
    float64, ``valid`` as text) and a Parquet table read one column at a time, so reading holds
    the arrays and a few blocks or one column of the file, never the whole table beside them
    (:data:`MAX_LOG_BYTES`)."""
    name = show_path(str(path))
    problem = _file_problem(path)
    if problem is not None:
        raise LogError(f"{name}: {problem}")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise LogError(f"{name}: cannot be read: {exc.strerror or exc}") from None
    if size > MAX_LOG_BYTES:
        raise LogError(f"{name}: {size} bytes, more than the {MAX_LOG_BYTES >> 30} GiB a table may have")
    if path.suffix == ".parquet":
        return _read_parquet(path, name)
    return _read_csv(path, name, size)


def _unique(name: str, columns: list[str]) -> None:
    """LogError at the first column name the header holds twice, with both positions (from 1)."""
    first: dict[str, int] = {}
    for j, column in enumerate(columns):
        if column in first:
            raise LogError(
                f"{name}: header: columns {first[column] + 1} and {j + 1} are both named {show(column)}; "
                "keep one"
            )
        first[column] = j


def _check_size(name: str, rows: int, columns: int) -> None:
    """LogError once the arrays of ``rows`` rows would take more than :data:`MAX_LOG_BYTES`."""
    if rows * columns * 8 > MAX_LOG_BYTES:
        raise LogError(
            f"{name}: {rows} rows of {columns} columns and more, more than the {MAX_LOG_BYTES >> 30} GiB "
            "of numbers a table may hold"
        )


def _csv_header(path: Path, name: str) -> list[str]:
    """The column names of a CSV table, as pyarrow reads them from its first non-empty line; LogError
    if that line is missing, too long or not UTF-8 (with the cell's bytes escaped)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    try:
        with open(path, "rb") as fh:
            line = b""
            while not line.strip(b"\r\n"):  # pyarrow skips empty lines before the header too
                line = fh.readline(_CSV_BLOCK_BYTES + 1)
                if not line:
                    raise LogError(f"{name}: empty (a table is a header line, then one row per sample)")
                if len(line) > _CSV_BLOCK_BYTES:
                    raise LogError(f"{name}: header: more than {_CSV_BLOCK_BYTES} bytes in the first line")
    except OSError as exc:
        raise LogError(f"{name}: cannot be read: {exc.strerror or exc}") from None
    line = line.removeprefix(b"\xef\xbb\xbf")  # a byte-order mark: UTF-8 all the same
    try:
        line.decode("utf-8")
    except UnicodeDecodeError as exc:
        column = line[: exc.start].count(b",") + 1
        cell = line.split(b",")[column - 1].strip(b"\r\n")
        raise LogError(
            f"{name}: header, column {column}: {show(cell)} is not UTF-8 text (byte {line[exc.start]:#04x}); "
            "the file must be UTF-8"
        ) from None
    if not line.endswith(b"\n"):
        line += b"\n"
    try:
        header = pcsv.open_csv(pa.BufferReader(line), read_options=pcsv.ReadOptions(use_threads=False))
    except pa.ArrowException as exc:
        raise LogError(one_line(f"{name}: header: cannot be read as CSV: {exc}")) from None
    names = header.schema.names
    _unique(name, names)
    return names


def _numbers(column: str, text: pa.Array) -> np.ndarray:
    """CSV cells read as text (null where empty), converted as the reader converts them: a number
    (blanks around it ignored; pyarrow's rules, not Python's), NaN where empty, and in ``valid``
    also true or false in any case. ArrowInvalid at a cell that is none of these."""
    import pyarrow as pa

    known: dict[str, float] = {}  # a valid column holds a few distinct texts
    out = np.empty(len(text))
    for i, cell in enumerate(text.to_pylist()):
        if cell is None:
            out[i] = np.nan
            continue
        if cell not in known:
            word = cell.strip(" \t")
            if column == "valid" and word.lower() in ("true", "false"):
                known[cell] = float(word.lower() == "true")
            else:
                known[cell] = pa.scalar(word).cast(pa.float64()).as_py()
        out[i] = known[cell]
    return out


def _read_csv(path: Path, name: str, size: int) -> dict[str, np.ndarray]:
    """A CSV table's columns (:func:`_read_table`; ``size``: the file's bytes), block by block:
    each block's columns are converted to float64 and copied into the arrays, then the block is
    let go. The arrays are sized from the first block's rows per byte with room to spare (pages
    never written cost no memory) and cut to the rows read at the end."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    names = _csv_header(path, name)
    invalid: list = []  # the row pyarrow found with too few or too many cells

    def on_invalid(row: pcsv.InvalidRow) -> str:
        invalid.append(row)
        return "error"

    columns = {n: np.empty(0) for n in names}
    done = 0  # rows read so far: the row offset of the next block
    try:
        reader = pcsv.open_csv(
            path,
            read_options=pcsv.ReadOptions(use_threads=False, block_size=_CSV_BLOCK_BYTES),
            parse_options=pcsv.ParseOptions(invalid_row_handler=on_invalid),
            convert_options=pcsv.ConvertOptions(
                column_types={n: pa.string() if n == "valid" else pa.float64() for n in names},
                strings_can_be_null=True,
            ),
        )
        if reader.schema.names != names:
            raise LogError(f"{name}: header: read as {show(reader.schema.names)}, then as {show(names)}")
        for batch in reader:
            rows = batch.num_rows
            if done + rows > len(columns[names[0]]):
                room = max(done + rows, int(1.5 * rows * max(size / _CSV_BLOCK_BYTES, 1.0)), 3 * done // 2)
                columns = {n: _grown(a, done, room) for n, a in columns.items()}
            for j, column in enumerate(names):
                cells = batch.column(j)
                columns[column][done : done + rows] = (
                    _numbers(column, cells) if column == "valid" else cells.to_numpy(zero_copy_only=False)
                )
            done += rows
            _check_size(name, done, len(names))
    except pa.ArrowInvalid as exc:
        if invalid:
            row = invalid[0]
            where = f"row {row.number - 1}" if row.number is not None else f"a row after row {done}"
            raise LogError(
                f"{name}: {where}: {row.actual_columns} cells where the header has {row.expected_columns} "
                f"({show(row.text)})"
            ) from None
        if "straddl" in str(exc):  # a line longer than a block: no table row is
            raise LogError(
                f"{name}: row {done + 1} or one after it is longer than {_CSV_BLOCK_BYTES} bytes "
                "(a table's rows are a few hundred)"
            ) from None
        raise _bad_cell(path, name, names, done, exc) from None
    except (OSError, pa.ArrowException) as exc:
        raise LogError(one_line(f"{name}: cannot be read as a CSV table: {exc}")) from None
    for values in columns.values():
        values.resize(done, refcheck=False)  # in place: the room never written is let go
    pa.default_memory_pool().release_unused()  # the blocks' memory, back to the system
    return columns


def _grown(values: np.ndarray, done: int, room: int) -> np.ndarray:
    """``values``' first ``done`` rows in a new array of ``room`` rows."""
    out = np.empty(room)
    out[:done] = values[:done]
    return out


def _bad_cell(path: Path, name: str, names: list[str], start: int, exc: Exception) -> LogError:
    """The LogError for the first cell from data row ``start + 1`` on that the float64 reading
    refused (pyarrow's ``exc`` names neither the row nor, for a byte that is not UTF-8, the value):
    the rows read again as bytes and each column converted as :func:`_read_csv` converts it."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    row = 0
    try:
        reader = pcsv.open_csv(
            path,
            read_options=pcsv.ReadOptions(use_threads=False, block_size=_CSV_BLOCK_BYTES),
            convert_options=pcsv.ConvertOptions(
                column_types={n: pa.binary() for n in names}, strings_can_be_null=True
            ),
        )
        for batch in reader:
            skip = min(max(start - row, 0), batch.num_rows)
            found: tuple[int, int] | None = None  # (index in the block, column index)
            for j, column in enumerate(names):
                i = _first_bad(column, batch.column(j).slice(skip))
                if i is not None and (found is None or skip + i < found[0]):
                    found = (skip + i, j)
            if found is not None:
                i, j = found
                cell = batch.column(j)[i].as_py()
                return LogError(
                    f"{name}: column {show(names[j])}, row {row + i + 1}: {_not_a_number(names[j], cell)}"
                )
            row += batch.num_rows
    except (OSError, pa.ArrowException):
        pass
    return LogError(one_line(f"{name}: cannot be read as a CSV table after row {start}: {exc}"))


def _first_bad(column: str, cells: pa.Array) -> int | None:
    """Index of the first of ``cells`` (bytes) that is not UTF-8 or does not convert
    (:func:`_numbers`), by bisection; None if all do."""
    import pyarrow as pa

    def converts(part: pa.Array) -> bool:
        try:
            _numbers(column, part.cast(pa.string()))
        except pa.ArrowException:
            return False
        return True

    if converts(cells):
        return None
    lo, hi = 0, len(cells)  # every cell before lo converts; one in [lo, hi) does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if converts(cells.slice(lo, mid - lo)):
            lo = mid
        else:
            hi = mid
    return lo


def _not_a_number(column: str, cell: bytes) -> str:
    """Why a CSV cell is refused, in words, its value quoted (bytes escaped if not UTF-8)."""
    try:
        text = cell.decode("utf-8")
    except UnicodeDecodeError as exc:
        return f"{show(cell)} is not UTF-8 text (byte {cell[exc.start]:#04x}); the file must be UTF-8"
    if column == "valid":
        return f"{show(text)} is not 0, 1, true or false"
    return f"{show(text)} is not a number (a number is digits with an optional sign, point and exponent: -1.5e-3)"


def _read_parquet(path: Path, name: str) -> dict[str, np.ndarray]:
    """A Parquet table's columns (:func:`_read_table`), one column read at a time."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        with pq.ParquetFile(path) as table:
            names = table.schema_arrow.names
            _unique(name, names)
            _check_size(name, table.metadata.num_rows, len(names))
            columns = {
                n: _parquet_numbers(name, n, table.read(columns=[n], use_threads=False).column(0))
                for n in names
            }
    except (OSError, pa.ArrowException) as exc:
        raise LogError(one_line(f"{name}: cannot be read as a Parquet table: {exc}")) from None
    pa.default_memory_pool().release_unused()  # the columns' Arrow memory, back to the system
    return columns


def _parquet_numbers(name: str, column: str, values: pa.ChunkedArray) -> np.ndarray:
    """A Parquet column as float64, NaN where null; LogError at the first value of a column that
    holds anything but numbers or booleans (text, times, lists)."""
    import pyarrow as pa

    kind = values.type
    if pa.types.is_dictionary(kind):
        kind = kind.value_type
        values = values.cast(kind)
    if (
        pa.types.is_integer(kind)
        or pa.types.is_floating(kind)
        or pa.types.is_boolean(kind)
        or pa.types.is_decimal(kind)
        or pa.types.is_null(kind)
    ):
        return values.cast(pa.float64(), safe=False).to_numpy()
    present = values.is_valid().to_numpy(zero_copy_only=False)
    if not present.any():
        return np.full(len(values), np.nan)
    row = int(np.argmax(present))
    raise LogError(
        f"{name}: column {show(column)}, row {row + 1}: {show(values[row].as_py())} is not a number "
        f"(the column holds {kind}; a Parquet table holds its numbers as numbers)"
    )


def _held(path: Path, column: str, row: int, value: float) -> str:
    """What ``column`` holds at data row ``row`` (from 1), for a message: ``empty`` or the cell's
    text quoted as the file has it (``'N/A'``, ``'NaN'``, ``'1e999'``), read again from the
    file; from ``value`` if that fails."""
    import pyarrow as pa

    try:
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            with pq.ParquetFile(path) as table:
                cell = table.read(columns=[column], use_threads=False).column(0)[row - 1]
            if not cell.is_valid:
                return "empty (null)"
        else:
            import pyarrow.csv as pcsv

            reader = pcsv.open_csv(
                path,
                read_options=pcsv.ReadOptions(use_threads=False, block_size=_CSV_BLOCK_BYTES),
                convert_options=pcsv.ConvertOptions(
                    include_columns=[column], column_types={column: pa.binary()}
                ),
            )
            seen = 0
            for batch in reader:
                if row <= seen + batch.num_rows:
                    text = batch.column(0)[row - 1 - seen].as_py().decode("utf-8", "backslashreplace")
                    return show(text.strip(" \t")) if text.strip(" \t") else "empty"
                seen += batch.num_rows
    except (OSError, pa.ArrowException, IndexError):
        pass
    if np.isnan(value):
        return "NaN"
    return show(float(value))


def _need(path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str) -> np.ndarray:
    missing = [n for n in names if n not in columns]
    if missing:
        raise LogError(
            f"{show_path(str(path))}: missing column {show(missing[0])} ({what}: {', '.join(names)})"
        )
    return np.stack([columns[n] for n in names], axis=-1)


def _angles(
    path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Angle columns, each as ``<name>_deg`` or ``<name>_rad`` (not both), every value finite and
    within its bound: the angles (K, len(names)) in radians, and the columns' names as the file
    has them."""
    out, found = [], []
    for n in names:
        have = [f"{n}_{u}" for u in ("rad", "deg") if f"{n}_{u}" in columns]
        if not have:
            raise LogError(
                f"{show_path(str(path))}: missing column {show(n + '_deg')} or {show(n + '_rad')} ({what})"
            )
        if len(have) > 1:
            raise LogError(
                f"{show_path(str(path))}: both columns {show(have[0])} and {show(have[1])}; keep one"
            )
        _finite(path, columns, (have[0],))
        _within(path, columns, (have[0],))
        out.append(columns[have[0]] * (1.0 if have[0].endswith("_rad") else units.DEG))
        found.append(have[0])
    return np.stack(out, axis=-1), tuple(found)


def _finite(
    path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], allow_nan: bool = False
) -> None:
    """Every value of ``names`` finite (or NaN, an empty cell, where allowed): LogError at the
    first offender by row and column, saying what the cell holds."""
    for n in names:
        if n not in columns:
            continue
        v = columns[n]
        bad = np.isinf(v) if allow_nan else ~np.isfinite(v)
        if bad.any():
            row = int(np.argmax(bad)) + 1
            need = "a finite number or nothing" if allow_nan else "a finite number"
            raise LogError(
                f"{show_path(str(path))}: column {show(n)}, row {row}: {_held(path, n, row, float(v[row - 1]))}; "
                f"{need} is needed here"
            )


def _within(
    path: Path,
    columns: dict[str, np.ndarray],
    names: tuple[str, ...],
    bounds: dict[str, tuple[float, float, str, str]] = _BOUNDS,
) -> None:
    """Every value of ``names`` within its physical bound (:data:`_BOUNDS`, or ``bounds``; NaN
    passes, :func:`_finite` judges it): LogError at the first that is not, with the bound in words."""
    for n in names:
        if n not in columns:
            continue
        low, high, unit, what = bounds[n]
        v = columns[n]
        bad = (v < low) | (v > high)
        if bad.any():
            row = int(np.argmax(bad)) + 1
            span = f"beyond +-{high:g} {unit}" if low == -high else f"outside [{low:g}, {high:g}] {unit}"
            raise LogError(
                f"{show_path(str(path))}: column {show(n)}, row {row}: {show(float(v[row - 1]))} is {span}, {what}"
            )


def _times(path: Path, columns: dict[str, np.ndarray]) -> np.ndarray:
    if "t_s" not in columns:
        raise LogError(f"{show_path(str(path))}: missing column 't_s' (time [s])")
    _finite(path, columns, ("t_s",))
    _within(path, columns, ("t_s",))
    t = columns["t_s"]
    if t.size == 0:
        raise LogError(f"{show_path(str(path))}: no rows")
    step = np.diff(t)
    if (step <= 0).any():
        row = int(np.argmax(step <= 0)) + 2
        kind = "repeats" if step[row - 2] == 0 else "goes back from"
        raise LogError(
            f"{show_path(str(path))}: column 't_s', row {row}: {float(t[row - 1])!r} {kind} the row before "
            f"({float(t[row - 2])!r}); times must increase strictly (sort the log, drop duplicates)"
        )
    return t


def _resample(
    t: np.ndarray, dtheta: np.ndarray, dv: np.ndarray, dt: float, off: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """The IMU on the constant grid ``t_0 + k dt`` up to the last sample: the cumulative angle and
    velocity increments (the integrals the IMU measured) interpolated linearly in time and
    differenced, so every interval of the grid gets the average rate of the log's interval(s) it
    overlaps and nothing measured is lost or counted twice. Returns the grid, its increments
    (row 0 zero) and a note on what was done."""
    steps = np.diff(t)
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1) * dt
    total = np.cumsum(np.concatenate([dtheta, dv], axis=1), axis=0)
    moved = np.column_stack([np.interp(grid, t, total[:, i]) for i in range(6)])
    inc = np.concatenate([np.zeros((1, 6)), np.diff(moved, axis=0)])
    worst = int(np.argmax(np.abs(steps - dt)))
    note = (
        f"{int(off.sum())} of {steps.size} intervals differ from {dt:.6g} s by more than {TIME_JITTER:.0%} "
        f"(row {worst + 2}: {steps[worst]:.6g} s); resampled to a constant {1.0 / dt:.6g} Hz, "
        f"{grid.size} samples"
    )
    return grid, inc[:, :3], inc[:, 3:], note


def read_log(directory: str | os.PathLike) -> Log:
    """Read and check the log in ``directory`` (module docstring), then its physical plausibility
    (tauvcore.log_checks: its notes join :attr:`Log.notes`). LogError on any problem."""
    root = Path(directory)
    if not root.is_dir():
        raise LogError(f"{show_path(str(root))}: not a directory (a log is a directory of sensor tables)")
    paths = {t: _table_path(root, t) for t in TABLES}
    if paths["imu"] is None:
        raise LogError(f"{show_path(str(root))}: no imu.csv or imu.parquet{raw_layout_hint(root)}")
    if paths["reference"] is None and paths["attitude"] is None:
        raise LogError(
            f"{show_path(str(root))}: no reference.csv or attitude.csv (or .parquet): the filters need a "
            "starting attitude, from a reference or from an attitude sensor"
        )
    imu_path = paths["imu"]
    imu = _read_table(imu_path)
    t = _times(imu_path, imu)
    if t.size < 3:
        raise LogError(f"{show_path(str(imu_path))}: {t.size} rows; an IMU log needs at least 3")
    from tauvcore import log_checks

    log_checks.check_imu_clock(t, imu_path)  # a clock in ms also spoils the gravity check below
    dt = np.diff(t)
    median = float(np.median(dt))
    gap = dt > MAX_GAP_STEPS * median
    if gap.any():
        row = int(np.argmax(dt)) + 2
        raise LogError(
            f"{show_path(str(imu_path))}: column 't_s', row {row}: {float(t[row - 1])!r} is {dt[row - 2]:.6g} s "
            f"after the row before, a gap of more than {MAX_GAP_STEPS} of the log's {median:.6g} s "
            "intervals: no inertial record bridges it (cut the log there)"
        )
    if all(n in imu for n in IMU_INCREMENTS):
        _finite(imu_path, imu, IMU_INCREMENTS)
        _within(imu_path, imu, IMU_INCREMENTS)
        dtheta = _need(imu_path, imu, IMU_INCREMENTS[:3], "increments")
        dv = _need(imu_path, imu, IMU_INCREMENTS[3:], "increments")
        accel_columns = IMU_INCREMENTS[3:]
    elif all(n in imu for n in IMU_RATES):
        _finite(imu_path, imu, IMU_RATES)
        _within(imu_path, imu, IMU_RATES)
        gyro = _need(imu_path, imu, IMU_RATES[:3], "rates")
        dtheta = np.concatenate([np.zeros((1, 3)), 0.5 * (gyro[1:] + gyro[:-1]) * dt[:, None]])
        del gyro
        accel = _need(imu_path, imu, IMU_RATES[3:], "rates")
        dv = np.concatenate([np.zeros((1, 3)), 0.5 * (accel[1:] + accel[:-1]) * dt[:, None]])
        del accel
        accel_columns = IMU_RATES[3:]
    else:
        missing = next(n for n in IMU_INCREMENTS if n not in imu)
        raise LogError(
            f"{show_path(str(imu_path))}: missing column {show(missing)} (the IMU as increments: "
            f"{', '.join(IMU_INCREMENTS)}; or as rates: {', '.join(IMU_RATES)})"
        )
    del imu  # its columns are t, dtheta and dv now
    dtheta[0] = 0.0
    dv[0] = 0.0
    notes: list[str] = []
    off = np.abs(dt - median) > TIME_JITTER * median
    if off.any():
        # the rate: the mean of the ordinary intervals (jitter cancels in their sum; the median of
        # jittered intervals is off by a fraction of the jitter)
        ordinary = np.abs(dt - median) < 0.5 * median
        t, dtheta, dv, note = _resample(t, dtheta, dv, float(np.mean(dt[ordinary])), off)
        notes.append(f"{imu_path.name}: {note}")
        dt = np.diff(t)
    f_mag = np.linalg.norm(dv[1:], axis=1) / dt
    first = t[1:] <= max(t[0] + 10.0, t[1])  # the first 10 s, at least one interval
    mean_f = float(np.mean(f_mag[first]))
    if not GRAVITY_BAND_MPS2[0] <= mean_f <= GRAVITY_BAND_MPS2[1]:
        raise LogError(
            f"{show_path(str(imu_path))}: columns {', '.join(accel_columns)}: the specific force averages "
            f"{mean_f:.6g} m/s^2 over the first 10 s, not gravity's 9.8 (in mg, g or mm/s^2? "
            "the columns must be SI, m/s^2 or m/s)"
        )

    out: dict = {"source": str(root), "imu_t_s": t, "dtheta_b": dtheta, "dv_b": dv, "notes": tuple(notes)}
    if paths["reference"] is not None:
        out.update(_read_reference(paths["reference"], t, median))
    _read_aiding(paths, out)
    out["sources"] = {
        name: _read_source(path, SOURCES[name])
        for name in SOURCES
        if (path := _table_path(root, name)) is not None
    }
    log = Log(**out)
    from tauvcore import log_checks  # cross-table plausibility (time and sensor units, signs)

    return dataclasses.replace(
        log,
        notes=log.notes
        + tuple(log_checks.check_plausible(log, {t: p for t, p in paths.items() if p is not None})),
    )


def _read_reference(ref_path: Path, t: np.ndarray, median: float) -> dict:
    ref = _read_table(ref_path)
    ref_t = _times(ref_path, ref)
    if any(f"lat_{u}" in ref for u in ("deg", "rad")):
        lat_lon, _ = _angles(ref_path, ref, ("lat", "lon"), "geodetic position")
        depth = _need(ref_path, ref, ("depth_m",), "geodetic position: lat, lon and depth_m")
        _finite(ref_path, ref, ("depth_m",))
        _within(ref_path, ref, ("depth_m",))
        position, geodetic = np.column_stack([lat_lon, depth]), True
    elif all(n in ref for n in REF_LOCAL):
        _finite(ref_path, ref, REF_LOCAL)
        _within(ref_path, ref, REF_LOCAL)
        position, geodetic = _need(ref_path, ref, REF_LOCAL, "local position"), False
    else:
        raise LogError(
            f"{show_path(str(ref_path))}: missing column 'lat_deg' or 'north_m' (the reference position: "
            "lat, lon (_deg or _rad) and depth_m; or north_m, east_m, down_m)"
        )
    euler, _ = _angles(ref_path, ref, ("roll", "pitch", "yaw"), "the reference attitude")
    vel = _need(ref_path, ref, REF_VEL, "the reference NED velocity")
    _finite(ref_path, ref, REF_VEL)
    _within(ref_path, ref, REF_VEL)
    if ref_t[0] > t[0] + 0.5 * median or ref_t[-1] < t[0]:
        raise LogError(
            f"{show_path(str(ref_path))}: column 't_s', row 1: the reference starts at {float(ref_t[0])!r} s, "
            f"after the IMU's first sample ({float(t[0])!r} s): the filters start from the reference"
        )

    return {
        "ref_t_s": ref_t,
        "ref_position": position,
        "ref_geodetic": geodetic,
        "ref_euler": euler,
        "ref_vel_n": vel,
    }


def _read_aiding(paths: dict[str, Path | None], out: dict) -> None:
    """The optional aiding tables into ``out``."""
    if paths["dvl"] is not None:
        p = paths["dvl"]
        cols = _read_table(p)
        out["dvl_t_s"] = _times(p, cols)
        beams = [n in cols for n in DVL_BEAMS]
        if all(beams) or (any(beams) and not all(n in cols for n in DVL_BODY)):  # the missing one named
            _finite(p, cols, DVL_BEAMS, allow_nan=True)
            _within(p, cols, DVL_BEAMS)
            out["dvl_beams_mps"] = _need(p, cols, DVL_BEAMS, "beam velocities")
        else:
            body = _need(p, cols, DVL_BODY, "a body velocity (or beam1_mps .. beam4_mps)")
            _finite(p, cols, DVL_BODY, allow_nan=True)
            _within(p, cols, DVL_BODY)
            valid = cols.get("valid", np.ones(body.shape[0]))
            _finite(p, cols, ("valid",))
            bad = ~np.isin(valid, (0.0, 1.0))
            if bad.any():
                row = int(np.argmax(bad))
                raise LogError(
                    f"{show_path(str(p))}: column 'valid', row {row + 1}: {show(float(valid[row]))} is not 0 or 1"
                )
            body = body.copy()
            body[valid == 0.0] = np.nan
            partial = np.isnan(body).any(axis=1) & ~np.isnan(body).all(axis=1)
            if partial.any():
                row = int(np.argmax(partial))
                column = DVL_BODY[int(np.argmax(np.isnan(body[row])))]
                raise LogError(
                    f"{show_path(str(p))}: column {show(column)}, row {row + 1}: "
                    f"{_held(p, column, row + 1, float(body[row, DVL_BODY.index(column)]))} where the row's "
                    "other components are numbers (a body velocity is all three or none: leave all three "
                    "empty, or set valid = 0)"
                )
            out["dvl_body_mps"] = body
    if paths["depth"] is not None:
        p = paths["depth"]
        cols = _read_table(p)
        out["depth_t_s"] = _times(p, cols)
        depth = _need(p, cols, ("depth_m",), "depth")[:, 0]
        _finite(p, cols, ("depth_m",))
        _within(p, cols, ("depth_m",))
        out["depth_m"] = depth
    if paths["attitude"] is not None:
        p = paths["attitude"]
        cols = _read_table(p)
        out["attitude_t_s"] = _times(p, cols)
        out["attitude_euler"], _ = _angles(p, cols, ("roll", "pitch", "yaw"), "attitude")


def _read_source(path: Path, source: AidingSource) -> dict[str, np.ndarray]:
    """A plug-in source's table (``t_s`` and :attr:`~tauvcore.aiding.source.AidingSource.columns`),
    each column finite (or empty where the source allows it) and within its bounds."""
    cols = _read_table(path)
    out = {"t_s": _times(path, cols)}
    names = tuple(c.name for c in source.columns)
    _need(path, cols, names, f"the {source.name} table: {source.summary}")
    for column in source.columns:
        _finite(path, cols, (column.name,), allow_nan=column.allow_nan)
        bounds = {column.name: (column.low, column.high, column.unit, column.what)}
        _within(path, cols, (column.name,), bounds)
        out[column.name] = cols[column.name]
    return out


def _has_imu(directory: Path) -> bool:
    """Whether ``directory`` has an entry named ``imu.csv`` or ``imu.parquet`` (of any kind: a
    file, a directory, a dangling link); False if it cannot be searched."""
    return any(os.path.lexists(directory / f"imu.{ext}") for ext in ("csv", "parquet"))


def find_logs(directory: str | os.PathLike) -> dict[str, str]:
    """The logs in ``directory`` by name: the directory itself if it is one (it has an ``imu``
    table), and each of its subdirectories that is; sorted by name. Only the ``imu`` entry's
    presence is checked here: one that is a directory, a dangling link or a loop counts, so that
    choosing the log gives :func:`read_log`'s message; a subdirectory that cannot be searched is
    left out. OSError if ``directory`` itself cannot be listed."""
    root = Path(directory)
    subdirectories = []
    for entry in root.iterdir():
        try:
            if entry.is_dir() and not entry.name.startswith("."):  # a writer's hidden temporary is no log
                subdirectories.append(entry)
        except OSError:  # an entry that cannot be looked at is no log to offer
            continue
    found = {}
    for candidate in [root, *sorted(subdirectories)]:
        if _has_imu(candidate):
            found[candidate.name or str(candidate)] = str(candidate)
    return found


RAW_LAYOUTS = {
    "an A-KIT segment (Snapir AUV)": (
        ("IMU.csv", "DVL.csv", "GT.csv"),
        "python scripts/akit_to_log.py DIR OUT",
    ),
}
"""Vendors' own layouts a log directory may be mistaken for: what they are -> (their files, the
converter that writes them as a log)."""


def raw_layout_hint(directory: str | os.PathLike) -> str:
    """``"; it looks like ... convert it first: ..."`` when ``directory`` holds a vendor's raw
    layout (:data:`RAW_LAYOUTS`), else ``""``: the end of a "no imu table" message."""
    root = Path(directory)
    for what, (files, converter) in RAW_LAYOUTS.items():
        try:
            if all((root / name).is_file() for name in files):
                return (
                    f"; it holds {', '.join(files)}, {what}: convert it to a log first with "
                    f"`{converter}`, then replay OUT"
                )
        except OSError:
            continue
    return ""


__all__ = [
    "CONFIG_FILE",
    "TABLES",
    "Log",
    "LogError",
    "find_logs",
    "raw_layout_hint",
    "read_log",
]
