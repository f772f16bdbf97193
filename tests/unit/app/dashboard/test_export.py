"""A dashboard run's downloads (app/dashboard/export.py), against the command line's files.

The JSON must be what ``tauv run --json`` writes for the same configuration and seed, byte for
byte; the Parquet what ``tauv mc``'s study writer makes of the same results, in the schema of a
real ``tauv mc`` runs.parquet; the HTML report must open without a network.
"""

from __future__ import annotations

import dataclasses
import io
import json
import re
import types

import numpy as np
import pyarrow.parquet as pq
import pytest

from app import cli
from app.dashboard import export
from app.dashboard.export import ExportError, FinishedRun
from app.reports.markdown_tables import CONSISTENCY_COLUMNS, ERROR_COLUMNS, summary_markdown
from app.reports.study_output import PARQUET_SERIES, StudyWriter
from tauvcore.engine.mission import run_streaming
from tauvcore.eval.study import ChunkSeries, series_of

ARGV = ["--trajectory", "straight", "--duration", "10", "--method", "ins,lc,tc", "--beams", "1,2,3", "--seed", "3"]


@pytest.fixture(scope="module")
def finished() -> FinishedRun:
    """The run a dashboard makes of ARGV's setup: the same configuration, the seed's generator."""
    config = cli.resolve_config(cli.build_parser().parse_args(["run", *ARGV]))
    return FinishedRun(config, run_streaming(config, np.random.default_rng(config.run.seed)))


@pytest.fixture(scope="module")
def cli_json(tmp_path_factory) -> bytes:
    path = tmp_path_factory.mktemp("cli") / "out.json"
    assert cli.main(["run", *ARGV, "--json", str(path)]) == 0
    return path.read_bytes()


def _table(content: bytes):
    return pq.read_table(io.BytesIO(content))


def test_json_is_what_tauv_run_writes_byte_for_byte(finished, cli_json) -> None:
    download = export.make("json", finished)
    assert download.name == "tauv-straight-10s-seed3-ins_lc_tc-beams123.json"
    assert download.content == cli_json


def test_json_of_a_monte_carlo_run_keeps_the_schema_and_says_how_many_runs(finished) -> None:
    config = finished.config.replace("initial_error", mode="random")      # as app.dashboard.worker runs Runs > 1
    run = export.finished_run(finished.config, run_streaming(config, np.random.default_rng(3), 2))
    assert run.config == config
    data = json.loads(export.results_json(run))
    assert list(data) == ["config", "results", "num_runs"] and data["num_runs"] == 2
    assert data["config"]["initial_error"]["mode"] == "random"
    assert export.finished_run(finished.config, finished.results).config == finished.config
    one = json.loads(export.results_json(finished))
    assert set(data["results"]["lc"]) == set(one["results"]["lc"])
    assert export.file_name(run, "json") == "tauv-straight-10s-seed3-ins_lc_tc-beams123-2runs.json"


def test_parquet_is_the_study_writer_s_table_of_the_same_results(finished, tmp_path) -> None:
    writer = StudyWriter(str(tmp_path / "study"))
    results = finished.results
    writer.add_chunk("straight", ChunkSeries(first=0, count=1, t_s=results["lc"].t_s,
                                             series={m: series_of(r) for m, r in results.items()},
                                             diverged={m: r.diverged for m, r in results.items()}))
    writer.finish({}, "")
    writer.commit()
    study = pq.read_table(tmp_path / "study" / "runs.parquet")
    download = _table(export.make("parquet", finished).content)
    assert download.equals(study)
    assert download.column_names == ["trajectory", "method", "run", "t_s", *PARQUET_SERIES]


def test_parquet_holds_the_json_s_series_and_tauv_mc_s_schema(finished, cli_json, tmp_path) -> None:
    table = _table(export.results_parquet(finished))
    data = json.loads(cli_json)["results"]
    T = len(data["lc"]["t"])
    assert table.num_rows == 3 * T and set(table.column("run").to_pylist()) == {0}
    assert table.column("method").to_pylist() == [m for m in data for _ in range(T)]
    for k, method in enumerate(data):
        rows = slice(k * T, (k + 1) * T)
        assert np.array_equal(np.asarray(table.column("t_s"))[rows], data[method]["t"])
        for name in PARQUET_SERIES:
            expected = np.array([np.nan if v is None else v for v in data[method][name]], dtype=np.float32)
            np.testing.assert_array_equal(np.asarray(table.column(name))[rows], expected, err_msg=f"{method} {name}")
    out = tmp_path / "mc"
    assert cli.main(["mc", "--duration", "2", "--method", "lc", "--runs", "1", "--out", str(out)]) == 0
    assert table.schema.equals(pq.read_table(out / "runs.parquet").schema)


def test_the_report_opens_offline_with_configuration_tables_and_figures(finished) -> None:
    download = export.make("html", finished)
    assert download.name == "tauv-straight-10s-seed3-ins_lc_tc-beams123.html"
    page = download.content.decode("utf-8")
    # plotly.js inline (a few MB), nothing loaded from elsewhere: no script or stylesheet by address
    assert len(page) > 1_000_000 and "plotly.js" in page.lower()
    scripts = re.findall(r"<script\b[^>]*>", page)
    assert scripts and not any("src" in tag for tag in scripts)
    outside = re.sub(r"<script\b[^>]*>.*?</script>", "", page, flags=re.S)
    assert not re.search(r"""(?:src|href|action)\s*=\s*["']?\s*(?:https?:)?//""", outside, flags=re.I)
    assert "<link" not in outside and "@import" not in outside and "url(" not in outside
    # the configuration, the Results tab's two tables, and the figures
    assert re.search(r"<tr><td>Seed</td><td>3</td></tr>", outside)
    assert re.search(r"<tr><td>DVL beams</td><td>1, 2, 3</td></tr>", outside)
    for column in ERROR_COLUMNS + CONSISTENCY_COLUMNS:
        assert f"<th>{column}</th>" in outside
    for method in ("INS", "LC", "TC"):
        assert f"<td>{method}</td>" in outside
    # the updates per source: each method's DVL bottom-track fused / rejected / unused, and coasted
    assert "<b>Updates per source</b>" in outside and "<th>DVL bottom-track</th>" in outside
    assert re.search(r"<tr><td>LC</td><td>\d+ / \d+ / \d+</td><td>\d+ of \d+</td></tr>", outside), outside[-3000:]
    assert page.count("Plotly.newPlot(") == 5
    for title in ("Velocity error", "Tilt error", "Heading error", "Position error", "NEES/dim"):
        assert title in page
    assert '"duration_s": 10.0' in outside          # the full configuration


def test_markdown_tables_become_html_tables(finished) -> None:
    html = export.markdown_html(summary_markdown(finished.results))
    assert html.count("<table>") == 2 and "|" not in html and "---" not in html
    assert "<p><b>Consistency</b>" in html


@pytest.mark.parametrize("kind", list(export.FORMATS))
def test_no_run_or_an_empty_one_is_refused_with_a_reason(kind, finished) -> None:
    with pytest.raises(ExportError, match="no results yet"):
        export.make(kind, None)
    empty = {m: r for m, r in finished.results.items() if False}
    with pytest.raises(ExportError, match="nothing to export"):
        export.make(kind, FinishedRun(finished.config, empty))


def test_an_unknown_kind_is_refused(finished) -> None:
    with pytest.raises(ExportError, match="unknown download 'csv'"):
        export.make("csv", finished)


def test_a_log_s_name_makes_a_safe_file_name_and_the_trajectory_column(finished) -> None:
    run = FinishedRun(finished.config, finished.results, log="../my log/é")
    assert re.fullmatch(r"tauv-log-[A-Za-z0-9._-]+-10s-seed3-ins_lc_tc-beams123\.parquet", export.file_name(run, "parquet"))
    assert set(_table(export.results_parquet(run)).column("trajectory").to_pylist()) == {"../my log/é"}
    assert json.loads(export.results_json(run))["log"] == "../my log/é"


def test_a_replayed_log_s_downloads_name_it_and_what_configured_it(finished) -> None:
    """A replay's JSON holds the log as ``tauv replay --json`` does (directory, its own
    configuration file, the layers, the start); the report's configuration table names the log
    instead of a simulated trajectory."""
    source = {"name": "dive7", "directory": "/data/dive7", "config_file": "/data/dive7/log.toml",
              "configuration": ["defaults", "the log's /data/dive7/log.toml (dvl.lever_arm_m)",
                                "the dashboard's controls"],
              "start": "start: on the reference's state at t = 0 s", "notes": []}
    run = FinishedRun(finished.config, finished.results, log="dive7", source=source)
    assert json.loads(export.results_json(run))["log"] == source
    page = export.report_html(run)
    assert "log dive7" in page and "/data/dive7/log.toml" in page and "start: on the reference" in page
    assert "<td>Trajectory</td>" not in page and "<td>Seabed</td>" not in page


def test_the_dashboard_s_download_button_notifies_instead_of_raising(finished) -> None:
    """app.dashboard.session_runs.RunTabs.download: no run, or a failure while sending, is a notification in
    the tab (red, naming why), never an exception in viser's callback thread."""
    from app.dashboard.session_runs import RunTabs

    class Client:
        def __init__(self, fail: bool) -> None:
            self.fail, self.sent = fail, []

        def send_file_download(self, name: str, content: bytes, save_immediately: bool = False) -> None:
            if self.fail:
                raise OSError("connection reset")
            self.sent.append((name, len(content), save_immediately))

    notes: list[tuple[str, str, bool]] = []

    def tab(run, fail=False):
        return types.SimpleNamespace(client=Client(fail), finished_run=run,
                                     notify=lambda title, body, error=False: notes.append((title, body, error)))

    RunTabs.download(tab(None), "json")
    assert notes == [("Cannot download", "no results yet: press Run and wait until the run completes (or Stop it)",
                      True)]
    notes.clear()
    ok = tab(finished)
    RunTabs.download(ok, "parquet")
    assert notes == [] and [(name, now) for name, _, now in ok.client.sent] == [("tauv-straight-10s-seed3-ins_lc_tc-beams123.parquet",
                                                                                 True)]
    RunTabs.download(tab(finished, fail=True), "json")
    assert notes == [("Cannot download", "JSON: OSError: connection reset", True)]


def test_a_smoothed_run_s_files_are_named_apart_from_the_same_run_unsmoothed(finished) -> None:
    smoothed = {m: dataclasses.replace(r, smoothed=r) for m, r in finished.results.items()}
    run = FinishedRun(finished.config, smoothed)
    assert export.file_name(run, "json") == "tauv-straight-10s-seed3-ins_lc_tc-beams123-smoothed.json"
    assert export.file_name(run, "json") != export.file_name(finished, "json")
