"""Writing a log in the format tauvcore.logs reads: a simulation's tables, written all or
nothing (every file complete in a hidden temporary directory, then moved into place)."""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import IO

import numpy as np

from tauvcore.aiding.sources import SOURCES
from tauvcore.log_columns import IMU_INCREMENTS, REF_LOCAL, REF_VEL
from tauvcore.logs import CONFIG_FILE, SOURCE_TABLES, TABLES


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
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"fmt must be 'csv' or 'parquet', got {fmt!r}")
    for table in tables:
        if table not in TABLES + tuple(SOURCE_TABLES.values()):
            raise ValueError(
                f"unknown table {table!r} (tables: {', '.join(TABLES + tuple(SOURCE_TABLES.values()))})"
            )
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
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(",".join(names) + "\n")
        fh.writelines(",".join("" if np.isnan(v) else repr(float(v)) for v in row) + "\n" for row in data)
        _flush(fh)


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

    The IMU as increments, the DVL as beams (NaN where not returned), each aiding source's (the
    depth, the attitude, ...), and the truth as the reference (at the IMU rate; geodetic in
    radians on WGS-84, else NED).

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
        Table name -> column name -> column (K,) over all chunks (for :func:`write_log`): ``imu``
        (``t_s`` [s], angle increments [rad] and velocity increments [m/s] in the body b-frame
        (FRD)), ``reference`` (``lat_rad``, ``lon_rad``, ``depth_m`` on WGS-84, else north, east,
        down [m]; roll, pitch, yaw [rad]; NED velocity [m/s]) and each aiding source's table, with
        its true errors; a table with no column is left out.
    """
    r = run_index

    def run_of(a: np.ndarray, time_axis_dims: int) -> np.ndarray:
        return a[:, r] if a.ndim > time_axis_dims else a

    parts: dict[str, dict[str, list[np.ndarray]]] = {t: {} for t in TABLES + tuple(SOURCE_TABLES.values())}

    def add(table: str, column: str, values: np.ndarray) -> None:
        parts[table].setdefault(column, []).append(np.asarray(values, dtype=float))

    for chunk in chunks:
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
    return {t: {c: np.concatenate(v) for c, v in cols.items()} for t, cols in parts.items() if cols}
