"""A dashboard run as files to keep: its results as the command line writes them, and a report
that opens offline.

- ``json``: the document ``tauv run --json`` writes for the same configuration and seed
  (app.reports.payload.run_payload), byte for byte: the configuration, and per method the per-epoch series,
  NIS and consistency of run 0 (with the smoother's results, per method its ``"smoothed"``). A Monte Carlo run (Runs > 1) adds ``"num_runs"``; every run's
  series are in the Parquet file (the CLI's JSON holds one run).
- ``parquet``: the long form of ``tauv mc``'s runs.parquet (app.reports.study_output.runs_table): one row
  per method, run and epoch, the errors and NEES as 32-bit floats; ``trajectory`` is the
  trajectory's name, or the replayed log's.
- ``mcap``: run 0's estimates, 1-sigma, errors, innovations (and the smoother's, and a simulation's
  truth) as ROS 2 messages in an MCAP file, as ``tauv run --mcap`` writes them
  (app.reports.mcap_export), for Foxglove or PlotJuggler.
- ``html``: one self-contained page (plotly.js embedded inline, nothing fetched when it opens):
  the configuration, the Results tab's tables (app.reports.markdown_tables.summary_markdown, the updates
  per source), the error and NEES/dim figures (with the smoother's results, its table and curves too), and the full
  configuration as JSON.

Everything here is a pure function of the finished run, tested without a browser
(tests/unit/app/dashboard/test_export.py); the dashboard's buttons call :func:`send`.
"""

from __future__ import annotations

import html
import io
import json
import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import viser

from app.dashboard.inputs import config_rows
from app.figures.error_figures import AUTO, error_figure, nees_figure
from app.reports.markdown_tables import counts_markdown, smoothed_markdown, summary_markdown
from app.reports.payload import config_to_json, run_payload
from app.reports.settings_text import file_stem, has_smoothed
from app.reports.study_output import PARQUET_WRITE_OPTIONS, runs_table
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult
from tauvcore.eval.study import ChunkSeries, series_of, study_config

FORMATS = {"json": "JSON", "parquet": "Parquet", "html": "HTML report", "mcap": "MCAP"}
"""Download kind -> its button's label."""
FORMAT_HINTS = {
    "json": "the configuration and per-epoch results, as `tauv run --json` writes them",
    "parquet": "every run's per-epoch errors and NEES, long form, as `tauv mc` writes runs.parquet",
    "html": "one page that opens offline: configuration, results tables, error and NEES figures",
    "mcap": "run 0's estimates, 1-sigma, errors, innovations and truth as ROS 2 messages, "
    "as `tauv run --mcap` writes them, for Foxglove or PlotJuggler",
}
REPORT_FIGURES = ("vel", "tilt", "heading", "pos")
"""The report's error figures (app.figures.error_figures.error_figure quantities), then NEES/dim of the full state."""
REPORT_MAX_POINTS = 2000
"""Points per trace in the report's figures (evenly strided, the last epoch kept): a 1440 s run at
10 Hz has 14,400 epochs, which would make the page tens of MB for no visible difference."""


class ExportError(Exception):
    """The run cannot be exported as asked; the message says why, in one line."""


@dataclass(frozen=True)
class FinishedRun:
    """A run whose final results arrived (a stopped run's are final up to where it stopped)."""

    config: Config  # the configuration it ran (a replayed log's, as the log made it)
    results: dict[str, MethodResult]  # every method's, at every output epoch
    log: str | None = None  # the replayed log's name; None: a simulation
    stopped: bool = False  # Stop ended it before the requested duration
    source: dict[str, Any] | None = (
        None  # the replayed log as app.dashboard.worker.replay_source describes it
    )

    @property
    def runs(self) -> int:
        """Monte Carlo runs (the results' second axis)."""
        return int(next(iter(self.results.values())).vel_err_mps.shape[1]) if self.results else 0


def finished_run(
    config: Config,
    results: dict[str, MethodResult],
    log: str | None = None,
    stopped: bool = False,
    source: dict[str, Any] | None = None,
) -> FinishedRun:
    """The run as the worker ran ``config``: with more than one run, each draws its initial errors
    (app.dashboard.worker.run_worker, as a study does: tauvcore.eval.study.study_config), so the exported
    configuration says so."""
    run = FinishedRun(config, results, log, stopped, source)
    if run.runs > 1:
        run = FinishedRun(study_config(config), results, log, stopped, source)
    return run


@dataclass(frozen=True)
class File:
    """One file to download."""

    name: str  # file name offered to the browser
    content: bytes


def _check(run: FinishedRun | None) -> FinishedRun:
    if run is None:
        raise ExportError("no results yet: press Run and wait until the run completes (or Stop it)")
    if not run.results or any(len(r.t_s) == 0 for r in run.results.values()):
        raise ExportError("the run ended before its first output epoch: there is nothing to export")
    return run


def file_name(run: FinishedRun, kind: str) -> str:
    """``tauv-<trajectory or log-name>-<duration>s-seed<seed>[-<setting>...].<ext>``: a token for
    every setting that differs from the defaults, the smoother and the runs of a Monte Carlo among
    them (app.reports.settings_text.file_stem: only letters, digits, ``.``, ``_`` and ``-``, a
    bounded length, the same name for the same run)."""
    smoothed = has_smoothed(run.results.values())
    return f"{file_stem(run.config, run.runs, run.log, smoothed)}.{kind}"


def results_json(run: FinishedRun) -> bytes:
    """The run as ``tauv run --json`` writes it (``tauv replay --json`` for a log, with the log's
    name for its path), plus ``"num_runs"`` after ``"results"`` when Runs > 1: strict UTF-8
    JSON, non-finite numbers as null."""
    run = _check(run)
    payload = run_payload(run.config, run.results, log=run.source if run.source is not None else run.log)
    if run.runs > 1:
        payload["num_runs"] = run.runs
    # the options write_json_atomic gives json.dump: the same text, byte for byte
    return json.dumps(payload, allow_nan=False).encode("utf-8")


def _chunks(results: dict[str, MethodResult]) -> list[ChunkSeries]:
    """The results as study chunks (all runs, first 0): one per set of methods that share their
    output epochs (every method of a finished run does; a chunk's table needs one time axis)."""
    groups: list[tuple[np.ndarray, list[str]]] = []
    for method, result in results.items():
        for t_s, methods in groups:
            if np.array_equal(t_s, result.t_s):
                methods.append(method)
                break
        else:
            groups.append((result.t_s, [method]))
    runs = int(next(iter(results.values())).vel_err_mps.shape[1])
    return [
        ChunkSeries(
            first=0,
            count=runs,
            t_s=t_s,
            series={m: series_of(results[m]) for m in methods},
            diverged={m: results[m].diverged for m in methods},
        )
        for t_s, methods in groups
    ]


def results_parquet(run: FinishedRun) -> bytes:
    """Every run's per-epoch series in ``tauv mc``'s runs.parquet schema and encoding
    (app.reports.study_output.runs_table, PARQUET_WRITE_OPTIONS)."""
    import pyarrow.parquet as pq

    run = _check(run)
    trajectory = run.log if run.log is not None else run.config.trajectory.name
    buffer = io.BytesIO()
    writer = None
    for chunk in _chunks(run.results):
        table = runs_table(trajectory, chunk)
        if writer is None:
            writer = pq.ParquetWriter(buffer, table.schema, **PARQUET_WRITE_OPTIONS)
        writer.write_table(table)
    assert writer is not None  # _check: at least one method
    writer.close()
    return buffer.getvalue()


def results_mcap(run: FinishedRun) -> bytes:
    """Run 0 as ``tauv run --mcap`` writes it (app.reports.mcap_export): a simulation's truth made
    again from its configuration; a replayed log's stamped from its start, without its reference
    (``tauv replay --mcap`` writes both)."""
    from app.reports.mcap_export import mcap_bytes, simulated_truth

    run = _check(run)
    truth = simulated_truth(run.config) if run.log is None else ()
    return mcap_bytes(run.config, run.results, truth=truth)


def _inline(text: str) -> str:
    """Escaped text with Markdown's ``**bold**`` and ``*italic*``."""
    text = html.escape(text)
    text = re.sub(r"\*\*(.+?)\*\*", r"<b>\1</b>", text)
    return re.sub(r"\*(.+?)\*", r"<i>\1</i>", text)


def _table(rows: list[list[str]], header: bool = True) -> str:
    head, body = (rows[0], rows[1:]) if header else (None, rows)
    parts = ["<table>"]
    if head is not None:
        parts.append("<tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head) + "</tr>")
    parts += ["<tr>" + "".join(f"<td>{_inline(c)}</td>" for c in row) + "</tr>" for row in body]
    return "".join(parts + ["</table>"])


def markdown_html(text: str) -> str:
    """The Markdown the Results tab shows (pipe tables, paragraphs with bold or italic) as HTML."""
    out: list[str] = []
    table: list[list[str]] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(c and set(c) <= set("-:") for c in cells):  # not the |---|---| line
                table.append(cells)
            continue
        if table:
            out.append(_table(table))
            table = []
        if line.strip():
            out.append(f"<p>{_inline(line)}</p>")
    return "".join(out)


REPORT_STYLE = (
    "body{font-family:sans-serif;margin:2em auto;max-width:1300px;padding:0 1em}"
    "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;padding:3px 8px}"
    "td+td,th+th{text-align:right}.figures{display:grid;grid-template-columns:1fr 1fr;gap:8px}"
    "pre{background:#f6f6f6;padding:1em;overflow:auto}"
)


def report_html(run: FinishedRun, max_points: int | None = REPORT_MAX_POINTS) -> str:
    """The run as one HTML page that needs no network: a heading naming the mission, the
    configuration table (the Results tab's, app.dashboard.inputs.config_rows), the results tables
    (app.reports.markdown_tables.summary_markdown; with the smoother's results its smoothed_markdown), the
    error figures REPORT_FIGURES and NEES/dim of the full state (at most ``max_points`` points per
    trace; the smoothed curves beside the filtered where the run has them), and the full
    configuration as JSON.
    plotly.js is embedded once, inline; no element loads anything (no ``src`` or ``href`` to
    a network address)."""
    run = _check(run)
    config, results = run.config, run.results
    what = (
        f"log {run.log}"
        if run.log is not None
        else f"{config.trajectory.name} ({config.trajectory.truth} truth)"
    )
    t_end = max(float(r.t_s[-1]) for r in results.values())
    title = f"tauv run: {what}, {t_end:g} s, seed {config.run.seed}"
    ended = f"stopped at t = {t_end:g} s" if run.stopped else "complete"
    description = (
        f"Methods {', '.join(m.upper() for m in results)}; {run.runs} run(s); {ended}. "
        "Exported from the tauv dashboard; the JSON and Parquet downloads hold every epoch."
    )
    smoothed = smoothed_markdown(results)  # "" unless the run has the smoother's results
    figures = [
        error_figure(results, q, log_y=AUTO, height_px=340, max_points=max_points, smoothed=bool(smoothed))
        for q in REPORT_FIGURES
    ]
    figures.append(
        nees_figure(results, "full", height_px=340, max_points=max_points, smoothed=bool(smoothed))
    )
    plots = [
        f.to_html(
            full_html=False, include_plotlyjs=k == 0, include_mathjax=False, config={"displaylogo": False}
        )
        for k, f in enumerate(figures)
    ]
    settings = [
        ["Setting", "Value"],
        *([name, value] for name, value in config_rows(config, run.runs, run.source)),
    ]
    full_config = json.dumps(config_to_json(config), indent=2, allow_nan=False)
    parts = [
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>",
        f"<style>{REPORT_STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p>{html.escape(description)}</p>",
        "<h2>Configuration</h2>",
        _table(settings),
        "<h2>Results</h2>",
        markdown_html(
            summary_markdown(results)
            + f"\n\n{counts_markdown(results)}"
            + (f"\n\n{smoothed}" if smoothed else "")
        ),
        "<h2>Figures</h2><div class='figures'>",
        *(f"<div>{p}</div>" for p in plots),
        "</div>",
        "<h2>Full configuration</h2><details><summary>as <code>tauv config</code> prints it (JSON)</summary>",
        f"<pre>{html.escape(full_config, quote=False)}</pre></details>",
        "</body></html>",
    ]
    return "".join(parts)


def make(kind: str, run: FinishedRun | None) -> File:
    """The download ``kind`` (one of FORMATS) of ``run``; ExportError if there is none to make."""
    if kind not in FORMATS:
        raise ExportError(f"unknown download {kind!r}; choose from {', '.join(FORMATS)}")
    run = _check(run)
    if kind == "json":
        content = results_json(run)
    elif kind == "parquet":
        content = results_parquet(run)
    elif kind == "mcap":
        content = results_mcap(run)
    else:
        content = report_html(run).encode("utf-8")
    return File(file_name(run, kind), content)


def send(client: viser.ClientHandle, kind: str, run: FinishedRun | None) -> File:
    """Make the download ``kind`` of ``run`` and send it to ``client``'s browser, which saves it
    at once (viser's file transfer, in 1 MB parts); ExportError if there is none to make."""
    file = make(kind, run)
    client.send_file_download(file.name, file.content, save_immediately=True)
    return file


__all__ = [
    "FORMATS",
    "ExportError",
    "File",
    "FinishedRun",
    "file_name",
    "finished_run",
    "make",
    "markdown_html",
    "report_html",
    "results_json",
    "results_mcap",
    "results_parquet",
    "send",
]
