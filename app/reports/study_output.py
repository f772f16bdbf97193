"""What a Monte Carlo study leaves in its output directory (``tauv mc``), and nothing half-written.

- ``summary.json``: the configuration, and per trajectory and method the per-epoch RMS over the
  runs of every error series and of the filter's own 1-sigma, the mean NEES (full and per block),
  the final values (RMS and per run), the consistency per block and the runs the divergence
  monitor flagged (strict JSON: non-finite numbers are null);
- ``runs.parquet``: every run's per-epoch series in long form, one row per (trajectory, method,
  run, epoch), columns :data:`PARQUET_SERIES` (written chunk by chunk, so memory does not grow
  with the number of runs); a study with the smoother (``tauv mc --smooth``) adds beside them the
  smoothed ones, ``smoothed_<series>`` (null for a method not smoothed);
- ``paper_comparison.md`` (``tauv reproduce`` only): every figure the paper states beside ours,
  with a verdict (tauvcore.eval.paper);
- ``report.html``: plotly figures in the layout of the paper's Figures 9-14 (velocity and
  attitude RMS against time per trajectory, with tilt, heading and NEES/dim beside them), with
  plotly.js embedded so that it opens offline.

Everything is written in a hidden temporary directory inside the output directory, flushed to
disk, and renamed into place only when the study has finished; an error (a full disk, a
file-size limit) or an interrupt removes it. The output directory is locked for the study
(:class:`DirectoryLock`): a second writer is refused at once.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from typing import Any

import numpy as np

from tauvcore.eval.study import ERROR_SERIES, NEES_SERIES, ChunkSeries
from tauvcore.logs.writer import OutputKind, fsync_path, replace_files
from tauvcore.validation import OutputDirError, one_line, show_path

PARQUET_SERIES = ERROR_SERIES + NEES_SERIES
"""The per-run columns of runs.parquet: the errors and the NEES (full and per block), as 32-bit
floats (7 digits) with zstd compression: 100 runs x 8 methods x 3 trajectories at 10 Hz are 6
million rows (440 MB as 64-bit floats with the sigmas). The filter's 1-sigma is in summary.json as
RMS over the runs."""

OUTPUT_FILES = ("summary.json", "runs.parquet", "report.html", "paper_comparison.md")


MC_STUDY = OutputKind(
    "tauv mc study",
    frozenset(OUTPUT_FILES) - {"paper_comparison.md"},
    frozenset({"summary.json"}),
    replace_flag="--replace",
)
"""What ``tauv mc`` leaves in its directory: a directory holding only these (summary.json among
them) holds an earlier study, replaced only with ``--replace`` (tauvcore.logs.writer.output_dir)."""
REPRODUCE_STUDY = OutputKind(
    "tauv reproduce study",
    frozenset(OUTPUT_FILES),
    frozenset({"summary.json", "paper_comparison.md"}),
    replace_flag="--replace",
)
"""What ``tauv reproduce`` leaves in its directory (as :data:`MC_STUDY`, with paper_comparison.md)."""


def _plain(value: Any) -> Any:
    """JSON-ready: arrays to lists, non-finite floats to None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        if value.dtype.kind == "f":
            plain = value.astype(object)
            plain[~np.isfinite(value)] = None
            return plain.tolist()
        return value.tolist()
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    return value


PARQUET_WRITE_OPTIONS: dict[str, Any] = {"compression": "zstd", "use_dictionary": ["trajectory", "method"]}
"""How runs.parquet is written (``pyarrow.parquet.ParquetWriter`` keywords): zstd, and dictionary
encoding for the two name columns only."""


def runs_table(trajectory: str, chunk: ChunkSeries) -> Any:
    """One chunk's runs as rows of runs.parquet: a ``pyarrow.Table`` with one row per (method,
    run, epoch), method-major then run-major, columns ``trajectory``, ``method`` (dictionary, int8
    codes), ``run`` (int32, the study's run index), ``t_s`` (float64) and :data:`PARQUET_SERIES`
    (float32), and for a chunk with smoothed series (``chunk.smoothed``) ``smoothed_<name>`` of each
    (NaN for a method without). A dashboard run's download is the same table (app.dashboard.export)."""
    import pyarrow as pa

    T = chunk.t_s.size
    methods = list(chunk.series)
    rows = chunk.count * T
    n = rows * len(methods)
    # trajectory and method as dictionary columns (one small dictionary, int8 codes): no
    # string per row; the floats without dictionary encoding (pyarrow's default tries it on
    # every column, which took 5 of the study's 7 s of Parquet writing and made the file larger)
    columns: dict[str, Any] = {
        "trajectory": pa.DictionaryArray.from_arrays(np.zeros(n, np.int8), pa.array([trajectory])),
        "method": pa.DictionaryArray.from_arrays(
            np.repeat(np.arange(len(methods), dtype=np.int8), rows), pa.array(methods)
        ),
        "run": np.tile(
            np.repeat(np.arange(chunk.first, chunk.first + chunk.count, dtype=np.int32), T), len(methods)
        ),
        "t_s": np.tile(chunk.t_s, chunk.count * len(methods)),
    }
    for name in PARQUET_SERIES:
        columns[name] = np.concatenate(
            [np.asarray(chunk.series[m][name], dtype=np.float32).T.reshape(-1) for m in methods]
        )  # run-major
    if chunk.smoothed:
        nan = np.full(rows, np.nan, np.float32)
        for name in PARQUET_SERIES:
            columns["smoothed_" + name] = np.concatenate(
                [
                    np.asarray(chunk.smoothed[m][name], dtype=np.float32).T.reshape(-1)
                    if m in chunk.smoothed
                    else nan
                    for m in methods
                ]
            )
    return pa.table(columns)


LOCK_FILE = ".tauv.lock"
"""The file in an output directory that a writer holds an exclusive ``fcntl.flock`` on while it
writes there (:class:`DirectoryLock`); it holds the writer's process id."""


def os_reason(exc: OSError) -> str:
    """Why a file operation failed, in a few words ("No space left on device"): the system's
    text for the error number (pyarrow's own wraps it in a sentence), else the message."""
    if exc.errno:
        return os.strerror(exc.errno)
    return one_line(exc.strerror or str(exc)) or type(exc).__name__


class DirectoryLock:
    """``directory`` held by one writer until :meth:`release`: an exclusive, non-blocking
    ``fcntl.flock`` on its :data:`LOCK_FILE`, refused at once (OutputDirError naming the
    holder's process id) while another holds it. The directory is created if missing
    (:attr:`created`). The kernel drops the lock when the process ends, however it ends, so a
    lock file left by a killed writer is harmless. ``name``: the directory as messages show it
    (default ``directory``)."""

    def __init__(self, directory: str, name: str | None = None) -> None:
        self.directory = directory
        self.shown = show_path(directory if name is None else name)
        self.path = os.path.join(directory, LOCK_FILE)
        self.created = False
        self._fd: int | None = None
        try:
            os.mkdir(directory)
            self.created = True
        except FileExistsError:
            pass
        except OSError as exc:
            raise OutputDirError(f"cannot create {self.shown}: {os_reason(exc)}") from None
        try:
            self._fd = self._take()
        except BaseException:
            self.release()
            raise

    def _take(self) -> int:
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
            except OSError as exc:
                raise OutputDirError(f"cannot write into {self.shown}: {os_reason(exc)}") from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
                os.close(fd)
                pid = f" (pid {holder})" if holder.isdigit() else ""
                raise OutputDirError(f"{self.shown} is being written by another tauv{pid}") from None
            except BaseException:
                os.close(fd)
                raise
            # the holder removes the file before it lets go: a lock on a file no longer there
            # (or replaced since) holds nothing, so open the one there now
            try:
                current = os.stat(self.path)
            except FileNotFoundError:
                current = None
            mine = os.fstat(fd)
            if current is not None and (current.st_dev, current.st_ino) == (mine.st_dev, mine.st_ino):
                os.ftruncate(fd, 0)
                os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
                return fd
            os.close(fd)

    def release(self, remove_created: bool = False) -> None:
        """Let go of the lock (its file removed first); with ``remove_created``, also remove the
        directory if this lock created it and it is empty."""
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)
            os.close(self._fd)
            self._fd = None
        if remove_created and self.created:
            with contextlib.suppress(OSError):
                os.rmdir(self.directory)  # only if empty: never anything of the user's


class StudyWriter:
    """Collects a study's outputs under temporary names, holding the output directory's
    :class:`DirectoryLock`; :meth:`commit` renames them into place. Every failure to write is an
    :class:`OutputDirError` naming the file and the reason."""

    def __init__(self, out_dir: str, name: str | None = None) -> None:
        """``out_dir`` from tauvcore.logs.writer.output_dir; created here if missing (and removed again by
        :meth:`abort` if the study fails); OutputDirError if another writer holds it. ``name``:
        the directory as messages show it (default ``out_dir``)."""
        self.out_dir = out_dir
        self.name = out_dir if name is None else name
        self.replaces: str | None = None  # the earlier study the outputs replace (the command says so)
        self._parquet = None
        self.lock = DirectoryLock(out_dir, self.name)
        self.created = self.lock.created
        try:
            self.tmp = tempfile.mkdtemp(prefix=".tauv-mc-", dir=out_dir)
        except OSError as exc:
            self.lock.release(remove_created=True)
            raise OutputDirError(f"cannot write into {show_path(self.name)}: {os_reason(exc)}") from None
        except BaseException:
            self.lock.release(remove_created=True)
            raise

    @contextlib.contextmanager
    def _writing(self, name: str) -> Iterator[str]:
        """The temporary path of output ``name``; an OSError while writing it becomes an
        OutputDirError naming the file it is for."""
        try:
            yield os.path.join(self.tmp, name)
        except OSError as exc:
            target = show_path(os.path.join(self.name, name))
            raise OutputDirError(f"cannot write {target}: {os_reason(exc)}") from None

    def add_chunk(self, trajectory: str, chunk: ChunkSeries) -> None:
        """Append one chunk's runs to runs.parquet (long form, :func:`runs_table`)."""
        import pyarrow.parquet as pq

        table = runs_table(trajectory, chunk)
        with self._writing("runs.parquet") as path:
            if self._parquet is None:
                self._parquet = pq.ParquetWriter(path, table.schema, **PARQUET_WRITE_OPTIONS)
            self._parquet.write_table(table)

    def _write_text(self, name: str, text: str) -> None:
        with self._writing(name) as path, open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())

    def finish(self, summary: dict[str, Any], report_html: str, comparison_md: str | None = None) -> None:
        """Write the study's other outputs (module docstring), each flushed to disk."""
        with self._writing("runs.parquet") as path:
            if self._parquet is not None:
                self._parquet.close()
                self._parquet = None
                fsync_path(path)
        # dumps, not dump: json.dump always takes the pure-Python encoder (2.7 s for the
        # study's 19 MB), dumps without indent the C one
        self._write_text("summary.json", json.dumps(_plain(summary), allow_nan=False))
        self._write_text("report.html", report_html)
        if comparison_md is not None:
            self._write_text("paper_comparison.md", comparison_md + "\n")

    def commit(self) -> list[str]:
        """Rename every output into the output directory as one change (if a rename fails, the
        ones done are undone: tauvcore.logs.writer.replace_files), remove the temporary directory and
        let go of the lock. Returns the paths written."""
        moves = [
            (os.path.join(self.tmp, name), os.path.join(self.out_dir, name))
            for name in OUTPUT_FILES
            if os.path.exists(os.path.join(self.tmp, name))
        ]
        try:
            replace_files(moves, os.path.join(self.tmp, "replaced"))
            fsync_path(self.out_dir)
        except OSError as exc:
            raise OutputDirError(f"cannot write into {show_path(self.name)}: {os_reason(exc)}") from None
        shutil.rmtree(self.tmp, ignore_errors=True)  # what the outputs replaced
        self.lock.release()
        return [target for _, target in moves]

    def abort(self) -> None:
        """Throw away everything written (the temporary directory, and the output directory if
        it was created here) and let go of the lock."""
        if self._parquet is not None:
            try:
                self._parquet.close()
            except Exception:  # noqa: BLE001, S110 - the file is thrown away with the directory
                pass
            self._parquet = None
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.lock.release(remove_created=True)
