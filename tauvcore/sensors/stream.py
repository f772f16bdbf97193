"""Every sensor's output chunk by chunk, so that memory holds a chunk of the mission, not all of it.

A run's random numbers come from named streams (:class:`SensorStreams`). With
:meth:`SensorStreams.spawned` each stream is an independent generator drawn in sequence, chunk
after chunk, so a run's numbers do not depend on how the mission is cut into chunks. With
:meth:`SensorStreams.single` every stream is one generator, and the whole mission as one chunk
repeats the whole-mission ``simulate`` functions (and ``tauvcore.engine.simulation.simulate``) draw for
draw: IMU accelerometer bias (turn-on value, walk), gyro bias, accelerometer noise, gyro noise
(then the DVL, the depth and the magnetometer, the echo sounder and the RPM: aiding sources drawn by
tauvcore.engine.source_streams from their streams here).

:class:`SensorStream` carries the IMU's state from chunk to chunk (the last value of each random
walk, whether its turn-on value was drawn) and is fed the truth chunks of
:class:`tauvcore.truth.kinematic.TruthStream` in order::

    truth = TruthStream(config.trajectory, config.earth, config.imu.rate_hz, chunk_samples=1500)
    sensors = SensorStream(imu_cfg, SensorStreams.spawned(rng), num_runs, truth.num_samples, truth.dt_s)
    for k0, chunk in truth:
        imu = sensors.next_chunk(k0, chunk)

Every output has the run axis after time, ``(K, R, 3)``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tauvcore.sensors import imu
from tauvcore.sensors.timing import Rng
from tauvcore.truth.truth_record import Truth


@dataclass(frozen=True)
class SensorStreams:
    """One generator per random stream of a run (or of a batch of runs drawn together).

    The DVL has four streams, not one: bias, scale factor, noise and dropout draw different
    amounts per ping, so sharing one generator between them would interleave their draws
    differently for different chunkings.

    Raises
    ------
    TypeError
        If a field is not a ``numpy.random.Generator``.
    """

    accel_bias: np.random.Generator  # IMU accelerometer bias: turn-on value, then its walk
    gyro_bias: np.random.Generator  # IMU gyro bias: turn-on value, then its walk
    accel_noise: np.random.Generator  # IMU accelerometer white noise
    gyro_noise: np.random.Generator  # IMU gyro white noise
    dvl_bias: np.random.Generator  # DVL beam biases: turn-on values, then their walk
    # (tauvcore.aiding.dvl_beams, as the three below)
    dvl_scale_factor: np.random.Generator  # DVL scale factor: turn-on value, then its walk
    dvl_noise: np.random.Generator  # DVL beam white noise (the water-track noise from a child of it)
    dvl_dropout: np.random.Generator  # DVL random beam losses
    pressure: np.random.Generator  # depth white noise (tauvcore.aiding.depth)
    magnetometer: np.random.Generator  # attitude white noise (tauvcore.aiding.attitude_mag)
    initial: np.random.Generator  # the filter's random initial errors (drawn by the runner)
    imu_axes: np.random.Generator  # IMU scale factors and misalignments (drawn only if the IMU has them)
    echo_sounder: np.random.Generator  # altitude white noise (tauvcore.aiding.echo_altitude)
    rpm_scale_factor: np.random.Generator  # RPM-to-speed scale factor walk, kinematic truth
    # (tauvcore.aiding.propeller_rpm, as the two below)
    rpm_bias: np.random.Generator  # RPM-to-speed bias walk (kinematic truth)
    rpm_noise: np.random.Generator  # RPM white noise

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if not isinstance(getattr(self, f.name), np.random.Generator):
                raise TypeError(
                    f"SensorStreams.{f.name} must be a numpy.random.Generator, "
                    f"got {type(getattr(self, f.name)).__name__}"
                )

    @classmethod
    def single(cls, rng: np.random.Generator) -> SensorStreams:
        """Every stream the same generator: the draws of the whole-mission ``simulate`` functions.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's (or batch of runs') one generator.

        Returns
        -------
        SensorStreams
            Streams that are all ``rng``.
        """
        return cls(**{f.name: rng for f in dataclasses.fields(cls)})

    @classmethod
    def spawned(cls, rng: np.random.Generator) -> SensorStreams:
        """Independent children of ``rng`` (``rng.spawn``), one per stream in field order.

        A stream added at the end leaves the others' numbers unchanged.

        Parameters
        ----------
        rng : numpy.random.Generator
            The parent generator (its spawn counter advances by the number of streams).

        Returns
        -------
        SensorStreams
            One independent child generator per stream.
        """
        names = [f.name for f in dataclasses.fields(cls)]
        return cls(**dict(zip(names, rng.spawn(len(names)), strict=True)))


class SensorStream:
    """The IMU of a mission, chunk by chunk, for ``num_runs`` runs (the other sensors are aiding
    sources: tauvcore.engine.source_streams).

    ``streams``: one :class:`SensorStreams` for all runs (each draw has the run axis, as
    ``simulate(..., num_runs)`` does), or a list of ``num_runs`` of them, run r drawn from its own
    alone and the runs stacked along the run axis. ``num_samples`` and ``dt_s``: the whole
    mission's (``TruthStream.num_samples``, ``.dt_s``). The config is used as given (make it ideal
    first if need be).

    Parameters
    ----------
    imu_config : ImuConfig
        The IMU's rate [Hz] and error model (1-sigma values), used as given.
    streams : SensorStreams or Sequence of SensorStreams
        One for all runs, or ``num_runs`` of them, one per run.
    num_runs : int
        Number of runs R (>= 1), the output's run axis.
    num_samples : int
        The whole mission's number of samples (>= 1).
    dt_s : float
        The whole mission's sample interval [s] (> 0), ``1 / imu_config.rate_hz``.

    Raises
    ------
    ValueError
        If ``num_runs`` or ``num_samples`` is not a whole number >= 1, ``dt_s`` is not positive, the
        truth's rate ``1 / dt_s`` is not ``imu.rate_hz``, or ``streams`` is neither one
        SensorStreams nor a list of ``num_runs`` of them.
    """

    def __init__(
        self,
        imu_config: imu.ImuConfig,
        streams: SensorStreams | Sequence[SensorStreams],
        num_runs: int,
        num_samples: int,
        dt_s: float,
    ) -> None:
        if isinstance(num_runs, bool) or not isinstance(num_runs, (int, np.integer)) or num_runs < 1:
            raise ValueError(f"num_runs must be a whole number >= 1, got {num_runs!r}")
        if isinstance(num_samples, bool) or not isinstance(num_samples, (int, np.integer)) or num_samples < 1:
            raise ValueError(f"num_samples must be a whole number >= 1, got {num_samples!r}")
        if not dt_s > 0:
            raise ValueError(f"dt_s must be positive, got {dt_s!r}")
        if abs(1.0 / dt_s - imu_config.rate_hz) > 1e-6 * imu_config.rate_hz:
            raise ValueError(
                f"truth is sampled at {1.0 / dt_s:g} Hz but imu.rate_hz is {imu_config.rate_hz:g}"
            )
        names = [f.name for f in dataclasses.fields(SensorStreams)]
        if isinstance(streams, SensorStreams):
            rngs: dict[str, Rng] = {name: getattr(streams, name) for name in names}
        else:
            streams = list(streams)
            if len(streams) != num_runs or not all(isinstance(s, SensorStreams) for s in streams):
                raise ValueError(
                    f"streams must be one SensorStreams or a list of num_runs ({num_runs}) of them, "
                    f"got {len(streams)} items"
                )
            # one list of per-run generators per stream: run r draws from its own alone (the numbers
            # it would draw as a batch of one), the runs' arithmetic is done together
            rngs = {name: [getattr(st, name) for st in streams] for name in names}
        self._streams = imu.ImuStreams(
            rngs["accel_bias"], rngs["gyro_bias"], rngs["accel_noise"], rngs["gyro_noise"], rngs["imu_axes"]
        )
        self.imu_config = imu_config
        self.num_runs = int(num_runs)
        self.num_samples = int(num_samples)
        self.dt_s = float(dt_s)
        self._imu_state = imu.ImuState()
        self.next_k0 = 0  # first sample of the next chunk expected

    def next_chunk(self, k0: int, truth: Truth) -> imu.ImuData:
        """The IMU over the mission's samples ``[k0, k0 + K)``.

        Chunks must come in order, each starting where the previous one ended.

        Parameters
        ----------
        k0 : int
            The mission's index of the chunk's first sample (0 for the first chunk).
        truth : Truth
            True motion at those K samples (the chunk of
            :class:`tauvcore.truth.kinematic.TruthStream`): increments ``dtheta_ib_b`` (K, 3) [rad]
            and ``dv_b`` (K, 3) [m/s], rate ``omega_ib_b`` (K, 3) [rad/s] and specific force ``f_b``
            (K, 3) [m/s^2], body b-frame (FRD).

        Returns
        -------
        ImuData
            The simulated IMU: times (K,) [s], measured angle increments (K, R, 3) [rad] and velocity
            increments (K, R, 3) [m/s], true accelerometer (K, R, 3) [m/s^2] and gyro (K, R, 3)
            [rad/s] biases, body b-frame (FRD).

        Raises
        ------
        ValueError
            If chunks do not come in order, or the chunk does not fit the mission's samples.
        """
        k = truth.num_samples
        if k0 != self.next_k0:
            raise ValueError(
                f"chunks must come in order: expected one starting at sample {self.next_k0}, got {k0}"
            )
        if k < 1 or k0 + k > self.num_samples:
            raise ValueError(
                f"a chunk of {k} samples from {k0} does not fit the mission's {self.num_samples}"
            )
        imu_data, self._imu_state = imu.simulate_chunk(
            truth, k0, self.imu_config, self._imu_state, self._streams, self.num_runs, self.dt_s
        )
        self.next_k0 = k0 + k
        return imu_data
