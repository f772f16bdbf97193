"""``tauv run --json`` and ``tauv replay --json`` written as the run goes: the document of
app.reports.payload.run_payload, with memory flat in the mission's length.

Each chunk's series (app.reports.payload.result_series, run 0) and NIS records are appended to files of
raw doubles in a temporary directory beside the output; at the end the document is written from
them, a block of values at a time, into a temporary file that is renamed over the output
(app.commands.outputs.write_text_atomic). It parses to the same document as writing the whole
results at once (tests/unit/app/commands/test_json_stream.py): every series the same numbers, the consistency
(summed chunk by chunk, tauvcore.eval.running) to 1e-9. On any failure, or an interruption, the
temporary files go and the output is untouched.

With the smoother (``tauv run --smooth``), the smoothed chunks the engine hands out after the
filtered ones (tauvcore.engine.mission.run_streaming's ``on_smoothed_chunk``) are spooled the same
way, and each method's object gets ``"smoothed"``: the same series keys over the smoothed
estimate (no ``nis``), its NEES consistency against truth in the same blocks and
``smoother_cuts``; null for a method the smoother did not run.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from typing import IO, Any

import numpy as np

from app.commands.outputs import write_text_atomic
from app.commands.values import UsageError
from app.reports.payload import config_to_json, consistency_to_json, nis_series, result_series
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult
from tauvcore.eval.running import MethodSummary, RunningSummary
from tauvcore.validation import show_path

BLOCK_VALUES = 65536
"""Values read back and formatted at a time (0.5 MB of doubles)."""


class RunJsonWriter:
    """The ``--json`` document of a run, fed chunk by chunk (module docstring).

    Parameters
    ----------
    path : str
        The output file (its directory must be writable; checked before the run).
    config : Config
        The run's configuration: the document's ``config``, and the origin of ``est_lat_deg`` etc.
    log : dict[str, Any] or None
        A replay's ``log`` section (app.reports.payload.run_payload: its directory, configuration, start
        and notes), written between ``config`` and ``results``; None: a run's document, without.
    smoothed : bool
        Whether the run smooths (:meth:`add_smoothed`): each method then gets ``"smoothed"``.
    """

    def __init__(
        self, path: str, config: Config, log: dict[str, Any] | None = None, smoothed: bool = False
    ) -> None:
        self.path = path
        self.smoothed = smoothed
        self.smoothed_series: dict[str, list[str]] = {}  # method -> its smoothed series' names
        self.smoothed_last: dict[str, MethodResult] = {}  # each smoothed method's latest chunk
        self.config = config
        self.log = log
        self.origin = (config.earth.latitude_rad, config.earth.longitude_rad)
        self.spool = tempfile.mkdtemp(prefix=".tauv-", suffix=".json.parts", dir=os.path.dirname(path) or ".")
        self.series: dict[str, list[str]] = {}  # method -> its series' names, in the document's order
        self.sources: dict[str, list[str]] = {}  # method -> its NIS sources, in the order they came
        self.last: dict[str, MethodResult] = {}  # each method's latest chunk: its verdict so far

    def _file(self, method: str, name: str) -> str:
        return os.path.join(self.spool, f"{method}.{name}.bin")

    def add(self, results: dict[str, MethodResult]) -> None:
        """Append one chunk's run-0 series and NIS records.

        Parameters
        ----------
        results : dict[str, MethodResult]
            Method name -> its results over the chunk.

        Raises
        ------
        OSError
            The spool could not be written (a full disk): the caller removes it (:meth:`discard`).
        """
        for method, r in results.items():
            self.last[method] = r
            if r.t_s.size:
                series = result_series(r, 0, self.origin)
                self.series.setdefault(method, list(series))
                for name, values in series.items():
                    _append(self._file(method, name), np.asarray(values, dtype=np.float64))
            sources = self.sources.setdefault(method, [])
            for source, record in r.updates.items():
                if source not in sources:
                    sources.append(source)
                t, nis, dof = nis_series(record, 0)
                _append(self._file(method, f"nis.{source}.t"), np.asarray(t, dtype=np.float64))
                _append(self._file(method, f"nis.{source}.nis"), np.asarray(nis, dtype=np.float64))
                _append(self._file(method, f"nis.{source}.dof"), np.asarray(dof, dtype=np.int64))

    def add_smoothed(self, results: dict[str, MethodResult]) -> None:
        """Append one chunk's run-0 smoothed series (the engine's ``on_smoothed_chunk``).

        Parameters
        ----------
        results : dict[str, MethodResult]
            Method name -> its smoothed results over the chunk.

        Raises
        ------
        OSError
            The spool could not be written: the caller removes it (:meth:`discard`).
        """
        for method, r in results.items():
            self.smoothed_last[method] = r
            if r.t_s.size:
                series = result_series(r, 0, self.origin)
                self.smoothed_series.setdefault(method, list(series))
                for name, values in series.items():
                    _append(self._file(method, "smoothed." + name), np.asarray(values, dtype=np.float64))

    def write(
        self, summaries: dict[str, MethodSummary], smoothed: dict[str, MethodSummary] | None = None
    ) -> None:
        """Write the document to ``path`` (atomically) and remove the spool.

        Parameters
        ----------
        summaries : dict[str, MethodSummary]
            The run's summaries (tauvcore.eval.running.RunningSummary): each method's consistency.
        smoothed : dict[str, MethodSummary] or None
            The smoothed methods' summaries (their consistency); None: none.

        Raises
        ------
        OSError
            The document could not be written: ``path`` is untouched, nothing is left behind.
        """

        def document(fh: IO[str]) -> None:
            fh.write('{"config": ')
            json.dump(config_to_json(self.config), fh, allow_nan=False)
            if self.log is not None:
                fh.write(', "log": ')
                json.dump(self.log, fh, allow_nan=False)
            fh.write(', "results": {')
            for k, method in enumerate(self.last):
                fh.write(("" if k == 0 else ", ") + json.dumps(method) + ": ")
                self._method(fh, method, summaries[method], (smoothed or {}).get(method))
            fh.write("}}")

        try:
            write_text_atomic(self.path, document)
        finally:
            self.discard()

    def _method(
        self, fh: IO[str], method: str, summary: MethodSummary, smoothed: MethodSummary | None
    ) -> None:
        fh.write("{")
        for name in self.series.get(method, []):
            fh.write(json.dumps(name) + ": ")
            _write_list(fh, self._file(method, name), np.float64)
            fh.write(", ")
        fh.write('"nis": {')
        for k, source in enumerate(self.sources.get(method, [])):
            fh.write(("" if k == 0 else ", ") + json.dumps(source) + ': {"t": ')
            _write_list(fh, self._file(method, f"nis.{source}.t"), np.float64)
            fh.write(', "nis": ')
            _write_list(fh, self._file(method, f"nis.{source}.nis"), np.float64)
            fh.write(', "dof": ')
            _write_list(fh, self._file(method, f"nis.{source}.dof"), np.int64)
            fh.write("}")
        last = self.last[method]
        diverged_at = float(last.diverged_at_s[0])
        tail: dict[str, Any] = {
            "consistency": consistency_to_json(summary.consistency),
            "counts": summary.counts.to_json(),
            "diverged": bool(last.diverged[0]),
            "diverged_at_s": diverged_at if np.isfinite(diverged_at) else None,
            "p_floor_count": int(last.p_floor_count[0]),
        }
        fh.write("}")
        if self.smoothed:
            fh.write(', "smoothed": ')
            self._smoothed(fh, method, smoothed)
        fh.write(", " + json.dumps(tail, allow_nan=False)[1:])

    def _smoothed(self, fh: IO[str], method: str, summary: MethodSummary | None) -> None:
        """A method's ``"smoothed"`` object: its series, consistency and cuts; null if not smoothed."""
        last = self.smoothed_last.get(method)
        if last is None or summary is None:
            fh.write("null")
            return
        fh.write("{")
        for name in self.smoothed_series.get(method, []):
            fh.write(json.dumps(name) + ": ")
            _write_list(fh, self._file(method, "smoothed." + name), np.float64)
            fh.write(", ")
        cuts = last.smoother_cuts
        tail = {
            "consistency": consistency_to_json(summary.consistency),
            "smoother_cuts": int(cuts[0]) if cuts is not None else 0,
        }
        fh.write(json.dumps(tail, allow_nan=False)[1:])

    def discard(self) -> None:
        """Remove the spool (after :meth:`write`, or when the run failed)."""
        shutil.rmtree(self.spool, ignore_errors=True)


class RunReduction:
    """What ``tauv run`` and ``tauv replay`` make of the results as the engine hands them out: the
    summary's running sums (tauvcore.eval.running) and, with ``--json``, the document spooled as it
    goes (:class:`RunJsonWriter`). A failure to write the document is one line naming ``--json``,
    its file and the reason.

    Parameters
    ----------
    config : Config
        The run's configuration.
    json_path : str or None
        The ``--json`` output, checked (app.commands.outputs.json_target); None: no document.
    json_arg : str or None
        ``--json`` as given, for the message.
    log : dict[str, Any] or None
        A replay's ``log`` section (:class:`RunJsonWriter`).
    smoothed : bool
        Whether the run smooths: the smoothed chunks (:meth:`add_smoothed`) get their own sums
        (:attr:`smoothed_summaries`) and their series in the document.

    Raises
    ------
    UsageError
        The document's spool cannot be made.
    """

    def __init__(
        self,
        config: Config,
        json_path: str | None,
        json_arg: str | None,
        log: dict[str, Any] | None = None,
        smoothed: bool = False,
    ) -> None:
        self.running = RunningSummary()
        self.smoothed = RunningSummary() if smoothed else None
        self.smoothed_summaries: dict[str, MethodSummary] | None = None  # after finish, with smoothed
        self.json_name = show_path(str(json_arg))
        self.writer = (
            None
            if json_path is None
            else self._writing(RunJsonWriter, json_path, config, log=log, smoothed=smoothed)
        )

    def _writing(self, write: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return write(*args, **kwargs)
        except OSError as exc:
            raise UsageError(f"--json: cannot write {self.json_name}: {exc.strerror or exc}") from None

    def add(self, results: dict[str, MethodResult]) -> None:
        """One chunk of results: into the sums and the document (the engine's ``on_chunk``)."""
        self.running.add(results)
        if self.writer is not None:
            self._writing(self.writer.add, results)

    def add_smoothed(self, results: dict[str, MethodResult]) -> None:
        """One chunk of smoothed results: into their sums and the document (the engine's
        ``on_smoothed_chunk``)."""
        if self.smoothed is not None:
            self.smoothed.add(results)
        if self.writer is not None:
            self._writing(self.writer.add_smoothed, results)

    def discard(self) -> None:
        """The run failed or was interrupted: the document's spool goes, the output untouched."""
        if self.writer is not None:
            self.writer.discard()

    def finish(self) -> dict[str, MethodSummary]:
        """The run's summaries; with ``--json`` the document written (atomically) from them.

        Returns
        -------
        dict[str, MethodSummary]
            Method name -> its summary (tauvcore.eval.running.RunningSummary.summaries); the
            smoothed methods' are then :attr:`smoothed_summaries`.
        """
        summaries = self.running.summaries()
        if self.smoothed is not None:
            self.smoothed_summaries = self.smoothed.summaries()
        if self.writer is not None:
            self._writing(self.writer.write, summaries, self.smoothed_summaries)
        return summaries


def _append(path: str, values: np.ndarray) -> None:
    with open(path, "ab") as fh:
        fh.write(np.ascontiguousarray(values).tobytes())


def _write_list(fh: IO[str], path: str, dtype: type) -> None:
    """A spooled array as a JSON list: floats as JSON writes them (their repr), null where not
    finite; integers as integers."""
    values = np.fromfile(path, dtype=dtype) if os.path.exists(path) else np.zeros(0, dtype)
    fh.write("[")
    for start in range(0, values.size, BLOCK_VALUES):
        block = values[start : start + BLOCK_VALUES]
        if dtype is np.int64:
            text = ", ".join(str(v) for v in block.tolist())
        else:
            finite = np.isfinite(block)
            text = ", ".join(
                repr(v) if ok else "null" for v, ok in zip(block.tolist(), finite.tolist(), strict=True)
            )
        fh.write((", " if start else "") + text)
    fh.write("]")
