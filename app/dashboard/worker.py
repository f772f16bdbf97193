"""Runs in a pool of worker processes, streaming progress to the dashboard.

Separate processes keep a long run from holding the server's interpreter: two tabs running at
once use both cores, and neither tab's controls wait on the other's run. The processes start
with the server (numpy, scipy and tauvcore already imported when Run is pressed) and lower
their own priority, so on a small machine the interactive server and the browser win the CPU
over a background computation. Messages on a run's queue (:attr:`RunHandle.queue`):

- ``("truth", dict)``: the truth at the output epochs (with the seabed under it) and the DVL
  pings, for the 3-D view and the Seabed tab;
- ``("sensors", dict)``: one run's raw measurements so far (app.figures.sensor_view.SensorView), before
  each progress and the final message (a replayed log's once, whole, after its truth);
- ``("progress", t_s, results)``: results so far, every ``progress_interval_s`` simulated seconds
  (the first paper's methods only: the engine's live callback does not carry Yoo 2014's); a
  long mission's (below), every chunk of mission (``STREAM_CHUNK_S``), all its methods;
- ``("done", results, stopped)``: the final (or, after Stop, partial) results, every method's;
  with the smoother each method's carries its smoothed results
  (``MethodResult.smoothed``; reduced to bins as its filtered ones are);
- ``("smoothing",)``: the forward pass is done (or stopped) and the smoother's backward pass
  begins; after Stop the worker is then let finish it (a second Stop kills it).
- ``("error", message)``: one line, for a notification (also when the worker process died).

A simulated mission whose output epochs exceed ``tauvcore.eval.envelope.SCREEN_BINS`` is reduced
as it streams to at most that many time bins (:func:`decimation`): its results are
:class:`~tauvcore.eval.envelope.DecimatedResult` (each series at every bin's last epoch, the
minimum and maximum of every plotted curve per bin, the summary from every epoch), its truth view
holds the truth at the bins' last epochs, so that neither the worker's memory nor the messages
grow with the mission's length. A shorter mission, and a replayed log, is sent at every output
epoch, as it was computed.

The pool is this module's own, not ``concurrent.futures.ProcessPoolExecutor``: one dead
worker (the out-of-memory killer's SIGKILL) breaks a ``ProcessPoolExecutor`` for good and kills
the runs of its other workers with it. Here each worker is one process with one pipe; a
dispatcher thread in the server forwards each worker's messages to its run's queue, notices a
worker's death through the process sentinel, ends that run alone with an error naming the
signal, and starts a replacement. Runs beyond the worker count wait in line (first come, first
served) and can ask their place (:meth:`RunHandle.position`). There is no manager process and
no cross-process lock: Stop is a message on the worker's pipe, which the run polls.
"""

from __future__ import annotations

import collections
import dataclasses
import importlib
import multiprocessing as mp
import multiprocessing.connection as mp_connection
import os
import queue as queue_mod
import signal
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from app.dashboard import budget
from app.dashboard.live_results import thin
from app.dashboard.truth_view import decimation, log_truth_view, truth_view
from app.figures.sensor_view import SensorViewBuilder
from tauvcore.config import Config, from_dict, to_dict
from tauvcore.engine.mission import Sinks, Watch, run, run_streaming
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import SimChunk
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.engine.tape import SmoothingError
from tauvcore.eval.envelope import EnvelopeReducer
from tauvcore.eval.study import run_rng
from tauvcore.validation import ConfigError

# Preloaded with the worker: tauvcore imports scipy.special at a run's first chi-square quantile
# (so that `tauv --help` need not), and its 22 MiB would otherwise land inside that run's memory
# budget (app/dashboard/budget.py).
importlib.import_module("scipy.special")

WORKER_NICENESS = 10
PROGRESS_MIN_WALL_S = 0.8  # live updates at most this often (wall time)
PROGRESS_MAX_EPOCHS = 1200  # output epochs per live update (evenly thinned, last one kept)
STOP_POLL_S = 0.05  # how often the run looks for a Stop message on its pipe (wall time)
STOP_GRACE_S = 2.0  # a run that has not ended this long after Stop (it polls only once the
# filter loop runs, not while truth and sensors are generated) is killed
WORKER_START_TIMEOUT_S = 120.0  # a worker imports numpy, scipy and tauvcore before it is ready
MAX_START_FAILURES = 3  # workers dying before they are ready: give up replacing them
PR_SET_PDEATHSIG = 1  # prctl option (linux/prctl.h): signal this process when its parent dies


def default_workers() -> int:
    """min(2, CPU count): two tabs compute at once, and a small machine keeps a core for the server."""
    return max(1, min(2, os.cpu_count() or 1))


def _throttled(check: Callable[[], bool], period_s: float) -> Callable[[], bool]:
    """``check`` asked at most every ``period_s`` (wall time); once true it stays true."""
    state = {"t": 0.0, "value": False}

    def wrapped() -> bool:
        now = time.monotonic()
        if not state["value"] and now - state["t"] >= period_s:
            state["t"], state["value"] = now, bool(check())
        return state["value"]

    return wrapped


def replay_source(
    config: Config, log_dir: str, rng: np.random.Generator
) -> tuple[Config, Any, dict[str, Any], Any]:
    """The dashboard's replay of ``log_dir`` (a log's directory or a ROS bag) under ``config``
    (the controls over the log's own configuration file, or the bag's own mapping's ``[config]``,
    app.dashboard.inputs.config_from_controls): the configuration and simulation
    tauvcore.eval.replay.prepare makes of them, as ``tauv replay`` does (a bag read under its own
    mapping, tauvcore.logs.bags.read_recording, as ``tauv replay BAG --bag-mapping`` that file), and
    the log described as ``tauv replay --json``'s ``"log"`` (its directory, its configuration
    file, what configured the run, where the filters started, what the NEES is measured against,
    the reader's notes; a bag's mapping too), and the log itself."""
    from tauvcore.eval.replay import config_keys, log_config, prepare, start_description
    from tauvcore.logs.bags import is_bag, mapping_beside, read_recording

    raw, config_file = log_config(log_dir)
    log = read_recording(log_dir, config.dvl.A_b)
    config, sim = prepare(config, log, rng)
    bag = is_bag(log_dir)
    layers = ["defaults"]
    if config_file is not None:
        kind = "the bag mapping's [config] in" if bag else "the log's"
        if config_file.endswith(":/tf_static"):  # the DVL's lever arm from the bag (bag_config)
            kind = "the bag's"
        layers.append(f"{kind} {config_file} ({config_keys(raw) or 'empty'})")
    layers.append("the dashboard's controls")
    source = {
        "name": os.path.basename(os.path.normpath(log_dir)),
        "directory": log_dir,
        "config_file": config_file,
        "configuration": layers,
        "start": start_description(config, log),
        "reference": config.reference.describe(log.ref_t_s is not None),
        "notes": list(log.notes),
    }
    if bag:
        source["bag_mapping"] = mapping_beside(log_dir)
    return config, sim, source, log


def run_worker(
    config_dict: dict[str, Any],
    num_runs: int,
    queue: Any,
    stop_event: Any,
    progress_interval_s: float = 2.0,
    log_dir: str | None = None,
    smooth_mb: float | None = None,
    batch: tuple[int, int] | None = None,
) -> None:
    """Simulate (or, with ``log_dir``, replay that log: tauvcore.eval.replay), run all methods,
    with their sensor errors recorded where the run fits the memory budget with them
    (app.dashboard.budget.records_sensor_errors), and stream results to ``queue`` (anything with ``put``)
    and one run's raw measurements (app.figures.sensor_view); the run ends early once
    ``stop_event.is_set()`` (anything with ``is_set``). A replay first sends ``("config", dict,
    source)``: the configuration as the log made it (its length, rate, origin and start) and
    :func:`replay_source`'s description of the log. A simulated mission of more output epochs
    than tauvcore.eval.envelope.SCREEN_BINS streams its results into bins (:func:`decimation`,
    tauvcore.eval.envelope.EnvelopeReducer) and sends those. With ``smooth_mb`` (megabytes of
    the smoother's tape held in memory: tauvcore.engine.smoothing.SmoothOptions) the smoother runs
    after the forward pass and the final results carry the smoothed ones
    (``MethodResult.smoothed``), a run in bins its smoothed bins (:func:`with_smoothed_bins`).

    A Monte Carlo (``num_runs`` > 1) draws run i from its own generator, the study's
    (tauvcore.eval.study.run_rng: ``tauv mc`` with the same seed gives the same numbers), so
    that it may be computed in batches: ``batch`` (first, count) computes runs first ..
    first + count - 1 of the ``num_runs`` alone (app.dashboard.split_run joins the batches). A
    batch after the first sends its final results only: the truth, the Sensors tab (run 1's)
    and the live results are the first batch's."""
    try:
        config = from_dict(config_dict)
        first, count = (0, num_runs) if batch is None else batch
        lead = first == 0
        rng = np.random.default_rng(config.run.seed)
        if num_runs > 1:
            config = config.replace("initial_error", mode="random")
        try:
            limit_bytes = budget.budget_bytes()
        except ValueError:  # refused by the server before the run started; not reached
            limit_bytes = budget.DEFAULT_BUDGET_BYTES
        should_stop = _throttled(stop_event.is_set, STOP_POLL_S)
        options: dict[str, Any] = {  # what the engine takes however the run goes
            "sensor_errors": budget.records_sensor_errors(config, num_runs, limit_bytes, smooth_mb),
            "smooth": None
            if smooth_mb is None
            else SmoothOptions(budget_mb=float(smooth_mb), on_start=lambda: queue.put(("smoothing",))),
        }
        rngs = [run_rng(config.run.seed, i) for i in range(first, first + count)]
        if not lead:  # a later batch of a Monte Carlo (app.dashboard.split_run): its final results only
            results = run_streaming(config, rngs, count, watch=Watch(should_stop=should_stop), **options)
            queue.put(("done", results, stop_event.is_set()))
            return
        sim = log = None
        if log_dir is not None:
            config, sim, source, log = replay_source(config, log_dir, rng)
            queue.put(("config", to_dict(config), source))
        step = max(1, round(config.imu.rate_hz / config.filter.output_rate_hz))
        # a replayed log is held whole: its results at every output epoch
        per_bin = decimation(config)[1] if sim is None else 1
        view = (
            truth_view(config, step, per_bin)
            if sim is None
            else log_truth_view(sim.truth, config, sim.dvl, step)
        )
        queue.put(("truth", view))
        # the IMU rows of the Sensors tab: a long mission's thinned as they come, not at the end
        sensors = SensorViewBuilder(step * per_bin, config.dvl.beam_mask, compact=per_bin > 1)
        live = _Live(queue, sensors, with_sensors=sim is None)  # a log's view is sent once, whole
        watch = Watch(live.progress, progress_interval_s, PROGRESS_MIN_WALL_S, should_stop)
        if sim is not None:  # a replay: its view sent whole, its results judged against its reference
            from tauvcore.eval.judging import judged

            sensors.add(SimChunk.whole(sim))
            queue.put(("sensors", sensors.view()))
            results = run(config, sim, rng, watch, **options)
            results = judged(log, results, config.filter.output_rate_hz)  # the smoothed results too
        elif per_bin > 1:
            runs = rngs if num_runs > 1 else rng
            results = _simulate_in_bins(config, runs, count, live, options, Watch(should_stop=should_stop))
        else:
            results = run_streaming(
                config,
                rngs if num_runs > 1 else rng,
                count,
                watch=watch,
                sinks=Sinks(on_sim_chunk=sensors.add),
                **options,  # the smoother's results kept: each method's results carry their smoothed ones
            )
            queue.put(("sensors", sensors.view()))
        queue.put(("done", results, stop_event.is_set()))
    except Exception as exc:  # noqa: BLE001 - any failure is the run's: the dashboard shows it, the server keeps serving
        queue.put(("error", failure_message(exc)))


class _Live:
    """A run's live messages on ``queue``: the results so far, after the Sensors tab's view (built
    by ``sensors`` as a simulation makes its chunks), at most one each PROGRESS_MIN_WALL_S (the
    engine gathers the results no more often: Watch.min_wall_s)."""

    def __init__(self, queue: Any, sensors: SensorViewBuilder, with_sensors: bool) -> None:
        self.queue, self.sensors, self.with_sensors = queue, sensors, with_sensors
        self.last_sent = 0.0  # time.monotonic() of the last results sent

    def send(self, t_s: float, results: Callable[[], Mapping[str, MethodResult]]) -> None:
        """``results()``, the results at ``t_s`` [s] of the mission, unless sent too recently."""
        now = time.monotonic()
        if now - self.last_sent >= PROGRESS_MIN_WALL_S:
            if self.with_sensors:
                self.queue.put(("sensors", self.sensors.view()))
            self.queue.put(("progress", t_s, results()))
            self.last_sent = now

    def progress(self, t: float, res: dict[str, MethodResult]) -> None:
        """The engine's live callback: thinned, a live view needs the shape of the curves, not
        every epoch of a long run (the final message has them all)."""
        self.send(t, lambda: thin(res, PROGRESS_MAX_EPOCHS))


def _simulate_in_bins(
    config: Config,
    rng: np.random.Generator | list[np.random.Generator],
    num_runs: int,
    live: _Live,
    options: dict[str, Any],
    watch: Watch,
) -> dict[str, MethodResult]:
    """A simulated mission of more output epochs than SCREEN_BINS: every chunk of results folded
    into bins (:func:`decimation`, tauvcore.eval.envelope.EnvelopeReducer) as the engine hands it
    out, the live view the bins so far; with the smoother its results in bins of their own."""
    num_epochs, per_bin, dt_out_s = decimation(config)
    reducer = EnvelopeReducer(num_epochs, dt_out_s, per_bin)
    smoothed = EnvelopeReducer(num_epochs, dt_out_s, per_bin)

    def reduce(chunk: dict[str, MethodResult]) -> None:
        reducer.add(chunk)
        live.send(max((float(r.t_s[-1]) for r in chunk.values() if len(r.t_s)), default=0.0), reducer.results)

    smooth = options["smooth"]
    run_streaming(
        config,
        rng,
        num_runs,
        keep=False,
        watch=watch,
        sinks=Sinks(
            on_chunk=reduce,
            on_sim_chunk=live.sensors.add,
            on_smoothed_chunk=smoothed.add if smooth is not None else None,
        ),
        **options,
    )
    results: dict[str, MethodResult] = dict(reducer.results())
    if smooth is not None:
        results = with_smoothed_bins(results, smoothed)
    live.queue.put(("sensors", live.sensors.view()))
    return results


def with_smoothed_bins(
    results: dict[str, MethodResult], smoothed: EnvelopeReducer
) -> dict[str, MethodResult]:
    """``results`` in bins with each method's smoothed results, reduced to the same bins by
    ``smoothed`` (fed the smoother's chunks), attached (``MethodResult.smoothed``).

    Parameters
    ----------
    results : dict[str, MethodResult]
        Method name -> its results in bins (tauvcore.eval.envelope.DecimatedResult).
    smoothed : EnvelopeReducer
        The smoothed results' reducer.

    Returns
    -------
    dict[str, MethodResult]
        ``results``, each method the smoother ran for with its smoothed bins.
    """
    bins = smoothed.results()
    return {m: dataclasses.replace(r, smoothed=bins[m]) if m in bins else r for m, r in results.items()}


def failure_message(exc: BaseException) -> str:
    """The one line a tab is shown for a run that raised: a configuration error as its own clean
    message (it names the field and value), anything else said to be a fault of ours."""
    if isinstance(exc, ConfigError):
        return str(exc)
    from tauvcore.logs import LogError

    if isinstance(exc, LogError):  # a bad log: its file, column, row and value
        return str(exc)
    if isinstance(exc, SmoothingError):  # its temporary directory: one line naming it
        return str(exc)
    if isinstance(exc, MemoryError):
        return "the run ran out of memory; shorten the duration or use fewer runs"
    return f"the run failed unexpectedly ({type(exc).__name__}: {exc}); this is a bug, please report it"


# ---------------------------------------------------------------------------- worker process side
class _PipeQueue:
    """``put`` sends the message to the server over the worker's pipe."""

    def __init__(self, conn: mp_connection.Connection) -> None:
        self._conn = conn

    def put(self, message: tuple) -> None:
        self._conn.send(message)


class _PipeStop:
    """``is_set`` is true once the server has sent ``("stop",)`` for the current run."""

    def __init__(self, conn: mp_connection.Connection) -> None:
        self._conn = conn
        self._stopped = False

    def is_set(self) -> bool:
        # during a run the server sends nothing but Stop, so every pending message is one
        while not self._stopped and self._conn.poll():
            self._stopped = self._conn.recv()[0] == "stop"
        return self._stopped


def _die_with_parent() -> None:
    """Ask the kernel to SIGKILL this process when the server dies (even by SIGKILL itself), so
    no worker outlives it computing for nobody (Linux; elsewhere the closed pipe ends it)."""
    parent = os.getppid()
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:  # the server died before the request took effect
        os._exit(0)


def _worker_main(conn: mp_connection.Connection) -> None:
    """A worker process: announce itself, then run one task at a time until the pipe closes."""
    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group; the server ends us
    try:
        os.nice(WORKER_NICENESS)
    except OSError:  # not permitted: run at normal priority
        pass
    try:
        conn.send(("ready", os.getpid()))
        while True:
            message = conn.recv()
            if message[0] == "run":
                _, config_dict, num_runs, progress_interval_s, log_dir, smooth_mb, batch = message
                run_worker(
                    config_dict,
                    num_runs,
                    _PipeQueue(conn),
                    _PipeStop(conn),
                    progress_interval_s,
                    log_dir,
                    smooth_mb,
                    batch,
                )
                conn.send(("end",))
            elif message[0] == "vehicle":  # Calibrate or Tune on a log (app.dashboard.vehicle_tasks)
                from app.dashboard.vehicle_tasks import run_vehicle_task

                _, kind, config_dict, log_dir = message
                queue = _PipeQueue(conn)
                try:
                    run_vehicle_task(kind, config_dict, log_dir, queue, _PipeStop(conn))
                except Exception as exc:  # noqa: BLE001 - any failure is the task's: the tab shows it, the server keeps serving
                    queue.put(("error", failure_message(exc)))
                conn.send(("end",))
            # ("stop",) after its run had ended: nothing to stop
    except (EOFError, OSError):  # the server closed the pipe (or died): nothing left to do
        pass


# ---------------------------------------------------------------------------- server side
class RunHandle:
    """One submitted run: its message queue (``queue.Queue`` of the tuples above), Stop, state."""

    def __init__(self, pool: RunPool, task: tuple, messages: Any = None) -> None:
        self.queue: Any = queue_mod.Queue() if messages is None else messages  # anything with put
        self._pool = pool
        self._task = task
        self._done = threading.Event()

    def stop(self) -> None:
        """End the run. A waiting run leaves the line at once: :meth:`finished` is true when this
        returns, its queue stays empty and no worker ever receives it. A computing run is sent
        Stop and returns its partial results (its worker is killed if it has not ended
        ``STOP_GRACE_S`` later)."""
        self._pool._stop(self)

    def finished(self) -> bool:
        """True once every message of the run is on :attr:`queue` (done, error, or never started)."""
        return self._done.is_set()

    def position(self) -> int:
        """0 while computing (or finished), k >= 1 while waiting with k - 1 runs ahead of it;
        exact from the moment :meth:`RunPool.start` returns (the run is in line by then)."""
        return self._pool._position(self)


@dataclasses.dataclass(eq=False)
class _Worker:
    """One worker process as the server sees it."""

    process: Any  # multiprocessing Process (spawn context)
    # the server's end of the worker's pipe (PipeConnection: Pipe()'s on Windows, as the checker sees all platforms)
    conn: mp_connection.Connection | mp_connection.PipeConnection
    ready: bool = False  # imports done, waiting for a task
    handle: RunHandle | None = None  # the run it computes
    stop_sent: bool = False  # Stop already sent for that run
    stop_sent_at: float = 0.0  # when (time.monotonic)
    killed_for_stop: bool = False  # killed because its run ignored Stop: the run ends as stopped


def death_message(exitcode: int | None) -> str:
    """One line for the tab whose run was on a worker that died with ``exitcode``."""
    if exitcode is not None and exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = "unknown signal"
        cause = f"killed by signal {-exitcode} ({name}"
        cause += ", as the out-of-memory killer does)" if -exitcode == signal.SIGKILL else ")"
    else:
        cause = f"exit status {exitcode}"
    return (
        f"the worker computing this run died ({cause}); a new worker replaces it. "
        "Press Run to try again (a shorter mission or fewer runs needs less memory)."
    )


class RunPool:
    """The server's worker processes: at most ``workers`` runs compute at once, the rest wait.

    Parameters
    ----------
    workers : number of worker processes (default :func:`default_workers`).
    """

    def __init__(self, workers: int | None = None) -> None:
        self.workers = default_workers() if workers is None else int(workers)
        if self.workers < 1:
            raise ValueError(f"workers must be >= 1, got {workers!r}")
        self._ctx = mp.get_context("spawn")  # no fork of a threaded server
        self._lock = threading.Lock()
        self._workers: list[_Worker] = []
        self._pending: collections.deque[RunHandle] = collections.deque()
        self._closed = False
        self._start_failures = 0
        self._broken: str | None = None  # set when workers cannot even start
        self._wake_r, self._wake_w = os.pipe()
        self._ready = threading.Condition(self._lock)
        # every worker is started by the dispatcher thread, which lives as long as the pool:
        # the kernel's parent-death signal follows the thread that forked the process
        self._thread = threading.Thread(target=self._dispatch, name="tauv-run-pool", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + WORKER_START_TIMEOUT_S
        with self._ready:
            while sum(w.ready for w in self._workers) < self.workers and self._broken is None:
                if not self._ready.wait(timeout=max(0.0, deadline - time.monotonic())):
                    break
            broken = self._broken
        if broken is not None:
            self.shutdown()
            raise RuntimeError(broken)

    # ------------------------------------------------------------------ API
    def start(
        self,
        config_dict: dict[str, Any],
        num_runs: int,
        progress_interval_s: float = 2.0,
        log_dir: str | None = None,
        smooth_mb: float | None = None,
        batch: tuple[int, int] | None = None,
        messages: Any = None,
    ) -> RunHandle:
        """Queue a run (a replay of ``log_dir`` if given; with ``smooth_mb``, the smoother after it,
        its tape's memory in MB; with ``batch`` (first, count), those runs of the ``num_runs`` only:
        :func:`run_worker`); it computes as soon as a worker is free. Its messages go to its own
        queue (:attr:`RunHandle.queue`), or to ``messages`` (anything with ``put``) if given."""
        task = ("run", config_dict, num_runs, progress_interval_s, log_dir, smooth_mb, batch)
        return self._submit(task, messages)

    def start_vehicle(self, kind: str, config_dict: dict[str, Any], log_dir: str) -> RunHandle:
        """Queue a calibration or a tuning (``kind``, app.dashboard.vehicle_tasks.TASKS) on the log
        ``log_dir`` under ``config_dict``; its messages are app.dashboard.vehicle_tasks's, its Stop a run's."""
        return self._submit(("vehicle", kind, config_dict, log_dir))

    def _submit(self, task: tuple, messages: Any = None) -> RunHandle:
        handle = RunHandle(self, task, messages)
        with self._lock:
            if self._closed or self._broken is not None:
                handle.queue.put(("error", self._broken or "the server is shutting down"))
                handle._done.set()
                return handle
            self._pending.append(handle)
        self._wake()
        return handle

    def pids(self) -> list[int]:
        """Process ids of the current worker processes (for tests and diagnostics)."""
        with self._lock:
            return [w.process.pid for w in self._workers if w.process.pid is not None]

    def busy_pids(self) -> list[int]:
        """Process ids of the workers computing a run now."""
        with self._lock:
            return [w.process.pid for w in self._workers if w.handle is not None]

    def idle_workers(self) -> int:
        """Workers ready and computing nothing, less the runs waiting for one."""
        with self._lock:
            idle = sum(w.ready and w.handle is None for w in self._workers)
            return max(0, idle - len(self._pending))

    def shutdown(self) -> None:
        """Kill every worker at once (a run in progress is abandoned, not awaited) and reap them."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            workers, self._workers = self._workers, []
            handles = [w.handle for w in workers if w.handle is not None] + list(self._pending)
            self._pending.clear()
        for w in workers:
            try:
                w.process.kill()
            except (OSError, AttributeError):  # never started, or already reaped
                pass
        self._wake()
        for w in workers:
            w.process.join(timeout=1.0)
            w.conn.close()
        self._thread.join(timeout=1.0)
        for handle in handles:
            handle.queue.put(("error", "the server is shutting down"))
            handle._done.set()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
        _stop_resource_tracker()

    # ------------------------------------------------------------------ internals
    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"x")
        except OSError:  # closed at shutdown
            pass

    def _position(self, handle: RunHandle) -> int:
        with self._lock:
            try:
                return self._pending.index(handle) + 1
            except ValueError:
                return 0

    def _stop(self, handle: RunHandle) -> None:
        with self._lock:
            if handle in self._pending:
                self._pending.remove(handle)
                handle._done.set()  # never started: no message, the queue stays empty
                return
            for w in self._workers:
                if w.handle is handle and not w.stop_sent:
                    w.stop_sent, w.stop_sent_at = True, time.monotonic()
                    try:
                        w.conn.send(("stop",))
                    except OSError:  # it just died; the dispatcher reports it
                        pass
        self._wake()  # the dispatcher times the grace period from now

    def _spawn(self) -> None:
        parent_conn, child_conn = self._ctx.Pipe(duplex=True)
        process = self._ctx.Process(target=_worker_main, args=(child_conn,), name="tauv-worker", daemon=True)
        process.start()
        child_conn.close()  # the worker holds the only other end: its death reads as EOF here
        self._workers.append(_Worker(process=process, conn=parent_conn))

    def _dispatch(self) -> None:
        """The dispatcher thread: on any failure of its own the pool is marked broken, every
        waiting or computing run gets the error, and later runs get it at once."""
        try:
            self._dispatch_loop()
        except Exception as exc:  # noqa: BLE001 - told to every tab instead of a silent dead thread
            with self._lock:
                self._broken = f"the run pool failed ({type(exc).__name__}: {exc}); restart the server"
                handles = [w.handle for w in self._workers if w.handle is not None] + list(self._pending)
                self._pending.clear()
                for w in self._workers:
                    w.handle = None
                self._ready.notify_all()
            for handle in handles:
                handle.queue.put(("error", self._broken))
                handle._done.set()

    def _dispatch_loop(self) -> None:
        """Forward messages, notice deaths, replace the dead, hand waiting runs to idle workers."""
        with self._lock:
            for _ in range(self.workers):
                self._spawn()
        while True:
            with self._lock:
                if self._closed:
                    return
                workers = list(self._workers)
            watched: list[Any] = [self._wake_r]
            for w in workers:
                watched += [w.conn, w.process.sentinel]
            try:
                ready = mp_connection.wait(watched, timeout=self._kill_overdue())
            except OSError:  # a descriptor closed under us: shutting down
                return
            with self._lock:
                if self._closed:
                    return
            if self._wake_r in ready:
                try:
                    os.read(self._wake_r, 4096)
                except OSError:
                    return
            for w in workers:
                if w.conn in ready:
                    self._receive(w)
                if w.process.sentinel in ready or w.conn.closed:
                    self._bury(w)
            self._assign()

    def _kill_overdue(self) -> float | None:
        """Kill the workers whose run ignored Stop for STOP_GRACE_S (its death is then buried as
        a stop, and a replacement starts); return how long until the next one is due, or None."""
        now, due = time.monotonic(), None
        with self._lock:
            for w in self._workers:
                if w.handle is None or not w.stop_sent or w.killed_for_stop:
                    continue
                left = w.stop_sent_at + STOP_GRACE_S - now
                if left <= 0:
                    w.killed_for_stop = True
                    try:
                        w.process.kill()
                    except (OSError, AttributeError):
                        pass
                else:
                    due = left if due is None else min(due, left)
        return due

    def _receive(self, w: _Worker) -> None:
        """Read one message from ``w``; EOF means it died (its sentinel says so next)."""
        try:
            message = w.conn.recv()
        except (EOFError, OSError):
            w.conn.close()
            return
        except Exception as exc:  # noqa: BLE001 - a message cut off by the worker's death: unpickling it raises anything
            message = ("error", f"unreadable message from the worker: {type(exc).__name__}")
        kind = message[0]
        with self._lock:
            if kind == "ready":
                w.ready = True
                self._start_failures = 0
                self._ready.notify_all()
            elif kind == "end":
                handle, w.handle, w.stop_sent = w.handle, None, False
                if handle is not None:
                    handle._done.set()
            elif kind == "smoothing" and w.handle is not None:  # the run heeded Stop: it smooths
                w.stop_sent = False  # what ran, and is not killed for it (a second Stop is)
                w.handle.queue.put(message)
            elif w.handle is not None:
                w.handle.queue.put(message)

    def _bury(self, w: _Worker) -> None:
        """``w`` exited: deliver what it sent, end its run with an error, start a replacement."""
        while not w.conn.closed:
            try:
                if not w.conn.poll():
                    break
            except OSError:
                break
            self._receive(w)
        w.process.join(timeout=1.0)
        if not w.conn.closed:
            w.conn.close()
        with self._lock:
            if self._closed or w not in self._workers:
                return
            self._workers.remove(w)
            handle, w.handle = w.handle, None
            if not w.ready:
                self._start_failures += 1
            if self._start_failures >= MAX_START_FAILURES:
                self._broken = (
                    f"the worker processes cannot start ({death_message(w.process.exitcode)}); "
                    "restart the server"
                )
                failed = list(self._pending)
                self._pending.clear()
            else:
                failed = []
                self._spawn()
            self._ready.notify_all()
        if handle is not None:
            if not w.killed_for_stop:  # killed for Stop: the tab reports "Run stopped"
                handle.queue.put(("error", death_message(w.process.exitcode)))
            handle._done.set()
        for other in failed:
            other.queue.put(("error", self._broken))
            other._done.set()

    def _assign(self) -> None:
        with self._lock:
            for w in self._workers:
                if not self._pending:
                    return
                if w.ready and w.handle is None and not w.conn.closed:
                    handle = self._pending.popleft()
                    try:
                        w.conn.send(handle._task)
                    except OSError:  # died this instant: the run waits for the replacement
                        self._pending.appendleft(handle)
                        continue
                    w.handle, w.stop_sent = handle, False


def _stop_resource_tracker() -> None:
    """Stop multiprocessing's resource tracker (a spawn-started helper process) with the pool,
    so no process of the server outlives it; tolerant of a Python without the private API.

    The tracker ends when every holder of its pipe has closed it: every spawned child holds one,
    so this waits for it only when no child process is left (another pool may still run)."""
    if mp.active_children():
        return
    try:
        from multiprocessing import resource_tracker

        stop = getattr(resource_tracker._resource_tracker, "_stop", None)  # private: not in the stubs
        if stop is not None:
            stop()
    except Exception:  # noqa: BLE001, S110 - best effort: it also ends when this process exits
        pass
