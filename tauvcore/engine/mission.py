"""Run a mission: one bank per filter family side by side over the same chunks, on a
whole simulation (:func:`run`; its results handed out chunk by chunk: :func:`run_chunked`) or
generated chunk by chunk so that memory does not grow with the mission's length
(:func:`run_streaming`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.chunk_driver import UNWATCHED, Watch
from tauvcore.engine.filter_bank import FilterBank
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import ChunkSource, SimChunk, Simulation, chunks_of
from tauvcore.engine.smoothing import SmoothOptions, forward
from tauvcore.engine.source_streams import SourceStream
from tauvcore.engine.start import initial_covariance, initial_nominal
from tauvcore.engine.yoo_bank import YooBank
from tauvcore.filter.families import FAMILIES, family_of
from tauvcore.filter.layout import STATE
from tauvcore.sensors.stream import SensorStream, SensorStreams
from tauvcore.truth import truth_stream


def run(
    config: Config,
    sim: Simulation,
    rng: np.random.Generator | Sequence[np.random.Generator],
    watch: Watch = UNWATCHED,
    sensor_errors: bool = False,
    smooth: SmoothOptions | None = None,
) -> dict[str, MethodResult]:
    """Run every method of ``config.run.methods`` on a whole simulation; results keyed by method.

    :func:`run_streaming` does the same without holding the whole simulation.

    Parameters
    ----------
    config : Config
        The configuration: the methods (``config.run.methods``), the filters' tuning, the
        initial errors and the aiding sources fused (``config.run.aiding``).
    sim : Simulation
        Truth and every sensor's output for ``sim.num_runs`` runs R (:func:`simulate`, or a log:
        :func:`tauvcore.eval.replay.log_simulation`).
    rng : numpy.random.Generator or Sequence[numpy.random.Generator]
        What the filters' initial errors are drawn from: one generator for the batch of R runs,
        or one per run (R of them).
    watch : Watch
        Progress calls and stop requests while it runs (:class:`~tauvcore.engine.chunk_driver.Watch`;
        a stop returns the results up to that epoch).
    sensor_errors : bool
        Whether every output epoch also records each method's estimated sensor errors, their
        1-sigma and their truth (``MethodResult.sensor_est``, ``sensor_sigma``, ``sensor_true``,
        (T, R, S) in the SI units of :func:`tauvcore.engine.results.sensor_states`); False: those
        are None and cost nothing. Every other number is the same either way.
    smooth : SmoothOptions or None
        Also run the fixed-interval smoother after the forward pass (tauvcore.engine.smoothing)
        and give each method's smoothed results as ``MethodResult.smoothed``; the simulation is
        then fed in chunks of :data:`STREAM_CHUNK_S` (the same
        numbers), so that the smoother's tape is stored chunk by chunk. None: no smoother.

    Returns
    -------
    dict[str, MethodResult]
        Method name -> its results over the T output epochs and R runs (series (T, R), in the
        units their field names carry), in ``config.run.methods`` order.
    """
    banks = Banks(
        config,
        sim.num_runs,
        sim.truth.num_samples,
        sim.truth.dt_s,
        rng,
        sensor_errors=sensor_errors,
        smooth=smooth,
    )
    if smooth is None:
        banks.feed(SimChunk.whole(sim), watch)
        return banks.results()
    chunk_samples = max(1, round(STREAM_CHUNK_S / sim.truth.dt_s))
    for chunk in chunks_of(sim, chunk_samples):
        if not banks.feed(chunk, watch):
            break
    return banks.with_smoothed(banks.results())


def run_chunked(
    config: Config,
    sim: ChunkSource,
    rng: np.random.Generator | Sequence[np.random.Generator],
    on_chunk: Callable[[dict[str, MethodResult]], None],
    chunk_s: float | None = None,
    smooth: SmoothOptions | None = None,
    on_smoothed_chunk: Callable[[dict[str, MethodResult]], None] | None = None,
) -> None:
    """Run every method of ``config.run.methods`` on a whole simulation or a log, handing the
    results out chunk by chunk instead of keeping them, so that they do not grow with the
    mission's length.

    The banks are fed the simulation's chunks (:func:`~tauvcore.engine.simulation.chunks_of`) and
    keep nothing; the numbers are those of :func:`run` on the same simulation, its results cut at
    the chunks' ends (tests/unit/tauvcore/eval/test_replay_stream.py).

    Parameters
    ----------
    config : Config
        As in :func:`run`.
    sim : ChunkSource
        Truth and every sensor's output for ``sim.num_runs`` runs R: a whole simulation as in
        :func:`run`, or a log whose rows are made chunk by chunk (tauvcore.eval.replay.LogRows).
    rng : numpy.random.Generator or Sequence[numpy.random.Generator]
        As in :func:`run`: what the filters' initial errors are drawn from.
    on_chunk : Callable[[dict[str, MethodResult]], None]
        ``on_chunk(results)`` receives each chunk's output epochs and updates (and the monitor's
        verdict so far), method name -> :class:`MethodResult` (series (T_chunk, R)), in
        ``config.run.methods`` order.
    chunk_s : float or None
        Mission time per chunk [s]; None: :data:`STREAM_CHUNK_S`.
    smooth : SmoothOptions or None
        Also run the fixed-interval smoother once the forward pass is done
        (tauvcore.engine.smoothing); None: no smoother.
    on_smoothed_chunk : Callable[[dict[str, MethodResult]], None] or None
        With ``smooth``: ``on_smoothed_chunk(results)`` then receives the smoothed results chunk by
        chunk in the mission's order (the 20-state methods', series (T_chunk, R), with
        ``smoother_cuts``), after every ``on_chunk``.

    Raises
    ------
    SmoothingError
        The smoother cannot write its temporary directory.
    """
    dt_s = sim.dt_s
    banks = Banks(config, sim.num_runs, sim.num_samples, dt_s, rng, keep=False, smooth=smooth)
    chunk_samples = max(1, round((STREAM_CHUNK_S if chunk_s is None else chunk_s) / dt_s))
    for chunk in chunks_of(sim, chunk_samples):
        banks.feed(chunk)
        on_chunk(banks.take())
    banks.hand_out_smoothed(on_smoothed_chunk)


BANKS: dict[str, type[FilterBank | YooBank]] = {"eskf": FilterBank, "yoo": YooBank}
"""The bank of each error state (tauvcore.filter.families.spec.Family.error_state): the families on
one error state run side by side in one bank."""


class Banks:
    """One bank per error state of the filter families with methods in ``config.run.methods``
    (tauvcore.filter.families: the 20-state :class:`FilterBank` runs the first paper's methods and
    every family on its error state, the :class:`YooBank` Yoo 2014's), fed the same chunks, their
    results in ``config.run.methods`` order.

    Every family's filters start from the same estimate (one draw of the initial errors per run,
    :meth:`start`). The first bank leads: it is fed last, polls the stop requests and
    calls the progress with every bank's results so far; the others' results are cut where a stop
    ended it (:attr:`until_s`).

    Parameters
    ----------
    config : Config
        The configuration; ``config.run.methods`` names the methods of every bank.
    num_runs : int
        Monte Carlo runs R of the batch.
    num_samples : int
        IMU samples K of the whole mission.
    dt_s : float
        IMU sample interval [s].
    rng : numpy.random.Generator or Sequence[numpy.random.Generator]
        What the initial errors are drawn from: one generator for the batch, or one per run (R).
    keep : bool
        Whether the banks keep every chunk's results (:meth:`results`); False: only what
        :meth:`take` has not handed out yet, so that memory does not grow with the mission.
    sensor_errors : bool
        Whether the banks record the estimated sensor errors, their 1-sigma and their truth at
        every output epoch (:func:`run`).
    smooth : SmoothOptions or None
        The banks keep the smoother's tape (:meth:`smoothed`); None: no smoother.
    """

    def __init__(
        self,
        config: Config,
        num_runs: int,
        num_samples: int,
        dt_s: float,
        rng: np.random.Generator | Sequence[np.random.Generator],
        keep: bool = True,
        sensor_errors: bool = False,
        smooth: SmoothOptions | None = None,
    ) -> None:
        self.config, self.rng, self.keep, self.num_runs = config, rng, keep, num_runs
        self.smooth = smooth
        self.order = config.run.methods
        states = dict.fromkeys(family.error_state for family in FAMILIES.values())
        methods = {name: tuple(m for m in self.order if family_of(m).error_state == name) for name in states}
        # the error states with methods; with none, the first family's bank (it records the truth)
        names = [name for name, own in methods.items() if own] or [next(iter(states))]
        # the smoother's budget, shared by each bank's two tapes (its marks, its smoothed stores)
        self.share = 0.5 / len(names)
        self.banks = [
            BANKS[name](
                config.replace("run", methods=methods[name]),
                num_runs,
                num_samples,
                dt_s,
                keep=keep,
                sensor_errors=sensor_errors,
                tape=smooth.tape(self.share) if smooth is not None else None,
            )
            for name in names
        ]
        self.stopped = False
        self.until_s: float | None = None  # where the leading bank stopped the run (the others go on)

    def start(self, chunk: SimChunk) -> None:
        """Every bank's initial states from the first chunk: one draw of the initial errors per run
        (tauvcore.engine.start.initial_nominal), the estimate at t = 0 they all start from.

        Parameters
        ----------
        chunk : SimChunk
            The mission's first chunk (its truth at sample 0 and the DVL's first ping).
        """
        config, truth = self.config, chunk.truth
        P0 = initial_covariance(config, truth.euler[0])
        nav = initial_nominal(config, truth, self.rng, (1, self.num_runs), P0[STATE.att, STATE.att]).nav
        for bank in self.banks:
            bank.start(chunk, (nav.pos_n[0], nav.vel_n[0], nav.C_nb[0]))

    def feed(self, chunk: SimChunk, watch: Watch = UNWATCHED) -> bool:
        """Run every bank over one chunk.

        The followers go first (the leader's progress then carries their results up to the same
        time); a stop request, polled by the leader, ends all of them at its epoch
        (:attr:`until_s`).

        Parameters
        ----------
        chunk : SimChunk
            The next chunk of the mission (chunks in order, the first at sample 0), R runs.
        watch : Watch
            Progress calls (with every bank's results so far) and stop requests
            (:class:`~tauvcore.engine.chunk_driver.Watch`).

        Returns
        -------
        bool
            True while the run goes on; False once a stop request ended it (at this chunk or an
            earlier one).

        Raises
        ------
        ValueError
            From the banks: the first chunk does not start at sample 0, or the chunks do not follow
            each other.
        """
        if self.stopped:
            return False
        if not self.banks[0].started:
            self.start(chunk)
        leader, *followers = self.banks
        for bank in followers:
            bank.feed(chunk)
        progress = watch.progress
        if progress is not None and followers:
            watch = replace(  # the leader's progress, with the others' results
                watch,
                progress=lambda t, first: progress(
                    t, self._merge(first, *(bank.results(until_s=t) for bank in followers))
                ),
            )
        going = leader.feed(chunk, watch)
        if not going and followers:
            self.until_s = leader.stopped_at_s
        self.stopped = not going
        return going

    def _merge(self, *parts: dict[str, MethodResult]) -> dict[str, MethodResult]:
        both = {name: result for part in parts for name, result in part.items()}
        return {m: both[m] for m in self.order if m in both}

    def _until(self, bank: FilterBank | YooBank) -> float | None:
        """Where ``bank``'s results end: the leader's own stop, the others' cut there."""
        return None if bank is self.banks[0] else self.until_s

    def results(self) -> dict[str, MethodResult]:
        """Every bank's results kept so far, up to where a stop request ended the run.

        Returns
        -------
        dict[str, MethodResult]
            Method name -> its results over the output epochs so far (series (T, R)), in
            ``config.run.methods`` order; all of them unless ``keep`` is False.
        """
        return self._merge(*(bank.results(self._until(bank)) for bank in self.banks))

    def take(self) -> dict[str, MethodResult]:
        """The output epochs and updates since the last :meth:`take`.

        Without ``keep`` they are dropped from the banks, so that memory does not grow with the
        mission.

        Returns
        -------
        dict[str, MethodResult]
            Method name -> its results over the output epochs since the last take (series
            (T_chunk, R)), in ``config.run.methods`` order.
        """
        return self._merge(*(bank.take(self._until(bank)) for bank in self.banks))

    def smoothed(self) -> tuple[Iterator[dict[str, MethodResult]], Callable[[], None]]:
        """The smoother's backward pass over the run so far, then its results chunk by chunk.

        Returns
        -------
        tuple
            An iterator of the smoothed results of each chunk in the mission's order (method name
            -> :class:`MethodResult`, series (T_chunk, R), with ``smoother_cuts``), and a function
            that removes what the smoother still holds (its temporary directories), to be called
            once done with the iterator.

        Raises
        ------
        SmoothingError
            The smoother cannot write its temporary directory.
        """
        options = self.smooth
        assert options is not None  # Banks made with smooth
        if options.on_start is not None:
            options.on_start()
        passes = []
        try:
            for bank in self.banks:
                out = options.tape(self.share)
                passes.append((bank, out))
                cuts = bank.smooth(out)
                passes[-1] = (bank, out, cuts)
        except BaseException:
            for done in passes:
                done[1].close()
            raise

        def chunks() -> Iterator[dict[str, MethodResult]]:
            for stores in zip(*(forward(out) for _, out, _ in passes), strict=True):
                parts = [
                    bank.smoothed_results(store, cuts)
                    for (bank, _, cuts), store in zip(passes, stores, strict=True)
                ]
                yield self._merge(*parts)

        def close() -> None:
            for _, out, _ in passes:
                out.close()

        return chunks(), close

    def hand_out_smoothed(self, on_smoothed_chunk: Callable[[dict[str, MethodResult]], None] | None) -> None:
        """The smoother's backward pass (if the banks keep a tape), its results handed to
        ``on_smoothed_chunk`` chunk by chunk in the mission's order, then let go.

        Parameters
        ----------
        on_smoothed_chunk : Callable[[dict[str, MethodResult]], None] or None
            Receives each chunk's smoothed results; None: the pass is not run.
        """
        if self.smooth is None or on_smoothed_chunk is None:
            return
        chunks, close = self.smoothed()
        try:
            for results in chunks:
                on_smoothed_chunk(results)
        finally:
            close()

    def with_smoothed(self, results: dict[str, MethodResult]) -> dict[str, MethodResult]:
        """``results`` of the whole run with each method's smoothed results attached
        (``MethodResult.smoothed``; the smoother's backward pass runs here).

        Parameters
        ----------
        results : dict[str, MethodResult]
            The run's results (:meth:`results`).

        Returns
        -------
        dict[str, MethodResult]
            The same, each with ``smoothed``.
        """
        if self.smooth is None:
            return results
        if self.smooth.on_start is not None:
            self.smooth.on_start()
        smoothed: dict[str, MethodResult] = {}
        for bank in self.banks:
            out = self.smooth.tape(self.share)
            try:
                cuts = bank.smooth(out)
                stores = list(forward(out))
                cat = {
                    name: np.concatenate([st[name] for st in stores], axis=1 if name == "series" else 0)
                    for name in stores[0]
                }
            finally:
                out.close()
            smoothed.update(bank.smoothed_results(cat, cuts))
        return {
            name: replace(result, smoothed=smoothed[name]) if name in smoothed else result
            for name, result in results.items()
        }


STREAM_CHUNK_S = 10.0
"""Seconds of mission :func:`run_streaming` generates and filters at a time (1,500 IMU samples at
150 Hz): memory then holds one chunk of truth and sensors, whatever the mission's length."""


@dataclass(frozen=True)
class Sinks:
    """Where :func:`run_streaming` hands each chunk as it is done.

    Attributes
    ----------
    on_chunk : Callable[[dict[str, MethodResult]], None] or None
        ``on_chunk(results)`` receives each chunk's output epochs and updates (and the monitor's
        verdict so far), method name -> :class:`MethodResult` (series (T_chunk, R)).
    on_sim_chunk : Callable[[SimChunk], None] or None
        ``on_sim_chunk(chunk)`` receives each chunk of the simulation itself (truth and sensors)
        before the banks run it (``tauv run --save-log`` writes them as a log: tauvcore.logs).
    on_smoothed_chunk : Callable[[dict[str, MethodResult]], None] or None
        With a smoother: the smoothed results chunk by chunk in the mission's order (series
        (T_chunk, R)), after the last ``on_chunk``; memory then does not grow with the mission
        (the smoother's tape beyond its budget is in a temporary directory).

    None: not called.
    """

    on_chunk: Callable[[dict[str, MethodResult]], None] | None = None
    on_sim_chunk: Callable[[SimChunk], None] | None = None
    on_smoothed_chunk: Callable[[dict[str, MethodResult]], None] | None = None


NO_SINKS = Sinks()
"""Nothing handed out chunk by chunk."""


def run_streaming(
    config: Config,
    rng: np.random.Generator | Sequence[np.random.Generator],
    num_runs: int = 1,
    chunk_s: float = STREAM_CHUNK_S,
    keep: bool = True,
    sensor_errors: bool = False,
    smooth: SmoothOptions | None = None,
    watch: Watch = UNWATCHED,
    sinks: Sinks = NO_SINKS,
) -> dict[str, MethodResult]:
    """Simulate and run chunk by chunk, so that memory does not depend on the mission's length.

    Truth (tauvcore.truth.truth_stream: kinematic or dynamic), the IMU
    (tauvcore.sensors.stream.SensorStream) and the aiding sources (:class:`SourceStream`) are
    generated ``chunk_s`` at a time and fed to the banks (:class:`Banks`: the 20-state
    :class:`FilterBank` and the YooBank).

    Each generator is split into independent named streams
    (:meth:`~tauvcore.sensors.stream.SensorStreams.spawned`: the IMU's, the DVL's, ..., the
    initial errors'), so the numbers do not depend on ``chunk_s`` (tests/unit/tauvcore/engine/test_stream_engine.py);
    they differ from :func:`simulate` + :func:`run`, which draw everything from one stream.

    Parameters
    ----------
    config : Config
        The configuration: trajectory, earth, sensors, filters and ``config.run.methods``.
    rng : numpy.random.Generator or Sequence[numpy.random.Generator]
        One generator for the batch of ``num_runs`` runs, or one per run (``num_runs`` of them: a
        study's runs, tauvcore.eval.study).
    num_runs : int
        Monte Carlo runs R of the batch.
    chunk_s : float
        Mission time generated and filtered at a time [s] (at least one DVL ping interval plus
        one IMU sample, so that the first chunk holds the first ping).
    keep : bool
        Whether the results of every chunk are kept; False: they are not kept and the return
        value holds only the last chunk's.
    sensor_errors : bool
        As in :func:`run`: record the estimated sensor errors, their 1-sigma and their truth
        (``MethodResult.sensor_est``, ``sensor_sigma``, ``sensor_true``, (T, R, S)); False: None.
    smooth : SmoothOptions or None
        Also run the fixed-interval smoother once the forward pass is done (or stopped)
        (tauvcore.engine.smoothing): with ``keep``, each method's result carries its
        ``smoothed`` results; with ``sinks.on_smoothed_chunk``, that receives them chunk by
        chunk. None: no smoother.
    watch : Watch
        As in :func:`run`.
    sinks : Sinks
        Where each chunk goes as it is done (:class:`Sinks`).

    Returns
    -------
    dict[str, MethodResult]
        Method name -> its results (series (T, R) over the output epochs, in the units their
        field names carry), in ``config.run.methods`` order: the whole mission's, or with
        ``keep`` False the last chunk's only.

    Raises
    ------
    ValueError
        A sequence ``rng`` whose length is not ``num_runs``: "one generator per run expected".
    SmoothingError
        The smoother cannot write its temporary directory.
    """
    per_run = not isinstance(rng, np.random.Generator)
    if per_run:
        rngs = list(rng)
        if len(rngs) != num_runs:
            raise ValueError(f"one generator per run expected ({num_runs}), got {len(rngs)}")
        streams: SensorStreams | list[SensorStreams] = [SensorStreams.spawned(g) for g in rngs]
        initial: np.random.Generator | list[np.random.Generator] = [s.initial for s in streams]
        plugin_rng: np.random.Generator | list[np.random.Generator] = rngs
    else:
        streams = SensorStreams.spawned(rng)
        initial = streams.initial
        plugin_rng = rng
    ideal = config.run.ideal
    rate = config.imu.rate_hz
    # the first chunk holds the first DVL ping: the records before it use that ping's true errors
    chunk_samples = max(2, round(max(chunk_s, 1.0 / config.dvl.rate_hz + 1.0 / rate) * rate))
    truths = truth_stream(config.trajectory, config.earth, rate, chunk_samples)
    sensors = SensorStream(
        config.imu.ideal() if ideal else config.imu, streams, num_runs, truths.num_samples, truths.dt_s
    )
    sources = SourceStream(config, plugin_rng, num_runs, truths.num_samples, truths.dt_s, streams)
    bank = Banks(
        config,
        num_runs,
        truths.num_samples,
        truths.dt_s,
        initial,
        keep=keep,
        sensor_errors=sensor_errors,
        smooth=smooth,
    )
    last: dict[str, MethodResult] = {}
    for k0, truth in truths:
        chunk = SimChunk(k0, truth, sensors.next_chunk(k0, truth), sources=sources.next_chunk(k0, truth))
        if sinks.on_sim_chunk is not None:
            sinks.on_sim_chunk(chunk)
        going = bank.feed(chunk, watch)
        if sinks.on_chunk is not None or not keep:
            last = bank.take()
            if sinks.on_chunk is not None:
                sinks.on_chunk(last)
        if not going:
            break
    if smooth is None:
        return bank.results() if keep else last
    if sinks.on_smoothed_chunk is not None or not keep:
        bank.hand_out_smoothed(sinks.on_smoothed_chunk)
        return bank.results() if keep else last
    return bank.with_smoothed(bank.results())
