"""The aiding sources of a run (tauvcore.aiding.sources), simulated chunk by chunk.

A source aboard every vehicle (the DVL, the depth, the magnetometer, the echo sounder, the RPM)
draws from its streams of the run's tauvcore.sensors.stream.SensorStreams and is simulated
whether or not ``run.aiding`` fuses it.

Every other registered source's streams are children of the run's generator, spawned after the
sensors' in registry order whether the source is on or not: turning a source on changes no other
source's numbers; it is simulated only when ``run.aiding`` turns it on. Either way the numbers do
not depend on how the mission is cut into chunks.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tauvcore.aiding.source import SourceData
from tauvcore.aiding.sources import FUSED, SOURCES
from tauvcore.config import Config
from tauvcore.filter.layout import Layout
from tauvcore.sensors.stream import SensorStreams
from tauvcore.sensors.timing import Rng, epoch_indices_between
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.world import World


def active(config: Config) -> tuple[str, ...]:
    """The sources the engine fuses that ``config.run.aiding`` turns on, in registry order.

    Registry order is their order of fusion at an epoch they share; the DVL's beams the methods
    fuse themselves.

    Parameters
    ----------
    config : Config
        The configuration; ``config.run.aiding`` names the sources turned on.

    Returns
    -------
    tuple[str, ...]
        The names of the sources fused, in registry order (tauvcore.aiding.sources.FUSED).
    """
    return tuple(name for name in FUSED if name in config.run.aiding)


def _on(config: Config) -> tuple[str, ...]:
    """Every source ``run.aiding`` turns on, those the methods fuse (the DVL) too, in registry order."""
    return tuple(name for name in SOURCES if name in config.run.aiding)


def _section(config: Config, name: str):
    return config.section(SOURCES[name].section_name)


def layout_of(config: Config) -> Layout:
    """The error state of a run: the layout's 20, then the states its fused sources add.

    Parameters
    ----------
    config : Config
        The configuration; ``config.run.aiding`` names the sources turned on.

    Returns
    -------
    Layout
        The blocks of :meth:`AidingSource.states` of the sources ``run.aiding`` turns on, in
        registry order.
    """
    return Layout(tuple(b for name in _on(config) for b in SOURCES[name].states(_section(config, name))))


def states_truth(config: Config, truth: Truth) -> np.ndarray:
    """The true values of the states :func:`layout_of` adds, at a truth chunk's samples.

    Parameters
    ----------
    config : Config
        The configuration.
    truth : Truth
        A chunk of the mission's truth (K samples).

    Returns
    -------
    numpy.ndarray
        Shape (K, E), the sources' :meth:`AidingSource.states_truth` side by side, in the states'
        units.
    """
    parts = [
        SOURCES[name].states_truth(_section(config, name), truth)
        for name in _on(config)
        if SOURCES[name].states(_section(config, name))
    ]
    return np.ascontiguousarray(np.concatenate(parts, axis=1) if parts else np.zeros((truth.num_samples, 0)))


def simulated(config: Config) -> tuple[str, ...]:
    """The sources a run simulates: those aboard, and those ``config.run.aiding`` turns on.

    Parameters
    ----------
    config : Config
        The configuration; ``config.run.aiding`` names the sources turned on.

    Returns
    -------
    tuple[str, ...]
        The names of the sources simulated, in registry order (tauvcore.aiding.sources.SOURCES).
    """
    return tuple(name for name, s in SOURCES.items() if s.aboard or name in config.run.aiding)


def _children(rng: np.random.Generator) -> dict[str, dict[str, np.random.Generator]]:
    """One child of ``rng`` per stream of every registered source not aboard, in registry order."""
    spawned = {name: s for name, s in SOURCES.items() if not s.aboard}
    names = [(source, stream) for source, s in spawned.items() for stream in s.streams]
    children = rng.spawn(len(names)) if names else []
    out: dict[str, dict[str, np.random.Generator]] = {source: {} for source in spawned}
    for (source, stream), child in zip(names, children, strict=True):
        out[source][stream] = child
    return out


class SourceStream:
    """The sources of ``config`` over a mission, simulated chunk by chunk for a batch of runs.

    Parameters
    ----------
    config : Config
        The configuration: each source's section, ``run.aiding`` and ``run.ideal`` (errors
        zeroed), and the trajectory's world (its seabed).
    rng : numpy.random.Generator or Sequence[numpy.random.Generator]
        For the sources not aboard: one generator for the batch, or one per run (each run's
        numbers then its own, as a batch of one would draw them).
    num_runs : int
        Monte Carlo runs R.
    num_samples : int
        IMU samples K of the whole mission.
    dt_s : float
        IMU sample interval [s].
    streams : SensorStreams or Sequence[SensorStreams]
        The run's sensor streams (the same one for the batch, or one per run) for the sources
        aboard.
    """

    def __init__(
        self,
        config: Config,
        rng: np.random.Generator | Sequence[np.random.Generator],
        num_runs: int,
        num_samples: int,
        dt_s: float,
        streams: SensorStreams | Sequence[SensorStreams],
    ) -> None:
        self.num_runs, self.num_samples, self.dt_s = num_runs, num_samples, dt_s
        self.t_end_s = (num_samples - 1) * dt_s
        if isinstance(rng, np.random.Generator):
            per_source: dict[str, dict[str, Rng]] = {k: dict(v) for k, v in _children(rng).items()}
        else:
            runs = [_children(g) for g in rng]
            per_source = {
                source: {stream: [r[source][stream] for r in runs] for stream in SOURCES[source].streams}
                for source in runs[0]
            }
        for name, source in SOURCES.items():
            if source.aboard:
                per_source[name] = {
                    stream: getattr(streams, stream)
                    if isinstance(streams, SensorStreams)
                    else [getattr(st, stream) for st in streams]
                    for stream in source.streams
                }
        world = World.of(config.trajectory)
        self.sources = []
        for name in simulated(config):
            source = SOURCES[name]
            section = config.section(source.section_name)
            if config.run.ideal:
                section = source.ideal(section)
            self.sources.append(
                [name, source, section, per_source[name], source.initial_state(section, num_runs, world)]
            )

    def next_chunk(self, k0: int, truth: Truth) -> dict[str, SourceData]:
        """Every simulated source's epochs within the chunk ``truth``.

        Chunks come in order; each source carries its state from one chunk to the next.

        Parameters
        ----------
        k0 : int
            The mission's IMU sample index of the chunk's first row.
        truth : Truth
            The true motion over the chunk's n samples, the mission's samples ``k0 .. k0 + n - 1``
            (NED n-frame and body b-frame as its fields say).

        Returns
        -------
        dict[str, SourceData]
            Source name -> its epochs within the chunk: times (E,) [s], global IMU sample indices
            (E,), and each column (E, R) in SI units (NaN: no measurement).
        """
        k1 = k0 + truth.num_samples
        out = {}
        for entry in self.sources:
            name, source, section, rngs, state = entry
            epochs = epoch_indices_between(
                source.rate_hz(section), self.t_end_s, self.dt_s, self.num_samples, k0, k1
            )
            out[name], entry[4] = source.simulate_chunk(
                truth, k0, epochs, section, state, rngs, self.num_runs, self.num_samples
            )
        return out
