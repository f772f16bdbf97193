"""Replay a recorded log (tauvcore.logs) through the filter bank, every method as on simulated data.

The log takes the place of the simulation: its IMU increments are the IMU, its DVL, depth and
attitude rows the aiding sensors (at the IMU sample nearest each), and its reference, interpolated
to the IMU's times, the truth the errors and the NEES of the navigation blocks are measured
against. What a log cannot know is left NaN: the true sensor errors, hence the NEES of the full
state and of the sensor block. The configuration supplies the filters' tuning and the DVL's
geometry; the log fixes the IMU rate, the mission's length and origin.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from typing import Any

import numpy as np

from tauvcore import units
from tauvcore.aiding import dvl_beams
from tauvcore.aiding.attitude_mag import EULER
from tauvcore.aiding.source import SourceData
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import Config, from_dict, read_toml
from tauvcore.engine.mission import Watch, run, run_chunked
from tauvcore.engine.results import MethodResult
from tauvcore.engine.rpm_aid import ECHO_SOURCE, RPM_SOURCE
from tauvcore.engine.simulation import ChunkSource, Simulation
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.engine.source_streams import active
from tauvcore.eval.corrections import calibrated
from tauvcore.eval.judging import judged
from tauvcore.geo.earth import ned_from_geodetic
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3, log_so3
from tauvcore.logs import CONFIG_FILE, Log, LogError
from tauvcore.sensors import imu as imu_sensor
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import ConfigError, show_path


def _column(log: Log, values: np.ndarray | None, what: str) -> np.ndarray:
    """A table's column that the reader fills together with the table's times (``what``: the
    table's name), so present wherever the caller found those times; LogError if not."""
    if values is None:
        raise LogError(f"{show_path(log.source)}: the log has no {what}")
    return values


def log_config(directory: str | os.PathLike) -> tuple[dict[str, Any], str | None]:
    """The log's own configuration (:data:`tauvcore.logs.CONFIG_FILE` in its directory; a ROS
    bag's: its own mapping's ``[config]`` and the DVL's lever arm from its ``/tf_static``,
    tauvcore.logs.bags.own_mapping, bag_config): its raw tables, checked on their own, and its path.

    Parameters
    ----------
    directory : str or os.PathLike
        The log's directory, or a ROS bag.

    Returns
    -------
    tuple[dict[str, Any], str or None]
        The raw tables (section -> key -> value, in the file's units: degrees where the
        configuration takes degrees) and the file's path; ``({}, None)`` when the log has none.

    Raises
    ------
    LogError
        Naming the file, for a file that cannot be read or does not check.
    """
    from tauvcore.logs.bags import bag_config, is_bag, own_mapping

    if is_bag(directory):  # a bag's own configuration: its own mapping's [config]
        return bag_config(own_mapping(directory), directory)
    path = os.path.join(os.fspath(directory), CONFIG_FILE)
    if not os.path.lexists(path):
        return {}, None
    try:
        raw = read_toml(path, label="the log's configuration")
        from_dict(raw)
    except ConfigError as exc:
        text = str(exc)
        if not text.startswith("the log's configuration"):
            text = f"the log's configuration {show_path(path)}: {text}"
        raise LogError(text) from None
    return raw, path


def config_keys(raw: dict[str, Any]) -> str:
    """The keys a raw configuration sets, ``section.key``, comma-separated (past six: how many
    more), for the line that says what configured a replay.

    Parameters
    ----------
    raw : dict[str, Any]
        A raw configuration: section -> key -> value (:func:`log_config`).

    Returns
    -------
    str
        ``section.key`` of each key set, comma-separated (the first six, then "and N more");
        empty for none.
    """
    names = [f"{sec}.{key}" for sec, values in raw.items() if isinstance(values, dict) for key in values]
    return ", ".join(names) if len(names) <= 6 else f"{', '.join(names[:6])} and {len(names) - 6} more"


def replay_config(config: Config, log: Log) -> Config:
    """``config`` with what the log fixes.

    The log fixes the IMU rate, the mission's length and starting depth, (a geodetic reference)
    the origin's latitude and longitude, and where the filters start.

    With a reference the filters start on its first row (``run.ideal``: no offset added, the
    initial errors as P0's sigmas), or off it by the initial errors as a simulation adds them
    when ``replay.initial_errors`` (fixed, or drawn from the seed). Without one they start from the
    sensors' own first values (:func:`_start_from_sensors`), as uncertain as those sensors: P0's
    attitude and velocity sigmas at least their noise. A replay sets ``run.ideal`` itself: the
    log's sensors are what they are.

    Parameters
    ----------
    config : Config
        The configuration as given (the filters' tuning, the DVL's geometry, ``replay``).
    log : Log
        The recorded log, in SI units and the frames of tauvcore.conventions.

    Returns
    -------
    Config
        ``config`` with ``imu.rate_hz`` (1 / the log's IMU interval [Hz]),
        ``trajectory.duration_s`` [s] and ``depth_m`` [m], (geodetic) ``earth.latitude_deg`` and
        ``longitude_deg`` [deg], the initial errors and ``run.ideal`` as the log makes them.

    Raises
    ------
    LogError
        If the log's values are outside what the configuration allows.
    """
    try:
        config = config.replace("imu", rate_hz=_clock_rate_hz(log.dt_s))
        if log.ref_t_s is not None:
            depth = float(_reference_at(log, log.imu_t_s[:1])[0][0, 2])
        elif (depth_table := log.table("depth", ("depth_m",))) is not None and depth_table[0].size:
            depth = float(depth_table[1][0, 0])
        else:
            depth = config.trajectory.depth_m
        config = config.replace("trajectory", duration_s=max(log.duration_s, 1.0), depth_m=max(depth, 0.0))
        if log.ref_geodetic:
            ref_position = _column(log, log.ref_position, "reference position")
            lat0, lon0 = ref_position[0, 0], ref_position[0, 1]
            config = config.replace("earth", latitude_deg=lat0 / units.DEG, longitude_deg=lon0 / units.DEG)
        if log.ref_t_s is None:
            # the start is the sensors' own first values, as uncertain as those sensors: P0's
            # attitude and velocity sigmas at least their noise
            ie, mag, dvl = config.initial_error, config.magnetometer, config.dvl
            config = config.replace(
                "initial_error",
                roll_pitch_deg=max(ie.roll_pitch_deg, mag.roll_pitch_noise_deg),
                yaw_deg=max(ie.yaw_deg, mag.yaw_noise_deg),
                vel_mps=tuple(max(v, 2.0 * dvl.noise_mps) for v in ie.vel_mps),
            )
        config = config.replace("run", ideal=not config.replay.initial_errors)
    except ConfigError as exc:
        raise LogError(f"{show_path(log.source)}: the log does not fit the configuration: {exc}") from None
    return config


def _clock_rate_hz(dt_s: float) -> float:
    """The IMU's rate [Hz] of its median sample interval ``dt_s`` [s]: ``1 / dt_s``, or the whole
    number of hertz it is within 1e-9 of (time stamps in seconds carry the rounding of their
    float; a 50 Hz clock 1000 s into a log reads 49.99999999999996 Hz, below ``imu.rate_hz``'s
    lowest 50)."""
    rate_hz = 1.0 / dt_s
    whole = float(round(rate_hz))
    return whole if whole > 0.0 and abs(rate_hz - whole) <= 1e-9 * rate_hz else rate_hz


def start_description(config: Config, log: Log) -> str:
    """One line on where the filters of a replay start.

    Parameters
    ----------
    config : Config
        The replay's configuration (from :func:`replay_config`): its initial errors and seed.
    log : Log
        The recorded log.

    Returns
    -------
    str
        Where the filters start (the reference's state at its first IMU time [s], or the log's own
        sensors) and with what: the initial errors drawn or fixed, or the initial sigmas
        (position [m], velocity [m/s], roll/pitch and yaw [deg]).
    """
    ie = config.initial_error
    sigmas = (
        f"position {'/'.join(f'{v:g}' for v in ie.pos_m)} m, velocity {'/'.join(f'{v:g}' for v in ie.vel_mps)} m/s, "
        f"roll/pitch {ie.roll_pitch_deg:g} deg, yaw {ie.yaw_deg:g} deg"
    )
    if log.ref_t_s is not None:
        where = f"the reference's state at t = {float(log.imu_t_s[0]):g} s"
    else:
        where = "the log's own sensors (first attitude row, first DVL velocity, first depth)"
    if config.replay.initial_errors and ie.mode == "random":
        return f"start: {where} plus initial errors drawn from seed {config.run.seed}, 1-sigma {sigmas}"
    if config.replay.initial_errors:
        return f"start: {where} plus the fixed initial errors {sigmas}"
    return f"start: on {where}, initial sigmas {sigmas}"


def _reference_at(log: Log, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reference position, Euler angles and NED velocity at times ``t`` (K,): linear in position and
    velocity, and along the shortest rotation between the two neighbouring attitudes (exact at
    the reference's own times)."""
    rt = _column(log, log.ref_t_s, "reference")
    ref_position = _column(log, log.ref_position, "reference position")
    ref_vel_n = _column(log, log.ref_vel_n, "reference velocity")
    ref_euler = _column(log, log.ref_euler, "reference attitude")
    if rt.size > 2 and t.size:  # the rows around t only (t may be a chunk: LogRows): the same numbers
        lo = min(max(int(np.searchsorted(rt, t[0], side="right")) - 1, 0), rt.size - 2)
        hi = max(min(int(np.searchsorted(rt, t[-1], side="right")) + 1, rt.size), lo + 2)
        rt, ref_position, ref_vel_n, ref_euler = (a[lo:hi] for a in (rt, ref_position, ref_vel_n, ref_euler))
    pos = np.column_stack([np.interp(t, rt, ref_position[:, i]) for i in range(3)])
    vel = np.column_stack([np.interp(t, rt, ref_vel_n[:, i]) for i in range(3)])
    if rt.size == 1:
        return pos, np.broadcast_to(ref_euler[0], (t.size, 3)).copy(), vel
    j = np.clip(np.searchsorted(rt, t, side="right") - 1, 0, rt.size - 2)
    frac = np.clip((t - rt[j]) / (rt[j + 1] - rt[j]), 0.0, 1.0)
    C_j = C_nb_from_euler(ref_euler[j])  # the attitudes either side (only those: t may be a chunk)
    step = log_so3(np.swapaxes(C_j, -1, -2) @ C_nb_from_euler(ref_euler[j + 1]))
    C = C_j @ exp_so3(frac[:, None] * step)
    at_node = frac == 0.0
    C[at_node] = C_j[at_node]
    euler = _euler_of(C)
    euler[at_node] = ref_euler[j[at_node]]
    return pos, euler, vel


def _euler_of(C: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of C_nb (ZYX, tauvcore.conventions) -> (..., 3)."""
    roll = np.arctan2(C[..., 2, 1], C[..., 2, 2])
    pitch = -np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(C[..., 1, 0], C[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def _epochs(log: Log, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """IMU sample nearest each time, and which rows land within the IMU's span (one row per
    sample: a second row on the same sample is left out)."""
    t0, dt, K = log.imu_t_s[0], log.dt_s, log.imu_t_s.size
    k = np.rint((t - t0) / dt).astype(np.int64)
    keep = (k >= 0) & (k < K)
    keep[1:] &= k[1:] != k[:-1]
    return k, keep


def _start_from_sensors(config: Config, log: Log) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Without a reference, where the filters start: the attitude sensor's first row, the first
    valid bottom-track DVL velocity (a body velocity, or the least squares of three or more beams;
    none: at rest) turned to NED with that attitude, at the configured origin and the starting depth
    (the depth sensor's first row). Returned as one-row reference arrays (position, Euler, NED
    velocity; the position geodetic on WGS-84, NED from the surface point on the flat earth)."""
    attitude = log.table("mag", EULER)
    if attitude is None or attitude[0].size == 0:
        raise LogError(
            f"{show_path(log.source)}: no reference and no attitude table: nothing says where the "
            "filters start"
        )
    euler = attitude[1][:1]
    C = C_nb_from_euler(euler)[0]
    vel_b = np.zeros(3)
    if log.dvl_body_mps is not None:
        ok = np.isfinite(log.dvl_body_mps).all(axis=1)
        if log.dvl_water_track is not None:
            ok &= ~log.dvl_water_track[:, 0]
        if ok.any():
            vel_b = log.dvl_body_mps[np.argmax(ok)]
    elif log.dvl_beams_mps is not None:
        beams = log.dvl_beams_mps
        if log.dvl_water_track is not None:  # over ground: bottom-track beams only
            beams = np.where(log.dvl_water_track, np.nan, beams)
        ok = np.isfinite(beams).sum(axis=1) >= 3
        if ok.any():
            y = beams[np.argmax(ok)]
            use = np.isfinite(y)
            vel_b = np.linalg.lstsq(config.dvl.A_b[use], y[use], rcond=None)[0]
    depth = config.trajectory.depth_m
    if config.earth.geodetic:
        position = np.array([[config.earth.latitude_rad, config.earth.longitude_rad, depth]])
    else:
        position = np.array([[0.0, 0.0, depth]])
    return position, euler, (C @ vel_b)[None]


def log_simulation(config: Config, log: Log, rng: np.random.Generator) -> Simulation:
    """The log as a one-run :class:`~tauvcore.engine.simulation.Simulation` under ``config``.

    The log corrected by ``config``'s ``[calibration]`` (tauvcore.eval.corrections), the DVL's beams
    and outages of ``config.dvl`` applied to its returns (and its dropout drawn from ``rng``), a
    body velocity projected onto the beams. The reference,
    interpolated to the IMU's times, is the truth. Without a reference the truth is known at the
    start only (:func:`_start_from_sensors`) and NaN after it: the errors are then unknown, the
    estimates are not. :class:`LogRows` makes the same rows chunk by chunk.

    Parameters
    ----------
    config : Config
        The replay's configuration (from :func:`replay_config`).
    log : Log
        The recorded log: IMU increments (K, 3) [rad], [m/s] in the body frame, the reference
        (position, Euler angles [rad], NED velocity [m/s]), the DVL and the aiding sources'
        tables, in SI units.
    rng : numpy.random.Generator
        What the DVL's dropout is drawn from.

    Returns
    -------
    Simulation
        One run (R = 1): the truth at the K IMU samples (positions (K, 3) NED [m] from the
        sea-surface point at the configured origin, a local reference's as they are; velocities
        (K, 3) [m/s] NED and body; attitude; the instantaneous rates and specific force NaN), the
        IMU increments (K, 1, 3) [rad], [m/s], and each source's epochs at the IMU sample nearest
        each row (values (E, 1)).

    Raises
    ------
    LogError
        As :class:`LogRows`.
    """
    rows = LogRows(config, log, rng)
    truth, imu = rows.rows(0, rows.num_samples)
    return Simulation(truth=truth, imu=imu, num_runs=1, sources=rows.sources)


class LogRows:
    """The log as a one-run simulation whose truth and IMU rows are made as they are asked for
    (:meth:`rows`): a replay fed chunk by chunk (tauvcore.engine.simulation.chunks_of) holds the
    log and one chunk, not a second copy of it as truth (:func:`log_simulation`: all rows at once).

    The log is corrected by ``[calibration]`` (tauvcore.eval.corrections), the sources' epochs made
    whole, the DVL's dropout drawn from ``rng`` as :func:`log_simulation` draws it. The rows are
    those of :func:`log_simulation` bit for bit with a reference at the IMU's rate; between the rows
    of a slower reference the interpolated attitude may differ in its last bit (exp_so3 takes its
    series or its sines by the largest angle it is given: a chunk's, not the whole log's).

    Parameters
    ----------
    config : Config
        The replay's configuration (from :func:`replay_config`).
    log : Log
        The recorded log, in SI units and the frames of tauvcore.conventions.
    rng : numpy.random.Generator
        What the DVL's dropout is drawn from.

    Raises
    ------
    LogError
        No reference and no attitude table (nothing says where the filters start); a local
        reference (north_m, east_m, down_m) under a geodetic earth (``--earth flat``, or give it
        as lat, lon and depth_m); a reference or DVL table without its columns.
    """

    num_runs = 1

    def __init__(self, config: Config, log: Log, rng: np.random.Generator) -> None:
        log = calibrated(log, config.calibration, config.dvl.A_b)  # the log itself when zero
        t = log.imu_t_s
        self.config = config
        self.known = log.ref_t_s is not None  # whether the log has a reference: else the truth is
        # known at the start only (first_row: position, Euler angles, NED velocity)
        self.first_row: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        if not self.known:
            start_pos, start_euler, start_vel = _start_from_sensors(config, log)
            self.first_row = start_pos[0], start_euler[0], start_vel[0]
            log = dataclasses.replace(
                log,
                ref_t_s=t[:1],
                ref_position=start_pos,
                ref_euler=start_euler,
                ref_vel_n=start_vel,
                ref_geodetic=config.earth.geodetic,
            )
        if not log.ref_geodetic and config.earth.geodetic:
            raise LogError(
                f"{show_path(log.source)}: the reference is local (north_m, east_m, down_m); replay it with "
                "--earth flat, or give it as lat, lon and depth_m"
            )
        self.log = log
        self.t_s = t - t[0]  # (K,) the mission's times [s] from the log's first IMU sample
        self.step_s = log.dt_s  # the IMU's sample interval [s] (a median over the log: once)
        self.start_pos = _reference_at(log, t[:1])[0][0]  # the reference position at the first sample
        self.sources = _log_sources(config, log, self.t_s, rng)

    @property
    def num_samples(self) -> int:
        """IMU samples K of the log."""
        return int(self.t_s.size)

    @property
    def dt_s(self) -> float:
        """The log's IMU sample interval [s]."""
        return self.step_s

    def rows(self, k0: int, k1: int) -> tuple[Truth, imu_sensor.ImuData]:
        """The truth and the IMU at samples ``k0 .. k1 - 1``
        (:meth:`~tauvcore.engine.simulation.ChunkSource.rows`).

        Parameters
        ----------
        k0 : int
            The first sample, 0 <= k0 < K.
        k1 : int
            One past the last sample, k0 < k1 <= K.

        Returns
        -------
        tuple[Truth, ImuData]
            The truth at those samples (the reference interpolated to them; positions NED [m]
            from the sea-surface point at the configured origin, a local reference's as they are;
            velocities [m/s] NED and body; attitude; the instantaneous rates and specific force
            NaN), and the log's IMU increments (n, 1, 3) [rad], [m/s] with unknown (NaN) biases.
        """
        config, log = self.config, self.log
        n = k1 - k0
        if self.known:
            pos, euler, vel_n = _reference_at(log, log.imu_t_s[k0:k1])
        else:
            pos, euler, vel_n = (np.full((n, 3), np.nan) for _ in range(3))
            if k0 == 0 and self.first_row is not None:
                pos[0], euler[0], vel_n[0] = self.first_row
        C = C_nb_from_euler(euler)
        vel_b = np.einsum("kji,kj->ki", C, vel_n)
        if log.ref_geodetic:
            if config.earth.geodetic:
                pos_nav = pos
            else:
                start = (self.start_pos[0], self.start_pos[1], 0.0)
                pos_nav = ned_from_geodetic(pos[:, 0], pos[:, 1], -pos[:, 2], start)
            origin = (config.earth.latitude_rad, config.earth.longitude_rad, 0.0)
            pos_n = ned_from_geodetic(pos[:, 0], pos[:, 1], -pos[:, 2], origin)
        else:
            pos_n = pos_nav = pos
        nan3 = np.full((n, 3), np.nan)
        truth = Truth(
            name="log",
            earth=config.earth,
            t_s=self.t_s[k0:k1],
            pos_n=pos_n,
            vel_n=vel_n,
            vel_b=vel_b,
            C_nb=C,
            euler=euler,
            omega_nb_b=nan3,
            omega_ib_b=nan3,
            f_b=nan3,
            dtheta_ib_b=log.dtheta_b[k0:k1],
            dv_b=log.dv_b[k0:k1],
            step_s=self.step_s,
            pos_nav=pos_nav,
        )
        imu = imu_sensor.ImuData(
            t_s=truth.t_s,
            dtheta_b=log.dtheta_b[k0:k1, None],
            dv_b=log.dv_b[k0:k1, None],
            accel_bias=np.full((n, 1, 3), np.nan),
            gyro_bias=np.full((n, 1, 3), np.nan),
        )
        return truth, imu


def _log_sources(
    config: Config, log: Log, t_s: np.ndarray, rng: np.random.Generator
) -> dict[str, SourceData]:
    """Each source's epochs at the IMU sample nearest each of its rows (``t_s``: the IMU samples'
    times from the first [s]); the DVL's beams and outages of ``config.dvl`` applied, its dropout
    drawn from ``rng``."""
    sources = {}
    if log.dvl_t_s is not None:
        k, keep = _epochs(log, log.dvl_t_s)
        k = k[keep]
        if log.dvl_beams_mps is not None:
            y = log.dvl_beams_mps[keep]
        else:
            y = _column(log, log.dvl_body_mps, "DVL velocity")[keep] @ config.dvl.A_b.T
        truths = {name: values[keep] for name, values in log.dvl_truth.items()}
        water = None if log.dvl_water_track is None else log.dvl_water_track[keep]
        both = None if log.dvl_water_mps is None else log.dvl_water_mps[keep]  # beside bottom-track
        sources["dvl"] = dvl_beams.from_log(t_s[k], k, y, truths, config.dvl, rng, water, both)
    for name, table in log.sources.items():
        k, keep = _epochs(log, table["t_s"])
        source = SOURCES[name]
        sources[name] = SourceData(
            t_s=t_s[k[keep]],
            index=k[keep],
            values={c.name: table[c.name][keep][:, None] for c in source.columns},
            truth={c.name: table[c.name][keep][:, None] for c in source.truth_columns},
        )
    return sources


def with_imu_errors(
    sim: Simulation, imu_config: imu_sensor.ImuConfig, rng: np.random.Generator
) -> Simulation:
    """The log's IMU with a simulated IMU's errors added on top.

    The errors are the turn-on biases, their walks, white noise, scale factors and misalignments
    of ``imu_config``, drawn from ``rng`` as tauvcore.sensors.imu does for a simulation: a
    navigation-grade log made to behave like a lesser IMU. The log's own increments play the
    truth's part.

    Parameters
    ----------
    sim : Simulation
        The log as a one-run simulation (:func:`log_simulation`).
    imu_config : ImuConfig
        The IMU whose errors are added (its rate the log's).
    rng : numpy.random.Generator
        What the errors are drawn from.

    Returns
    -------
    Simulation
        ``sim`` with the IMU increments (K, 1, 3) [rad], [m/s] in the body frame replaced by the
        log's plus the drawn errors.
    """
    errors = imu_sensor.simulate(sim.truth, imu_config, rng, 1)
    imu = dataclasses.replace(sim.imu, dtheta_b=errors.dtheta_b, dv_b=errors.dv_b)
    return dataclasses.replace(sim, imu=imu)


def rpm_readers(config: Config) -> list[tuple[str, tuple[str, ...]]]:
    """What of ``config`` reads the propeller's RPM and the echo sounder's altitude.

    Both are read by the velocity Kalman filter of tauvcore.engine.rpm_aid, which the ``vkf``
    method (--method) and ``run.rpm_fallback`` (--rpm-fallback) run.

    Parameters
    ----------
    config : Config
        The configuration: ``run.methods`` and ``run.rpm_fallback``.

    Returns
    -------
    list[tuple[str, tuple[str, ...]]]
        Each reader (the setting and its command-line option, for a message) with the names of the
        sources it reads; empty if nothing reads them.
    """
    needed = (RPM_SOURCE, ECHO_SOURCE)
    out = []
    if "vkf" in config.run.methods:
        out.append(("run.methods (--method) names vkf, which", needed))
    if config.run.rpm_fallback:
        out.append(("run.rpm_fallback (--rpm-fallback)", needed))
    return out


def prepare(
    config: Config,
    log: Log,
    rng: np.random.Generator,
    imu_errors: imu_sensor.ImuConfig | None = None,
    imu_tuning: imu_sensor.ImuConfig | None = None,
) -> tuple[Config, Simulation]:
    """The configuration as the log makes it and the log as a one-run simulation under it.

    The configuration from :func:`replay_config`, the simulation from :func:`log_simulation`;
    with ``imu_errors``, that IMU's errors added to the log's (:func:`with_imu_errors`) and the
    filters tuned for it (what the log's IMU then behaves as, where its own is much the better),
    or for ``imu_tuning`` (``tauv replay --imu-errors P --imu Q``). ``tauv replay`` and the
    dashboard's replay both start here, so the same log and configuration give the same run.

    Parameters
    ----------
    config : Config
        The configuration as given.
    log : Log
        The recorded log.
    rng : numpy.random.Generator
        What the DVL's dropout and the added IMU errors are drawn from.
    imu_errors : ImuConfig or None
        An IMU whose errors are added to the log's; None: the log's IMU as it is.
    imu_tuning : ImuConfig or None
        The IMU the filters are tuned for, the errors added still ``imu_errors``'; None:
        ``imu_errors``, or without them ``config.imu``.

    Returns
    -------
    tuple[Config, Simulation]
        The replay's configuration and the log as a one-run simulation (R = 1).

    Raises
    ------
    LogError
        ``run.aiding`` (--aiding) names a source the log has no table of; the ``vkf`` method or
        ``run.rpm_fallback`` reads a source the log has no table of; or as
        :func:`replay_config` and :func:`log_simulation`.
    """
    tuning = imu_errors if imu_tuning is None else imu_tuning
    if tuning is not None:
        config = config.replace("imu", **dataclasses.asdict(tuning))
    config = _checked_replay_config(config, log)
    sim = log_simulation(config, log, rng)
    if imu_errors is not None:  # at the log's rate, as the tuning
        sim = with_imu_errors(sim, dataclasses.replace(imu_errors, rate_hz=config.imu.rate_hz), rng)
    return config, sim


def _checked_replay_config(config: Config, log: Log) -> Config:
    """:func:`replay_config`, and LogError if a source that ``config`` fuses or reads has no table
    in the log (:func:`prepare`)."""
    config = replay_config(config, log)
    for name in active(config):
        if name not in log.sources:
            raise LogError(
                f"{show_path(log.source)}: run.aiding (--aiding) names {name}, but the log has no "
                f"{SOURCES[name].table}.csv or {SOURCES[name].table}.parquet"
            )
    for what, needed in rpm_readers(config):
        for name in needed:
            if name not in log.sources:
                raise LogError(
                    f"{show_path(log.source)}: {what} reads the {SOURCES[name].label.lower()}, but the log has "
                    f"no {SOURCES[name].table}.csv or {SOURCES[name].table}.parquet"
                )
    return config


def prepare_rows(
    config: Config,
    log: Log,
    rng: np.random.Generator,
    imu_errors: imu_sensor.ImuConfig | None = None,
    imu_tuning: imu_sensor.ImuConfig | None = None,
) -> tuple[Config, ChunkSource]:
    """:func:`prepare` for a replay fed chunk by chunk (:func:`replay_chunked`): the log's rows
    made as the chunks ask for them (:class:`LogRows`: the same numbers, to the last bit of an
    interpolated attitude). With ``imu_errors`` the whole simulation of :func:`prepare`: the
    added errors are drawn over the whole log at once (:func:`with_imu_errors`).

    Parameters
    ----------
    config : Config
    log : Log
    rng : numpy.random.Generator
    imu_errors : ImuConfig or None
    imu_tuning : ImuConfig or None
        As :func:`prepare` takes them (the log read whole).

    Returns
    -------
    tuple[Config, ChunkSource]
        The replay's configuration and the log as a one-run simulation (R = 1): its rows
        (:class:`LogRows`), or with ``imu_errors`` or ``imu_tuning`` :func:`prepare`'s whole one.

    Raises
    ------
    LogError
        As :func:`prepare`.
    """
    if imu_errors is not None or imu_tuning is not None:
        return prepare(config, log, rng, imu_errors, imu_tuning)
    config = _checked_replay_config(config, log)
    return config, LogRows(config, log, rng)


def replay(
    config: Config,
    log: Log,
    rng: np.random.Generator,
    progress: Callable[[float, dict[str, MethodResult]], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    imu_errors: imu_sensor.ImuConfig | None = None,
) -> tuple[Config, dict[str, MethodResult]]:
    """Every method of ``config.run.methods`` on the log.

    The results are as :func:`~tauvcore.engine.mission.run` gives them for a simulation, as far
    as the log can judge them (:func:`judged`).

    Parameters
    ----------
    config : Config
        The configuration as given.
    log : Log
        The recorded log.
    rng : numpy.random.Generator
        The random initial errors, DVL dropout and added IMU errors, if any.
    progress : Callable[[float, dict[str, MethodResult]], None] or None
        As in :func:`~tauvcore.engine.mission.run`: ``progress(t_s, partial_results)`` with the
        log's time since its start [s].
    should_stop : Callable[[], bool] or None
        As in :func:`~tauvcore.engine.mission.run`: polled at every output epoch.
    imu_errors : ImuConfig or None
        An IMU whose errors are added to the log's (:func:`prepare`); None: the log's IMU.

    Returns
    -------
    tuple[Config, dict[str, MethodResult]]
        The configuration as the log made it (:func:`replay_config`) and the results (one run:
        series (T, 1)) by method name.

    Raises
    ------
    LogError
        As :func:`prepare`.
    """
    config, sim = prepare(config, log, rng, imu_errors)
    results = run(config, sim, rng, Watch(progress=progress, should_stop=should_stop))
    return config, judged(log, results, config.filter.output_rate_hz)


def replay_chunked(
    config: Config,
    sim: ChunkSource,
    log: Log,
    rng: np.random.Generator,
    on_chunk: Callable[[dict[str, MethodResult]], None],
    chunk_s: float | None = None,
    smooth: SmoothOptions | None = None,
    on_smoothed_chunk: Callable[[dict[str, MethodResult]], None] | None = None,
) -> None:
    """Every method of ``config.run.methods`` on the log, its results handed out chunk by chunk
    instead of kept (``tauv replay``: memory for the results flat in the log's length).

    The chunks' results put end to end are :func:`replay`'s (the same numbers: the banks fed the
    log as chunks, tauvcore.engine.mission.run_chunked), each chunk judged as far as the log can
    judge it (:func:`judged`).

    Parameters
    ----------
    config : Config
        The replay's configuration, from :func:`prepare_rows`.
    sim : ChunkSource
        The log as a one-run simulation, from :func:`prepare_rows` (or :func:`prepare`) with the
        same ``rng``.
    log : Log
        The recorded log (whether it has a reference: :func:`judged`).
    rng : numpy.random.Generator
        The generator :func:`prepare` drew from: the filters' random initial errors come next.
    on_chunk : Callable[[dict[str, MethodResult]], None]
        ``on_chunk(results)`` receives each chunk's output epochs and updates (and the monitor's
        verdict so far), method name -> :class:`MethodResult` (series (T_chunk, 1)), judged.
    chunk_s : float or None
        The log's time per chunk [s]; None: tauvcore.engine.mission.STREAM_CHUNK_S.
    smooth : SmoothOptions or None
        Also run the fixed-interval smoother after the forward pass; None: no smoother.
    on_smoothed_chunk : Callable[[dict[str, MethodResult]], None] or None
        With ``smooth``: receives the smoothed results of every method chunk by chunk in
        the log's order, judged as ``on_chunk``'s, after the last ``on_chunk``.
    """
    run_chunked(
        config,
        sim,
        rng,
        lambda results: on_chunk(judged(log, results, config.filter.output_rate_hz)),
        chunk_s,
        smooth=smooth,
        on_smoothed_chunk=None
        if on_smoothed_chunk is None
        else (lambda results: on_smoothed_chunk(judged(log, results, config.filter.output_rate_hz))),
    )
