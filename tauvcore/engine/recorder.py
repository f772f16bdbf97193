"""The record of one aiding source's updates for a whole bank, kept chunk by chunk, with the
columns the divergence monitor reads for the whole mission."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import numpy.typing as npt

from tauvcore.engine.monitor import InnovationTest
from tauvcore.engine.results import UpdateRecord
from tauvcore.filter.eskf import (
    UpdateOutcome,
)


def handed_out(recorders: Iterable[Recorder], keep: bool) -> None:
    """The sealed chunks of ``recorders`` handed out (a bank's ``take``): marked taken if the bank
    keeps them, else dropped."""
    for rec in recorders:
        if keep:
            rec.taken = len(rec.chunks)
        else:
            rec.drain()


class Recorder:
    """Collects the updates of one source for the whole bank (methods x runs, one row per update:
    the compiled correction's outcome as it comes, no per-method copies), and hands out each
    method's record (:meth:`build`).

    Rows are stacked into one array per field at the end of every chunk (:meth:`seal`), so a long
    mission holds a few arrays per chunk, not thousands of tiny ones; sealed chunks can be handed
    out and dropped (:meth:`drain`), while what the divergence monitor needs (times, NIS, dof,
    fused, valid: a few bytes per update and run) is kept for the whole mission.

    ``members`` (M,): the methods this source updates (they get a record); ``rows`` (M,): how many
    measurement rows each method's record has (the DVL's widest is tightly coupled's 4; the loosely
    coupled velocity's 3), None: all. ``shared``: fields of the ping, the same for every method
    (the beams that returned)."""

    MONITOR = ("nis", "nis_dof", "fused", "valid")
    MONITOR_OPTIONAL = ("reset",)  # the DVL's records only
    ROW_FIELDS = ("z", "innovation", "innovation_var", "fused_rows", "rejected_rows")

    def __init__(self, members: npt.ArrayLike, rows: np.ndarray | None = None) -> None:
        self.members = np.asarray(members, dtype=bool)
        self.rows_of = rows
        self.t: list[float] = []
        self.rows: list[dict[str, np.ndarray]] = []
        self.chunks: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []  # sealed (t, fields)
        self.monitor_t = np.zeros(0)  # the monitor's columns, grown by doubling
        self.monitor: dict[str, np.ndarray] = {}
        self.taken = 0  # sealed chunks already handed out (FilterBank.take with keep)
        self.count = 0  # updates recorded over the whole mission
        self.tests: dict[int, InnovationTest] = {}  # each method's innovation test, read as it grows

    def add(
        self,
        t: float,
        outcome: UpdateOutcome,
        valid: np.ndarray,
        shared: dict[str, np.ndarray] | None = None,
        **extra: np.ndarray,
    ) -> None:
        """One update of every method and run: ``outcome`` and ``valid``, ``extra`` (M, R, ...);
        ``shared`` (R, ...)."""
        self.t.append(t)
        self.rows.append(
            {
                "z": outcome.z,
                "innovation": outcome.innovation,
                "innovation_var": outcome.innovation_var,
                "test_ratio": outcome.test_ratio,
                "fused": outcome.fused,
                "rejected": outcome.rejected,
                "valid": valid,
                "fused_rows": outcome.fused_rows,
                "rejected_rows": outcome.rejected_rows,
                "nis": outcome.nis,
                "nis_dof": outcome.nis_dof,
                "unusable": outcome.unusable,
                **({} if outcome.log_det_s is None else {"log_det_s": outcome.log_det_s}),
                **extra,
                **{f"shared:{k}": v for k, v in (shared or {}).items()},
            }
        )
        self.count += 1

    def seal(self) -> None:
        if not self.rows:
            return
        fields = {k: np.stack([r[k] for r in self.rows]) for k in self.rows[0]}
        t = np.asarray(self.t)
        self.chunks.append((t, fields))
        self._monitor_append(t, fields)
        self.t, self.rows = [], []

    def _monitor_append(self, t: np.ndarray, fields: dict[str, np.ndarray]) -> None:
        """Copy a chunk's monitor columns into buffers that double when full (a long mission's
        monitor is then four arrays, not four per chunk)."""
        done = self.count - t.size
        if not self.monitor:
            self.monitor_t = np.empty(max(64, t.size))
            self.monitor = {
                k: np.empty((self.monitor_t.size,) + fields[k].shape[1:], fields[k].dtype)
                for k in self.MONITOR + self.MONITOR_OPTIONAL
                if k in fields
            }
        if done + t.size > self.monitor_t.size:
            size = max(2 * self.monitor_t.size, done + t.size)
            self.monitor_t = np.resize(self.monitor_t, size)
            self.monitor = {k: np.resize(v, (size,) + v.shape[1:]) for k, v in self.monitor.items()}
        self.monitor_t[done : done + t.size] = t
        for k in self.monitor:
            self.monitor[k][done : done + t.size] = fields[k]

    def build(self, m: int, first: int = 0) -> UpdateRecord | None:
        """Method ``m``'s record of the sealed chunks from ``first`` on (None if there are none)."""
        chunks = self.chunks[first:]
        if not chunks:
            return None
        rows = None if self.rows_of is None else int(self.rows_of[m])
        fields = {}
        for k in chunks[0][1]:
            if k.startswith("shared:"):
                fields[k[len("shared:") :]] = np.concatenate([c[1][k] for c in chunks])
                continue
            a = np.concatenate([c[1][k][:, m] for c in chunks])
            fields[k] = a[..., :rows] if rows is not None and k in self.ROW_FIELDS else a
        return UpdateRecord(t_s=np.concatenate([c[0] for c in chunks]), **fields)

    def drain(self) -> None:
        self.chunks = []
        self.taken = 0

    def divergence_s(self, m: int) -> np.ndarray:
        """First flag of method ``m``'s innovation test over the whole mission so far (R,)."""
        n = self.count - len(self.t)  # sealed updates
        c = {k: v[:n, m] for k, v in self.monitor.items()}
        if m not in self.tests:
            self.tests[m] = InnovationTest(c["nis"].shape[1])
        return self.tests[m](
            self.monitor_t[:n], c["nis"], c["nis_dof"], c["fused"], c["valid"], reset=c.get("reset")
        )
