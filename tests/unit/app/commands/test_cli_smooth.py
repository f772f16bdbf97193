"""``--smooth`` of ``tauv run``, ``tauv replay`` and ``tauv mc``: the smoothed series and summaries
beside the filtered, equal to the library's; bad smoother flags one line and exit 2; the smoother's
temporary directory gone after the command, whatever happened."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from app.cli import build_parser, main, resolve_config
from app.reports.payload import result_series
from tauvcore.engine import tape
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import BLOCK_DIMS
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.running import summarise

RUN = ("--trajectory", "figure8", "--duration", "30", "--seed", "4", "--method", "ins,lc,tc,vkf")
"""A short seeded mission: three 20-state methods and one of Yoo 2014's."""


def _run(capsys: pytest.CaptureFixture, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture
def spills(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The temporary directories the smoother's tapes spilled to (tauvcore.engine.tape.Tape)."""
    made: list[str] = []
    original = tape.Tape._tmp

    def _tmp(self: tape.Tape) -> str:
        path = original(self)
        if path not in made:
            made.append(path)
        return path

    monkeypatch.setattr(tape.Tape, "_tmp", _tmp)
    return made


def _close(json_values: list, values: np.ndarray, what: str) -> None:
    got = np.array([np.nan if v is None else v for v in json_values], dtype=float)
    np.testing.assert_allclose(got, values, rtol=1e-9, atol=1e-9, equal_nan=True, err_msg=what)


def test_run_smooth_json_and_table_are_the_library_s_smoothed_results(capsys, tmp_path, spills) -> None:
    """``tauv run --smooth --json``: every smoothed series of run 0 equals run_streaming(...,
    smooth=...)'s ``.smoothed`` on the same seed to 1e-9, its consistency the summary of those
    results (Yoo 2014's method's too); the filtered series are the run's without the smoother;
    the tape spilled to --smooth-dir (a budget at its floor) and nothing is left there."""
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    out = tmp_path / "run.json"
    code, printed, err = _run(capsys, "run", *RUN, "--smooth", "--smooth-memory-mb", "2.7",
                              "--smooth-dir", str(scratch), "--json", str(out))
    assert code == 0, err
    assert spills and all(Path(p).parent.parent == scratch for p in spills)   # spilled, in a directory of its own
    assert list(scratch.iterdir()) == []
    data = json.loads(out.read_text())["results"]
    config = resolve_config(build_parser().parse_args(["run", *RUN]))
    results = run_streaming(config, np.random.default_rng(config.run.seed), smooth=SmoothOptions())
    origin = (config.earth.latitude_rad, config.earth.longitude_rad)
    for method in ("ins", "lc", "tc", "vkf"):
        smoothed = results[method].smoothed
        got = data[method]["smoothed"]
        expected = result_series(smoothed, 0, origin)
        assert list(got)[: len(expected)] == list(expected)
        for name, values in expected.items():
            _close(got[name], values, f"{method} smoothed {name}")
        for name, values in result_series(results[method], 0, origin).items():
            _close(data[method][name], values, f"{method} filtered {name}")
        c = summarise({method: smoothed})[method].consistency
        assert set(got["consistency"]["nees"]) == set(BLOCK_DIMS) and got["consistency"]["nis"] == {}, method
        for block, s in c.nees.items():
            want = None if np.isnan(s.per_dim) else pytest.approx(s.per_dim, rel=1e-9)  # VKF: no position
            assert got["consistency"]["nees"][block]["per_dim"] == want
        assert got["smoother_cuts"] == int(smoothed.smoother_cuts[0])
    lc = results["lc"]
    assert np.sqrt(np.mean(lc.smoothed.vel_err_mps**2)) < np.sqrt(np.mean(lc.vel_err_mps**2))
    table = printed[printed.index("Smoothed beside filtered"):].splitlines()
    rows = {line.split()[0] + " " + line.split()[1]: line.split()[2:] for line in table[3:]}
    vkf = results["vkf"]
    for label, r in (("LC filtered", lc), ("LC smoothed", lc.smoothed), ("VKF smoothed", vkf.smoothed)):
        assert float(rows[label][0]) == pytest.approx(np.sqrt(np.mean(r.vel_err_mps[:, 0] ** 2)), abs=1e-4)
        assert float(rows[label][3]) == pytest.approx(np.sqrt(np.mean(r.pos_err_m[:, 0] ** 2)), abs=1e-3)
    assert "nan" not in printed.lower()


def test_replay_smooth_reproduces_run_smooth(capsys, tmp_path) -> None:
    """``tauv run --smooth --save-log`` then ``tauv replay --smooth --initial-errors`` on that log:
    the smoothed series of the JSON are the run's (as the filtered ones are:
    tests/unit/tauvcore/eval/test_replay.py), and the smoother's temporary directory is gone."""
    argv = ("--method", "lc,tc", "--aiding", "dvl,depth")
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    code, _, err = _run(capsys, "run", "--trajectory", "lawnmower", "--duration", "30", *argv, "--smooth",
                        "--save-log", str(tmp_path / "log"), "--json", str(tmp_path / "run.json"))
    assert code == 0, err
    code, printed, err = _run(capsys, "replay", str(tmp_path / "log"), *argv, "--initial-errors", "--smooth",
                              "--smooth-dir", str(scratch), "--smooth-memory-mb", "1.8",
                              "--json", str(tmp_path / "replay.json"))
    assert code == 0, err
    assert list(scratch.iterdir()) == []
    assert "LC smoothed" in printed and "--smooth" not in printed.splitlines()[1]   # not a configuration layer
    ran = json.loads((tmp_path / "run.json").read_text())["results"]
    replayed = json.loads((tmp_path / "replay.json").read_text())["results"]
    for method in ("lc", "tc"):
        for name in ("pos_err_m", "vel_err_mps", "att_err_deg", "nees_pos", "nees_vel"):
            a = np.array(ran[method]["smoothed"][name], dtype=float)
            b = np.array(replayed[method]["smoothed"][name], dtype=float)
            np.testing.assert_allclose(b, a, rtol=1e-7, atol=1e-9 * np.abs(a).max(), err_msg=f"{method} {name}")
        assert np.sqrt(np.mean(b**2)) > 0.0


def test_mc_smooth_summary_parquet_and_report(capsys, tmp_path) -> None:
    """``tauv mc --smooth``: summary.json carries each 20-state method's smoothed RMS, final
    statistics and NEES per block (Yoo 2014's method's too), the smoothed velocity RMS below the
    filtered; runs.parquet the smoothed columns beside the filtered; the table and
    the report the smoothed rows."""
    import pyarrow.parquet as pq

    out = tmp_path / "study"
    code, printed, err = _run(capsys, "mc", "--trajectory", "figure8", "--duration", "30", "--method", "lc,vkf",
                              "--runs", "3", "--seed", "2", "--smooth", "--out", str(out))
    assert code == 0, err
    summary = json.loads((out / "summary.json").read_text())["trajectories"]["figure8"]["methods"]
    assert summary["vkf"]["smoothed"] is not None
    lc, smoothed = summary["lc"], summary["lc"]["smoothed"]
    assert set(smoothed["consistency"]) == set(BLOCK_DIMS)
    assert set(smoothed["final_rms"]) == set(lc["final_rms"])
    filtered_rms = np.array(lc["rms"]["vel_err_mps"], dtype=float)
    smoothed_rms = np.array(smoothed["rms"]["vel_err_mps"], dtype=float)
    assert np.sqrt(np.mean(smoothed_rms**2)) < 0.8 * np.sqrt(np.mean(filtered_rms**2))
    table = pq.read_table(out / "runs.parquet")
    assert {"smoothed_vel_err_mps", "smoothed_nees_vel", "vel_err_mps"} <= set(table.column_names)
    method = np.array(table.column("method").to_pylist())
    column = table.column("smoothed_vel_err_mps").to_numpy(zero_copy_only=False)
    assert np.isfinite(column[method == "vkf"]).all()
    lc_rows = column[method == "lc"].reshape(3, -1)        # run-major
    assert np.isfinite(lc_rows).all()
    np.testing.assert_allclose(np.sqrt(np.mean(np.square(lc_rows.astype(float)), axis=0)), smoothed_rms,
                               rtol=1e-6, atol=1e-7)
    rows = {" ".join(line.split()[:2]): line.split()[2:] for line in
            printed[printed.index("Filtered and smoothed: RMS over the runs and the whole mission"):].splitlines()[2:]}
    assert "VKF smoothed" in rows
    for label, part in (("LC filtered", lc), ("LC smoothed", smoothed)):
        vel = np.array(part["rms"]["vel_err_mps"], dtype=float)
        assert float(rows[label][0]) == pytest.approx(np.sqrt(np.mean(vel**2)), abs=1e-4)
        c = part["consistency"]["vel"]
        assert rows[label][4 + 2 * 2] == f"{c['per_dim']:.2f}"        # NEES/dim of the velocity block
    assert float(rows["LC smoothed"][0]) < float(rows["LC filtered"][0])
    assert "filtered and smoothed" in (out / "report.html").read_text()


@pytest.mark.parametrize("argv, line", [
    (["run", "--smooth", "--smooth-memory-mb", "0"], "--smooth-memory-mb: expected a positive number of megabytes, got '0'"),
    (["run", "--smooth", "--smooth-memory-mb", "-3"], "--smooth-memory-mb: expected a positive number of megabytes, got '-3'"),
    (["run", "--smooth", "--smooth-memory-mb", "lots"], "--smooth-memory-mb: expected a positive number of megabytes, got 'lots'"),
    (["run", "--smooth", "--smooth-memory-mb", "nan"], "--smooth-memory-mb: expected a positive number of megabytes, got 'nan'"),
    (["run", "--smooth", "--smooth-memory-mb", "0.5"], "--smooth-memory-mb: '0.5' MB is below what the smoother holds of one chunk: at least 1.2 MB for 2 smoothed methods"),
    (["mc", "--runs", "20", "--out", "OUT", "--smooth", "--smooth-memory-mb", "5"], "at least 11.7 MB for 2 smoothed methods and 10 runs per chunk"),
    (["run", "--smooth-memory-mb", "64"], "--smooth-memory-mb '64': only with --smooth"),
    (["replay", "LOG", "--smooth-dir", "/tmp"], "--smooth-dir '/tmp': only with --smooth"),
    (["run", "--smooth", "--smooth-dir", "/no/such/dir"], "--smooth-dir: '/no/such/dir' is not a directory"),
    (["mc", "--runs", "2", "--out", "OUT", "--smooth", "--smooth-dir", "/no/such/dir"], "--smooth-dir: '/no/such/dir' is not a directory"),
])
def test_bad_smoother_flags_are_one_line_and_exit_2(capsys, tmp_path, monkeypatch, argv, line) -> None:
    """Nothing runs and nothing is made: the study's --out is not created."""
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", lambda *a, **k: pytest.fail("ran"))
    monkeypatch.setattr("tauvcore.eval.study.run_study", lambda *a, **k: pytest.fail("ran"))
    argv = [str(tmp_path / "out") if a == "OUT" else str(tmp_path) if a == "LOG" else a for a in argv]
    code, out, err = _run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("tauv: error: ") and line in err
    assert not (tmp_path / "out").exists()


def test_an_interrupted_smoothing_writes_nothing_and_leaves_no_tape(capsys, tmp_path, monkeypatch, spills) -> None:
    """Ctrl-C while the smoothed chunks come: exit 130, no --json, the spool and the smoother's
    directory (spilled to) removed."""
    from app.commands.json_stream import RunReduction

    def interrupt(self, results) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(RunReduction, "add_smoothed", interrupt)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    code, _, err = _run(capsys, "run", *RUN, "--smooth", "--smooth-memory-mb", "2.7", "--smooth-dir",
                        str(scratch), "--json", str(tmp_path / "out.json"))
    assert code == 130 and "interrupted" in err
    assert spills and not any(os.path.exists(p) for p in spills)
    assert list(scratch.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scratch"]


def test_a_full_disk_under_the_tape_is_one_line_and_nothing_is_written(capsys, tmp_path, monkeypatch, spills) -> None:
    """The tape cannot be written (no space left): one line naming --smooth-dir and the reason,
    exit 2; neither --json nor --save-log is left, nor the smoother's directory."""
    import errno

    def no_space(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(tape.np, "save", no_space)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    code, out, err = _run(capsys, "run", *RUN, "--smooth", "--smooth-memory-mb", "2.7", "--smooth-dir", str(scratch),
                          "--json", str(tmp_path / "out.json"), "--save-log", str(tmp_path / "log"))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("tauv: error: --smooth-dir: the smoother's tape cannot be written")
    assert "No space left on device" in err
    assert spills and list(scratch.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scratch"]
