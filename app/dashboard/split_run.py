"""A dashboard Monte Carlo on both workers: its runs in two batches, one per worker, joined when
both end.

Run i of a Monte Carlo draws from its own generator (app.dashboard.worker.run_worker), so the
batches ``[0, k)`` and ``[k, R)`` computed apart and joined (tauvcore.engine.run_joining) are
the ``R`` runs computed on one worker, to the last bit (tests/unit/app/dashboard/test_split_run.py).
The tab reads a :class:`SplitRun` as it reads a :class:`~app.dashboard.worker.RunHandle`: the
first batch's truth, Sensors view (run 1's), live results (its runs so far) and smoother notice
pass as they come; the final message carries every run. Stop stops both batches; batches stopped
at different epochs are joined over the epochs both reached. An error of either batch is the
run's, and stops the other.

A mission reduced to time bins as it streams (app.dashboard.truth_view.decimation), a replayed
log, a single run and a run started while a worker is busy stay on one worker (:func:`splits`).
"""

from __future__ import annotations

import queue as queue_mod
import threading
from typing import Any

from app.dashboard.truth_view import decimation
from app.dashboard.worker import RunPool
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult
from tauvcore.engine.run_joining import joined_runs, until

POLL_S = 0.1  # how often the joining thread looks whether a batch ended without a last message


def splits(config: Config, num_runs: int, log_dir: str | None, pool: RunPool) -> bool:
    """Whether a run of ``config`` is split across the pool's workers: a simulated Monte Carlo
    (``num_runs`` >= 2) held whole (not reduced to time bins), with two workers idle (a worker
    busy with another tab's run would hold the second batch back)."""
    return log_dir is None and num_runs >= 2 and decimation(config)[1] == 1 and pool.idle_workers() >= 2


class _Tagged:
    """The queue a batch's messages go to: ``(index, message)`` on the shared ``out``."""

    def __init__(self, out: queue_mod.Queue, index: int) -> None:
        self.out, self.index = out, index

    def put(self, message: tuple) -> None:
        self.out.put((self.index, message))


class SplitRun:
    """A Monte Carlo of ``num_runs`` in two batches on ``pool``: a RunHandle to its reader.

    Parameters
    ----------
    pool : RunPool
        The server's workers.
    config_dict : dict
        The configuration (tauvcore.config.to_dict).
    num_runs : int
        Monte Carlo runs R, at least 2: runs 0 .. ceil(R / 2) - 1 on one worker, the rest on the other.
    progress_interval_s, smooth_mb :
        As :meth:`RunPool.start`.
    """

    def __init__(
        self,
        pool: RunPool,
        config_dict: dict[str, Any],
        num_runs: int,
        progress_interval_s: float = 2.0,
        smooth_mb: float | None = None,
    ) -> None:
        if num_runs < 2:
            raise ValueError(f"a split run needs at least 2 runs, got {num_runs}")
        self.queue: queue_mod.Queue = queue_mod.Queue()
        self._from_batches: queue_mod.Queue = queue_mod.Queue()
        self._done = threading.Event()
        first = (num_runs + 1) // 2
        self.batches = [
            pool.start(
                config_dict,
                num_runs,
                progress_interval_s,
                smooth_mb=smooth_mb,
                batch=batch,
                messages=_Tagged(self._from_batches, i),
            )
            for i, batch in enumerate([(0, first), (first, num_runs - first)])
        ]
        threading.Thread(target=self._join, name="tauv-split-run", daemon=True).start()

    def stop(self) -> None:
        """Stop both batches (RunHandle.stop)."""
        for batch in self.batches:
            batch.stop()

    def finished(self) -> bool:
        """True once every message of the run is on :attr:`queue`."""
        return self._done.is_set()

    def position(self) -> int:
        """The first batch's place in line (RunHandle.position): the run shows once it computes."""
        return self.batches[0].position()

    def _join(self) -> None:
        finals: list[dict[str, MethodResult] | None] = [None, None]
        ended = [False, False]
        stopped = False
        try:
            while not all(ended):
                try:
                    index, message = self._from_batches.get(timeout=POLL_S)
                except queue_mod.Empty:
                    for i, batch in enumerate(self.batches):  # ended with no last message: stopped
                        if batch.finished() and self._from_batches.empty():
                            ended[i] = True
                    continue
                kind = message[0]
                if kind == "done":
                    finals[index], ended[index] = message[1], True
                    stopped = stopped or bool(message[2])
                elif kind == "error":
                    self.queue.put(message)
                    self.stop()
                    return
                elif index == 0:  # truth, sensors, live results, the smoother's notice
                    self.queue.put(message)
            if finals[0] is not None and finals[1] is not None:
                self.queue.put(("done", _joined(finals[0], finals[1]), stopped))
            elif finals[0] is not None or finals[1] is not None:  # one batch stopped before it began
                self.queue.put(("done", finals[0] if finals[0] is not None else finals[1], True))
        except Exception as exc:  # noqa: BLE001 - told to the tab as the run's error, never a silent thread
            self.queue.put(
                ("error", f"the run's two batches could not be joined ({type(exc).__name__}: {exc})")
            )
            self.stop()
        finally:
            self._done.set()


def _joined(a: dict[str, MethodResult], b: dict[str, MethodResult]) -> dict[str, MethodResult]:
    """Both batches' results as one, over the epochs both reached (they differ after Stop)."""
    epochs = min(len(next(iter(part.values())).t_s) for part in (a, b))
    return joined_runs([until(a, epochs), until(b, epochs)])
