"""``tauv mc`` end to end on a short mission, and its bad input.

The study writes summary.json, runs.parquet and report.html into --out only when it has
finished: bad input, an unreachable Dask scheduler or an interrupt leave no result file and no
temporary directory behind.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pyarrow.parquet as pq
import pytest

from app import cli
from app.reports.study_output import OUTPUT_FILES, PARQUET_SERIES
from tauvcore.eval import study

SHORT = ["--trajectory", "figure8", "--method", "ins,tc", "--beams", "1,2", "--duration", "20", "--seed", "3"]


def _strict_json(path: str):
    def refuse(name):
        raise ValueError(f"non-finite number {name} in strict JSON")
    with open(path, encoding="utf-8") as fh:
        return json.load(fh, parse_constant=refuse)


def _leftovers(out) -> list[str]:
    return sorted(os.listdir(out)) if os.path.isdir(out) else []


def test_a_study_writes_its_three_files(tmp_path, capsys):
    out = tmp_path / "study"
    assert cli.main(["mc", *SHORT, "--runs", "4", "--out", str(out)]) == 0
    assert _leftovers(out) == sorted(set(OUTPUT_FILES) - {"paper_comparison.md"})   # no temporary directory left
    summary = _strict_json(out / "summary.json")
    methods = summary["trajectories"]["figure8"]["methods"]
    assert set(methods) == {"ins", "tc"} and summary["num_runs"] == 4
    T = len(summary["trajectories"]["figure8"]["t_s"])
    assert T == 201
    for m in methods.values():
        assert len(m["rms"]["vel_err_mps"]) == T and len(m["final_per_run"]["tilt_err_deg"]) == 4
        assert set(m["consistency"]) == {"full", "pos", "vel", "tilt", "heading", "sensor"}
    table = pq.read_table(out / "runs.parquet")
    assert table.num_rows == 2 * 4 * T
    assert set(PARQUET_SERIES) <= set(table.column_names)
    assert table.column("method").to_pylist() == ["ins"] * 4 * T + ["tc"] * 4 * T
    assert set(table.column("trajectory").to_pylist()) == {"figure8"}
    assert table.column("run").to_pylist()[:T + 1] == [0] * T + [1]
    # the Parquet rows are the summary's runs: RMS over runs at the end, from either
    vel = np.asarray(table.column("vel_err_mps")).reshape(2, 4, T)          # method-major, run-major
    assert methods["tc"]["final_rms"]["vel_err_mps"] == pytest.approx(float(np.sqrt(np.mean(vel[1, :, -1] ** 2.0))),
                                                                    rel=1e-6)           # float32 in the file
    page = (out / "report.html").read_text(encoding="utf-8")
    # plotly.js inline (a few MB), nothing loaded from elsewhere: no script or stylesheet by URL
    assert len(page) > 1_000_000 and "<script src=" not in page and "<link " not in page
    assert "figure8" in page
    printed = capsys.readouterr().out
    assert "TC" in printed and "wrote" in printed


def test_the_same_seed_gives_the_same_numbers_with_any_number_of_workers(tmp_path):
    a, b = tmp_path / "one", tmp_path / "two"
    assert cli.main(["mc", *SHORT, "--runs", "12", "--out", str(a), "--workers", "1"]) == 0
    assert cli.main(["mc", *SHORT, "--runs", "12", "--out", str(b), "--workers", "2"]) == 0
    assert _strict_json(a / "summary.json") == _strict_json(b / "summary.json")
    assert pq.read_table(a / "runs.parquet").equals(pq.read_table(b / "runs.parquet"))


@pytest.mark.parametrize("extra, message", [
    (["--runs", "0"], "--runs: must be a whole number from 1 to 100000, got '0'"),
    (["--runs", "abc"], "--runs"),
    (["--runs", "2", "--workers", "0"], "--workers: must be a whole number from 1 to 64, got '0'"),
    (["--runs", "2", "--workers", "-1"], "--workers"),
    (["--runs", "2", "--dask", ""], "--dask: expected a scheduler address"),
    (["--runs", "2", "--dask", "tcp://127.0.0.1:9", "--workers", "2"], "--workers: not with --dask"),
    (["--runs", "2", "--method", "bogus"], "--method"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, extra, message):
    out = tmp_path / "study"
    assert cli.main(["mc", "--duration", "5", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in err[0]
    assert not out.exists()


def test_an_output_that_cannot_be_a_directory_is_refused(tmp_path, capsys):
    a_file = tmp_path / "file"
    a_file.write_text("keep me")
    assert cli.main(["mc", "--duration", "5", "--runs", "2", "--out", str(a_file)]) == 2
    assert "is not a directory" in capsys.readouterr().err
    assert a_file.read_text() == "keep me"
    assert cli.main(["mc", "--duration", "5", "--runs", "2", "--out", str(tmp_path / "no" / "such")]) == 2
    assert "no such parent directory" in capsys.readouterr().err


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_an_unwritable_directory_is_refused(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    assert cli.main(["mc", "--duration", "5", "--runs", "2", "--out", str(locked / "s")]) == 2
    assert "permission denied" in capsys.readouterr().err


def test_an_unreachable_dask_scheduler_is_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(study, "DASK_CONNECT_TIMEOUT_S", 1)
    out = tmp_path / "study"
    assert cli.main(["mc", "--duration", "5", "--runs", "2", "--out", str(out), "--dask", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tauv: error: --dask: cannot reach a scheduler at 'tcp://127.0.0.1:9'")
    assert not out.exists()


def test_an_interrupted_study_leaves_nothing_that_looks_like_a_result(tmp_path, monkeypatch):
    from app.reports import study_output
    calls = []

    def interrupted(self, trajectory, chunk):
        calls.append(chunk.first)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return original(self, trajectory, chunk)

    original = study_output.StudyWriter.add_chunk
    monkeypatch.setattr(study_output.StudyWriter, "add_chunk", interrupted)
    existing = tmp_path / "existing"
    existing.mkdir()
    (existing / "summary.json").write_text("{\"an\": \"older study\"}")
    assert cli.main(["mc", *SHORT, "--runs", "25", "--out", str(existing), "--replace"]) == 130
    assert _leftovers(existing) == ["summary.json"]                      # the old result untouched, no temp dir
    assert (existing / "summary.json").read_text() == "{\"an\": \"older study\"}"
    fresh = tmp_path / "fresh"
    calls.clear()
    assert cli.main(["mc", *SHORT, "--runs", "25", "--out", str(fresh)]) == 130
    assert not fresh.exists()                                            # the directory it created is gone too


def test_a_worker_that_dies_ends_the_study_with_one_line_and_nothing_written(tmp_path, capsys, monkeypatch):
    from concurrent.futures.process import BrokenProcessPool

    def dying(*args, **kwargs):
        yield from []
        raise BrokenProcessPool("A process in the process pool was terminated abruptly")

    monkeypatch.setattr(study, "iterate_chunks", dying)
    out = tmp_path / "study"
    assert cli.main(["mc", *SHORT, "--runs", "4", "--out", str(out), "--workers", "2"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a worker process died" in err[0] and "Traceback" not in err[0]
    assert not out.exists()


def test_a_real_worker_killed_mid_study_is_reported(tmp_path, capsys, monkeypatch):
    """The real pool: its workers are killed as soon as the first chunk is handed over."""
    import signal

    from app.reports import study_output
    original = study_output.StudyWriter.add_chunk

    def kill_workers(self, trajectory, chunk):
        for child in __import__("multiprocessing").active_children():
            try:
                os.kill(child.pid, signal.SIGKILL)
            except ProcessLookupError:  # gone between the listing and the kill (a CI run saw it)
                pass
        return original(self, trajectory, chunk)

    monkeypatch.setattr(study_output.StudyWriter, "add_chunk", kill_workers)
    out = tmp_path / "study"
    # 60 runs of a 300 s mission (6 chunks of about half a second each): when the first chunk is
    # handed over, the workers have at least two more to compute. (Many short chunks raced: the
    # workers could finish them all before the first reached the writer.)
    args = [a if a != "20" else "300" for a in SHORT]
    code = cli.main(["mc", *args, "--runs", "60", "--out", str(out), "--workers", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1 and "a worker process died" in err[0]
    assert not out.exists()
