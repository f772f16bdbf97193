"""What each method did with each aiding source: its updates fused, rejected and unused, and the
DVL pings on which nothing aided its velocity.

Counted from the update records the engine leaves (tauvcore.engine.results.UpdateRecord: per
update and run the ``fused``, ``rejected`` and ``valid`` flags), summed over the runs:

- **fused**: the filter took the measurement, at least one of its rows (a tightly coupled ping
  whose gate refused one beam and kept three is fused);
- **rejected**: the source gave a measurement and the filter took none of it (the gate refused
  every row, or its innovation covariance was unusable);
- **unused**: the source gave the method nothing at that update (no measurement: beams lost or out
  of range, a dropout; or, for a velocity the method chose not to take, see below).

Every update of every run is exactly one of the three: ``fused + rejected + unused`` is the
source's updates times the runs.

The DVL's ping carries three velocity sources, each counted over every ping (:data:`PING_SOURCES`):

- ``dvl_bottom``: the DVL's bottom-track (the record ``dvl``);
- ``dvl_water``: its water-track beams, fused against the current states (the record ``water``,
  tauvcore.engine.dvl_fusion.fuse_water_track, tauvcore.engine.yoo_loop.run_stops);
- ``rpm``: the propeller's velocity from Yoo 2014's velocity Kalman filter: the ``--rpm-fallback``
  of the 20-state methods where they have no bottom-track velocity (the record ``rpm``), and
  ``vkf``'s velocity at the pings its eq. 29 switch gives to the RPM (those rows of ``vkf``'s
  ``dvl`` record, told apart by its trace's ``rpm_in_use``; its bottom-track is the other rows).

A ping the source did not measure at (the bottom-track at a ping ``vkf`` gave to the RPM, the RPM
at a ping with a bottom-track velocity) is unused by that source. **Coasted** is per method: the
pings on which no velocity of any of the three was fused (the DVL gave nothing usable, or the gate
refused it, and no fallback fused), the INS then running on its own from ping to ping.

Every other source (depth, mag, usbl, a registered method's pseudo-measurement) is counted over
its own epochs, under its record's name (so are the water-track and RPM records of results without
a DVL record, which the engine does not make).

:func:`lockout_resets` counts what else a DVL method's record tells of its pings: the velocity
resets to the DVL after a lock-out (tauvcore.engine.lockout).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from tauvcore.engine.results import MethodResult, UpdateRecord

PING_SOURCES = ("dvl_bottom", "dvl_water", "rpm")
"""The velocity sources of a DVL ping, in the order the tables show them (module docstring)."""
SOURCE_LABELS = {"dvl_bottom": "DVL bottom-track", "dvl_water": "DVL water-track", "rpm": "RPM velocity"}
"""How the tables head a ping source; every other source is headed by its record's name."""
_PING_RECORDS = {"dvl": "dvl_bottom", "water": "dvl_water", "rpm": "rpm"}
"""The update records of the ping sources: record name -> source."""


@dataclass(frozen=True)
class SourceCounts:
    """One source's updates for one method, summed over the runs; each update of each run is one
    of the three (module docstring)."""

    fused: int  # the filter took the measurement (at least one row)
    rejected: int  # a measurement the filter took none of (the gate, or S unusable)
    unused: int  # no measurement of this source at this update for this method

    @property
    def updates(self) -> int:
        """Updates times runs: ``fused + rejected + unused``."""
        return self.fused + self.rejected + self.unused

    def __add__(self, other: SourceCounts) -> SourceCounts:
        return SourceCounts(
            self.fused + other.fused, self.rejected + other.rejected, self.unused + other.unused
        )

    def cell(self) -> str:
        """``fused/rejected/unused``, as the tables print it."""
        return f"{self.fused}/{self.rejected}/{self.unused}"

    def to_json(self) -> dict[str, int]:
        """``{"fused", "rejected", "unused"}``."""
        return {"fused": self.fused, "rejected": self.rejected, "unused": self.unused}


@dataclass(frozen=True)
class MethodCounts:
    """One method's counts, summed over the runs: per source (:class:`SourceCounts`), the DVL's
    pings and the pings it coasted on."""

    sources: dict[str, SourceCounts] = field(default_factory=dict)  # source -> its counts: the ping
    # sources first (PING_SOURCES' order), then the others in the records' order
    pings: int = 0  # DVL pings times runs (0: the method has no DVL record)
    coasted: int | None = None  # pings (times runs) on which no velocity was fused; None: no DVL record

    def __add__(self, other: MethodCounts) -> MethodCounts:
        """The counts of two stretches of a run (two chunks) together. A ping source is unused at
        every ping of both it did not fuse or reject, also in a stretch without its record (the
        20-state bank records the RPM only at the pings that asked for it)."""
        names = list(dict.fromkeys([*self.sources, *other.sources]))
        zero = SourceCounts(0, 0, 0)
        pings = self.pings + other.pings
        sources = {}
        for name in names:
            total = self.sources.get(name, zero) + other.sources.get(name, zero)
            if name in PING_SOURCES and pings:
                total = SourceCounts(total.fused, total.rejected, pings - total.fused - total.rejected)
            sources[name] = total
        coasted = (
            None
            if self.coasted is None and other.coasted is None
            else (self.coasted or 0) + (other.coasted or 0)
        )
        return MethodCounts(_ordered(sources), pings, coasted)

    def to_json(self) -> dict[str, Any]:
        """``{"sources": {source: {"fused", "rejected", "unused"}}, "pings": int, "coasted": int or
        null}`` (the ``counts`` of ``tauv run --json`` and of a study's summary)."""
        return {
            "sources": {name: c.to_json() for name, c in self.sources.items()},
            "pings": self.pings,
            "coasted": self.coasted,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> MethodCounts:
        """The counts :meth:`to_json` wrote.

        Parameters
        ----------
        data : Mapping[str, Any]
            ``{"sources": {source: {"fused", "rejected", "unused"}}, "pings", "coasted"}``.

        Returns
        -------
        MethodCounts
            The same counts.
        """
        sources = {
            name: SourceCounts(int(c["fused"]), int(c["rejected"]), int(c["unused"]))
            for name, c in data["sources"].items()
        }
        coasted = data["coasted"]
        return cls(sources, int(data["pings"]), None if coasted is None else int(coasted))


def _ordered(sources: Mapping[str, SourceCounts]) -> dict[str, SourceCounts]:
    first = [s for s in PING_SOURCES if s in sources]
    return {**{s: sources[s] for s in first}, **{k: v for k, v in sources.items() if k not in PING_SOURCES}}


def _split(record: UpdateRecord, take: np.ndarray) -> tuple[int, int, np.ndarray]:
    """Fused and rejected of ``record``'s entries where ``take`` (U, R), and where it fused."""
    fused = take & record.fused
    rejected = take & record.valid & ~record.fused
    return int(fused.sum()), int(rejected.sum()), fused


def _at_pings(t_ping_s: np.ndarray, record: UpdateRecord, name: str) -> np.ndarray:
    """The ping (row of the DVL record) of each of ``record``'s updates, recorded at the pings."""
    rows = np.searchsorted(t_ping_s, record.t_s)
    inside = rows < t_ping_s.size
    if not (inside.all() and np.array_equal(t_ping_s[rows], record.t_s)):
        raise ValueError(f"the {name} record has updates at times that are not the DVL's pings")
    return rows


def method_counts(result: MethodResult) -> MethodCounts:
    """The counts of one method's results (module docstring).

    Parameters
    ----------
    result : MethodResult
        One method's results over R runs (a whole run, or one chunk of it): its update records,
        and for ``vkf`` its trace (``vkf_trace["rpm_in_use"]``, (U, R) at the DVL's pings).

    Returns
    -------
    MethodCounts
        Per source with a record its fused, rejected and unused updates summed over the runs; the
        DVL's pings and the pings coasted on (None without a DVL record).
    """
    sources: dict[str, SourceCounts] = {}
    updates = result.updates
    dvl = updates.get("dvl")
    pings, coasted = 0, None
    if dvl is not None:
        U, R = dvl.fused.shape
        pings = U * R
        rpm_rows = None
        if result.vkf_trace is not None and "rpm_in_use" in result.vkf_trace:
            rpm_rows = np.asarray(result.vkf_trace["rpm_in_use"], dtype=bool).reshape(U, R)
        bottom = ~rpm_rows if rpm_rows is not None else np.ones((U, R), bool)
        f, r, aided = _split(dvl, bottom)
        sources["dvl_bottom"] = SourceCounts(f, r, pings - f - r)
        if rpm_rows is not None:  # vkf: the velocity of eq. 29's RPM pings
            f, r, fused = _split(dvl, rpm_rows)
            sources["rpm"] = SourceCounts(f, r, pings - f - r)
            aided = aided | fused
        for name in ("water", "rpm"):
            record = updates.get(name)
            if record is None:
                continue
            f, r, fused = _split(record, np.ones(record.fused.shape, bool))
            source = _PING_RECORDS[name]
            sources[source] = sources.get(source, SourceCounts(0, 0, 0)) + SourceCounts(f, r, pings - f - r)
            rows = _at_pings(dvl.t_s, record, name)
            np.logical_or.at(aided, rows, fused)
        coasted = int(np.sum(~aided))
    for name, record in updates.items():
        if name in _PING_RECORDS and dvl is not None:
            continue
        f, r, _ = _split(record, np.ones(record.fused.shape, bool))
        source = _PING_RECORDS.get(name, name)
        sources[source] = SourceCounts(f, r, int(record.fused.size) - f - r)
    return MethodCounts(_ordered(sources), pings, coasted)


def lockout_resets(result: MethodResult) -> np.ndarray:
    """How many times each run's velocity was reset to the DVL after a lock-out.

    Parameters
    ----------
    result : MethodResult
        One method's results over R runs.

    Returns
    -------
    numpy.ndarray
        Shape (R,), int: the resets of tauvcore.engine.lockout in the DVL's update records (zero
        for a method that does not fuse the DVL).
    """
    dvl = result.updates.get("dvl")
    if dvl is None or dvl.reset is None:
        return np.zeros(result.pos_err_m.shape[1], dtype=int)
    return dvl.reset.sum(axis=0).astype(int)
