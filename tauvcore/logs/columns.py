"""The columns of a log's tables: their names, each one's physical bounds, and the checks a column
passes as it is read (present, finite or empty where a table allows it, within its bounds; the
times strictly increasing), each refusal one :class:`~tauvcore.validation.LogError` naming the
file, the column, the row and what the cell holds.

The bounds are what physics allows a vehicle at sea (a latitude within 90 deg, a DVL velocity
within :data:`~tauvcore.conventions.MAX_SPEED_MPS`, ...): a value beyond one is in other units or no measurement.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.aiding import dvl_beams
from tauvcore.conventions import MAX_SPEED_MPS
from tauvcore.logs.table_io import held
from tauvcore.validation import LogError, show, show_path

IMU_INCREMENTS = ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps")
IMU_RATES = ("gyro_x_rps", "gyro_y_rps", "gyro_z_rps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2")
DVL_BEAMS = dvl_beams.BEAMS
DVL_BODY = ("vel_x_mps", "vel_y_mps", "vel_z_mps")
DVL_WATER_TRACK = dvl_beams.WATER_TRACK
DVL_BODY_WATER_TRACK = "water_track"
"""A body velocity's mode column: 1 water-track, 0 bottom-track."""
DVL_WATER_BEAMS = dvl_beams.WATER_BEAMS
"""Water-track beam velocities beside bottom-track ones (a DVL that outputs both from one ping)."""
REF_VEL = ("vel_north_mps", "vel_east_mps", "vel_down_mps")
REF_LOCAL = ("north_m", "east_m", "down_m")
MAX_TIME_S = 1e20
"""Largest time stamp [s] (3e12 years): more than any clock counts, in seconds or in the
nanoseconds since 1970 (1.8e18) a time stamp in other units may be; beyond it the differences
between rows overflow."""
MAX_DTHETA_RAD = 1.0
"""Largest angle increment of one IMU sample [rad] (57 deg: 100 rad/s at 100 Hz, 10 rad/s at
10 Hz, beyond what a vehicle at sea turns); a larger one is in degrees or no measurement."""
MAX_DV_MPS = 50.0
"""Largest velocity increment of one IMU sample [m/s] (5 g over a 1 s sample, far more at a
usual rate); a larger one is in other units or no measurement."""
MAX_GYRO_RPS = 20.0
"""Largest angular rate [rad/s] (1150 deg/s, the range of a MEMS gyro beyond any vehicle at sea);
a larger one is in deg/s or no measurement."""
MAX_ACCEL_MPS2 = 500.0
"""Largest specific force [m/s^2] (50 g, the range of a wide-range MEMS accelerometer; a vehicle
at sea feels about 1 g); a larger one is in mg or mm/s^2, or no measurement."""
DEPTH_RANGE_M = (-100.0, 12_000.0)
"""Depths [m] a log may hold (positive down): the deepest ocean is 10,935 m (Challenger Deep);
up to 100 m above the surface allows for a vehicle on deck, a crane, a pressure sensor's offset."""
MAX_LOCAL_M = 2.0e7
"""Largest north or east distance [m] of a local reference from the mission origin: half the
earth's circumference, as far as any point of the earth is."""
LATITUDE_MAX_DEG = 90.0
"""Largest latitude, north or south [deg] (the poles; pi/2 in ``lat_rad``)."""
LONGITUDE_MAX_DEG = 180.0
"""Largest longitude, east or west [deg] (pi in ``lon_rad``): -180 to 180, east positive."""
MAX_ANGLE_RAD = 1.0e4
"""Largest roll, pitch or yaw [rad] (1600 turns: an unwrapped heading over any mission stays well
within); a larger one is no angle (a time stamp, a sentinel such as 1e300), and beyond 1e15 rad
float64 cannot even hold its sine."""


def _bounds() -> dict[str, tuple[float, float, str, str]]:
    """Each column's physical bounds: (low, high, unit, what a value beyond them is, in words)."""
    speed = "faster than a vehicle under water moves"
    depth = (*DEPTH_RANGE_M, "m", "deeper than the ocean, or high above it")
    table: dict[str, tuple[float, float, str, str]] = {"depth_m": depth, "down_m": depth}
    for names, bound, unit, what in (
        (("t_s",), MAX_TIME_S, "s", "more than any clock counts"),
        (IMU_INCREMENTS[:3], MAX_DTHETA_RAD, "rad", "more than an IMU turns in one sample"),
        (IMU_INCREMENTS[3:], MAX_DV_MPS, "m/s", "more than an IMU's velocity changes in one sample"),
        (IMU_RATES[:3], MAX_GYRO_RPS, "rad/s", "faster than a vehicle at sea turns"),
        (IMU_RATES[3:], MAX_ACCEL_MPS2, "m/s^2", "more than a vehicle at sea feels"),
        (DVL_BEAMS + DVL_WATER_BEAMS + DVL_BODY + REF_VEL, MAX_SPEED_MPS, "m/s", speed),
        (REF_LOCAL[:2], MAX_LOCAL_M, "m", "farther than any point of the earth is"),
    ):
        table.update(dict.fromkeys(names, (-bound, bound, unit, what)))
    angles = [
        ("lat", LATITUDE_MAX_DEG, "no latitude (the poles are at 90 deg)"),
        ("lon", LONGITUDE_MAX_DEG, "no longitude (-180 to 180 deg, east positive; from 0-360: subtract 360)"),
    ] + [(n, MAX_ANGLE_RAD / units.DEG, "no attitude angle") for n in ("roll", "pitch", "yaw")]
    for name, bound_deg, what in angles:
        table[f"{name}_deg"] = (-bound_deg, bound_deg, "deg", what)
        table[f"{name}_rad"] = (-bound_deg * units.DEG, bound_deg * units.DEG, "rad", what)
    return table


BOUNDS = _bounds()
"""Each column's physical bounds (low, high, unit, what a value beyond them is, in words), checked
as a table is read (:func:`check_within`)."""


def need_columns(path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str) -> np.ndarray:
    missing = [n for n in names if n not in columns]
    if missing:
        raise LogError(
            f"{show_path(str(path))}: missing column {show(missing[0])} ({what}: {', '.join(names)})"
        )
    return np.stack([columns[n] for n in names], axis=-1)


def angle_columns(
    path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Angle columns, each as ``<name>_deg`` or ``<name>_rad`` (not both), every value finite and
    within its bound: the angles (K, len(names)) in radians, and the columns' names as the file
    has them."""
    out, found = [], []
    for n in names:
        have = [f"{n}_{u}" for u in ("rad", "deg") if f"{n}_{u}" in columns]
        if not have:
            raise LogError(
                f"{show_path(str(path))}: missing column {show(n + '_deg')} or {show(n + '_rad')} ({what})"
            )
        if len(have) > 1:
            raise LogError(
                f"{show_path(str(path))}: both columns {show(have[0])} and {show(have[1])}; keep one"
            )
        check_finite(path, columns, (have[0],))
        check_within(path, columns, (have[0],))
        out.append(columns[have[0]] * (1.0 if have[0].endswith("_rad") else units.DEG))
        found.append(have[0])
    return np.stack(out, axis=-1), tuple(found)


def check_finite(
    path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], allow_nan: bool = False
) -> None:
    """Every value of ``names`` finite (or NaN, an empty cell, where allowed): LogError at the
    first offender by row and column, saying what the cell holds."""
    for n in names:
        if n not in columns:
            continue
        v = columns[n]
        bad = np.isinf(v) if allow_nan else ~np.isfinite(v)
        if bad.any():
            row = int(np.argmax(bad)) + 1
            need = "a finite number or nothing" if allow_nan else "a finite number"
            raise LogError(
                f"{show_path(str(path))}: column {show(n)}, row {row}: {held(path, n, row, float(v[row - 1]))}; "
                f"{need} is needed here"
            )


def check_within(
    path: Path,
    columns: dict[str, np.ndarray],
    names: tuple[str, ...],
    bounds: dict[str, tuple[float, float, str, str]] = BOUNDS,
) -> None:
    """Every value of ``names`` within its physical bound (:data:`BOUNDS`, or ``bounds``; NaN
    passes, :func:`check_finite` judges it): LogError at the first that is not, with the bound in words."""
    for n in names:
        if n not in columns:
            continue
        low, high, unit, what = bounds[n]
        v = columns[n]
        bad = (v < low) | (v > high)
        if bad.any():
            row = int(np.argmax(bad)) + 1
            span = f"beyond +-{high:g} {unit}" if low == -high else f"outside [{low:g}, {high:g}] {unit}"
            raise LogError(
                f"{show_path(str(path))}: column {show(n)}, row {row}: {show(float(v[row - 1]))} is {span}, {what}"
            )


def time_column(path: Path, columns: dict[str, np.ndarray]) -> np.ndarray:
    if "t_s" not in columns:
        raise LogError(f"{show_path(str(path))}: missing column 't_s' (time [s])")
    check_finite(path, columns, ("t_s",))
    check_within(path, columns, ("t_s",))
    t = columns["t_s"]
    if t.size == 0:
        raise LogError(f"{show_path(str(path))}: no rows")
    step = np.diff(t)
    if (step <= 0).any():
        row = int(np.argmax(step <= 0)) + 2
        kind = "repeats" if step[row - 2] == 0 else "goes back from"
        raise LogError(
            f"{show_path(str(path))}: column 't_s', row {row}: {float(t[row - 1])!r} {kind} the row before "
            f"({float(t[row - 2])!r}); times must increase strictly (sort the log, drop duplicates)"
        )
    return t
