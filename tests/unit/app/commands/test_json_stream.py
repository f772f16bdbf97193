"""`tauv run` reduced chunk by chunk: the summary's sums (tauvcore.eval.running) and the --json
document written as the run goes (app.commands.json_stream) against the whole results held at once."""

import json
import math
import os

import numpy as np
import pytest

from app.commands.json_stream import RunJsonWriter
from app.commands.outputs import write_json_atomic
from app.reports.payload import run_payload
from app.reports.tables import summary_table
from tauvcore.config import Config
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.eval.running import RunningSummary, summarise


@pytest.fixture(scope="module")
def config() -> Config:
    # every kind of record: the 20-state and Yoo's methods, beams lost and back, depth, magnetometer
    # and USBL aiding (a source whose first update comes after the first chunks)
    from tauvcore.sensors.dvl import Outage

    config = Config().replace("trajectory", name="figure8", duration_s=150.0)
    config = config.replace("dvl", outages=(Outage(beams=(3, 4), start_s=40.0, end_s=90.0),))
    return config.replace("run", methods=("ins", "lc", "tc", "nsv", "elc", "ins-dvl", "vkf"),
                          aiding=("dvl", "depth", "mag", "usbl"))


@pytest.fixture(scope="module")
def whole(config):
    return run_streaming(config, np.random.default_rng(3))


def _streamed(config, tmp_path, chunk_s: float):
    running = RunningSummary()
    writer = RunJsonWriter(str(tmp_path / "streamed.json"), config)

    def on_chunk(results):
        running.add(results)
        writer.add(results)

    run_streaming(config, np.random.default_rng(3), keep=False, chunk_s=chunk_s, sinks=Sinks(on_chunk=on_chunk))
    summaries = running.summaries()
    writer.write(summaries)
    return summaries, tmp_path / "streamed.json"


def _assert_same(a, b, path="") -> None:
    """Equal documents: the same keys and numbers (consistency sums to 1e-9, the rest exactly)."""
    assert type(a) is type(b) or {type(a), type(b)} <= {int, float}, path
    if isinstance(a, dict):
        assert list(a) == list(b), path
        for k in a:
            _assert_same(a[k], b[k], f"{path}/{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for k, (x, y) in enumerate(zip(a, b)):
            _assert_same(x, y, f"{path}[{k}]")
    elif isinstance(a, float) and "/consistency/" in path:
        assert math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12), (path, a, b)
    else:
        assert a == b, (path, a, b)


@pytest.mark.parametrize("chunk_s", [7.0, 60.0])
def test_the_streamed_json_is_the_whole_run_s_document(config, whole, tmp_path, chunk_s):
    write_json_atomic(str(tmp_path / "whole.json"), run_payload(config, whole))
    _, streamed = _streamed(config, tmp_path, chunk_s)
    a = json.loads((tmp_path / "whole.json").read_text())
    b = json.loads(streamed.read_text())
    assert set(a["results"]["lc"]["nis"]) == {"dvl", "depth", "mag", "usbl"}
    assert any(d > 0 for d in a["results"]["lc"]["nis"]["usbl"]["dof"])
    for method in a["results"]:  # the NIS sources may come in another order: compare them by name
        a["results"][method]["nis"] = dict(sorted(a["results"][method]["nis"].items()))
        b["results"][method]["nis"] = dict(sorted(b["results"][method]["nis"].items()))
    _assert_same(a, b)
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tauv-")] == []  # the spool is gone


def test_the_running_summary_is_the_whole_run_s(config, whole, tmp_path):
    summaries, _ = _streamed(config, tmp_path, 7.0)
    reference = summarise(whole)
    assert list(summaries) == list(reference)
    for method, s in summaries.items():
        r = reference[method]
        for name in s.final:
            np.testing.assert_allclose(s.final[name], r.final[name], rtol=1e-12, atol=0.0)
        for name in s.rms:
            np.testing.assert_allclose(s.rms[name], r.rms[name], rtol=1e-9, atol=0.0)
        assert (s.counts, s.reset_times_s, s.diverged) == (r.counts, r.reset_times_s, r.diverged)
        for block, n in s.consistency.nees.items():
            m = r.consistency.nees[block]
            np.testing.assert_allclose([n.per_dim, n.in_band], [m.per_dim, m.in_band], rtol=1e-9)
        for source, n in s.consistency.nis.items():
            m = r.consistency.nis[source]
            np.testing.assert_allclose([n.per_dof, n.in_band], [m.per_dof, m.in_band], rtol=1e-9)
            assert n.count == m.count
    # the whole results' summary is the table the command printed before it streamed
    assert summary_table(summaries, config, 1.0) == summary_table(whole, config, 1.0)


def test_a_failed_write_leaves_neither_the_spool_nor_a_partial_file(config, whole, tmp_path):
    writer = RunJsonWriter(str(tmp_path / "out.json"), config)
    writer.add(whole)
    with pytest.raises(KeyError):
        writer.write({})  # no summaries: fails half-way through the document
    assert os.listdir(tmp_path) == []


def test_a_last_chunk_of_one_output_epoch_is_reduced_like_the_others() -> None:
    """A 40 s mission in 10 s chunks ends with a chunk of one sample (one output epoch, fewer than
    Yoo's bank has methods): it is handed out and reduced as the others."""
    config = Config().replace("trajectory", duration_s=40.0).replace("run", methods=("lc", "ins-dvl", "vkf"))
    whole = run_streaming(config, np.random.default_rng(0))
    parts: list = []
    run_streaming(config, np.random.default_rng(0), keep=False, sinks=Sinks(on_chunk=parts.append))
    assert parts[-1]["vkf"].t_s.size == 1
    running = RunningSummary()
    for p in parts:
        running.add(p)
    assert summary_table(running.summaries(), config, 1.0) == summary_table(whole, config, 1.0)
    for m in ("lc", "ins-dvl", "vkf"):
        np.testing.assert_array_equal(np.concatenate([p[m].pos_err_m for p in parts]), whole[m].pos_err_m)
        np.testing.assert_array_equal(parts[-1][m].diverged_at_s, whole[m].diverged_at_s)


def test_the_streamed_smoothed_json_is_the_whole_run_s_document(config, tmp_path):
    """``--smooth``: the smoothed chunks spooled after the filtered ones (their tape spilled to
    files) write the document of the whole smoothed results (app.reports.payload.run_payload): each
    method's "smoothed" the same series and consistency (Yoo 2014's too); the spool and the
    tape's files gone."""
    from app.commands.json_stream import RunReduction
    from tauvcore.engine.smoothing import SmoothOptions

    short = config.replace("trajectory", duration_s=100.0)
    whole = run_streaming(short, np.random.default_rng(3), chunk_s=7.0, smooth=SmoothOptions())
    write_json_atomic(str(tmp_path / "whole.json"), run_payload(short, whole))
    reduction = RunReduction(short, str(tmp_path / "streamed.json"), "streamed.json", smoothed=True)
    tape = tmp_path / "tape"
    tape.mkdir()
    run_streaming(short, np.random.default_rng(3), keep=False, chunk_s=7.0, smooth=SmoothOptions(budget_mb=0.0, directory=str(tape)), sinks=Sinks(on_chunk=reduction.add, on_smoothed_chunk=reduction.add_smoothed))
    reduction.finish()
    a = json.loads((tmp_path / "whole.json").read_text())
    b = json.loads((tmp_path / "streamed.json").read_text())
    assert len(a["results"]["vkf"]["smoothed"]["t"]) == len(a["results"]["lc"]["smoothed"]["t"]) == 1001
    assert a["results"]["lc"]["smoothed"]["vel_err_mps"] != a["results"]["lc"]["vel_err_mps"]
    for method in a["results"]:
        a["results"][method]["nis"] = dict(sorted(a["results"][method]["nis"].items()))
        b["results"][method]["nis"] = dict(sorted(b["results"][method]["nis"].items()))
    _assert_same(a, b)
    assert [p for p in os.listdir(tmp_path) if p.startswith(".tauv-")] == []
    assert [p for p in tape.iterdir() if any(p.iterdir())] == []     # every spilled segment removed
