"""A mission's data: the truth and every sensor's output for R Monte Carlo runs, whole
(:class:`Simulation`, :func:`simulate`) or as the chunks the banks are fed (:class:`SimChunk`),
from a simulation or a recorded log (tauvcore.logs) alike."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Protocol

import numpy as np

from tauvcore.aiding import dvl_beams
from tauvcore.aiding.source import SourceData
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import Config
from tauvcore.engine.source_streams import SourceStream
from tauvcore.sensors import dvl as dvl_sensor
from tauvcore.sensors import imu as imu_sensor
from tauvcore.sensors.stream import SensorStreams
from tauvcore.truth import Truth, generate


@dataclass(frozen=True)
class Simulation:
    """Truth and every sensor's output for R Monte Carlo runs (run axis after time)."""

    truth: Truth
    imu: imu_sensor.ImuData
    num_runs: int
    sources: Mapping[str, SourceData] = field(default_factory=dict)  # the aiding sources
    # (tauvcore.aiding.sources) by name: those aboard (dvl, depth, mag, echo, rpm; a log's: those it
    # has tables of) and those run.aiding turns on

    @cached_property
    def dvl(self) -> dvl_sensor.DvlData:
        """The DVL source's epochs as the pings the banks read (none if there is no DVL)."""
        return dvl_beams.pings(self.sources.get("dvl"), self.num_runs)

    @property
    def num_samples(self) -> int:
        """IMU samples K of the mission."""
        return self.truth.num_samples

    @property
    def dt_s(self) -> float:
        """IMU sample interval [s]."""
        return self.truth.dt_s

    def rows(self, k0: int, k1: int) -> tuple[Truth, imu_sensor.ImuData]:
        """Samples ``k0 .. k1 - 1`` of the truth and the IMU (:meth:`ChunkSource.rows`).

        Parameters
        ----------
        k0 : int
            First sample of the chunk.
        k1 : int
            One past the chunk's last sample (at most K).

        Returns
        -------
        tuple[Truth, ImuData]
            Views of the whole mission's arrays: the truth, and the IMU's increments and true
            biases, run axis after time.
        """
        imu = self.imu
        return _truth_rows(self.truth, k0, k1), dataclasses.replace(
            imu, **{f.name: getattr(imu, f.name)[k0:k1] for f in dataclasses.fields(imu)}
        )


class ChunkSource(Protocol):
    """A mission whose truth and IMU rows are had by sample range (:func:`chunks_of`): a whole
    :class:`Simulation`, or a log whose rows are made as they are asked for
    (tauvcore.eval.replay.LogRows)."""

    @property
    def num_runs(self) -> int:
        """Monte Carlo runs R."""
        ...

    @property
    def sources(self) -> Mapping[str, SourceData]:
        """The aiding sources' epochs over the whole mission, as :attr:`Simulation.sources`."""
        ...

    @property
    def num_samples(self) -> int:
        """IMU samples K of the mission."""
        ...

    @property
    def dt_s(self) -> float:
        """IMU sample interval [s]."""
        ...

    def rows(self, k0: int, k1: int) -> tuple[Truth, imu_sensor.ImuData]:
        """The truth and the IMU at samples ``k0 .. k1 - 1``.

        Parameters
        ----------
        k0 : int
            Index of the first sample asked for, 0 <= k0 < K.
        k1 : int
            Index one past the last, k0 < k1 <= K.

        Returns
        -------
        tuple[Truth, ImuData]
            The truth at those samples (its ``t_s`` the mission's times [s], its ``step_s`` the
            sample interval [s]) and the IMU's increments (n, R, 3) [rad], [m/s] and true biases.
        """
        ...


def simulate(
    config: Config, rng: np.random.Generator, num_runs: int = 1, truth: Truth | None = None
) -> Simulation:
    """Generate the truth (unless given) and the sensor outputs of a whole mission.

    The sensors' errors are zeroed if ``config.run.ideal``. The DVL, the depth and the
    magnetometer draw from ``rng`` after the IMU; the echo sounder and the RPM from a child of
    ``rng``; the other sources from their children of a second child.

    Parameters
    ----------
    config : Config
        The configuration: trajectory, earth, IMU (its ``rate_hz`` the truth's sample rate [Hz])
        and the aiding sources.
    rng : numpy.random.Generator
        Every draw of the sensors' errors; what it draws next is the filters' initial errors
        (:func:`~tauvcore.engine.mission.run` with the same generator).
    num_runs : int
        Monte Carlo runs R.
    truth : Truth or None
        The true motion at the IMU's samples (K samples, NED n-frame and body b-frame as its
        fields say); None: generated from ``config.trajectory``.

    Returns
    -------
    Simulation
        Truth (K samples), the IMU's increments (K, R, 3) [rad], [m/s] in the body frame, and
        every simulated source's epochs (values (E, R)), run axis after time.
    """
    ideal = config.run.ideal
    if truth is None:
        truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    imu_cfg = config.imu.ideal() if ideal else config.imu
    imu = imu_sensor.simulate(truth, imu_cfg, rng, num_runs)
    extra, plugins = rng.spawn(2)
    # the DVL, the depth and the magnetometer draw from rng after the IMU; the echo sounder and the
    # RPM from a child of rng (spawning draws nothing: what rng draws next, the filters' initial
    # errors, is what it drew before those two sensors existed); the other sources from their
    # children of a second child
    aboard = dataclasses.replace(
        SensorStreams.single(rng), echo_sounder=extra, rpm_scale_factor=extra, rpm_bias=extra, rpm_noise=extra
    )
    return Simulation(
        truth=truth,
        imu=imu,
        sources=SourceStream(config, plugins, num_runs, truth.num_samples, truth.dt_s, aboard).next_chunk(
            0, truth
        ),
        num_runs=num_runs,
    )


@dataclass(frozen=True)
class SimChunk:
    """Samples ``k0 .. k0 + n - 1`` of a simulation: truth and IMU rows for those samples, the aiding
    sensors' epochs among them (global sample indices), run axis after time."""

    k0: int
    truth: Truth
    imu: imu_sensor.ImuData
    sources: Mapping[str, SourceData] = field(default_factory=dict)  # as Simulation.sources

    @cached_property
    def dvl(self) -> dvl_sensor.DvlData:
        """As :attr:`Simulation.dvl`."""
        runs = self.imu.dtheta_b.shape[1] if self.imu.dtheta_b.ndim == 3 else 1
        return dvl_beams.pings(self.sources.get("dvl"), runs)

    @classmethod
    def whole(cls, sim: Simulation) -> SimChunk:
        """A whole simulation as one chunk, from sample 0.

        Parameters
        ----------
        sim : Simulation
            Truth and every sensor's output for R runs (K samples).

        Returns
        -------
        SimChunk
            Samples 0 .. K - 1 of ``sim``: its truth, IMU rows and sources' epochs.
        """
        return cls(0, sim.truth, sim.imu, sim.sources)


def chunks_of(sim: ChunkSource, chunk_samples: int) -> Iterator[SimChunk]:
    """A whole simulation, or a log (tauvcore.eval.replay), as the chunks the banks are fed, so
    that their results can be handed out chunk by chunk (tauvcore.engine.mission.run_chunked).

    The chunks are ``sim``'s rows (:meth:`ChunkSource.rows`: a simulation's views, a log's made as
    they are asked for), ``chunk_samples`` samples each but the first, which reaches
    at least one sample past the first DVL ping (the banks take the true DVL errors from the first
    chunk's first ping, as from a whole simulation's) and the last. Each chunk holds the sources'
    epochs among its samples; a source read at its latest epoch rather than fused (the echo
    sounder, the propeller's RPM: :attr:`~tauvcore.aiding.source.AidingSource.fused` and
    ``methods_fuse`` False) also holds its last epoch before the chunk, so a chunk reads what the
    whole simulation would. The banks fed these chunks give the numbers they give fed
    :meth:`SimChunk.whole` (tests/unit/tauvcore/eval/test_replay_stream.py).

    Parameters
    ----------
    sim : ChunkSource
        Truth and every sensor's output for R runs (K samples): a :class:`Simulation`, or a log's
        rows.
    chunk_samples : int
        IMU samples per chunk, at least 1.

    Yields
    ------
    SimChunk
        Samples ``k0 .. k0 + n - 1`` of ``sim``, in order, the first at sample 0, the last ending
        at sample K - 1.

    Raises
    ------
    ValueError
        If ``chunk_samples`` is less than 1.
    """
    if chunk_samples < 1:
        raise ValueError(f"chunk_samples must be at least 1, got {chunk_samples}")
    K = sim.num_samples
    pings = sim.sources["dvl"].index if "dvl" in sim.sources else np.zeros(0, np.int64)
    k0 = 0
    k1 = max(chunk_samples, int(pings[0]) + 1 if len(pings) else 0)
    while k0 < K:
        k1 = min(k1, K)
        truth, imu = sim.rows(k0, k1)
        yield SimChunk(
            k0, truth, imu, {name: _epochs_between(name, data, k0, k1) for name, data in sim.sources.items()}
        )
        k0, k1 = k1, k1 + chunk_samples


def _truth_rows(truth: Truth, k0: int, k1: int) -> Truth:
    """Samples ``k0 .. k1 - 1`` of a whole mission's truth (views), its step kept exact."""
    rows = {
        f.name: value[k0:k1]
        for f in dataclasses.fields(truth)
        if isinstance(value := getattr(truth, f.name), np.ndarray)
    }
    vehicle = truth.vehicle
    if vehicle is not None:
        vehicle = dataclasses.replace(
            vehicle, **{f.name: getattr(vehicle, f.name)[k0:k1] for f in dataclasses.fields(vehicle)}
        )
    return dataclasses.replace(truth, **rows, step_s=truth.dt_s, vehicle=vehicle)


def _epochs_between(name: str, data: SourceData, k0: int, k1: int) -> SourceData:
    """Source ``name``'s epochs at samples ``k0 .. k1 - 1`` (views); with its last epoch before
    ``k0`` for a source read at its latest epoch (:func:`chunks_of`)."""
    source = SOURCES.get(name)
    latest_read = source is not None and not source.fused and not source.methods_fuse
    a, b = np.searchsorted(data.index, (k0, k1))
    if latest_read and a > 0:
        a -= 1
    return SourceData(
        t_s=data.t_s[a:b],
        index=data.index[a:b],
        values={k: v[a:b] for k, v in data.values.items()},
        truth={k: v[a:b] for k, v in data.truth.items()},
    )
