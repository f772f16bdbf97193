"""What the dashboard's 3-D view, Vehicle, Seabed and Components tabs read of the truth, sent
before a run (the worker's ``("truth", dict)`` message, app.dashboard.worker): the truth at the output epochs
with the seabed under it, the current around it and the DVL's scheduled pings, of a simulated
mission (:func:`truth_view`, generated a chunk at a time) or a replayed log
(:func:`log_truth_view`), and how a long mission is reduced to time bins (:func:`decimation`).
"""

from __future__ import annotations

from typing import Any, TypedDict

import numpy as np

from app.dashboard import budget
from tauvcore.config import Config
from tauvcore.eval.envelope import epochs_per_bin
from tauvcore.sensors.dvl import slant_ranges_m
from tauvcore.sensors.timing import epoch_indices_between
from tauvcore.truth import truth_stream
from tauvcore.truth.current import current_field
from tauvcore.truth.kinematic import bathymetry


class TruthView(TypedDict):
    """The ``("truth", ...)`` message's dict: :func:`truth_view` or :func:`log_truth_view`."""

    t_s: np.ndarray  # (T,) the output epochs [s]
    pos_n: np.ndarray  # (T, 3)
    C_nb: np.ndarray  # (T, 3, 3)
    ping_t_s: np.ndarray  # the DVL pings [s]
    ping_available: np.ndarray  # (pings, 4) the beams the schedule lets return
    altitude_m: np.ndarray | None  # (T,); None for a replayed log
    slant_range_m: np.ndarray | None  # (T, 4); None for a replayed log
    propeller_rpm: np.ndarray | None  # (T,); None but for the dynamic truth
    fin_angles_rad: np.ndarray | None  # (T, 4); None but for the dynamic truth
    vel_n: np.ndarray | None  # (T, 3) true NED velocity [m/s] of a long mission's rows, too far apart
    # for their positions' central difference (app.figures.error_figures.error_components); None otherwise
    current_n_mps: np.ndarray | None  # (T, 3) the ocean current at the vehicle, NED [m/s]; None in
    # still water and for a replayed log
    vel_water_b: np.ndarray | None  # (T, 3) the vehicle's velocity through the water, body [m/s]; None
    # when current_n_mps is


def decimation(config: Config) -> tuple[int, int, float]:
    """How a dashboard run of ``config`` is reduced: its output epochs T, the output epochs per bin
    k (tauvcore.eval.envelope.epochs_per_bin: 1, not reduced, unless T exceeds SCREEN_BINS) and
    the interval between output epochs [s]."""
    step = max(1, round(config.imu.rate_hz / config.filter.output_rate_hz))
    num_epochs = budget.output_epochs(config)
    return num_epochs, epochs_per_bin(num_epochs), step / config.imu.rate_hz


def truth_view(config: Config, step: int, epochs_per_bin: int = 1) -> TruthView:
    """What the 3-D view needs before the run: the truth at the output epochs (every ``step``-th
    IMU sample, generated a chunk at a time and thinned) and the DVL ping times with the beams
    the schedule lets return (random drop-outs show once the results carry them). With
    ``epochs_per_bin`` k > 1 (a long mission reduced to bins, :func:`decimation`) only the first
    output epoch and the last of every k, the epochs the reduced results are at.

    The seabed at the same rows (the mission's bathymetry, tauvcore.truth.kinematic):
    ``altitude_m`` (T,) the true height above the seabed straight below, what an ideal echo
    sounder measures [m]; ``slant_range_m`` (T, 4) each beam's range from the DVL head to the
    seabed, inf beyond the DVL's range, by the DVL simulation's own tracer
    (tauvcore.sensors.dvl.slant_ranges_m) [m].

    With the dynamic truth (its chunks carry a :class:`~tauvcore.truth.VehicleRecord`) also the
    vehicle's actuators at the same rows: ``propeller_rpm`` (T,) [rev/min] and ``fin_angles_rad``
    (T, 4), fins 1-4 of tauvcore.truth.vehicle [rad]; both None for the kinematic truth.

    With ``epochs_per_bin`` > 1 also ``vel_n`` (T, 3), the true NED velocity [m/s]: the rows are
    seconds apart, too far for the central difference of their positions; None otherwise.

    In a current (tauvcore.truth.current) also ``current_n_mps`` (T, 3), the current at the vehicle,
    NED [m/s] (``Truth.current_n_mps``), and ``vel_water_b`` (T, 3), the velocity through the water
    ``vel_b - C_nb^T c_n``, body [m/s]; both None in still water."""
    stream = truth_stream(config.trajectory, config.earth, config.imu.rate_hz, chunk_samples=step * 1000)
    seabed = bathymetry(config.trajectory)
    still = current_field(config.trajectory) is None
    t, pos, C, altitude, ranges, rpm, fins, vel, current, water = [], [], [], [], [], [], [], [], [], []
    last_epoch = (stream.num_samples - 1) // step
    for k0, chunk in stream:
        rows = np.arange((-k0) % step, chunk.num_samples, step)
        if epochs_per_bin > 1:
            epoch = (k0 + rows) // step
            rows = rows[(epoch % epochs_per_bin == epochs_per_bin - 1) | (epoch == 0) | (epoch == last_epoch)]
        t.append(chunk.t_s[rows])
        pos.append(chunk.pos_n[rows])
        C.append(chunk.C_nb[rows])
        vel.append(chunk.vel_n[rows])
        altitude.append(seabed.depth_m(chunk.pos_n[rows, 0], chunk.pos_n[rows, 1]) - chunk.depth_m[rows])
        ranges.append(slant_ranges_m(chunk, rows, config.dvl, seabed))
        if chunk.vehicle is not None:
            rpm.append(chunk.vehicle.propeller_rpm[rows])
            fins.append(chunk.vehicle.fin_angles_rad[rows])
        if not still:
            assert chunk.current_n_mps is not None  # every truth records the current it flies in
            current.append(chunk.current_n_mps[rows])
            water.append(chunk.vel_water_b[rows])
    t_end = (stream.num_samples - 1) * stream.dt_s
    pings = (
        epoch_indices_between(
            config.dvl.rate_hz, t_end, stream.dt_s, stream.num_samples, 0, stream.num_samples
        )
        * stream.dt_s
    )
    return {
        "t_s": np.concatenate(t),
        "pos_n": np.concatenate(pos),
        "C_nb": np.concatenate(C),
        "ping_t_s": pings,
        "ping_available": config.dvl.scheduled_availability(pings),
        "altitude_m": np.concatenate(altitude),
        "slant_range_m": np.concatenate(ranges),
        "propeller_rpm": np.concatenate(rpm) if rpm else None,
        "fin_angles_rad": np.concatenate(fins) if fins else None,
        "vel_n": np.concatenate(vel) if epochs_per_bin > 1 else None,
        "current_n_mps": None if still else np.concatenate(current),
        "vel_water_b": None if still else np.concatenate(water),
    }


def log_truth_view(truth: Any, config: Config, dvl: Any, step: int) -> TruthView:
    """:func:`truth_view` of a replayed log: its reference at the output epochs, its DVL pings
    (a log records no seabed, no actuators and no current: ``altitude_m``, ``slant_range_m``,
    ``propeller_rpm``, ``fin_angles_rad``, ``current_n_mps`` and ``vel_water_b`` are None)."""
    rows = np.arange(0, truth.num_samples, step)
    return {
        "t_s": truth.t_s[rows],
        "pos_n": truth.pos_n[rows],
        "C_nb": truth.C_nb[rows],
        "ping_t_s": dvl.t_s,
        "ping_available": config.dvl.scheduled_availability(dvl.t_s),
        "altitude_m": None,
        "slant_range_m": None,
        "propeller_rpm": None,
        "fin_angles_rad": None,
        "vel_n": None,
        "current_n_mps": None,
        "vel_water_b": None,
    }
