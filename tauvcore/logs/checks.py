"""Physical plausibility of a log that reads well: clocks, units, signs and axes.

:func:`tauvcore.logs.read_log` makes sure a log is well formed (its columns, numbers and
increasing times); :func:`check_plausible` makes sure it is physically right, because a wrong
log reads without complaint and replays into nonsense: a DVL clock in milliseconds leaves every
ping outside the IMU's span, a gyro in deg/s makes every filter diverge within seconds, a flipped
accelerometer axis tilts the INS by twice the vehicle's attitude. Each check compares a sensor
with what physics or another table of the same log predicts, per axis and over windows of about
:data:`~tauvcore.logs.evidence.WINDOW_S`, as a least-squares slope of the measured against the
predicted (1 if right) and their match (the cosine of the angle between the two series, 1 if they
agree in shape):

1. clocks: the IMU's interval within :data:`IMU_INTERVAL_RANGE_S` (:func:`check_imu_clock`);
   every other table within the IMU's span, an aiding sensor no sparser than
   :data:`MAX_AIDING_INTERVAL_S` (:func:`_check_clocks`);
2. the gyro against the rotation between successive reference (or attitude-table) attitudes, and
   no sustained rate beyond :data:`~tauvcore.logs.motion_checks.MAX_TURN_RATE_RPS`
   (:func:`~tauvcore.logs.motion_checks.check_gyro`,
   :func:`~tauvcore.logs.motion_checks.check_gyro_bound`);
3. the accelerometer against gravity and the reference's acceleration resolved in the body
   (:func:`~tauvcore.logs.motion_checks.check_accel`);
4. attitude (and latitude, longitude) within their ranges: beyond, degrees under a ``_rad`` name
   (:func:`_check_ranges`; check 2 catches the small angles that stay within);
5. the reference velocity against the reference's own position differences
   (:func:`~tauvcore.logs.motion_checks.check_velocity`);
6. depths below the sea surface, the depth table with the reference's (:func:`_check_depth`);
7. the DVL against the reference velocity resolved in the body
   (:func:`~tauvcore.logs.motion_checks.check_dvl`).

They run in the order 1, 4, 6, 5, 2, 3, 7, so that each leans only on what the ones before it
have passed (the gyro's check on the reference's attitude, the DVL's on its velocity).

Columns that explain the predicted axes far better in another order are swapped axes; a slope
near a known unit factor (57.3: degrees for radians; 1.944: knots for m/s; -1: a sign) is that
unit. Either is refused with one :class:`LogError` naming the file, the column, the row (data
rows from 1) and its value, what it looks like and what to do. Where a check cannot be sure (too
little motion to judge an axis, an unexplained slope) it returns a note naming the file and the
column. An axis on which neither side moves is not judged and not noted: its scale cannot matter
to the replay. Everything runs vectorised over the log's arrays; the files are opened (their
header, a column) only to word a message.

Here are the checks of the clocks, the ranges and the depths, and :func:`check_plausible`, which
runs them all; the checks against the vehicle's motion (2, 3, 5, 7) are tauvcore.logs.motion_checks,
the comparison they make and the files' columns and values their messages quote
tauvcore.logs.evidence.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.aiding.attitude_mag import EULER
from tauvcore.aiding.sources import SOURCES
from tauvcore.logs.evidence import file_angle_columns, table_file
from tauvcore.logs.log_record import Log
from tauvcore.logs.motion_checks import (
    MAX_TURN_RATE_RPS,
    check_accel,
    check_attitude_units,
    check_dvl,
    check_gyro,
    check_gyro_bound,
    check_gyro_earth_rate,
    check_velocity,
)
from tauvcore.validation import LogError, show, show_path

IMU_INTERVAL_RANGE_S = (1e-4, 1.0)
"""The IMU's median sample interval [s]: an IMU samples at 1 Hz to 10 kHz. Outside, the clock is
in other units: 10 "s" between samples of a 100 Hz IMU is milliseconds, 10000 microseconds."""
MAX_OUTSIDE_FRACTION = 0.5
"""Largest share of a table's rows outside the IMU's span before the table is refused: a table
on the IMU's clock overlaps it almost wholly; one on another clock (or in other units) mostly not."""
MAX_AIDING_INTERVAL_S = 1000.0
"""Median interval [s] at and beyond which a DVL, depth or attitude table is refused: 100 times
the 10 s any of those sensors reports within (a DVL pings at 0.05-25 Hz, a pressure sensor and
an AHRS faster), and exactly the interval of a 1 Hz sensor's times in milliseconds."""
MIN_DEPTH_M = -1.0
"""Shallowest depth [m] a submerged vehicle's depth can be: 1 m above the mean surface, beyond
waves of a working sea state and the 0.5 m of water the air pressure varies by."""
DEPTH_AGREEMENT_M = 3.0
"""Median difference [m] between the depth table and the reference depth beyond which it is noted:
a pressure sensor's offset and the lever arm between it and the reference point are below a metre
or two."""


# ------------------------------------------------------------------------------------------ clocks
def _time_units(interval_s: float, low: float, high: float) -> str | None:
    """Which unit would bring ``interval_s`` within [low, high] s, if one does."""
    for factor, unit in ((1e3, "milliseconds"), (1e6, "microseconds"), (1e9, "nanoseconds")):
        if low <= interval_s / factor <= high:
            return unit
    return None


def check_imu_clock(imu_t_s: np.ndarray, path: Path) -> None:
    """LogError unless the IMU's median interval lies within :data:`IMU_INTERVAL_RANGE_S` (the
    first of the checks; the reader may call it before judging the accelerometer by gravity,
    whose average over the first 10 s a clock in milliseconds also spoils)."""
    if imu_t_s.size < 2:
        return
    steps = np.diff(imu_t_s)
    median = float(np.median(steps))
    low, high = IMU_INTERVAL_RANGE_S
    if low <= median <= high:
        return
    unit = _time_units(median, low, high)
    factor = {"milliseconds": 1e3, "microseconds": 1e6, "nanoseconds": 1e9}.get(unit or "", 1.0)
    looks = (
        f"times in {unit}? Give t_s in seconds (divide by {factor:g} in every table: they share one clock)"
        if unit
        else "the column is not a time in seconds"
    )
    raise LogError(
        f"{show_path(str(path))}: column 't_s', row 2: {float(imu_t_s[1])!r} is {float(steps[0]):.6g} after the row "
        f"before (the median interval: {median:.6g}): an IMU samples every {low:g} to {high:g} s (1 Hz to 10 kHz); "
        f"{looks}"
    )


def _check_clocks(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """Every table on the IMU's clock (check 1): most rows within the IMU's span, and the aiding
    sensors' median interval below :data:`MAX_AIDING_INTERVAL_S`; rows outside are noted."""
    t_imu = log.imu_t_s
    half = 0.5 * log.dt_s
    start, end = float(t_imu[0]), float(t_imu[-1])
    for table, t in (
        ("dvl", log.dvl_t_s),
        *((SOURCES[name].table, rows["t_s"]) for name, rows in log.sources.items()),
        ("reference", log.ref_t_s),
    ):
        if t is None or t.size == 0:
            continue
        path = show_path(str(table_file(files, log, table)))
        outside = (t < start - half) | (t > end + half)
        share = float(outside.mean())
        if share > MAX_OUTSIDE_FRACTION:
            row = int(np.argmax(outside)) + 1
            hint = next(
                (
                    f"times in {unit}? Give t_s in seconds (divide by {factor:g})"
                    for factor, unit in ((1e3, "milliseconds"), (1e6, "microseconds"))
                    if np.mean((t / factor >= start - half) & (t / factor <= end + half))
                    > MAX_OUTSIDE_FRACTION
                ),
                "another clock or origin? Put every table on the IMU's clock",
            )
            raise LogError(
                f"{path}: column 't_s', row {row}: {float(t[row - 1])!r} s is outside the IMU's span "
                f"({start:.6g} to {end:.6g} s), as are {int(outside.sum())} of its {t.size} rows; {hint}"
            )
        if table != "reference" and t.size > 1:
            steps = np.diff(t)
            median = float(np.median(steps))
            if median >= MAX_AIDING_INTERVAL_S:
                row = int(np.argmax(steps >= MAX_AIDING_INTERVAL_S)) + 2
                raise LogError(
                    f"{path}: column 't_s', row {row}: {float(t[row - 1])!r} is {float(steps[row - 2]):.6g} s after "
                    f"the row before; a median interval of {median:.6g} s is no {table} sensor's (they report "
                    f"within 10 s): times in milliseconds? Give t_s in seconds (divide by 1000)"
                )
        if outside.any():
            row = int(np.argmax(outside)) + 1
            notes.append(
                f"{path}: column 't_s': {int(outside.sum())} of {t.size} rows (the first: row {row}, "
                f"{float(t[row - 1])!r} s) are outside the IMU's span ({start:.6g} to {end:.6g} s) and left out"
            )


# -------------------------------------------------------------------------------- ranges and depth
def _check_ranges(log: Log, files: Mapping[str, Path]) -> None:
    """Attitude within roll +-pi and pitch +-pi/2, latitude +-pi/2 and longitude +-2 pi (check 4):
    beyond, the values are degrees under a ``_rad`` name. A yaw beyond +-2 pi is refused where it
    also turns faster than :data:`~tauvcore.logs.motion_checks.MAX_TURN_RATE_RPS` from one row to
    the next (a heading in degrees: 57 times its rate, and a jump of 360 where it wraps); a
    smooth one is an unwrapped heading in radians, which the format allows (a heading in degrees
    that turns too slowly to tell is left to the gyro's comparison,
    :func:`~tauvcore.logs.motion_checks.check_gyro`)."""
    sets = []
    attitude = log.table("mag", EULER)
    for table, t, euler in (
        ("reference", log.ref_t_s, log.ref_euler),
        (SOURCES["mag"].table, *(attitude or (None, None))),
    ):
        if t is None or euler is None:
            continue
        over = np.abs(euler) > np.array([np.pi, np.pi / 2, 2 * np.pi])
        if over[:, 2].any() and t.size > 1:
            fast = np.abs(np.diff(euler[:, 2])) > MAX_TURN_RATE_RPS * np.diff(t)
            over[:, 2] &= fast.any()
        sets.append((table, ("roll", "pitch", "yaw"), euler, over, (np.pi, np.pi / 2, 2 * np.pi)))
    if log.ref_geodetic and log.ref_position is not None:
        position = log.ref_position[:, :2]
        sets.append(
            (
                "reference",
                ("lat", "lon"),
                position,
                np.abs(position) > np.array([np.pi / 2, 2 * np.pi]),
                (np.pi / 2, 2 * np.pi),
            )
        )
    for table, bases, values, over, limits in sets:
        if not over.any():
            continue
        row, axis = (int(v) for v in np.argwhere(over)[0])
        path = table_file(files, log, table)
        column = file_angle_columns(path, bases)[axis]
        in_deg = column.endswith("_deg")
        value = values[row, axis] / units.DEG if in_deg else values[row, axis]
        limit = limits[axis] / units.DEG if in_deg else limits[axis]
        looks = (
            "not an angle in degrees"
            if in_deg
            else "in degrees under _rad? Name the columns _deg, or give radians"
        )
        if bases[axis] == "yaw":
            looks += f" (and it turns faster than {MAX_TURN_RATE_RPS:g} rad/s between rows)"
        raise LogError(
            f"{show_path(str(path))}: column {show(column)}, row {row + 1}: {value:.6g} is beyond +-{limit:.6g}, "
            f"the range of a {bases[axis]}: {looks}"
        )


def _check_depth(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """Depths below the surface (check 6): a reference depth shallower than :data:`MIN_DEPTH_M` is
    refused, as is a depth table whose median is; a depth table off the reference by more than
    :data:`DEPTH_AGREEMENT_M` (median) is noted."""
    ref_t, ref_depth = log.ref_t_s, None
    if ref_t is not None and log.ref_position is not None:
        ref_depth = log.ref_position[:, 2]
        above = ref_depth < MIN_DEPTH_M
        if above.any():
            row = int(np.argmax(above)) + 1
            path = table_file(files, log, "reference")
            column = "depth_m" if log.ref_geodetic else "down_m"
            raise LogError(
                f"{show_path(str(path))}: column {show(column)}, row {row}: {float(ref_depth[row - 1]):.6g} m, above "
                f"the sea surface (a depth is positive down, and above {MIN_DEPTH_M:g} m a vehicle is out of the "
                "water): a height or altitude given as depth? Negate it"
            )
    depth = log.table("depth", ("depth_m",))
    if depth is None or depth[0].size == 0:
        return
    path = table_file(files, log, SOURCES["depth"].table)
    depth_t_s, d = depth[0], depth[1][:, 0]
    compare = None
    if ref_t is not None and ref_depth is not None:
        inside = (depth_t_s >= ref_t[0]) & (depth_t_s <= ref_t[-1])
        if inside.any():
            compare = d[inside] - np.interp(depth_t_s[inside], ref_t, ref_depth)
    if float(np.median(d)) < MIN_DEPTH_M:
        row = int(np.argmax(d < MIN_DEPTH_M)) + 1
        against = ""
        if ref_t is not None and ref_depth is not None:
            at = float(np.interp(depth_t_s[row - 1], ref_t, ref_depth))
            against = f"; the reference is at {at:.6g} m then"
        raise LogError(
            f"{show_path(str(path))}: column 'depth_m', row {row}: {float(d[row - 1]):.6g} m, above the sea surface as "
            f"most rows are{against}: the sign is flipped (a height, not a depth)? Give depth positive down"
        )
    if compare is not None and compare.size and abs(float(np.median(compare))) > DEPTH_AGREEMENT_M:
        notes.append(
            f"{show_path(str(path))}: column 'depth_m' differs from the reference depth by {float(np.median(compare)):+.3g} m "
            f"(median; more than {DEPTH_AGREEMENT_M:g} m): an offset (surface pressure, another reference point)?"
        )


# ---------------------------------------------------------------------------------------- the entry
def check_plausible(log: Log, files: Mapping[str, Path]) -> list[str]:
    """Check that a read log is physically right (module docstring); LogError on the first thing
    that is not, else the notes on what could not be checked for sure (each naming file and column).

    Parameters
    ----------
    log : the log as :func:`tauvcore.logs.read_log` made it (SI units, the frames of
        tauvcore.conventions).
    files : table name -> the table's file (``{"imu": Path(".../imu.csv"), ...}``), for the
        messages' file and column names.
    """
    notes: list[str] = []
    check_imu_clock(log.imu_t_s, table_file(files, log, "imu"))
    _check_clocks(log, files, notes)
    _check_ranges(log, files)
    _check_depth(log, files, notes)
    check_velocity(log, files, notes)
    check_attitude_units(log, files)
    gyro_notes: list[str] = []
    check_gyro(log, files, gyro_notes)
    check_gyro_bound(log, files)
    if gyro_notes:  # axes it could not judge: the earth's rate may still show a gyro in deg/s
        check_gyro_earth_rate(log, files)
    notes.extend(gyro_notes)
    check_accel(log, files)
    check_dvl(log, files, notes)
    return notes


__all__ = ["check_imu_clock", "check_plausible"]
