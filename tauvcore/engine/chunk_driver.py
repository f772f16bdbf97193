"""The chunk driver both filter banks are: a mission's chunks fed in order, stops polled, results
stored and handed out.

A bank (tauvcore.engine.filter_bank.FilterBank, tauvcore.engine.yoo_bank.YooBank) brings its
states, its set-up and how it runs the stops of a chunk (:meth:`ChunkDriver._run_chunk`: a
generator that advances the nominal states and covariances over the chunk's stops, fuses its
aiding epochs, records its output epochs into the chunk's store, and yields at the output epochs
where the driver asked to be called back). The driver owns everything else, once for both:

- the constants of the strapdown, the covariance and output grids and the gate;
- the order of the chunks, the raw IMU increments carried from one chunk to the next;
- when to come back to Python (:class:`Watch`): at every output epoch while someone polls
  ``should_stop``, else every ``interval_s`` of simulated time for ``progress``, else only where
  the bank needs to (its aiding epochs);
- stop and progress: a stop ends the results at that output epoch; a progress call sees every
  result so far;
- the rest of a chunk after its last stop (the nominal state goes on, the covariance waits);
- the store: each chunk's output epochs (and the bank's own per-update arrays) as one dict of
  arrays, sealed when the chunk ends, and handed out by :meth:`take` and :meth:`results`; the
  sensor errors' arrays (``sensor_errors``) have a row per output epoch only when asked for.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.results import SENSOR_FIELDS, STATE_FIELDS, MethodResult
from tauvcore.engine.simulation import SimChunk
from tauvcore.filter.kernels.common import plain
from tauvcore.filter.kernels.strapdown_kernels import StrapdownConstants, advance
from tauvcore.ins.strapdown import Strapdown, body_increments

EPOCH_FIELDS = frozenset(
    (
        "t_s",
        "out_k",
        "series",
        "nees_block",
        "est_pos_n",
        "pos_cov_ne_m2",
        "est_vel_n",
        "est_euler",
        *SENSOR_FIELDS,
        *STATE_FIELDS,
    )
)
"""The store's fields with one row per output epoch (``series`` along its second axis, the others
along their first; the sensor errors' rows only when the bank records them, none otherwise; the
sources' states' (tauvcore.engine.results.STATE_FIELDS) with no columns when there are none);
every other field has one row per update (``up_k``, ``up_t``)."""

Store = dict[str, np.ndarray]


@dataclass(frozen=True)
class Watch:
    """Who watches a run while it goes, and may end it: what the chunk loop calls back between
    output epochs. The results do not depend on it.

    Attributes
    ----------
    progress : Callable[[float, dict[str, MethodResult]], None] or None
        ``progress(t_s, results)`` with the simulated time [s] and the results so far (for live
        displays), every ``interval_s`` of simulated time; None: not called.
    interval_s : float
        Simulated time between two calls of ``progress`` [s].
    min_wall_s : float
        Wall time [s] that must pass between two calls of ``progress`` (0: every interval):
        gathering the results so far is what a call costs (a live display needs about one a
        second, not one per 2 s of a mission that runs 100 times faster than real time).
    should_stop : Callable[[], bool] or None
        ``should_stop()``, polled at every output epoch (``config.filter.output_rate_hz``, 10 Hz
        by default, of simulated time: a few milliseconds of wall time); True ends the run at that
        epoch, the results ending there. None: the run goes to the end.
    """

    progress: Callable[[float, dict[str, MethodResult]], None] | None = None
    interval_s: float = 5.0
    min_wall_s: float = 0.0
    should_stop: Callable[[], bool] | None = None


UNWATCHED = Watch()
"""No progress, no stop requests."""


class ChunkInputs:
    """A chunk's IMU increments as the strapdown takes them (tauvcore.ins.strapdown.body_increments):
    coning- and sculling-corrected ``phi_raw``, ``dv_raw`` and the raw ``dtheta`` (contiguous), and
    the raw gyro increment of the sample before the chunk (None before the first)."""

    __slots__ = ("dtheta", "dv_raw", "phi_raw", "prev_dtheta")

    def __init__(
        self, phi_raw: np.ndarray, dv_raw: np.ndarray, dtheta: np.ndarray, prev_dtheta: np.ndarray | None
    ) -> None:
        self.phi_raw, self.dv_raw, self.dtheta, self.prev_dtheta = phi_raw, dv_raw, dtheta, prev_dtheta


class ChunkDriver:
    """The part of a filter bank that is not its filter: see the module docstring.

    Subclasses set the nominal states ``pos``, ``vel``, ``C``, ``ba``, ``bg`` ((M, R, ...) arrays)
    and ``dtheta_sum`` (R, 3) in their ``start`` and implement :meth:`_begin`, :meth:`_store`,
    :meth:`_run_chunk` and :meth:`_results`."""

    pos: np.ndarray
    vel: np.ndarray
    C: np.ndarray
    ba: np.ndarray
    bg: np.ndarray
    dtheta_sum: np.ndarray

    def __init__(
        self,
        config: Config,
        methods: tuple[str, ...],
        num_runs: int,
        num_samples: int,
        dt_s: float,
        keep: bool,
        sensor_errors: bool = False,
    ) -> None:
        self.config, self.methods, self.keep = config, methods, keep
        self.sensor_errors = sensor_errors  # record the estimated sensor errors, their sigma and truth
        self.batch = (len(methods), num_runs)
        self.num_samples, self.dt = num_samples, dt_s
        earth = config.earth
        strapdown = Strapdown(earth, dt_s)
        self.geodetic = earth.geodetic
        self.sd_consts = StrapdownConstants(
            dt_s,
            strapdown.C_earth,
            strapdown.C_earth_half,
            strapdown.g_n,
            strapdown.coriolis_T,
            self.geodetic,
        )
        # NED positions are recorded from the sea-surface point above the start (Truth.pos_n)
        self.origin = np.array([earth.latitude_rad, earth.longitude_rad, 0.0])
        self.w_ie = np.ascontiguousarray(earth.omega_ie_n, dtype=float)
        rate_hz = config.imu.rate_hz
        self.out_idx = np.arange(0, num_samples, max(1, round(rate_hz / config.filter.output_rate_hz)))
        self.cov_step = max(1, round(rate_hz / config.filter.covariance_rate_hz))
        self.gate = config.filter.gate_sigma
        self.started = False
        self.stopped = False
        self.stopped_at_s = np.nan  # the output epoch a stop request ended the results at
        self.last_progress_wall_s = -np.inf  # time.monotonic() of the last progress call
        self.chunks: list[Store] = []  # each chunk's store, sealed (:meth:`_seal`)
        self.taken = 0  # chunks handed out by take()
        self.prev_raw: tuple[np.ndarray, np.ndarray] | None = (
            None  # raw increments of the sample before a chunk
        )
        self.k_state = 0  # sample the nominal state is at
        self.k_cov = 0  # sample the covariance was last propagated to

    # ------------------------------------------------------------------ what a bank brings
    def _begin(self, chunk: SimChunk) -> None:
        """Called with the first chunk before anything else (set-up that needs its truth)."""
        raise NotImplementedError

    def _store(self, outs: np.ndarray, chunk: SimChunk | None) -> Store:
        """The arrays a chunk's results are written into, for output epochs at samples ``outs``
        (``out_k``) and the chunk's updates; ``chunk`` None: the empty store of no results."""
        raise NotImplementedError

    def _run_chunk(
        self, chunk: SimChunk, inputs: ChunkInputs, store: Store, poll_every: int
    ) -> Iterator[int]:
        """Run the chunk's stops, writing its results into ``store``; yield the sample of each
        output epoch at which the number of epochs recorded so far is a multiple of ``poll_every``
        (none if 0), once that epoch is recorded."""
        raise NotImplementedError

    def _results(self, cat: Store, taking: bool) -> dict[str, MethodResult]:
        """MethodResult per method from the concatenated stores ``cat``; ``taking``: for
        :meth:`take` (the bank hands out what it kept elsewhere since the last take, and lets go of
        it unless ``keep``)."""
        raise NotImplementedError

    def _sensor_store(self, T: int, S: int, fill: float) -> Store:
        """The sensor errors' arrays of a store of ``T`` output epochs: (T, M, R, S) filled with
        ``fill`` when the bank records them (``sensor_errors``), else (0, M, R, S), which the
        kernels leave alone."""
        shape = (T if self.sensor_errors else 0,) + self.batch + (S,)
        return {name: np.full(shape, fill) for name in SENSOR_FIELDS}

    def _sealed(self) -> None:
        """Called after each seal (a bank with its own per-chunk records closes them here)."""

    def _chunk_end(self, chunk: SimChunk) -> None:
        """Called once the chunk's last sample is reached, before its store is sealed."""

    # ------------------------------------------------------------------ the chunk loop
    def feed(self, chunk: SimChunk, watch: Watch = UNWATCHED) -> bool:
        """Run the bank over one chunk (chunks in order, the first at sample 0), called back as
        ``watch`` asks (:class:`Watch`); returns False once its ``should_stop`` said so (the
        results then end at that epoch)."""
        if self.stopped:
            return False
        if not self.started:
            if chunk.k0 != 0:
                raise ValueError(f"the first chunk must start at sample 0, got {chunk.k0}")
            self._begin(chunk)
        k0, n = chunk.k0, chunk.truth.num_samples
        if k0 != (0 if self.prev_raw is None else self.k_state + 1):
            raise ValueError(
                f"chunks must follow each other: expected one at sample {self.k_state + 1}, got {k0}"
            )
        imu = chunk.imu
        dtheta = np.ascontiguousarray(imu.dtheta_b)
        phi_raw, dv_raw = (np.ascontiguousarray(a) for a in body_increments(dtheta, imu.dv_b, self.prev_raw))
        inputs = ChunkInputs(phi_raw, dv_raw, dtheta, self.prev_raw[0] if self.prev_raw is not None else None)
        self.prev_raw = (dtheta[-1].copy(), np.array(imu.dv_b[-1]))
        progress, should_stop = watch.progress, watch.should_stop
        every = max(1, round(watch.interval_s * self.config.filter.output_rate_hz))
        poll_every = 1 if should_stop is not None else (every if progress is not None else 0)
        store = self._store(self.out_idx[(self.out_idx >= k0) & (self.out_idx < k0 + n)], chunk)
        for k in self._run_chunk(chunk, inputs, store, poll_every):
            t = float(chunk.truth.t_s[k - k0])
            if should_stop is not None and should_stop():
                self.stopped, self.stopped_at_s = True, t
                self._seal(store, k)
                return False
            done = int(np.searchsorted(self.out_idx, k, side="right"))  # output epochs recorded
            if (
                progress is not None
                and done % every == 0
                and done < self.out_idx.size
                and time.monotonic() - self.last_progress_wall_s >= watch.min_wall_s
            ):
                self._seal(store, k)
                progress(t, self.results())
                self.chunks.pop()
                self.last_progress_wall_s = time.monotonic()
        # the rest of the chunk: the nominal state goes on, the covariance step waits for its epoch
        if k0 + n - 1 > self.k_state:
            self._advance_to(inputs, k0, k0 + n - 1)
        self._chunk_end(chunk)
        self._seal(store, k0 + n - 1)
        return True

    def _advance_to(self, inputs: ChunkInputs, k0: int, k: int) -> None:
        """The nominal states from ``self.k_state`` to sample ``k`` of the chunk starting at ``k0``."""
        increments = (inputs.phi_raw, inputs.dv_raw, inputs.dtheta)
        k_from, k_to = self.k_state - k0, k - k0
        advance(
            self.pos,
            self.vel,
            self.C,
            self.ba,
            self.bg,
            increments,
            self.dtheta_sum,
            k_from,
            k_to,
            plain(self.sd_consts),
        )
        self.k_state = k

    # ------------------------------------------------------------------ the store
    def _seal(self, store: Store, k_last: int) -> None:
        """Keep the store's rows up to sample ``k_last`` (the whole chunk, or up to a stop)."""
        self.chunks.append(cut(store, k_last, "out_k", "up_k"))
        self._sealed()

    def results(self, until_s: float | None = None) -> dict[str, MethodResult]:
        """Every output epoch and update kept so far (all of them unless ``keep`` is False), none
        after ``until_s``."""
        return self._results(self._concatenate(self.chunks, until_s), taking=False)

    def take(self, until_s: float | None = None) -> dict[str, MethodResult]:
        """The output epochs and updates since the last :meth:`take` (none after ``until_s``);
        without ``keep`` they are dropped from the bank, so that memory does not grow with the
        mission."""
        chunks = self.chunks[self.taken :]
        if self.keep:
            self.taken = len(self.chunks)
        else:
            self.chunks, self.taken = [], 0
        return self._results(self._concatenate(chunks, until_s), taking=True)

    def _concatenate(self, chunks: list[Store], until_s: float | None) -> Store:
        if chunks:
            cat = {
                name: np.concatenate([c[name] for c in chunks], axis=1 if name == "series" else 0)
                for name in chunks[0]
            }
        else:
            cat = self._store(np.zeros(0, np.int64), None)
        return cat if until_s is None else cut(cat, until_s, "t_s", "up_t")


def cut(store: Store, last: Any, epoch_key: str, update_key: str) -> Store:
    """The store's rows up to ``last`` (inclusive) of its output epochs' ``store[epoch_key]`` and
    its updates' ``store[update_key]`` (views, not copies)."""
    T = int(np.searchsorted(store[epoch_key], last, side="right"))
    U = int(np.searchsorted(store[update_key], last, side="right")) if update_key in store else 0
    return {
        name: (a[:, :T] if name == "series" else a[:T] if name in EPOCH_FIELDS else a[:U])
        for name, a in store.items()
    }


def covariance_stops(event_idx: np.ndarray, k_cov: int, k_end: int, cov_step: int) -> list[int]:
    """Samples in ``(k_cov, k_end)`` at which the covariance is propagated (and the nominal state
    stops), the covariance having been propagated last at ``k_cov``: every event (aiding or output
    epoch, ``event_idx`` sorted) and every ``cov_step`` samples in between."""
    stops: list[int] = []
    prev = k_cov
    for e in [int(e) for e in event_idx if e > k_cov] + [k_end]:
        stops.extend(range(prev + cov_step, e, cov_step))
        if e < k_end:
            stops.append(e)
        prev = e
    return stops
