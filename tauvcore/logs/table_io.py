"""Reading one table of a log: a CSV or Parquet file into float64 columns, with every problem one
:class:`~tauvcore.validation.LogError` naming the file and, where there is one, the column, the
row (data rows from 1, the header not included) and the value as the file has it.

A CSV table is parsed one block at a time and a Parquet table one column at a time, so reading
holds the arrays and a few blocks or one column of the file, never the whole table beside them
(:data:`MAX_LOG_BYTES`). What the columns must hold (their names, finite values within physical
bounds) is tauvcore.logs.columns'; what the tables make together is tauvcore.logs'.
"""

from __future__ import annotations

import errno
import os
import stat
import typing
from pathlib import Path

import numpy as np

from tauvcore.validation import LogError, one_line, show, show_path

if typing.TYPE_CHECKING:
    import pyarrow as pa

MAX_LOG_BYTES = 4 << 30
"""Largest table read [bytes] (4 GiB; ten hours at 1 kHz in CSV is about 1.5 GB), as a file and as
the float64 arrays it becomes (8 bytes a value). Reading a table holds those arrays and a few
blocks of the file (of CSV, :data:`_CSV_BLOCK_BYTES`; of Parquet, one column). A CSV of
full-precision numbers (about 22 bytes a value) becomes arrays of 0.4 times its size: a 216 MB
IMU table is read at a peak of 168 MB resident, 78 MB of it the arrays and 58 MB Python and
the libraries. So the cap costs at most 4 GiB of arrays (for a 4 GiB CSV of full-precision
numbers, about 1.6 GiB), and :func:`tauvcore.logs.read_log` holds about twice the IMU table's
arrays while it makes its increments."""
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


def table_path(directory: Path, table: str) -> Path | None:
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


def read_table(path: Path) -> dict[str, np.ndarray]:
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
    """A CSV table's columns (:func:`read_table`; ``size``: the file's bytes), block by block:
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
    """A Parquet table's columns (:func:`read_table`), one column read at a time."""
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


def written_nan(path: Path, column: str, values: np.ndarray) -> int | None:
    """The first data row (from 1) of a CSV table's ``column`` whose cell is not empty yet reads
    as no number (``nan``, ``NaN``, ``N/A``), or None: where an empty cell means "no reading", a
    cell that says something else is refused. ``values``: the column as read (NaN where empty or
    written so). A Parquet table (whose writers give an empty cell as NaN or null alike) and a
    table that is no file (a bag's) have no such row."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    nan = np.flatnonzero(np.isnan(values))
    if nan.size == 0 or path.suffix != ".csv" or not os.path.isfile(path):
        return None
    try:
        cells = pcsv.read_csv(
            path,
            read_options=pcsv.ReadOptions(use_threads=False, block_size=_CSV_BLOCK_BYTES),
            convert_options=pcsv.ConvertOptions(
                include_columns=[column], column_types={column: pa.binary()}, strings_can_be_null=False
            ),
        ).column(0)
    except (OSError, pa.ArrowException):
        return None
    if len(cells) != values.size:
        return None
    written = [bool((cells[int(k)].as_py() or b"").strip(b" \t")) for k in nan]
    return int(nan[written.index(True)]) + 1 if any(written) else None


def held(path: Path, column: str, row: int, value: float) -> str:
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
