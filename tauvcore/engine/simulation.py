"""A mission's data: the truth and every sensor's output for R Monte Carlo runs, whole
(:class:`Simulation`, :func:`simulate`) or as the chunks the banks are fed (:class:`SimChunk`),
from a simulation or a recorded log (tauvcore.logs) alike."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from tauvcore.aiding import dvl_beams
from tauvcore.aiding.source import SourceData
from tauvcore.config import Config
from tauvcore.engine.sources import SourceStream
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
