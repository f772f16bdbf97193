"""What each method did with each aiding source (tauvcore.eval.counts), as the run table, the
``--json`` document, the dashboard and a study's summary and report show it: known answers on short
seeded runs (a window without beams, the RPM fallback, the VKF's RPM velocity, water-track), the
counts summed chunk by chunk, cut lists that say so, and Yoo 2014's consistency table headed with
its own dimensions."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from app.cli import main
from app.reports.markdown_tables import counts_markdown
from app.reports.payload import result_to_json
from app.reports.study_report import counts_table_html
from app.reports.tables import (
    COUNTS_TITLE,
    consistency_table,
    counts_table,
    cut_list,
    study_table,
    summary_table,
)
from tauvcore.config import Config, to_dict
from tauvcore.engine.mission import Sinks, run_streaming
from tauvcore.engine.results import UpdateRecord
from tauvcore.eval.counts import MethodCounts, SourceCounts, method_counts
from tauvcore.eval.running import RunningSummary, summarise
from tauvcore.eval.study import StudyAccumulator, compute_chunk
from tauvcore.sensors.dvl import Outage

WINDOW = Outage((1, 2, 3, 4), 10.0, 20.0)
"""Every beam lost for 10 s of a 30 s run at the DVL's 1 Hz: 10 of its 30 pings."""
BASE = Config().replace("trajectory", name="straight", duration_s=30.0)
OUTAGE = BASE.replace("dvl", outages=(WINDOW,))


def _counts(bottom: tuple[int, int, int], **others: tuple[int, int, int]) -> dict[str, SourceCounts]:
    return {"dvl_bottom": SourceCounts(*bottom), **{k: SourceCounts(*v) for k, v in others.items()}}


@pytest.fixture(scope="module")
def outage() -> dict:
    """The window without beams: the 20-state LC and TC, Yoo 2014's INS-DVL and VKF."""
    return run_streaming(OUTAGE.replace("run", methods=("lc", "tc", "ins-dvl", "vkf")), np.random.default_rng(0))


@pytest.fixture(scope="module")
def fallback() -> dict:
    """The same window with ``--rpm-fallback``, run in 5 s chunks, its summary summed chunk by chunk."""
    running = RunningSummary()
    config = OUTAGE.replace("run", methods=("lc", "tc"), rpm_fallback=True)
    results = run_streaming(config, np.random.default_rng(0), chunk_s=5.0, sinks=Sinks(on_chunk=running.add))
    return {"results": results, "running": running.summaries()}


@pytest.fixture(scope="module")
def water() -> dict:
    """A DVL that only water-tracks, the current as states: no bottom-track at any ping."""
    config = BASE.replace("run", methods=("lc", "vkf")).replace(
        "dvl", water_track="always", current_states="random-walk"
    )
    return run_streaming(config, np.random.default_rng(0))


# ------------------------------------------------------------------------------------- known answers
def test_a_window_without_beams_is_coasted_ping_for_ping(outage) -> None:
    pings = outage["lc"].updates["dvl"].t_s
    assert pings.size == 30 and int(np.sum((pings >= WINDOW.start_s) & (pings < WINDOW.end_s))) == 10
    for method in ("lc", "tc", "ins-dvl"):
        counts = method_counts(outage[method])
        assert counts == MethodCounts(_counts((20, 0, 10)), pings=30, coasted=10), method


def test_the_rpm_fallback_moves_the_window_from_coasted_to_the_rpm(fallback, outage) -> None:
    for method in ("lc", "tc"):
        counts = method_counts(fallback["results"][method])
        assert counts == MethodCounts(_counts((20, 0, 10), rpm=(10, 0, 20)), pings=30, coasted=0), method
        # the bottom-track's the same as without the fallback
        assert counts.sources["dvl_bottom"] == method_counts(outage[method]).sources["dvl_bottom"]


def test_the_vkf_counts_its_rpm_velocity_under_the_rpm_not_the_dvl(outage) -> None:
    vkf = outage["vkf"]
    counts = method_counts(vkf)
    assert counts == MethodCounts(_counts((20, 0, 10), rpm=(10, 0, 20)), pings=30, coasted=0)
    # its one velocity record holds both: every ping fused, 20 of them the DVL's
    assert int(vkf.updates["dvl"].fused.sum()) == 30


def test_water_track_is_counted_apart_from_bottom_track(water) -> None:
    assert method_counts(water["lc"]) == MethodCounts(_counts((0, 0, 30), dvl_water=(30, 0, 0)), 30, 0)
    vkf = method_counts(water["vkf"])  # without bottom-track the VKF's switch gives every ping to the RPM
    assert vkf == MethodCounts(_counts((0, 0, 30), dvl_water=(30, 0, 0), rpm=(30, 0, 0)), 30, 0)


def test_sources_off_the_ping_are_counted_over_their_own_epochs() -> None:
    config = BASE.replace("run", methods=("ins", "lc"), aiding=("dvl", "depth"))
    results = run_streaming(config, np.random.default_rng(0))
    depth = results["lc"].updates["depth"]
    counts = method_counts(results["lc"])
    assert list(counts.sources) == ["dvl_bottom", "depth"]
    assert counts.sources["depth"] == SourceCounts(int(depth.fused.sum()), 0, 0) and depth.fused.sum() > 0
    assert method_counts(results["ins"]) == MethodCounts({}, 0, None)


# ------------------------------------------------------------------------------------ chunk by chunk
def _record(t_s: list[float], fused: list[bool], valid: list[bool], rejected: list[bool] | None = None) -> UpdateRecord:
    U = len(t_s)
    f, v = np.array(fused)[:, None], np.array(valid)[:, None]
    r = np.array(rejected)[:, None] if rejected is not None else v & ~f
    zeros = np.zeros((U, 1, 3))
    return UpdateRecord(
        t_s=np.array(t_s, dtype=float), z=zeros, innovation=zeros, innovation_var=zeros + 1.0,
        test_ratio=np.zeros((U, 1)), fused=f, rejected=r, valid=v, fused_rows=np.repeat(f[..., None], 3, -1),
        rejected_rows=np.repeat(r[..., None], 3, -1), nis=np.zeros((U, 1)), nis_dof=np.full((U, 1), 3),
        unusable=np.zeros((U, 1), bool),
    )  # fmt: skip


def test_a_stretch_without_the_rpm_s_record_still_counts_its_pings_unused(outage) -> None:
    """The 20-state bank records the RPM only at the pings that asked for it: a chunk without such a
    ping has no RPM record, and its pings are the RPM's unused all the same."""
    r = outage["lc"]
    first = dataclasses.replace(r, updates={"dvl": _record([1, 2, 3], [True, True, True], [True] * 3)})
    second = dataclasses.replace(
        r,
        updates={
            # a partly fused ping (one row rejected) is fused; a ping the gate refused whole is rejected
            "dvl": _record([4, 5, 6, 7], [True, False, False, False], [True, True, False, False], [True, True, False, False]),
            "rpm": _record([6, 7], [True, False], [True, False]),
        },
    )  # fmt: skip
    total = method_counts(first) + method_counts(second)
    assert total == MethodCounts(_counts((4, 1, 2), rpm=(1, 0, 6)), pings=7, coasted=2)
    assert all(c.updates == 7 for c in total.sources.values())


def test_the_counts_summed_chunk_by_chunk_are_the_whole_run_s(fallback) -> None:
    whole = summarise(fallback["results"])
    for method, summary in fallback["running"].items():
        assert summary.counts == whole[method].counts == method_counts(fallback["results"][method])


def test_a_record_off_the_pings_is_refused(outage) -> None:
    r = outage["lc"]
    bad = dataclasses.replace(r, updates={"dvl": r.updates["dvl"], "rpm": _record([10.5], [True], [True])})
    with pytest.raises(ValueError, match="the rpm record has updates at times that are not the DVL's pings"):
        method_counts(bad)


# ----------------------------------------------------------------------------- where they are shown
def test_the_run_table_heads_each_source_apart_within_110_columns(outage, water) -> None:
    table = counts_table({**outage, "water": water["lc"]}).splitlines()
    assert table[: len(COUNTS_TITLE.splitlines())] == COUNTS_TITLE.splitlines()
    head, *rows = table[len(COUNTS_TITLE.splitlines()) :]
    assert head.split() == ["method", "DVL", "bottom-track", "DVL", "water-track", "RPM", "velocity", "coasted"]
    body = {row.split()[0]: row.split()[1:] for row in rows}
    assert body["LC"] == ["20/0/10", "-", "-", "10", "of", "30"]
    assert body["VKF"] == ["20/0/10", "-", "10/0/20", "0", "of", "30"]
    assert body["WATER"] == ["0/0/30", "30/0/0", "-", "0", "of", "30"]
    assert max(len(line) for line in table) <= 110


def test_the_cli_table_and_json_show_the_fallback_s_rpm(capsys, tmp_path) -> None:
    out_json = tmp_path / "out.json"
    code = main(["run", "--duration", "30", "--method", "ins,lc,vkf", "--outage", "1,2,3,4@10:20",
                 "--rpm-fallback", "--json", str(out_json)])  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "DVL fused/rej/coast" not in out
    lines = out.splitlines()
    head = lines.index(COUNTS_TITLE.splitlines()[-1]) + 1
    assert lines[head].split()[:5] == ["method", "DVL", "bottom-track", "RPM", "velocity"]
    assert lines[head + 1].split() == ["INS", "-", "-", "-"]
    assert lines[head + 2].split() == ["LC", "20/0/10", "10/0/20", "0", "of", "30"]
    assert lines[head + 3].split() == ["VKF", "20/0/10", "10/0/20", "0", "of", "30"]
    results = json.loads(out_json.read_text())["results"]
    assert results["ins"]["counts"] == {"sources": {}, "pings": 0, "coasted": None}
    for method in ("lc", "vkf"):
        assert results[method]["counts"] == {
            "sources": {
                "dvl_bottom": {"fused": 20, "rejected": 0, "unused": 10},
                "rpm": {"fused": 10, "rejected": 0, "unused": 20},
            },
            "pings": 30,
            "coasted": 0,
        }


def test_the_json_of_a_method_has_its_counts(water) -> None:
    document = result_to_json(water["lc"])
    assert document["counts"] == method_counts(water["lc"]).to_json()
    assert MethodCounts.from_json(document["counts"]) == method_counts(water["lc"])
    assert set(document["counts"]["sources"]) == {"dvl_bottom", "dvl_water"}


def test_the_dashboard_s_table_heads_each_source_apart(outage) -> None:
    lines = counts_markdown(outage).splitlines()
    assert lines[2] == "| method | DVL bottom-track | RPM velocity | coasted |"
    assert lines[4:] == [
        "| LC | 20 / 0 / 10 | - | 10 of 30 |",
        "| TC | 20 / 0 / 10 | - | 10 of 30 |",
        "| INS-DVL | 20 / 0 / 10 | - | 10 of 30 |",
        "| VKF | 20 / 0 / 10 | 10 / 0 / 20 | 0 of 30 |",
    ]


def test_a_study_sums_the_counts_over_its_chunks_and_reports_them() -> None:
    config = OUTAGE.replace("run", methods=("lc", "vkf"))
    accumulator = StudyAccumulator(("lc", "vkf"))
    for first in (0, 1):
        accumulator.add(compute_chunk(to_dict(config), 7, first, 1))
    summary = accumulator.summary()
    assert summary["methods"]["lc"]["counts"] == {
        "sources": {"dvl_bottom": {"fused": 40, "rejected": 0, "unused": 20}},
        "pings": 60,
        "coasted": 20,
    }
    assert summary["methods"]["vkf"]["counts"]["sources"]["rpm"] == {"fused": 20, "rejected": 0, "unused": 40}
    table = study_table(summary, "straight", 2, 1.0).splitlines()
    assert any(line.split() == ["LC", "40/0/20", "-", "20", "of", "60"] for line in table)
    assert any(line.split() == ["VKF", "40/0/20", "20/0/40", "0", "of", "60"] for line in table)
    html = counts_table_html(summary)
    assert "<th>DVL bottom-track</th><th>RPM velocity</th><th>coasted</th>" in html
    assert "<td>VKF</td><td>40 / 0 / 20</td><td>20 / 0 / 40</td><td>0 of 60</td>" in html


# ------------------------------------------------------------------------------ cut lists, headings
def test_a_cut_list_says_how_many_more() -> None:
    assert cut_list(["1", "2", "3"], 5, " s") == "1, 2, 3 s"
    assert cut_list([str(k) for k in range(17)], 5, " s") == "0, 1, 2, 3, 4 s ... and 12 more"


def test_the_run_table_says_how_many_reset_times_it_left_out(outage) -> None:
    summary = summarise({"lc": outage["lc"]})["lc"]
    many = dataclasses.replace(summary, reset_times_s=tuple(float(t) for t in range(10, 18)))
    row = next(line for line in summary_table({"lc": many}, OUTAGE, 1.0).splitlines() if line.startswith("LC "))
    assert row.endswith("velocity reset to the DVL after a lock-out at 10, 11, 12, 13, 14 s ... and 3 more")
    few = dataclasses.replace(summary, reset_times_s=(10.0, 11.0))
    row = next(line for line in summary_table({"lc": few}, OUTAGE, 1.0).splitlines() if line.startswith("LC "))
    assert row.endswith("after a lock-out at 10, 11 s")


def test_yoo_s_consistency_table_is_headed_with_its_12_states(outage) -> None:
    yoo = consistency_table({m: outage[m] for m in ("ins-dvl", "vkf")}, ("dvl",)).splitlines()
    assert yoo[1].split() == ["method", "full", "vel", "tilt", "heading", "sensor", "dvl"]
    assert yoo[2].split() == ["NEES/12", "NEES/3", "NEES/2", "NEES/1", "NEES/6", "NIS/dof"]
    mixed = consistency_table({m: outage[m] for m in ("lc", "vkf")}, ("dvl",)).splitlines()
    assert mixed[1].split() == ["method", "full", "pos", "vel", "tilt", "heading", "sensor", "dvl"]
    assert mixed[2].split() == ["20", "states", "NEES/20", "NEES/3", "NEES/3", "NEES/2", "NEES/1", "NEES/11", "NIS/dof"]
    assert mixed[3].startswith("LC ")
    assert mixed[4].split() == ["12", "states", "NEES/12", "NEES/3", "NEES/2", "NEES/1", "NEES/6", "NIS/dof"]
    assert mixed[5].startswith("VKF ") and mixed[5].split()[3] == "-"  # no position state


def test_the_smoothing_table_heads_yoo_s_rows_with_its_12_states(capsys) -> None:
    code = main(["run", "--duration", "20", "--method", "lc,vkf", "--smooth"])
    out, err = capsys.readouterr()
    assert code == 0, err
    lines = out.splitlines()
    first = next(k for k, line in enumerate(lines) if line.startswith("Smoothed beside filtered"))
    assert lines[first + 2].split()[:2] == ["20", "states"] and lines[first + 2].split()[-1] == "NEES/11"
    assert lines[first + 5].split()[:2] == ["12", "states"]
    assert lines[first + 5].split()[-5:] == ["NEES/12", "NEES/3", "NEES/2", "NEES/1", "NEES/6"]
    assert lines[first + 6].startswith("VKF filtered") and lines[first + 7].startswith("VKF smoothed")


def test_a_study_s_row_without_its_flagged_runs_says_how_many_more_it_left_out() -> None:
    from tauvcore.eval.study import RUN_SERIES, ChunkSeries

    accumulator, T = StudyAccumulator(("lc",)), 3
    flagged = np.arange(10) % 10 < 9  # runs 0-8 flagged, run 9 not
    series = {"lc": {n: np.ones((T, 10)) for n in RUN_SERIES}}
    accumulator.add(ChunkSeries(0, 10, np.arange(T, dtype=float), series, {"lc": flagged}))
    row = next(line for line in study_table(accumulator.summary(), "straight", 10, 1.0).splitlines() if "w/o" in line)
    assert row.endswith("runs 0, 1, 2, 3, 4, 5 ... and 3 more")
