"""What happened during a run, as events on its time axis: spans (a stretch of time) and instants
(a moment, ``end_s == start_s``), each with a kind (:data:`EVENT_KINDS`), the method it belongs to
(None for the mission's and the sensor's own) and a plain-words text with units.

Read from the configuration and the records the engine leaves (tauvcore.engine.results):

- ``outage`` (span, no method): a scheduled DVL outage, ``config.dvl.outages`` (its window and its
  beams);
- ``dropout`` (span, no method): DVL pings at which an enabled beam did not return though no
  scheduled outage names it (a random dropout, the bottom out of range, a log's own gaps), from
  ``UpdateRecord.beams_available`` of the DVL record (the sensor's, the same for every method: the
  first method that records it); consecutive pings with a lost beam are one span, its beams those
  lost at any of them;
- ``rpm`` (span, per method): pings at which the method took the propeller's (RPM) velocity in
  place of the DVL's bottom-track: the rows of the ``rpm`` record (the 20-state ``--rpm-fallback``)
  with a measurement, or ``vkf``'s pings its trace's ``rpm_in_use`` marks;
- ``rejection`` (instant, per method): an update of any aiding source whose every row the gate
  refused (``UpdateRecord.rejected``), with its test ratio and, for the DVL's beams, the beams;
- ``reset`` (instant, per method): the velocity reset to the DVL after a lock-out
  (``UpdateRecord.reset``, tauvcore.engine.lockout);
- ``diverged`` (instant, per method): the divergence monitor's first flag
  (``MethodResult.diverged_at_s``).

A span runs from its first ping to the next ping after its last (when the beams returned, the DVL
took over again), or to its last ping at the end of the record. A run reduced to time bins
(tauvcore.eval.envelope.DecimatedResult) carries each bin's last update: its spans and instants are
those of the bins, at the bins' last update times.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.results import MethodResult, UpdateRecord

EVENT_KINDS: dict[str, str] = {
    "outage": "scheduled DVL outage",
    "dropout": "DVL beams lost",
    "rpm": "RPM velocity in place of the DVL",
    "rejection": "gate rejection",
    "reset": "lock-out reset",
    "diverged": "divergence flagged",
}
"""Every kind of event, in the order legends list them, and how a person reads it."""
SPAN_KINDS = ("outage", "dropout", "rpm")
"""The kinds that last a while (``end_s > start_s`` unless a single ping)."""
INSTANT_KINDS = ("rejection", "reset", "diverged")
"""The kinds that happen at one moment (``end_s == start_s``)."""
_BEAM_ROWS = {"dvl": 4, "water": 4}
"""Sources whose update rows are the DVL's beams when they have this many rows (TC, water-track)."""


@dataclass(frozen=True)
class Event:
    """One event of a run (module docstring)."""

    kind: str  # one of EVENT_KINDS
    start_s: float  # when it began [s] on the mission's clock
    end_s: float  # when it ended [s]; == start_s for an instant
    method: str | None = None  # the method it belongs to; None: the mission's or the sensor's own
    beams: tuple[int, ...] = ()  # the DVL beams (1-4) it concerns; empty: none in particular
    text: str = ""  # what it was, in plain words with units (a plot's hover text)
    source: str | None = None  # the aiding source's record for a rejection ("dvl", "depth", ...)

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ValueError(f"Event.kind must be one of {', '.join(EVENT_KINDS)}, got {self.kind!r}")
        if not self.end_s >= self.start_s:
            raise ValueError(f"Event.end_s must be >= start_s = {self.start_s:g} s, got {self.end_s:g} s")

    @property
    def instant(self) -> bool:
        """Whether it happened at one moment (``end_s == start_s``)."""
        return self.end_s == self.start_s


def seconds(t_s: float) -> str:
    """A time as the texts print it: seconds to 0.01 s without trailing zeros ("100", "12.35")."""
    return f"{round(float(t_s), 2):g}"


def beams_text(beams: tuple[int, ...]) -> str:
    """``"beam 3"`` or ``"beams 3,4"``."""
    return ("beam " if len(beams) == 1 else "beams ") + ",".join(str(b) for b in beams)


def runs_of(flags: np.ndarray) -> list[tuple[int, int]]:
    """The stretches of consecutive True in ``flags`` (n,), as (first, last) indices, inclusive."""
    flags = np.asarray(flags, dtype=bool)
    if not flags.any():
        return []
    edges = np.diff(np.r_[0, flags.astype(np.int8), 0])
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def _span(t_s: np.ndarray, first: int, last: int) -> tuple[float, float]:
    """A stretch of pings ``first..last`` as times: its first ping to the next ping after its last
    (its last ping's own time at the end of the record)."""
    end = t_s[last + 1] if last + 1 < t_s.size else t_s[last]
    return float(t_s[first]), float(end)


def run_events(results: Mapping[str, MethodResult], config: Config, run: int = 0) -> list[Event]:
    """The events of run ``run`` of a mission or replay (module docstring).

    Parameters
    ----------
    results : Mapping[str, MethodResult]
        Method name -> its results over R runs (whole, thinned or reduced to bins).
    config : Config
        The run's configuration (its DVL's beams and scheduled outages).
    run : int
        Which of the R runs (0 for a single run).

    Returns
    -------
    list[Event]
        Every event, sorted by start time, then end time, then kind (:data:`EVENT_KINDS` order) and
        method; the mission's own (``method`` None) first at equal times.
    """
    runs = {r.pos_err_m.shape[1] for r in results.values()}
    if results and not all(0 <= run < n for n in runs):
        raise ValueError(f"run must be within [0, {min(runs) - 1}], got {run}")
    events = outage_events(config)
    events += dropout_events(results, config, run)
    for method, result in results.items():
        events += method_events(method, result, run)
    order = list(EVENT_KINDS)
    return sorted(
        events, key=lambda e: (e.start_s, e.end_s, e.method is not None, order.index(e.kind), e.method or "")
    )


def outage_events(config: Config) -> list[Event]:
    """The scheduled DVL outages of ``config`` (``config.dvl.outages``), one span each."""
    events = []
    for outage in config.dvl.outages:
        beams = tuple(sorted(outage.beams))
        window = f"{seconds(outage.start_s)}-{seconds(outage.end_s)} s"
        text = f"scheduled DVL outage: {beams_text(beams)} lost {window}"
        events.append(Event("outage", float(outage.start_s), float(outage.end_s), None, beams, text))
    return events


def _sensor_record(results: Mapping[str, MethodResult]) -> UpdateRecord | None:
    """The first DVL record of ``results`` that says which beams returned."""
    for result in results.values():
        dvl = result.updates.get("dvl")
        if dvl is not None and dvl.beams_available is not None and len(dvl.t_s):
            return dvl
    return None


def dropout_events(results: Mapping[str, MethodResult], config: Config, run: int = 0) -> list[Event]:
    """Stretches of DVL pings with an enabled beam lost that no scheduled outage names (no method:
    the sensor's own), from the first DVL record with ``beams_available``; a record reduced to
    bins marks a bin with any such ping (``lost_in_bin``)."""
    dvl = _sensor_record(results)
    if dvl is None:
        return []
    assert dvl.beams_available is not None  # _sensor_record's choice
    t_s = np.asarray(dvl.t_s, dtype=float)
    expected = config.dvl.scheduled_availability(t_s)
    lost = expected & ~np.asarray(dvl.beams_available[:, run], dtype=bool)
    binned = getattr(dvl, "lost_in_bin", None)
    if binned is not None:
        lost = lost | (expected & np.asarray(binned[:, run], dtype=bool))
    events = []
    for first, last in runs_of(np.any(lost, axis=1)):
        start, end = _span(t_s, first, last)
        beams = tuple(int(b) + 1 for b in np.flatnonzero(lost[first : last + 1].any(axis=0)))
        pings = last - first + 1
        text = (
            f"DVL {beams_text(beams)} lost {seconds(start)}-{seconds(end)} s "
            f"({pings} ping{'s' if pings > 1 else ''}, not scheduled)"
        )
        events.append(Event("dropout", start, end, None, beams, text))
    return events


def method_events(method: str, result: MethodResult, run: int = 0) -> list[Event]:
    """One method's events of run ``run``: its RPM spans, gate rejections, lock-out resets and
    divergence flag (module docstring), unsorted."""
    label = method.upper()
    events = rpm_events(method, result, run)
    for source, record in result.updates.items():
        events += rejection_events(method, source, record, run)
        events += reset_events(method, record, run) if source == "dvl" else []
    at = float(result.diverged_at_s[run])
    if np.isfinite(at):
        text = f"{label}: divergence flagged at {seconds(at)} s (the monitor's first flag)"
        events.append(Event("diverged", at, at, method, (), text))
    return events


def rejection_events(method: str, source: str, record: UpdateRecord, run: int = 0) -> list[Event]:
    """Updates of ``source`` whose every row the gate refused, one instant each (a record reduced
    to bins: each bin with a rejection, at its last update, ``rejected_in_bin``)."""
    rejected = np.asarray(record.rejected[:, run], dtype=bool)
    binned = getattr(record, "rejected_in_bin", None)
    if binned is not None:
        rejected = rejected | np.asarray(binned[:, run], dtype=bool)
    rows = record.rejected_rows.shape[2] if record.rejected_rows.ndim == 3 else 0
    events = []
    for u in np.flatnonzero(rejected):
        t = float(record.t_s[u])
        beams: tuple[int, ...] = ()
        if _BEAM_ROWS.get(source) == rows:
            beams = tuple(int(k) + 1 for k in np.flatnonzero(record.rejected_rows[u, run]))
        what = f", {beams_text(beams)}" if beams else ""
        ratio = float(record.test_ratio[u, run])
        ratio_text = f", test ratio {ratio:.3g}" if np.isfinite(ratio) else ""
        text = f"{method.upper()}: {source.upper()} update rejected by the gate at {seconds(t)} s{what}{ratio_text}"
        events.append(Event("rejection", t, t, method, beams, text, source))
    return events


def reset_events(method: str, record: UpdateRecord, run: int = 0) -> list[Event]:
    """The pings at which the velocity was reset to the DVL after a lock-out, one instant each (a
    record reduced to bins: each bin with a reset, ``reset_in_bin``)."""
    if record.reset is None:
        return []
    reset = np.asarray(record.reset[:, run], dtype=bool)
    binned = getattr(record, "reset_in_bin", None)
    if binned is not None:
        reset = reset | np.asarray(binned[:, run], dtype=bool)
    events = []
    for u in np.flatnonzero(reset):
        t = float(record.t_s[u])
        text = f"{method.upper()}: velocity reset to the DVL after a lock-out at {seconds(t)} s"
        events.append(Event("reset", t, t, method, (), text))
    return events


def rpm_events(method: str, result: MethodResult, run: int = 0) -> list[Event]:
    """Stretches of pings at which ``method`` took the RPM velocity in place of the DVL's
    bottom-track: the ``rpm`` record's rows with a measurement (consecutive on the DVL's pings),
    or ``vkf``'s trace's ``rpm_in_use``."""
    dvl = result.updates.get("dvl")
    rpm = result.updates.get("rpm")
    trace = result.vkf_trace
    if trace is not None and "rpm_in_use" in trace and len(trace["t_s"]):
        t_s = np.asarray(trace["t_s"], dtype=float)
        in_use = np.asarray(trace["rpm_in_use"], dtype=bool).reshape(t_s.size, -1)[:, run]
    elif rpm is not None and len(rpm.t_s):
        t_s = np.asarray(dvl.t_s if dvl is not None and len(dvl.t_s) else rpm.t_s, dtype=float)
        rows = np.clip(np.searchsorted(t_s, rpm.t_s), 0, t_s.size - 1)
        on_clock = np.isclose(t_s[rows], rpm.t_s, rtol=0.0, atol=1e-9)
        in_use = np.zeros(t_s.size, dtype=bool)
        in_use[rows[on_clock]] = np.asarray(rpm.valid[on_clock, run], dtype=bool)
    else:
        return []
    events = []
    for first, last in runs_of(in_use):
        start, end = _span(t_s, first, last)
        text = f"{method.upper()}: RPM velocity in place of the DVL {seconds(start)}-{seconds(end)} s"
        events.append(Event("rpm", start, end, method, (), text))
    return events


__all__ = [
    "EVENT_KINDS",
    "INSTANT_KINDS",
    "SPAN_KINDS",
    "Event",
    "beams_text",
    "dropout_events",
    "method_events",
    "outage_events",
    "rejection_events",
    "reset_events",
    "rpm_events",
    "run_events",
    "runs_of",
    "seconds",
]
