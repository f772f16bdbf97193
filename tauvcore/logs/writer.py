"""Writing a log in the format tauvcore.logs reads: a simulation's tables, written all or
nothing (every file complete in a hidden temporary directory, then moved into place), whole
(:func:`write_log`) or appended chunk by chunk as a simulation goes (:class:`LogWriter`: memory
flat in the mission's length, the same files)."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from tauvcore.aiding.sources import SOURCES
from tauvcore.logs.columns import IMU_INCREMENTS, REF_LOCAL, REF_VEL
from tauvcore.logs.reader import CONFIG_FILE, SOURCE_TABLES, TABLES
from tauvcore.validation import OutputDirError, show_path

WRITER_ENTRY_PREFIXES = (".tauv-", ".tauv.")
"""Names a writer gives its own entries in an output directory while it writes (its hidden temporary
directory, its lock file): a directory holding nothing else is empty to :func:`output_dir` (a
writer killed mid-write leaves them; a writer at work is refused by its lock instead)."""


@dataclass(frozen=True)
class OutputKind:
    """What a writer leaves in its directory, for :func:`output_dir` to recognise an earlier
    output of the same kind: its name in messages (``"tauv mc study"``), the files only it writes
    (every one there, none else, for an earlier one to be taken as its) and the flag that allows
    replacing it (None: an earlier one is always refused)."""

    name: str
    files: frozenset[str]
    required: frozenset[str]
    replace_flag: str | None = None

    def holds(self, entries: set[str]) -> bool:
        """Whether a directory with ``entries`` holds this kind's output: every file it must hold, and
        none it does not write.

        Parameters
        ----------
        entries : set of str
            The names in the directory, a writer's own (lock file, temporary folders) left out.

        Returns
        -------
        bool
            True for a non-empty set within this kind's files holding every required one.
        """
        return bool(entries) and self.required <= entries <= self.files


@dataclass(frozen=True)
class OutputDir:
    """A writer's directory as :func:`output_dir` found it."""

    path: str  # its real path (symbolic links resolved)
    exists: bool  # False: a new name in an existing directory, created by the writer
    replaces: str | None  # the earlier output of the same kind it holds, to be replaced (what it is)


def output_dir(
    path: str,
    label: str,
    kind: OutputKind | None = None,
    replace: bool = False,
    inputs: Sequence[tuple[str, str | None]] = (),
) -> OutputDir:
    """Check the directory a writer is to write into, before anything is computed or created: the
    rule every writer follows (``tauv run --save-log``, ``tauv mc --out``, ``tauv reproduce
    --out``, ``tauv log convert``, the converter scripts).

    Refused, each with one :class:`~tauvcore.validation.OutputDirError` naming ``label`` and the
    directory: an empty name (it is no directory's; the current directory is named ``.``), a name
    with a NUL character, an entry that is not a directory, a missing parent (nothing but the
    directory itself is ever created), a parent or directory not writable, a directory that holds
    one of ``inputs`` or lies in an input directory, one that holds a log, and one that holds
    anything else but an earlier output of ``kind``; that one only with ``replace`` (and the
    writer says it replaced it), else refused with how to replace it. Entries a writer names
    :data:`WRITER_ENTRY_PREFIXES` do not count.

    Parameters
    ----------
    path : str
        The directory as given.
    label : str
        The flag or argument that gave it (``--out``, ``OUT_DIR``), at the head of each message.
    kind : OutputKind or None
        What the writer leaves there, to recognise an earlier output of its own kind (None: none is).
    replace : bool
        Whether an earlier output of ``kind`` may be replaced (its ``replace_flag`` was given).
    inputs : Sequence of tuple of (str, str or None)
        What the command reads, as (description, path) pairs (``("the --config file", path)``):
        the directory must not hold one, nor be in an input directory.

    Returns
    -------
    OutputDir
        Its real path, whether it exists, and what earlier output it replaces (None: none).

    Raises
    ------
    OutputDirError
        As above.
    """
    if not path.strip():
        raise OutputDirError(f"{label}: {show_path(path)} is not a directory name")
    name = show_path(path)
    if "\x00" in path:
        raise OutputDirError(f"{label}: a directory name cannot contain a NUL character, got {name}")
    real = os.path.realpath(path)
    if os.path.lexists(path) and not os.path.isdir(real):
        what = "a dangling symbolic link" if not os.path.exists(real) else "not a directory"
        raise OutputDirError(f"{label}: {name} exists and is {what}")
    exists = os.path.isdir(real)
    if not exists:
        parent = os.path.dirname(real)
        if not os.path.isdir(parent):
            given = os.path.dirname(os.path.normpath(path)) or "."
            raise OutputDirError(
                f"{label}: cannot create {name}: no such parent directory {show_path(given)} "
                "(create it first: only the directory itself is created)"
            )
    target = real if exists else os.path.dirname(real)
    if not os.access(target, os.W_OK | os.X_OK):
        raise OutputDirError(
            f"{label}: cannot write into {show_path(path if exists else target)}: permission denied"
        )
    _refuse_holding_inputs(label, path, real, inputs)
    replaces = None
    if exists:
        try:
            entries = {e for e in os.listdir(real) if not e.startswith(WRITER_ENTRY_PREFIXES)}
        except OSError as exc:
            raise OutputDirError(f"{label}: cannot list {name}: {exc.strerror or exc}") from None
        logs = sorted(e for e in entries if e in ("imu.csv", "imu.parquet"))
        if logs:
            raise OutputDirError(
                f"{label}: {name} is a log directory (it holds {logs[0]}), not an empty directory; give a "
                "new or empty one (nothing is overwritten)"
            )
        if kind is not None and kind.holds(entries):
            if kind.replace_flag is None or not replace:
                how = f"add {kind.replace_flag} to replace it, or give" if kind.replace_flag else "give"
                raise OutputDirError(
                    f"{label}: {name} holds an earlier {kind.name} ({', '.join(sorted(entries))}); {how} a new "
                    "or empty directory"
                )
            replaces = kind.name
        elif entries:
            listing = ", ".join(show_path(e) for e in sorted(entries)[:3])
            more = f" and {len(entries) - 3} more" if len(entries) > 3 else ""
            raise OutputDirError(
                f"{label}: {name} is not an empty directory (it holds {listing}{more}); give a new or empty "
                "one (nothing is overwritten)"
            )
    return OutputDir(real, exists, replaces)


def _refuse_holding_inputs(
    label: str, given: str, out_real: str, inputs: Sequence[tuple[str, str | None]]
) -> None:
    """OutputDirError if the output directory ``out_real`` (``given``) holds one of ``inputs`` (by
    real path, or the same file by a hard link), or lies in an input directory: its writer could
    replace them."""
    for what, source in inputs:
        if not source:
            continue
        try:
            source_real = os.path.realpath(source)
        except (OSError, ValueError):
            continue
        holds = _inside(source_real, out_real) or _same_as_one_in(source_real, out_real)
        if holds:
            raise OutputDirError(
                f"{label}: {show_path(given)} holds {what} {show_path(source)}; choose another directory"
            )
        if os.path.isdir(source_real) and _inside(out_real, source_real):
            raise OutputDirError(
                f"{label}: {show_path(given)} is in {what} {show_path(source)}; choose another directory"
            )


def _inside(path: str, directory: str) -> bool:
    """Whether the real path ``path`` is the real path ``directory`` or below it."""
    return os.path.commonpath([path, directory]) == directory


def _same_as_one_in(path: str, directory: str) -> bool:
    """Whether a file directly in ``directory`` is the file ``path`` (a hard link, or a link)."""
    if not os.path.lexists(path) or not os.path.isdir(directory):
        return False
    try:
        with os.scandir(directory) as entries:
            return any(same_file(path, e.path) for e in entries)
    except OSError:
        return False


def same_file(a: str, b: str) -> bool:
    """Whether two paths name one file (through a symbolic or a hard link).

    Parameters
    ----------
    a : str
        One path.
    b : str
        The other.

    Returns
    -------
    bool
        True where both name the same file; False where either names nothing a system call takes.
    """
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def write_log(
    directory: str | os.PathLike,
    tables: dict[str, dict[str, np.ndarray]],
    fmt: str = "csv",
    config_toml: str | None = None,
) -> None:
    """Write ``tables`` as a log in ``directory``, all or nothing.

    CSV with every float written to its last digit (``repr``, so reading back is exact) or
    Parquet, and with ``config_toml`` the log's own configuration file :data:`CONFIG_FILE`. A
    file of the same name already there is replaced.

    All or nothing: every file is written into a hidden temporary directory inside ``directory``
    (the same file system) under a name no reader takes for a table, flushed to disk, and moved
    into place only when all are complete, the ``imu`` table last (a log is recognised by it,
    :func:`find_logs`). On any failure or interrupt (a full disk, a file-size limit, Ctrl-C) the
    temporary directory is removed, the files already moved are taken back (what they replaced
    restored) and the directories created here are removed, then the exception propagates:
    nothing partial and nothing that looks like a log is left.

    Parameters
    ----------
    directory : str or os.PathLike
        The log's directory (created, with its missing parents, if need be).
    tables : dict of str to dict of str to numpy.ndarray
        Table name (``imu``, ``dvl``, ``reference`` or an aiding source's table) -> column name ->
        column, a 1-D array (K,) per table (NaN: an empty cell), in the unit and frame the column's
        name says (tauvcore.logs), e.g. ``t_s`` [s], ``dv_x_mps`` [m/s] in the body b-frame (FRD).
    fmt : str
        ``"csv"`` or ``"parquet"``.
    config_toml : str or None
        Text of the log's configuration file (TOML) to write as :data:`CONFIG_FILE`; None: none.

    Raises
    ------
    ValueError
        If ``fmt`` is not 'csv' or 'parquet', or a table is unknown.
    """
    _check_format(fmt)
    for table in tables:
        _check_table(table)
    root = Path(directory)
    made = _make_dirs(root)
    tmp: Path | None = None
    try:
        tmp = Path(tempfile.mkdtemp(prefix=".tauv-log-", dir=root))
        moves = []
        if config_toml is not None:
            part = tmp / f"{CONFIG_FILE}.partial"
            with open(part, "w", encoding="utf-8") as fh:
                fh.write(config_toml)
                _flush(fh)
            moves.append((part, root / CONFIG_FILE))
        for table in sorted(tables, key=lambda t: t == "imu"):  # the imu table last
            part = tmp / f"{table}.{fmt}.partial"
            _write_table(part, tables[table], fmt)
            moves.append((part, root / f"{table}.{fmt}"))
        replace_files(moves, tmp / "replaced")
        fsync_path(root)
    except BaseException:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
        for made_dir in reversed(made):
            with contextlib.suppress(OSError):
                made_dir.rmdir()  # only if empty: never anything of the user's
        raise
    shutil.rmtree(tmp, ignore_errors=True)  # what the tables replaced


def _check_format(fmt: str) -> None:
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"fmt must be 'csv' or 'parquet', got {fmt!r}")


def _check_table(table: str) -> None:
    if table not in TABLES + tuple(SOURCE_TABLES.values()):
        raise ValueError(
            f"unknown table {table!r} (tables: {', '.join(TABLES + tuple(SOURCE_TABLES.values()))})"
        )


class LogWriter:
    """A log written as a simulation goes: each chunk's tables appended to their files, so that
    memory does not grow with the mission's length; :meth:`finish` puts the log in place all or
    nothing, as :func:`write_log` does.

    The files are those :func:`write_log` writes from the chunks' tables concatenated: CSV byte
    for byte, Parquet value for value (its row groups of :data:`ROW_GROUP_ROWS` rows, chunks
    gathered; tests/unit/tauvcore/logs/test_log_writer_stream.py). Each table's file is written, from the first chunk
    that has the table, into a hidden temporary directory inside ``directory`` under a name no
    reader takes for a table; :meth:`finish` flushes them to disk and moves them into place, the
    ``imu`` table last. Until then nothing in ``directory`` looks like a log; on a failure the
    caller calls :meth:`discard` (:meth:`finish` does it itself), which removes the temporary
    directory and the directories created here.

    Parameters
    ----------
    directory, fmt, config_toml
        As :func:`write_log`.

    Raises
    ------
    ValueError
        If ``fmt`` is not 'csv' or 'parquet'.
    OSError
        If the directory or the temporary one cannot be made (nothing is left behind).
    """

    def __init__(
        self, directory: str | os.PathLike, fmt: str = "csv", config_toml: str | None = None
    ) -> None:
        _check_format(fmt)
        self.root, self.fmt = Path(directory), fmt
        self.tables: dict[str, _TableFile] = {}  # table name -> its file, in the order the tables came
        self.made = _make_dirs(self.root)
        self.tmp: Path | None = None
        try:
            self.tmp = Path(tempfile.mkdtemp(prefix=".tauv-log-", dir=self.root))
            self.config_part: Path | None = None
            if config_toml is not None:
                self.config_part = self.tmp / f"{CONFIG_FILE}.partial"
                with open(self.config_part, "w", encoding="utf-8") as fh:
                    fh.write(config_toml)
                    _flush(fh)
        except BaseException:
            self.discard()
            raise

    def add(self, tables: dict[str, dict[str, np.ndarray]]) -> None:
        """Append one chunk's tables.

        Parameters
        ----------
        tables : dict of str to dict of str to numpy.ndarray
            Table name -> column name -> the chunk's rows of that column (K_chunk,), as
            :func:`write_log` takes them (:func:`chunk_tables`); a table's columns the same in
            every chunk.

        Raises
        ------
        ValueError
            If a table is unknown, or its columns are not those of its first chunk.
        OSError
            If a file cannot be written (a full disk, a file-size limit).
        """
        assert self.tmp is not None  # set by __init__, None only after discard()
        for table, columns in tables.items():
            out = self.tables.get(table)
            if out is None:
                _check_table(table)
                out = self.tables[table] = _TableFile(
                    self.tmp / f"{table}.{self.fmt}.partial", self.fmt, columns
                )
            out.append(columns)

    def finish(self) -> None:
        """Close every table, flushed to disk, and move them into place (the ``imu`` table last;
        a file of the same name already there is replaced); on any failure or interrupt, nothing
        is left (:meth:`discard`, the moves undone: :func:`replace_files`) and the exception
        propagates."""
        assert self.tmp is not None  # set by __init__, None only after discard()
        try:
            moves = []
            if self.config_part is not None:
                moves.append((self.config_part, self.root / CONFIG_FILE))
            for table in sorted(self.tables, key=lambda t: t == "imu"):  # the imu table last
                out = self.tables[table]
                out.close()
                moves.append((out.path, self.root / f"{table}.{self.fmt}"))
            replace_files(moves, self.tmp / "replaced")
            fsync_path(self.root)
        except BaseException:
            self.discard()
            raise
        shutil.rmtree(self.tmp, ignore_errors=True)  # what the tables replaced
        self.tmp = None

    def discard(self) -> None:
        """Remove the temporary directory and the directories created here (after a failure)."""
        for out in self.tables.values():
            out.abandon()
        if self.tmp is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            self.tmp = None
        for made_dir in reversed(self.made):
            with contextlib.suppress(OSError):
                made_dir.rmdir()  # only if empty: never anything of the user's
        self.made = []


ROW_GROUP_ROWS = 65536
"""Rows a Parquet table's row group holds at least (the last may hold fewer): :class:`LogWriter`
gathers a table's chunks until then, about 7 minutes of 150 Hz IMU (4 MB of its columns). A row
group per 10 s chunk (1,500 rows) would make the file about a fifth larger and twice as slow to
read, and the writer holds every row group's description until it writes the footer (about 16 MB
per hour of mission). The columns are written as plain values, without a dictionary: one of
65,536 mostly distinct doubles is larger than they are and slower to read (:func:`write_log`'s
row groups of a million rows give theirs up after 1 MB); a 10 h log is then the size
:func:`write_log` makes of it."""


class _TableFile:
    """One table's file of a :class:`LogWriter`: CSV rows appended chunk by chunk, or Parquet row
    groups of at least :data:`ROW_GROUP_ROWS` rows (``pyarrow.parquet.ParquetWriter``, its
    schema the first chunk's)."""

    def __init__(self, path: Path, fmt: str, first: dict[str, np.ndarray]) -> None:
        self.path, self.names = path, list(first)
        self.parquet: Any = None  # pyarrow.parquet.ParquetWriter, open until close() or abandon()
        self.pending: list[dict[str, np.ndarray]] = []  # chunks not yet in a row group
        self.pending_rows = 0
        if fmt == "parquet":
            import pyarrow.parquet as pq

            self.parquet = pq.ParquetWriter(str(path), self._arrow([first]).schema, use_dictionary=False)
        else:
            with open(path, "w", encoding="utf-8") as fh:
                fh.write(",".join(self.names) + "\n")

    def _arrow(self, chunks: list[dict[str, np.ndarray]]) -> Any:
        import pyarrow as pa

        return pa.table(
            {n: np.concatenate([np.asarray(c[n], dtype=float) for c in chunks]) for n in self.names}
        )

    def append(self, columns: dict[str, np.ndarray]) -> None:
        """Append one chunk's rows (ValueError if its columns are not the first chunk's)."""
        if list(columns) != self.names:
            raise ValueError(
                f"{self.path.name.split('.')[0]}: a chunk's columns {list(columns)} are not the first "
                f"chunk's {self.names}"
            )
        rows = len(columns[self.names[0]]) if self.names else 0
        if rows == 0:
            return  # no rows (a source without an epoch in the chunk)
        if self.parquet is not None:
            self.pending.append({n: np.array(columns[n], dtype=float) for n in self.names})
            self.pending_rows += rows
            if self.pending_rows >= ROW_GROUP_ROWS:
                self._write_row_group()
        else:
            with open(self.path, "a", encoding="utf-8") as fh:
                fh.write("".join(_csv_rows(columns, self.names)))

    def _write_row_group(self) -> None:
        self.parquet.write_table(self._arrow(self.pending), row_group_size=self.pending_rows)
        self.pending, self.pending_rows = [], 0

    def close(self) -> None:
        """Finish the file (the last row group, Parquet's footer) and flush it to disk."""
        if self.parquet is not None:
            if self.pending:
                self._write_row_group()
            self.parquet.close()
            self.parquet = None
        fsync_path(self.path)

    def abandon(self) -> None:
        """Let go of the file without finishing it (its directory is about to be removed)."""
        self.pending = []
        if self.parquet is not None:
            with contextlib.suppress(Exception):  # pyarrow's errors are not all OSErrors
                self.parquet.close()
            self.parquet = None


def _make_dirs(root: Path) -> list[Path]:
    """Create ``root`` and its missing parents; the directories created, outermost first."""
    missing = []
    for candidate in (root, *root.parents):
        if candidate.is_dir():
            break
        missing.append(candidate)
    made = []
    try:
        for candidate in reversed(missing):
            try:
                candidate.mkdir()
            except FileExistsError:
                if not candidate.is_dir():
                    raise
                continue  # made by someone else meanwhile: not ours to remove
            made.append(candidate)
    except BaseException:
        for made_dir in reversed(made):
            with contextlib.suppress(OSError):
                made_dir.rmdir()
        raise
    return made


def _write_table(path: Path, columns: dict[str, np.ndarray], fmt: str) -> None:
    """One table as a CSV or Parquet file at ``path``, flushed to disk."""
    names = list(columns)
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        with open(path, "wb") as fh:
            pq.write_table(pa.table({n: np.asarray(columns[n], dtype=float) for n in names}), fh)
            _flush(fh)
        return
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(names) + "\n")
        fh.writelines(_csv_rows(columns, names))
        _flush(fh)


def _csv_rows(columns: dict[str, np.ndarray], names: Sequence[str]) -> Iterator[str]:
    """The CSV rows of ``columns`` (in the order ``names``), each float to its last digit (its
    ``repr``: reading back is exact), an empty cell for NaN."""
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    return (",".join("" if np.isnan(v) else repr(float(v)) for v in row) + "\n" for row in data)


def _flush(fh: IO) -> None:
    """Flush ``fh`` through Python's buffer and the system's cache to the disk."""
    fh.flush()
    os.fsync(fh.fileno())


def fsync_path(path: str | os.PathLike) -> None:
    """Flush the file or directory ``path`` to the disk (a directory: its entries, the renames
    into it).

    Parameters
    ----------
    path : str or os.PathLike
        The file or directory to flush.
    """
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def replace_files(
    moves: Sequence[tuple[str | os.PathLike, str | os.PathLike]], aside: str | os.PathLike
) -> None:
    """Rename each ``(source, target)`` of ``moves``, in order, as one change.

    A target that exists is first renamed into the directory ``aside`` (created here, on the
    targets' file system); on any failure or interrupt every target already moved is removed and
    what it replaced is put back, then the exception propagates. On success ``aside`` holds the
    replaced files, for the caller to remove. A target that is a directory is refused
    (IsADirectoryError) before anything moves.

    Parameters
    ----------
    moves : Sequence of tuple of (str or os.PathLike, str or os.PathLike)
        The ``(source, target)`` paths to rename, in order.
    aside : str or os.PathLike
        The directory to create for the replaced targets, on the targets' file system; it must not
        exist yet.

    Raises
    ------
    IsADirectoryError
        If a target is a directory (not a link to one), before anything moves.
    """
    for _, target in moves:
        if os.path.isdir(target) and not os.path.islink(target):
            raise IsADirectoryError(21, "Is a directory", os.fspath(target))
    os.mkdir(aside)
    done: list[tuple[str | os.PathLike, str | None, bool]] = []  # target, where it went, placed
    try:
        for k, (source, target) in enumerate(moves):
            kept = None
            if os.path.lexists(target):
                kept = os.path.join(aside, str(k))
                os.rename(target, kept)
            done.append((target, kept, False))
            os.rename(source, target)
            done[-1] = (target, kept, True)
    except BaseException:
        for target, kept, placed in reversed(done):
            with contextlib.suppress(OSError):
                if placed:
                    os.unlink(target)
                if kept is not None:
                    os.rename(kept, target)
        raise


def simulation_tables(chunks: list, run_index: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """The tables of a log holding one run of a simulation given as its chunks in order.

    :func:`chunk_tables` of each chunk, end to end.

    Parameters
    ----------
    chunks : list
        The simulation's chunks in order (tauvcore.engine.simulation.SimChunk;
        ``[SimChunk.whole(sim)]`` for a whole one), arrays with the run axis after time, (K, R, ...).
    run_index : int
        The run to write, an index into the run axis R.

    Returns
    -------
    dict of str to dict of str to numpy.ndarray
        Table name -> column name -> column (K,) over all chunks (for :func:`write_log`), as
        :func:`chunk_tables` describes them.
    """
    parts: dict[str, dict[str, list[np.ndarray]]] = {}
    for chunk in chunks:
        for table, columns in chunk_tables(chunk, run_index).items():
            for column, values in columns.items():
                parts.setdefault(table, {}).setdefault(column, []).append(values)
    order = TABLES + tuple(SOURCE_TABLES.values())
    return {t: {c: np.concatenate(v) for c, v in parts[t].items()} for t in sorted(parts, key=order.index)}


def chunk_tables(chunk: Any, run_index: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """The rows one chunk of a simulation adds to each table of its log (for :class:`LogWriter`).

    The IMU as increments, the DVL as beams (NaN where not returned), each aiding source's (the
    depth, the attitude, ...), and the truth as the reference (at the IMU rate; geodetic in
    radians on WGS-84, else NED).

    Parameters
    ----------
    chunk : SimChunk
        A chunk of the simulation (tauvcore.engine.simulation.SimChunk), arrays with the run axis
        after time, (K_chunk, R, ...).
    run_index : int
        The run to write, an index into the run axis R.

    Returns
    -------
    dict of str to dict of str to numpy.ndarray
        Table name -> column name -> the chunk's rows (K_chunk,), in the order the log's tables
        come (tauvcore.logs.TABLES, then the sources'): ``imu`` (``t_s`` [s], angle increments
        [rad] and velocity increments [m/s] in the body b-frame (FRD)), ``reference``
        (``lat_rad``, ``lon_rad``, ``depth_m`` on WGS-84, else north, east, down [m]; roll, pitch,
        yaw [rad]; NED velocity [m/s]) and each aiding source's table, with its true errors (a
        source without an epoch in the chunk: its columns empty); a table with no column is left
        out.
    """
    r = run_index

    def run_of(a: np.ndarray, time_axis_dims: int) -> np.ndarray:
        return a[:, r] if a.ndim > time_axis_dims else a

    parts: dict[str, dict[str, np.ndarray]] = {t: {} for t in TABLES + tuple(SOURCE_TABLES.values())}

    def add(table: str, column: str, values: np.ndarray) -> None:
        parts[table][column] = np.asarray(values, dtype=float)

    truth, imu = chunk.truth, chunk.imu
    add("imu", "t_s", truth.t_s)
    dth, dv = run_of(imu.dtheta_b, 2), run_of(imu.dv_b, 2)
    for i in range(3):
        add("imu", IMU_INCREMENTS[i], dth[:, i])
        add("imu", IMU_INCREMENTS[3 + i], dv[:, i])
    add("reference", "t_s", truth.t_s)
    if truth.earth.geodetic:
        for i, n in enumerate(("lat_rad", "lon_rad", "depth_m")):
            add("reference", n, truth.pos_nav[:, i])
    else:
        for i, n in enumerate(REF_LOCAL):
            add("reference", n, truth.pos_n[:, i])
    for i, n in enumerate(("roll_rad", "pitch_rad", "yaw_rad")):
        add("reference", n, truth.euler[:, i])
    for i, n in enumerate(REF_VEL):
        add("reference", n, truth.vel_n[:, i])
    for name, data in chunk.sources.items():
        table = SOURCES[name].table
        add(table, "t_s", data.t_s)
        for column, values in {**data.values, **data.truth}.items():
            add(table, column, run_of(values, 1))
    return {t: cols for t, cols in parts.items() if cols}
