"""Monte Carlo studies: every run its own seeded unit, runs computed in chunks anywhere, results
identical whatever the split.

Run ``i`` of a study with seed ``s`` draws everything random (IMU, DVL, pressure and magnetometer
errors, its initial errors) from independent streams spawned from
``numpy.random.default_rng(SeedSequence(s, spawn_key=(i,)))`` (:func:`run_rng`, the i-th child of the
study's seed sequence; tauvcore.sensors.stream.SensorStreams.spawned). A chunk of runs ``[first, first +
count)`` is one batch of the filter bank (:func:`run_chunk`), truth and sensors streamed a few
seconds at a time; every method of a run sees the same sensor data. Since nothing in a run
depends on the others, the study's numbers do not depend on how its runs are chunked, on how many
workers compute them, or where (local processes, Dask): tests/unit/tauvcore/eval/test_study.py checks it.

A finished chunk is reduced at once (:class:`StudyAccumulator`): per method and output epoch the
sums that the RMS over runs, the mean NEES and the consistency summary need, so the study's memory
does not grow with its number of runs; the per-run series go to the caller (a Parquet writer) chunk
by chunk. With the smoother (``smooth``: tauvcore.engine.smoothing), each chunk also carries the
methods' smoothed series, run inside the chunk's batch, and the summary their RMS and
consistency beside the filtered (``"smoothed"`` of each method).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pickle
import tempfile
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from tauvcore.config import Config, from_dict, to_dict
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.results import BLOCK_DIMS, MethodResult, block_dims
from tauvcore.engine.smoothing import SmoothOptions, scratch
from tauvcore.eval.consistency import nees_band
from tauvcore.eval.counts import MethodCounts, lockout_resets, method_counts
from tauvcore.eval.study_statistics import final_statistics
from tauvcore.filter.layout import NEES_BLOCKS

ERROR_SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg")
"""Per-run error series a study keeps (norms, with the attitude split into tilt and heading)."""
SIGMA_SERIES = ("pos_sigma_m", "vel_sigma_mps", "att_sigma_deg", "tilt_sigma_deg", "heading_sigma_deg")
NEES_SERIES = ("nees",) + tuple(f"nees_{b}" for b in NEES_BLOCKS)
RUN_SERIES = ERROR_SERIES + SIGMA_SERIES + NEES_SERIES
"""Every per-run, per-epoch series of a study, as the Parquet file names its columns."""


def run_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of run ``index`` of a study seeded ``seed`` (independent of every other run).

    Parameters
    ----------
    seed : int
        The study's seed.
    index : int
        The run's index in the study, 0 .. num_runs - 1.

    Returns
    -------
    numpy.random.Generator
        ``default_rng(SeedSequence(seed, spawn_key=(index,)))``: the ``index``-th child of the
        study's seed sequence.
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def chunks(num_runs: int, chunk_runs: int) -> list[tuple[int, int]]:
    """``(first, count)`` of consecutive chunks of at most ``chunk_runs`` runs covering ``num_runs``.

    Parameters
    ----------
    num_runs : int
        Runs of the study, at least 1.
    chunk_runs : int
        Most runs per chunk, at least 1.

    Returns
    -------
    list[tuple[int, int]]
        Each chunk's first run index and number of runs, in run order; only the last may hold
        fewer than ``chunk_runs``.

    Raises
    ------
    ValueError
        ``num_runs`` or ``chunk_runs`` below 1: "num_runs and chunk_runs must be >= 1".
    """
    if num_runs < 1 or chunk_runs < 1:
        raise ValueError(f"num_runs and chunk_runs must be >= 1, got {num_runs!r}, {chunk_runs!r}")
    return [(first, min(chunk_runs, num_runs - first)) for first in range(0, num_runs, chunk_runs)]


def study_config(config: Config) -> Config:
    """The configuration a study runs: initial errors drawn per run (Table 2 values as 1-sigma).

    Parameters
    ----------
    config : Config
        The configuration as given.

    Returns
    -------
    Config
        ``config`` with ``initial_error.mode`` "random".
    """
    return config.replace("initial_error", mode="random")


def run_chunk(
    config: Config, seed: int, first: int, count: int, smooth: SmoothOptions | None = None
) -> dict[str, MethodResult]:
    """Runs ``first .. first + count - 1`` of the study, every method of ``config.run.methods``.

    One batch of the filter bank, truth and sensors streamed
    (:func:`~tauvcore.engine.mission.run_streaming`), each run drawing from its own generator
    (:func:`run_rng`); the initial errors drawn per run (:func:`study_config`).

    Parameters
    ----------
    config : Config
        The study's configuration.
    seed : int
        The study's seed.
    first : int
        Index of the chunk's first run in the study.
    count : int
        Runs in the chunk.
    smooth : SmoothOptions or None
        Also run the smoother (its tape spilling to a directory of its own, removed after:
        tauvcore.engine.smoothing.scratch); every method's results then carry
        ``smoothed``. None: no smoother.

    Returns
    -------
    dict[str, MethodResult]
        Method name -> its results over the T output epochs and the chunk's ``count`` runs (series
        (T, count)), in ``config.run.methods`` order.
    """
    rngs = [run_rng(seed, i) for i in range(first, first + count)]
    with scratch(smooth) as options:
        return run_streaming(study_config(config), rngs, num_runs=count, smooth=options)


@dataclass(frozen=True)
class ChunkSeries:
    """What a worker sends back for one chunk: per method, the per-run series and the verdicts.

    The per-run series (T, count) are in the units their names carry (:data:`RUN_SERIES`: [m],
    [m/s], [deg]; NEES dimensionless), the monitor's verdict (count,), the output epochs ``t_s``
    (T,) [s]. Small and plain, so it pickles cheaply to a process or over Dask."""

    first: int
    count: int
    t_s: np.ndarray
    series: dict[str, dict[str, np.ndarray]]  # method -> RUN_SERIES name -> (T, count)
    diverged: dict[str, np.ndarray]  # method -> (count,) bool
    resets: dict[str, np.ndarray] = field(default_factory=dict)  # method -> (count,) int: lock-out
    #                                                                 resets (tauvcore.engine.lockout)
    smoothed: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)  # the smoothed methods'
    # series as ``series`` (a study with the smoother), else empty
    counts: dict[str, MethodCounts] = field(default_factory=dict)  # method -> its updates per aiding
    #                                                                 source over the chunk's runs


def series_of(result: MethodResult) -> dict[str, np.ndarray]:
    """The per-run series a study keeps of one method's results.

    Parameters
    ----------
    result : MethodResult
        One method's results over T output epochs and R runs.

    Returns
    -------
    dict[str, numpy.ndarray]
        :data:`RUN_SERIES` name -> its series (T, R): the errors and sigmas in the units their
        names carry ([m], [m/s], [deg]), the NEES of the full state and of each block
        (``nees_<block>``), dimensionless.
    """
    out = {name: getattr(result, name) for name in ERROR_SERIES + SIGMA_SERIES}
    out["nees"] = result.nees
    for b, block in enumerate(NEES_BLOCKS):
        out[f"nees_{block}"] = result.nees_block[..., b]
    return out


def compute_chunk(
    config_dict: dict, seed: int, first: int, count: int, smooth: SmoothOptions | None = None
) -> ChunkSeries:
    """A worker's whole job (a local process or a Dask worker): plain inputs, plain outputs.

    Parameters
    ----------
    config_dict : dict
        The study's configuration as a plain dict (``tauvcore.config.to_dict``).
    seed : int
        The study's seed.
    first : int
        Index of the chunk's first run in the study.
    count : int
        Runs in the chunk.
    smooth : SmoothOptions or None
        Also the smoother's series (:func:`run_chunk`); None: no smoother.

    Returns
    -------
    ChunkSeries
        Per method, the per-run series (T, count) and the monitor's verdict (count,), with the
        output epochs (T,) [s]; with ``smooth`` the smoothed series of every method.
    """
    results = run_chunk(from_dict(config_dict), seed, first, count, smooth)
    any_result = next(iter(results.values()))
    return ChunkSeries(
        first=first,
        count=count,
        t_s=any_result.t_s,
        series={m: series_of(r) for m, r in results.items()},
        diverged={m: r.diverged.copy() for m, r in results.items()},
        resets={m: lockout_resets(r) for m, r in results.items()},
        counts={m: method_counts(r) for m, r in results.items()},
        smoothed={m: series_of(r.smoothed) for m, r in results.items() if r.smoothed is not None},
    )


@dataclass
class _MethodSums:
    sum_sq: dict[str, np.ndarray]  # ERROR_SERIES + SIGMA_SERIES: sum over runs of x^2 per epoch (finite only)
    finite: dict[str, np.ndarray]  # their finite counts per epoch
    nees_sum: dict[str, np.ndarray]  # NEES_SERIES: sum over runs per epoch (finite only)
    nees_finite: dict[str, np.ndarray]
    final: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)  # chunk's first run -> final values
    flagged: dict[int, np.ndarray] = field(default_factory=dict)  # chunk's first run -> (count,) bool
    resets: dict[int, np.ndarray] = field(default_factory=dict)  # chunk's first run -> (count,) int
    diverged: int = 0
    counts: MethodCounts = field(default_factory=MethodCounts)  # over the chunks added


class StudyAccumulator:
    """Per method and epoch, the sums a study's summary needs, fed chunk by chunk in any order.

    Parameters
    ----------
    methods : tuple[str, ...]
        The study's methods (``config.run.methods``), every chunk carrying each of them.
    smoothed : tuple[str, ...]
        The methods whose smoothed series every chunk carries (``ChunkSeries.smoothed``), summed
        apart in the same way; empty: a study without the smoother.
    """

    def __init__(self, methods: tuple[str, ...], smoothed: tuple[str, ...] = ()) -> None:
        self.methods = methods
        self.t_s: np.ndarray | None = None
        self.num_runs = 0
        self._sums: dict[str, _MethodSums] = {}
        self.smoothed = StudyAccumulator(smoothed) if smoothed else None

    def add(self, chunk: ChunkSeries) -> None:
        """Reduce one chunk into the sums: per epoch the finite entries' sum of squares of every
        error and sigma series, the sum of every NEES series, their counts, the chunk's final
        errors and its runs flagged by the monitor.

        Parameters
        ----------
        chunk : ChunkSeries
            One chunk's per-run series (T, count), every chunk on the same T output epochs.
        """
        if self.t_s is None:
            self.t_s = chunk.t_s
            T = chunk.t_s.size
            for m in self.methods:
                zeros = {n: np.zeros(T) for n in ERROR_SERIES + SIGMA_SERIES}
                self._sums[m] = _MethodSums(
                    sum_sq=zeros,
                    finite={n: np.zeros(T, int) for n in zeros},
                    nees_sum={n: np.zeros(T) for n in NEES_SERIES},
                    nees_finite={n: np.zeros(T, int) for n in NEES_SERIES},
                )
        self.num_runs += chunk.count
        for m in self.methods:
            s, series = self._sums[m], chunk.series[m]
            for n in ERROR_SERIES + SIGMA_SERIES:
                x = series[n]
                ok = np.isfinite(x)
                s.sum_sq[n] += np.square(np.where(ok, x, 0.0)).sum(axis=1)
                s.finite[n] += ok.sum(axis=1)
            for n in NEES_SERIES:
                x = series[n]
                ok = np.isfinite(x)
                s.nees_sum[n] += np.where(ok, x, 0.0).sum(axis=1)
                s.nees_finite[n] += ok.sum(axis=1)
            s.final[chunk.first] = {n: series[n][-1].copy() for n in ERROR_SERIES}
            s.flagged[chunk.first] = np.asarray(chunk.diverged[m], dtype=bool).copy()
            s.resets[chunk.first] = np.asarray(chunk.resets.get(m, np.zeros(chunk.count)), dtype=int).copy()
            s.diverged += int(chunk.diverged[m].sum())
            s.counts = s.counts + chunk.counts.get(m, MethodCounts())
        if self.smoothed is not None:
            self.smoothed.add(dataclasses.replace(chunk, series=chunk.smoothed, smoothed={}, counts={}))

    def rms(self, method: str, name: str) -> np.ndarray:
        """RMS over the runs per epoch (NaN where no run is finite).

        Parameters
        ----------
        method : str
            The method's name.
        name : str
            An error or sigma series (:data:`ERROR_SERIES`, :data:`SIGMA_SERIES`), e.g.
            ``pos_err_m``.

        Returns
        -------
        numpy.ndarray
            RMS over the finite runs, shape (T,), in the unit the series' name carries ([m],
            [m/s], [deg]).
        """
        s = self._sums[method]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.sqrt(s.sum_sq[name] / s.finite[name])

    def mean_nees(self, method: str, name: str) -> np.ndarray:
        """Mean NEES over the runs per epoch (NaN where no run is finite).

        Parameters
        ----------
        method : str
            The method's name.
        name : str
            A NEES series (:data:`NEES_SERIES`): ``nees`` (the full state) or ``nees_<block>``.

        Returns
        -------
        numpy.ndarray
            Mean over the finite runs, shape (T,), dimensionless (not divided by the dimension).
        """
        s = self._sums[method]
        with np.errstate(invalid="ignore", divide="ignore"):
            return s.nees_sum[name] / s.nees_finite[name]

    def consistency(self, method: str, block: str) -> dict[str, float | list[float]]:
        """NEES consistency of one block over all runs, as :func:`tauvcore.eval.consistency.summarise_nees`.

        NEES/dim over epochs and runs (finite entries) and the fraction of epochs whose run mean
        lies in the 99 % band (an epoch where a run's NEES is not finite counts as outside).

        Parameters
        ----------
        method : str
            The method's name (its NEES dimensions: :func:`~tauvcore.engine.results.block_dims`).
        block : str
            "full" or a key of ``tauvcore.filter.layout.NEES_BLOCKS``.

        Returns
        -------
        dict[str, float | list[float]]
            ``dim`` (the block's degrees of freedom), ``per_dim`` (NaN if no finite entry),
            ``in_band`` (fraction of the T epochs) and ``band_per_dim`` ([lower, upper]),
            dimensionless.
        """
        s = self._sums[method]
        name = "nees" if block == "full" else f"nees_{block}"
        dim = block_dims(method)[block]
        total, count = s.nees_sum[name].sum(), s.nees_finite[name].sum()
        lo, hi = nees_band(dim, self.num_runs)
        all_finite = s.nees_finite[name] == self.num_runs
        avg = s.nees_sum[name] / self.num_runs / dim
        inside = all_finite & (avg >= lo) & (avg <= hi)
        return {
            "dim": dim,
            "per_dim": float(total / count / dim) if count else float("nan"),
            "in_band": float(inside.mean()),
            "band_per_dim": [lo, hi],
        }

    def summary(self) -> dict:
        """The study's summary, JSON-ready.

        Per method: the per-epoch RMS of every error series and mean NEES, final values (RMS over
        runs at the last epoch, and each run's), the consistency per block, runs flagged.

        Returns
        -------
        dict
            ``t_s`` (T,) [s], ``num_runs`` and ``methods``: method name -> ``rms`` (series name ->
            (T,), in the series' unit), ``mean_nees`` (NEES series -> (T,)), ``final_rms``
            (error series -> float), ``final_per_run`` (error series -> (num_runs,) in run
            order), ``consistency`` (block -> :meth:`consistency`) and
            ``runs_flagged_by_monitor`` (int), ``flagged_runs`` (the flagged runs' numbers in the
            study), ``lockout_resets`` (int: the velocity resets to the DVL after a lock-out,
            tauvcore.engine.lockout), ``reset_runs`` (the numbers of the runs reset), ``counts``
            (per aiding source the updates fused, rejected and unused over every run, and the DVL
            pings coasted on: tauvcore.eval.counts.MethodCounts.to_json) and ``final_stats`` (error series -> :func:`final_statistics`: RMS, median and
            95th percentile over the runs at the last epoch, and the same over the runs the
            monitor did not flag). A study with the smoother adds ``smoothed`` to each method:
            the same keys over its smoothed series (its flags the forward pass's), or None for a
            method not smoothed.

        Raises
        ------
        ValueError
            No chunk was added: "no chunk was added".
        """
        if self.t_s is None:
            raise ValueError("no chunk was added")
        out: dict = {"t_s": self.t_s, "num_runs": self.num_runs, "methods": {}}
        for m in self.methods:
            s = self._sums[m]
            firsts = sorted(s.final)
            per_run = {n: np.concatenate([s.final[k][n] for k in firsts]) for n in ERROR_SERIES}
            flagged = np.concatenate([s.flagged[k] for k in firsts])
            resets = np.concatenate([s.resets[k] for k in firsts])
            run_numbers = np.concatenate([k + np.arange(s.flagged[k].size) for k in firsts])
            out["methods"][m] = {
                "rms": {n: self.rms(m, n) for n in ERROR_SERIES + SIGMA_SERIES},
                "mean_nees": {n: self.mean_nees(m, n) for n in NEES_SERIES},
                "final_rms": {n: float(self.rms(m, n)[-1]) for n in ERROR_SERIES},
                "final_per_run": per_run,
                "final_stats": {n: final_statistics(per_run[n], flagged) for n in ERROR_SERIES},
                "consistency": {b: self.consistency(m, b) for b in BLOCK_DIMS},
                "runs_flagged_by_monitor": s.diverged,
                "flagged_runs": [int(r) for r in run_numbers[flagged]],
                "lockout_resets": int(resets.sum()),
                "reset_runs": [int(r) for r in run_numbers[resets > 0]],
                "counts": s.counts.to_json(),
            }
        if self.smoothed is not None:
            smoothed = self.smoothed.summary()["methods"]
            for m in self.methods:
                out["methods"][m]["smoothed"] = smoothed.get(m)
        return out


def compute_chunk_to_file(
    config_dict: dict, seed: int, first: int, count: int, directory: str, smooth: SmoothOptions | None = None
) -> str:
    """:func:`compute_chunk` in a local worker process, its result pickled to a new file in ``directory``.

    Why not return the result through the pool's pipe: a worker killed (the out-of-memory killer)
    while it writes a large result (tens of MB) to the pipe leaves half a message in it, and
    ``ProcessPoolExecutor``'s result thread then waits for the rest forever instead of reporting
    the dead worker (seen with the killed-worker test). A path is a message of a few hundred
    bytes, written to the pipe in one piece.

    Parameters
    ----------
    config_dict : dict
        The study's configuration as a plain dict (``tauvcore.config.to_dict``).
    seed : int
        The study's seed.
    first : int
        Index of the chunk's first run in the study.
    count : int
        Runs in the chunk.
    directory : str
        The directory the file is written to (the pool's ``chunk_dir``).
    smooth : SmoothOptions or None
        Also the smoother's series (:func:`compute_chunk`); None: no smoother.

    Returns
    -------
    str
        The path of the file holding the pickled :class:`ChunkSeries`.
    """
    chunk = compute_chunk(config_dict, seed, first, count, smooth)
    fd, path = tempfile.mkstemp(prefix=f"chunk-{first}-", suffix=".pickle", dir=directory)
    with os.fdopen(fd, "wb") as fh:
        pickle.dump(chunk, fh, protocol=pickle.HIGHEST_PROTOCOL)
    return path


def _load_chunk_file(path: str) -> ChunkSeries:
    try:
        with open(path, "rb") as fh:
            return pickle.load(fh)
    finally:
        with contextlib.suppress(OSError):
            os.remove(path)


class ChunkPool(ProcessPoolExecutor):
    """Local worker processes (spawned) that hand their chunks over as files in ``chunk_dir``.

    Each worker runs :func:`compute_chunk_to_file`.

    Parameters
    ----------
    workers : int
        Worker processes.
    chunk_dir : str
        The directory the workers write their chunk files to.
    """

    def __init__(self, workers: int, chunk_dir: str) -> None:
        import multiprocessing as mp

        super().__init__(max_workers=workers, mp_context=mp.get_context("spawn"))
        self.chunk_dir = chunk_dir


@contextlib.contextmanager
def local_pool(workers: int) -> Iterator[ChunkPool | None]:
    """``workers`` local processes to share between several studies.

    Each process then starts and loads the compiled kernels once. Chunk files go to a temporary
    directory, removed at the end; on an error or Ctrl-C the queued chunks never start.

    Parameters
    ----------
    workers : int
        Worker processes; 1 or fewer: no pool.

    Yields
    ------
    ChunkPool or None
        The pool (:class:`ChunkPool`), or None for ``workers`` <= 1.
    """
    if workers <= 1:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="tauv-chunks-") as chunk_dir:
        pool = ChunkPool(workers, chunk_dir)
        try:
            yield pool
        except BaseException:
            # an error or Ctrl-C: the queued chunks (several studies' with submit_chunks) never
            # start; the running ones end, and their files go with the directory
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        pool.shutdown(wait=True)


def _submit(
    pool: Executor, config_dict: dict, seed: int, first: int, count: int, smooth: SmoothOptions | None
) -> Future:
    if isinstance(pool, ChunkPool):
        return pool.submit(compute_chunk_to_file, config_dict, seed, first, count, pool.chunk_dir, smooth)
    return pool.submit(compute_chunk, config_dict, seed, first, count, smooth)


def _result(future: Future) -> ChunkSeries:
    out = future.result()
    return _load_chunk_file(out) if isinstance(out, str) else out


def submit_chunks(
    config: Config,
    num_runs: int,
    seed: int,
    pool: Executor,
    chunk_runs: int | None = None,
    smooth: SmoothOptions | None = None,
) -> list[Future]:
    """Queue every chunk of a study on ``pool`` at once, for :func:`run_study` to consume.

    :func:`run_study` (``submitted=``) consumes them in run order. Several studies queued back to
    back keep the workers busy across their boundaries (a study of one large chunk, or an odd
    number, leaves a worker idle otherwise); with :func:`local_pool` the finished chunks wait as
    files, not in memory.

    Parameters
    ----------
    config : Config
        The study's configuration.
    num_runs : int
        Runs of the study, at least 1.
    seed : int
        The study's seed.
    pool : concurrent.futures.Executor
        Where the chunks run (a :class:`ChunkPool` from :func:`local_pool`, or another executor).
    chunk_runs : int or None
        Most runs per chunk; None: :data:`CHUNK_RUNS`.
    smooth : SmoothOptions or None
        Also the smoother's series in each chunk (:func:`run_chunk`); None: no smoother.

    Returns
    -------
    list[concurrent.futures.Future]
        One future per chunk, in run order: a :class:`ChunkSeries`, or on a :class:`ChunkPool`
        the path of the file holding it.

    Raises
    ------
    ValueError
        ``num_runs`` or ``chunk_runs`` below 1 (:func:`chunks`).
    """
    config_dict = to_dict(config)
    return [
        _submit(pool, config_dict, seed, first, count, smooth)
        for first, count in chunks(num_runs, chunk_runs or CHUNK_RUNS)
    ]


def iterate_chunks(
    config: Config,
    num_runs: int,
    seed: int,
    workers: int = 1,
    dask_address: str | None = None,
    chunk_runs: int | None = None,
    pool: Executor | None = None,
    submitted: list[Future] | None = None,
    smooth: SmoothOptions | None = None,
) -> Iterator[ChunkSeries]:
    """Compute the study's chunks and yield them in run order.

    In this process (``workers`` 1), on ``workers`` local processes (or the given ``pool``,
    :func:`local_pool`), or on the Dask scheduler at ``dask_address`` (its workers need this
    package installed; see docs/studies.md); or the chunks :func:`submit_chunks` queued
    (``submitted``).

    Parameters
    ----------
    config : Config
        The study's configuration.
    num_runs : int
        Runs of the study, at least 1.
    seed : int
        The study's seed.
    workers : int
        Local worker processes; 1 or fewer: this process.
    dask_address : str or None
        Address of a Dask scheduler to compute the chunks on (waited for
        :data:`DASK_CONNECT_TIMEOUT_S` [s]); None: no Dask.
    chunk_runs : int or None
        Most runs per chunk; None: :data:`CHUNK_RUNS`.
    pool : concurrent.futures.Executor or None
        An executor to run the chunks on instead of new local processes (ignored with
        ``dask_address``).
    submitted : list[concurrent.futures.Future] or None
        The chunks :func:`submit_chunks` queued (same config, seed, chunking); given, the other
        ways are not used.
    smooth : SmoothOptions or None
        Also the smoother's series in each chunk, run where the chunk is (:func:`run_chunk`);
        None: no smoother.

    Yields
    ------
    ChunkSeries
        Each chunk's per-run series (T, count), in run order.

    Raises
    ------
    ValueError
        ``num_runs`` or ``chunk_runs`` below 1 (:func:`chunks`), when the first chunk is asked for.
    OSError
        No Dask scheduler answers at ``dask_address`` within :data:`DASK_CONNECT_TIMEOUT_S`
        (``distributed.Client``; ``TimeoutError`` is one).
    """
    if submitted is not None:
        for f in submitted:
            yield _result(f)
        return
    size = chunk_runs or CHUNK_RUNS
    parts = chunks(num_runs, size)
    config_dict = to_dict(config)
    if pool is not None and dask_address is None:
        futures = [_submit(pool, config_dict, seed, first, count, smooth) for first, count in parts]
        for f in futures:
            yield _result(f)
        return
    if dask_address is not None:
        from distributed import Client

        with Client(dask_address, timeout=DASK_CONNECT_TIMEOUT_S) as client:
            futures = [
                client.submit(compute_chunk, config_dict, seed, first, count, smooth, pure=False)
                for first, count in parts
            ]
            for f in futures:
                yield f.result()
        return
    if workers <= 1:
        for first, count in parts:
            yield compute_chunk(config_dict, seed, first, count, smooth)
        return
    with local_pool(workers) as own:
        assert own is not None  # workers > 1 here: local_pool gives its processes
        futures = [_submit(own, config_dict, seed, first, count, smooth) for first, count in parts]
        for f in futures:
            yield _result(f)


DASK_CONNECT_TIMEOUT_S = 10
"""How long to wait for a Dask scheduler before giving up (an unreachable address is bad input)."""


CHUNK_RUNS = 10
"""Runs per chunk. Fixed, not derived from the number of workers: the filter bank's batched
products can differ in the last bit with the batch's size (1e-13 measured), so a fixed chunking
makes a study's numbers bit-identical whatever the workers and wherever they run. Ten runs keep
``tauv mc --method lc --runs 100`` under 300 MB (285 MB measured, 318 MB with 25)."""

PAPER_CHUNK_RUNS = 50
"""Runs per chunk of ``tauv reproduce``'s studies of several methods (fixed too), and four times
as many for a study of one method (its LC reference): larger chunks pay the per-chunk work
(truth, the Python between compiled calls) fewer times. 25 and 25: 48.8 CPU-s, 26.1 s wall;
50 and 100 with every study queued at once (:func:`submit_chunks`): see docs/studies.md."""


def paper_chunk_runs(config: Config) -> int:
    """Runs per chunk of a ``tauv reproduce`` study (:data:`PAPER_CHUNK_RUNS`).

    Parameters
    ----------
    config : Config
        The study's configuration; ``config.run.methods`` says how many methods it runs.

    Returns
    -------
    int
        :data:`PAPER_CHUNK_RUNS` for several methods, four times as many for one.
    """
    return PAPER_CHUNK_RUNS if len(config.run.methods) > 1 else 4 * PAPER_CHUNK_RUNS


def run_study(
    config: Config,
    num_runs: int,
    *,
    workers: int = 1,
    dask_address: str | None = None,
    on_chunk: Callable[[ChunkSeries], object] | None = None,
    progress: Callable[[int, int], object] | None = None,  # what they return is not used
    chunk_runs: int | None = None,
    pool: Executor | None = None,
    submitted: list[Future] | None = None,
    smooth: SmoothOptions | None = None,
) -> StudyAccumulator:
    """A whole study: every chunk reduced into the accumulator, in run order.

    Each chunk is handed to ``on_chunk`` (e.g. a Parquet writer) in run order, and
    ``progress(runs_done, num_runs)`` is called after each.

    Parameters
    ----------
    config : Config
        The study's configuration; ``config.run.methods`` names its methods and ``config.run.seed``
        is the study's seed (run i draws from :func:`run_rng` ``(config.run.seed, i)``).
    num_runs : int
        Runs of the study, at least 1.
    workers : int
        Local worker processes; 1 or fewer: this process.
    dask_address : str or None
        Address of a Dask scheduler to compute the chunks on; None: no Dask.
    on_chunk : Callable[[ChunkSeries], object] or None
        ``on_chunk(chunk)`` receives each chunk's per-run series (T, count); what it returns is
        not used. None: not called.
    progress : Callable[[int, int], object] or None
        ``progress(runs_done, num_runs)`` after each chunk; what it returns is not used. None: not
        called.
    chunk_runs : int or None
        Most runs per chunk; None: :data:`CHUNK_RUNS`.
    pool : concurrent.futures.Executor or None
        An executor to run the chunks on (:func:`local_pool`); None: as ``workers`` says.
    submitted : list[concurrent.futures.Future] or None
        Its chunks as :func:`submit_chunks` queued them (same config and seed ``config.run.seed``,
        chunking, smoother).
    smooth : SmoothOptions or None
        Also smooth every run inside its chunk (:func:`run_chunk`) and sum the methods'
        smoothed series apart (the summary's ``smoothed``); None: no smoother.

    Returns
    -------
    StudyAccumulator
        The sums of every chunk; its :meth:`StudyAccumulator.summary` is the study's summary.

    Raises
    ------
    ValueError
        ``num_runs`` or ``chunk_runs`` below 1 (:func:`chunks`).
    """
    methods = tuple(config.run.methods)
    smoothed = methods if smooth is not None else ()
    acc = StudyAccumulator(methods, smoothed)
    chunks_of = iterate_chunks(
        config, num_runs, config.run.seed, workers, dask_address, chunk_runs, pool, submitted, smooth
    )
    for chunk in chunks_of:
        acc.add(chunk)
        if on_chunk is not None:
            on_chunk(chunk)
        if progress is not None:
            progress(acc.num_runs, num_runs)
    return acc
