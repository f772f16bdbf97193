"""What a Monte Carlo study leaves in its output directory (``tauv mc``), and nothing half-written.

- ``summary.json``: the configuration, and per trajectory and method the per-epoch RMS over the
  runs of every error series and of the filter's own 1-sigma, the mean NEES (full and per block),
  the final values (RMS and per run), the consistency per block and the runs the divergence
  monitor flagged (strict JSON: non-finite numbers are null);
- ``runs.parquet``: every run's per-epoch series in long form, one row per (trajectory, method,
  run, epoch), columns :data:`PARQUET_SERIES` (written chunk by chunk, so memory does not grow
  with the number of runs);
- ``paper_comparison.md`` (``tauv reproduce`` only): every figure the paper states beside ours,
  with a verdict (tauvcore.eval.paper);
- ``report.html``: plotly figures in the layout of the paper's Figures 9-14 (velocity and
  attitude RMS against time per trajectory, with tilt, heading and NEES/dim beside them), with
  plotly.js embedded so that it opens offline.

Everything is written in a hidden temporary directory inside the output directory and renamed
into place only when the study has finished; an error or an interrupt removes it.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from typing import Any

import numpy as np

from tauvcore.eval.study import ERROR_SERIES, NEES_SERIES, ChunkSeries

PARQUET_SERIES = ERROR_SERIES + NEES_SERIES
"""The per-run columns of runs.parquet: the errors and the NEES (full and per block), as 32-bit
floats (7 digits) with zstd compression: 100 runs x 8 methods x 3 trajectories at 10 Hz are 6
million rows (440 MB as 64-bit floats with the sigmas). The filter's 1-sigma is in summary.json as
RMS over the runs."""

OUTPUT_FILES = ("summary.json", "runs.parquet", "report.html", "paper_comparison.md")


class OutputDirError(ValueError):
    """The output directory cannot be used; the message names it and says why."""


def check_out_dir(path: str) -> str:
    """The real path of ``path`` if it can become the output directory (an existing writable
    directory, or a new name in an existing directory). Creates nothing."""
    if not path.strip():
        raise OutputDirError("expected a directory name, got ''")
    real = os.path.realpath(path)
    if os.path.exists(real) and not os.path.isdir(real):
        raise OutputDirError(f"{path!r} exists and is not a directory")
    target = real if os.path.isdir(real) else os.path.dirname(real)
    if not os.path.isdir(target):
        raise OutputDirError(f"cannot create {path!r}: no such parent directory")
    if not os.access(target, os.W_OK | os.X_OK):
        raise OutputDirError(f"cannot write into {target!r}: permission denied")
    return real


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
    (float32). A dashboard run's download is the same table (app.export)."""
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
    return pa.table(columns)


class StudyWriter:
    """Collects a study's outputs under temporary names; :meth:`commit` renames them into place."""

    def __init__(self, out_dir: str) -> None:
        """``out_dir`` from :func:`check_out_dir`; created here if missing (and removed again by
        :meth:`abort` if the study fails)."""
        self.out_dir = out_dir
        self.created = not os.path.isdir(out_dir)
        try:
            if self.created:
                os.mkdir(out_dir)
            self.tmp = tempfile.mkdtemp(prefix=".tauv-mc-", dir=out_dir)
        except OSError as exc:
            raise OutputDirError(f"cannot write into {out_dir!r}: {exc.strerror or exc}") from None
        self._parquet = None

    def add_chunk(self, trajectory: str, chunk: ChunkSeries) -> None:
        """Append one chunk's runs to runs.parquet (long form, :func:`runs_table`)."""
        import pyarrow.parquet as pq

        table = runs_table(trajectory, chunk)
        if self._parquet is None:
            self._parquet = pq.ParquetWriter(
                os.path.join(self.tmp, "runs.parquet"), table.schema, **PARQUET_WRITE_OPTIONS
            )
        self._parquet.write_table(table)

    def finish(self, summary: dict[str, Any], report_html: str, comparison_md: str | None = None) -> None:
        if self._parquet is not None:
            self._parquet.close()
            self._parquet = None
        with open(os.path.join(self.tmp, "summary.json"), "w", encoding="utf-8") as fh:
            # dumps, not dump: json.dump always takes the pure-Python encoder (2.7 s for the
            # study's 19 MB), dumps without indent the C one
            fh.write(json.dumps(_plain(summary), allow_nan=False))
        with open(os.path.join(self.tmp, "report.html"), "w", encoding="utf-8") as fh:
            fh.write(report_html)
        if comparison_md is not None:
            with open(os.path.join(self.tmp, "paper_comparison.md"), "w", encoding="utf-8") as fh:
                fh.write(comparison_md + "\n")

    def commit(self) -> list[str]:
        """Rename every output into the output directory (each an atomic replace); remove the
        temporary directory. Returns the paths written."""
        written = []
        for name in OUTPUT_FILES:
            src = os.path.join(self.tmp, name)
            if os.path.exists(src):
                dst = os.path.join(self.out_dir, name)
                os.replace(src, dst)
                written.append(dst)
        shutil.rmtree(self.tmp, ignore_errors=True)
        return written

    def abort(self) -> None:
        if self._parquet is not None:
            try:
                self._parquet.close()
            except Exception:  # noqa: BLE001, S110 - the file is thrown away with the directory
                pass
            self._parquet = None
        shutil.rmtree(self.tmp, ignore_errors=True)
        if self.created:
            with contextlib.suppress(OSError):
                os.rmdir(self.out_dir)  # only if empty: never anything of the user's
