"""A run's events (tauvcore.eval.events): known answers on small hand-built results (spans merged
from consecutive pings, instants for rejections, resets and divergence, sorted by time) and on a
short seeded run with a scheduled outage of beams 3 and 4 at 100-150 s."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import MethodResult, UpdateRecord
from tauvcore.eval.events import EVENT_KINDS, Event, run_events, runs_of
from tauvcore.sensors.dvl import Outage

PINGS_S = np.arange(10, dtype=float)
"""Ten DVL pings at 1 Hz, 0-9 s."""


def _record(t_s: np.ndarray, runs: int = 1, rows: int = 4, **flags: np.ndarray) -> UpdateRecord:
    """An update record of ``len(t_s)`` updates, every update valid and fused unless ``flags``
    (each (U, R), or (U, R, 4) for ``beams_available``) say otherwise."""
    U = len(t_s)
    ones, zeros = np.ones((U, runs), bool), np.zeros((U, runs), bool)
    fields = dict(
        t_s=t_s, z=np.zeros((U, runs, rows)), innovation=np.zeros((U, runs, rows)),
        innovation_var=np.ones((U, runs, rows)), test_ratio=np.full((U, runs), 0.5), fused=ones,
        rejected=zeros, valid=ones, fused_rows=np.ones((U, runs, rows), bool),
        rejected_rows=np.zeros((U, runs, rows), bool), nis=np.zeros((U, runs)),
        nis_dof=np.full((U, runs), rows), unusable=zeros,
    )
    fields.update(flags)
    return UpdateRecord(**fields)


def _result(method: str, updates: dict[str, UpdateRecord], diverged_at_s: float = np.nan,
            runs: int = 1, vkf_trace: dict | None = None) -> MethodResult:
    T = 11
    z = np.zeros((T, runs))
    at = np.full(runs, diverged_at_s)
    return MethodResult(
        method=method, t_s=np.arange(T, dtype=float), vel_err_mps=z, att_err_deg=z, pos_err_m=z,
        vel_sigma_mps=z, att_sigma_deg=z, pos_sigma_m=z, nees=z, tilt_err_deg=z, heading_err_deg=z,
        tilt_sigma_deg=z, heading_sigma_deg=z, nees_block=np.zeros((T, runs, 6)),
        est_pos_n=np.zeros((T, runs, 3)), diverged=~np.isnan(at), diverged_at_s=at,
        p_floor_count=np.zeros(runs, int), updates=updates, vkf_trace=vkf_trace)


def test_runs_of_consecutive_flags():
    assert runs_of(np.array([0, 1, 1, 0, 1, 0, 0, 1, 1, 1], bool)) == [(1, 2), (4, 4), (7, 9)]
    assert runs_of(np.zeros(4, bool)) == []
    assert runs_of(np.ones(3, bool)) == [(0, 2)]


def test_scheduled_outage_is_one_span_of_its_beams():
    config = Config().replace("dvl", outages=(Outage((4, 3), 2.0, 5.0),))
    (event,) = run_events({}, config)
    assert event == Event("outage", 2.0, 5.0, None, (3, 4), "scheduled DVL outage: beams 3,4 lost 2-5 s")
    assert not event.instant


def test_unscheduled_lost_beams_are_dropout_spans_to_the_ping_they_returned():
    """Beam 2 lost at pings 3-4 and beam 1 at ping 5 (one span 3-6 s of beams 1,2); beams 3,4 lost
    at 6-7 s inside their scheduled outage (no dropout); beam 4 lost at the last ping (a span that
    ends at its own ping)."""
    available = np.ones((10, 1, 4), bool)
    available[3:5, 0, 1] = False
    available[5, 0, 0] = False
    available[6:8, 0, 2:] = False
    available[9, 0, 3] = False
    config = Config().replace("dvl", outages=(Outage((3, 4), 6.0, 8.0),))
    results = {"lc": _result("lc", {"dvl": _record(PINGS_S, beams_available=available)})}
    dropouts = [e for e in run_events(results, config) if e.kind == "dropout"]
    assert [(e.start_s, e.end_s, e.beams, e.method) for e in dropouts] == [
        (3.0, 6.0, (1, 2), None), (9.0, 9.0, (4,), None)]
    assert dropouts[0].text == "DVL beams 1,2 lost 3-6 s (3 pings, not scheduled)"


def test_beams_the_configuration_disables_are_no_dropout():
    available = np.ones((10, 1, 4), bool)
    available[:, 0, 3] = False
    results = {"lc": _result("lc", {"dvl": _record(PINGS_S, beams_available=available)})}
    assert run_events(results, Config().replace("dvl", beams=(1, 2, 3))) == []
    assert [e.kind for e in run_events(results, Config())] == ["dropout"]


def test_rejections_resets_and_divergence_are_instants_of_their_method_sorted_by_time():
    rejected = np.zeros((10, 2), bool)
    rejected[[2, 7], 1] = True
    rejected[4, 0] = True
    rows = np.zeros((10, 2, 4), bool)
    rows[7, 1, [0, 3]] = True
    ratio = np.full((10, 2), 0.5)
    ratio[7, 1] = 12.25
    reset = np.zeros((10, 2), bool)
    reset[8, 1] = True
    depth = _record(np.array([1.5, 6.5]), runs=2, rows=1, rejected=np.array([[False, False], [False, True]]))
    results = {
        "tc": _result("tc", {"dvl": _record(PINGS_S, 2, rejected=rejected, rejected_rows=rows, test_ratio=ratio,
                                            reset=reset), "depth": depth}, runs=2),
        "ins-dvl": _result("ins-dvl", {}, diverged_at_s=343.4, runs=2),
    }
    events = run_events(results, Config(), run=1)
    assert [(e.kind, e.start_s, e.method, e.source) for e in events] == [
        ("rejection", 2.0, "tc", "dvl"), ("rejection", 6.5, "tc", "depth"), ("rejection", 7.0, "tc", "dvl"),
        ("reset", 8.0, "tc", None), ("diverged", 343.4, "ins-dvl", None)]
    assert all(e.instant for e in events)
    assert events[2].beams == (1, 4)
    assert events[2].text == "TC: DVL update rejected by the gate at 7 s, beams 1,4, test ratio 12.2"
    assert events[3].text == "TC: velocity reset to the DVL after a lock-out at 8 s"
    assert events[4].text == "INS-DVL: divergence flagged at 343.4 s (the monitor's first flag)"
    assert [e.start_s for e in run_events(results, Config(), run=0) if e.kind == "rejection"] == [4.0]
    with pytest.raises(ValueError, match="run must be within"):
        run_events(results, Config(), run=2)


def test_rpm_fallback_rows_on_consecutive_pings_are_one_span():
    """The 20-state bank records the RPM only at the pings that asked for it: pings 3, 4, 5 and 8
    (8 without a measurement): one span 3-6 s."""
    rpm = _record(np.array([3.0, 4.0, 5.0, 8.0]), rows=3, valid=np.array([[True], [True], [True], [False]]))
    results = {"lc": _result("lc", {"dvl": _record(PINGS_S), "rpm": rpm})}
    (event,) = run_events(results, Config())
    assert (event.kind, event.start_s, event.end_s, event.method) == ("rpm", 3.0, 6.0, "lc")
    assert event.text == "LC: RPM velocity in place of the DVL 3-6 s"


def test_vkf_rpm_in_use_spans():
    in_use = np.zeros((10, 1), bool)
    in_use[6:, 0] = True
    results = {"vkf": _result("vkf", {"dvl": _record(PINGS_S)}, vkf_trace={"t_s": PINGS_S, "rpm_in_use": in_use})}
    assert [(e.kind, e.start_s, e.end_s) for e in run_events(results, Config())] == [("rpm", 6.0, 9.0)]


def test_event_checks_its_kind_and_times():
    with pytest.raises(ValueError, match="Event.kind must be one of outage"):
        Event("storm", 1.0, 2.0)
    with pytest.raises(ValueError, match="Event.end_s must be >= start_s = 2 s, got 1 s"):
        Event("outage", 2.0, 1.0)
    assert set(EVENT_KINDS) >= {"outage", "dropout", "rpm", "rejection", "reset", "diverged"}


@pytest.fixture(scope="module")
def outage_run():
    """A 160 s straight run, LC and TC, beams 3 and 4 lost 100-150 s."""
    config = (Config().replace("trajectory", name="straight", duration_s=160.0)
              .replace("dvl", outages=(Outage((3, 4), 100.0, 150.0),))
              .replace("run", methods=("lc", "tc")))
    return config, run_streaming(config, np.random.default_rng(0))


def test_a_run_with_an_outage_of_beams_3_and_4(outage_run):
    config, results = outage_run
    events = run_events(results, config)
    outages = [e for e in events if e.kind == "outage"]
    assert [(e.start_s, e.end_s, e.beams, e.method) for e in outages] == [(100.0, 150.0, (3, 4), None)]
    assert "beams 3,4" in outages[0].text and "100-150 s" in outages[0].text
    # the DVL's record agrees with the schedule: nothing lost that the outage does not name
    assert [e for e in events if e.kind == "dropout"] == []
    assert events == sorted(events, key=lambda e: e.start_s)
    assert all(e.method in (None, "lc", "tc") for e in events)
