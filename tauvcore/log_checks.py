"""Physical plausibility of a log that reads well: clocks, units, signs and axes.

:func:`tauvcore.logs.read_log` makes sure a log is well formed (its columns, numbers and
increasing times); :func:`check_plausible` makes sure it is physically right, because a wrong
log reads without complaint and replays into nonsense: a DVL clock in milliseconds leaves every
ping outside the IMU's span, a gyro in deg/s makes every filter diverge within seconds, a flipped
accelerometer axis tilts the INS by twice the vehicle's attitude. Each check compares a sensor
with what physics or another table of the same log predicts, per axis and over windows of about
:data:`WINDOW_S`, as a least-squares slope of the measured against the predicted (1 if right)
and their match (the cosine of the angle between the two series, 1 if they agree in shape):

1. clocks: the IMU's interval within :data:`IMU_INTERVAL_RANGE_S` (:func:`check_imu_clock`);
   every other table within the IMU's span, an aiding sensor no sparser than
   :data:`MAX_AIDING_INTERVAL_S` (:func:`_check_clocks`);
2. the gyro against the rotation between successive reference (or attitude-table) attitudes, and
   no sustained rate beyond :data:`MAX_TURN_RATE_RPS` (:func:`_check_gyro`, :func:`_check_gyro_bound`);
3. the accelerometer against gravity and the reference's acceleration resolved in the body
   (:func:`_check_accel`);
4. attitude (and latitude, longitude) within their ranges: beyond, degrees under a ``_rad`` name
   (:func:`_check_ranges`; check 2 catches the small angles that stay within);
5. the reference velocity against the reference's own position differences (:func:`_check_velocity`);
6. depths below the sea surface, the depth table with the reference's (:func:`_check_depth`);
7. the DVL against the reference velocity resolved in the body (:func:`_check_dvl`).

They run in the order 1, 4, 6, 5, 2, 3, 7, so that each leans only on what the ones before it
have passed (the gyro's check on the reference's attitude, the DVL's on its velocity).

Columns that explain the predicted axes far better in another order are swapped axes; a slope
near a known unit factor (57.3: degrees for radians; 1.944: knots for m/s; -1: a sign) is that
unit. Either is refused with one :class:`LogError` naming the file, the column, the row (data
rows from 1) and its value, what it looks like and what to do. Where a check cannot be sure (too
little motion to judge an axis, an unexplained slope) it returns a note naming the file and the
column. An axis on which neither side moves is not judged and not noted: its scale cannot matter
to the replay. Everything runs vectorised over the
log's arrays; the files are opened (their header, a column) only to word a message.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.geo.earth import OMEGA_IE_RPS, radii_of_curvature_m
from tauvcore.geo.rotations import C_nb_from_euler, log_so3
from tauvcore.log_record import Log
from tauvcore.sensors.dvl import DvlConfig
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
WINDOW_S = 1.0
"""Length of the windows sensors are compared over [s]: the IMU's noise averages out over a
second and a reference's 1 Hz rows still resolve an AUV's turns (it turns less than pi in it)."""
MIN_MATCH = 0.7
"""Smallest match (cosine between measured and predicted series) an axis is judged on: below it
noise or unmodelled effects dominate (an AHRS's 1-6 deg noise against a slow turn) and a slope
says nothing."""
SWAP_RATIO = 0.25
"""How much better the measured columns in another order must explain the predicted axes to call
them swapped: at most a quarter of the energy their own order leaves unexplained. The axes of a
manoeuvring vehicle are partly correlated (a pitched vehicle's yaw rate shows on its roll axis, the
roll rate follows the yaw rate in a banked turn), so a wrong order explains some, never most."""
MIN_TURN_RATE_RPS = 0.2 * units.DEG
"""RMS turn rate about an axis [rad/s] from which the gyro's scale on it is judged: well above a
navigation-grade reference's noise and a MEMS gyro's bias (3 deg/h = 0.0008 deg/s) and earth rate
(0.004 deg/s), yet below what any manoeuvre or a hull's roll in a swell shows."""
GYRO_SLOPE_FACTOR = 3.0
"""A gyro slope within this factor of 1 (or of a unit factor) is taken as that: wide enough for
the attenuation an AHRS's noise brings to a fitted slope (to half), and the bands about 1 and
about the degree's 57.3 (up to 3, down to 19) stay far apart."""
MAX_TURN_RATE_RPS = 3.0
"""Largest turn rate [rad/s] an AUV sustains over :data:`WINDOW_S` (170 deg/s; a torpedo-shaped
vehicle turns at tens of deg/s at most): beyond it the gyro is not in rad/s."""
GRAVITY_WINDOW_S = 10.0
"""The span [s] from the IMU's first sample over which the mean specific force is compared with
gravity: long enough to average out a swell, short enough that the vehicle's attitude is known."""
MAX_GRAVITY_ANGLE_RAD = 20.0 * units.DEG
"""Largest angle between the mean measured specific force and gravity predicted in the body by
the reference's attitude (and acceleration): an attitude reference is good to a degree, an AHRS
to a few, the accelerations of the first seconds of a mission are a few percent of g. A flipped
or swapped axis turns the vector by about twice the tilt or by 90-180 deg."""
MAX_TILT_RAD = 60.0 * units.DEG
"""Without any attitude, the tilt from level a vehicle may have at the start: the specific force's
down component must then be negative (FRD: -9.8 m/s^2 level at rest) and at least cos(60 deg),
half, of its magnitude."""
MIN_SPECIFIC_FORCE_MPS2 = 0.1
"""RMS specific force on an accelerometer axis [m/s^2] from which its sign and axis are judged over
the log: 20 times a MEMS accelerometer's bias (0.5 mg), a tilt of 0.6 deg under gravity."""
ACCEL_SLOPE_FACTOR = 1.5
"""An accelerometer slope within this factor of +-1 is taken as right or flipped (units are the
reader's gravity band's business; scale errors are below 1 %)."""
MIN_SPEED_MPS = 0.1
"""RMS speed on an axis [m/s] from which a velocity's sign, unit and axis are judged: more than
twice a DVL beam's noise per ping (0.042 m/s, Table 2), a twentieth of an AUV's cruise."""
VELOCITY_SLOPE_FACTOR = 1.2
"""A velocity slope within this factor of 1 (or of a unit factor) is taken as that: the real
scale errors (sound speed, a DVL's 1 %) are far smaller; the knot's 1.944, km/h's 3.6 lie beyond."""
MAX_VELOCITY_RESIDUAL_MPS = 0.2
"""RMS difference [m/s] between a reference's velocity and its position differences beyond which
the two are noted as not belonging together (a navigation solution's agree to centimetres per
second; a water-relative velocity in a current would not)."""
MIN_DEPTH_M = -1.0
"""Shallowest depth [m] a submerged vehicle's depth can be: 1 m above the mean surface, beyond
waves of a working sea state and the 0.5 m of water the air pressure varies by."""
DEPTH_AGREEMENT_M = 3.0
"""Median difference [m] between the depth table and the reference depth beyond which it is noted:
a pressure sensor's offset and the lever arm between it and the reference point are below a metre
or two."""

MAX_LEVER_ARM_M = 10.0
"""Longest lever arm [m] between the DVL's head and the IMU that the DVL check allows for (as the
configuration's ``dvl.lever_arm_m``): an AUV is a few metres long."""
LEVER_RATE_SPAN_S = 0.5
"""Span [s] about each ping the gyro's rate is averaged over for the lever arm's ``omega x l``."""

DEGREES = 1.0 / units.DEG
"""A value in degrees is this many times its value in radians (57.3)."""
KNOTS = 1.0 / units.KNOT
"""A speed in knots is this many times its value in m/s (1.944)."""
KM_PER_H = 3.6
"""A speed in km/h is this many times its value in m/s."""
CM_PER_S = 100.0
"""A speed in cm/s is this many times its value in m/s."""
MM_PER_S = 1000.0
"""A speed in mm/s is this many times its value in m/s (a DVL's native unit)."""
_AXES = "xyz"
_NED = ("north", "east", "down")


# --------------------------------------------------------------------------- the files, for messages
def _header(path: Path) -> tuple[str, ...]:
    """The column names of a table: the first line of a CSV, the schema of a Parquet file."""
    try:
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            return tuple(pq.read_schema(path).names)
        with open(path, encoding="utf-8") as fh:
            return tuple(c.strip().strip('"') for c in fh.readline().rstrip("\r\n").split(","))
    except OSError:
        return ()


def _columns(path: Path, *families: tuple[str, ...]) -> list[str]:
    """For each family of spellings (``("gyro_x_rps", "dtheta_x_rad")``), the one in the file."""
    names = _header(path)
    return [next((n for n in family if n in names), family[0]) for family in families]


def _angle_columns(path: Path, bases: tuple[str, ...]) -> list[str]:
    return _columns(path, *((f"{b}_rad", f"{b}_deg") for b in bases))


def _column_values(path: Path, column: str) -> np.ndarray | None:
    """One column of a table as floats (None if it cannot be read): for the values a message quotes."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    import pyarrow.parquet as pq

    try:
        if path.suffix == ".parquet":
            col = pq.read_table(path, columns=[column]).column(0)
        else:
            col = pcsv.read_csv(path, convert_options=pcsv.ConvertOptions(include_columns=[column])).column(0)
        return col.to_numpy(zero_copy_only=False).astype(float)
    except (OSError, KeyError, ValueError, pa.ArrowException):  # a message's detail only: the finding stands
        return None


def _row_at(path: Path, t: float) -> int:
    """The data row (from 1) of a table whose time is nearest ``t`` [s]."""
    times = _column_values(path, "t_s")
    if times is None or times.size == 0:
        return 1
    return int(np.argmin(np.abs(times - t))) + 1


def _value(path: Path, column: str, row: int) -> str:
    """The value at ``row`` (from 1) of a column as the file has it."""
    values = _column_values(path, column)
    if values is None or not 1 <= row <= values.size:
        return "?"
    return f"{values[row - 1]:.6g}"


# -------------------------------------------------------------------------------- the comparison
@dataclass(frozen=True)
class _Fit:
    """Measured series (windows, m) against predicted ones (windows, n), per pair of axes."""

    slope: np.ndarray  # (n, m) least-squares slope of measured axis j on predicted axis i
    match: np.ndarray  # (n, m) cosine between them (uncentred correlation), 0 where undefined
    unexplained: np.ndarray  # (n, m) energy of measured j left by its slope on i: |m_j|^2 (1 - match^2)
    rms_pred: np.ndarray  # (n,) RMS of each predicted axis
    rms_meas: np.ndarray  # (m,) RMS of each measured axis
    count: int  # windows compared

    @staticmethod
    def of(pred: np.ndarray, meas: np.ndarray) -> _Fit:
        """Over the rows where both are finite, pair by pair (a missing beam drops that beam only)."""
        ok_p, ok_m = np.isfinite(pred), np.isfinite(meas)
        P, M = np.where(ok_p, pred, 0.0), np.where(ok_m, meas, 0.0)
        cross = P.T @ M
        pp = (P * P).T @ ok_m
        mm = ok_p.T.astype(float) @ (M * M)
        pairs = ok_p.T.astype(float) @ ok_m
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = np.where(pp > 0, cross / pp, np.nan)
            match = np.nan_to_num(cross / np.sqrt(pp * mm), nan=0.0)
            unexplained = np.where(pp > 0, mm - cross * np.nan_to_num(slope), mm)
            diag = np.arange(min(pred.shape[1], meas.shape[1]))
            counts = np.maximum(pairs[diag, diag], 1.0)
            rms_pred = np.sqrt(pp[diag, diag] / counts)
            rms_meas = np.sqrt(mm[diag, diag] / counts)
        return _Fit(slope, match, unexplained, rms_pred, rms_meas, int(ok_p.all(axis=1).sum()))


@dataclass(frozen=True)
class _Finding:
    """What a comparison found on one axis."""

    kind: str  # "swap", "factor" (a known factor or sign), "unmatched", "unexplained"
    axis: int  # the predicted axis
    column: int  # the measured axis (column) concerned: another one for a swap
    slope: float
    match: float
    factor: float = 1.0  # the known factor the slope is near ("factor")


def _swapped_columns(fit: _Fit, floor: float) -> list[_Finding]:
    """The columns of a swap, if the measured columns in another order explain the predicted axes
    much better than in their own: each column scaled by its own least-squares slope (so a unit or
    a sign does not count here), the other order must leave at most :data:`SWAP_RATIO` of the
    energy the file's order leaves unexplained, on axes that move (RMS >= ``floor``)."""
    n = fit.rms_pred.size
    if fit.unexplained.shape != (n, n):
        return []
    rows = np.arange(n)
    own = float(fit.unexplained[rows, rows].sum())
    best, best_left = None, own
    for order in itertools.permutations(range(n)):
        left = float(fit.unexplained[rows, list(order)].sum())
        if left < best_left:
            best, best_left = order, left
    if best is None or best_left >= SWAP_RATIO * own:
        return []
    moved = [i for i in range(n) if best[i] != i]
    if all(fit.rms_pred[i] < floor for i in moved):
        return []
    return [
        _Finding("swap", i, best[i], float(fit.slope[i, best[i]]), float(fit.match[i, best[i]]))
        for i in moved
    ]


def _judge(fit: _Fit, floor: float, tolerance: float, factors: tuple[float, ...]) -> list[_Finding]:
    """The findings of a comparison, refusals (a swap, then known factors) before notes.

    First the order of the columns (:func:`_swapped_columns`). Then each axis where either side
    moves (RMS >= ``floor``): the slope of its own column, where it matches at least
    :data:`MIN_MATCH`, is taken as the nearest of 1 and ``factors`` (same sign, within a factor
    ``tolerance``): anything but 1 is refused; near none of them it is "unexplained", and a poor
    match "unmatched" (notes)."""
    swaps = _swapped_columns(fit, floor)
    if swaps:
        return swaps
    factor_findings, notes = [], []
    for i in range(fit.rms_pred.size):
        if max(fit.rms_pred[i], fit.rms_meas[i]) < floor:
            continue
        s, c = float(fit.slope[i, i]), float(fit.match[i, i])
        if abs(c) < MIN_MATCH or not np.isfinite(s):
            notes.append(_Finding("unmatched", i, i, s, c))
            continue
        near = [
            f for f in (1.0, *factors) if np.sign(f) == np.sign(s) and abs(np.log(s / f)) <= np.log(tolerance)
        ]
        if not near:
            notes.append(_Finding("unexplained", i, i, s, c))
            continue
        best = min(near, key=lambda f: abs(np.log(s / f)))
        if best != 1.0:
            factor_findings.append(_Finding("factor", i, i, s, c, best))
    return factor_findings + notes


def _worst(pred: np.ndarray, meas: np.ndarray, finding: _Finding) -> int:
    """The window where the finding's column disagrees most with its own axis (the evidence a
    message quotes)."""
    gap = np.abs(meas[:, finding.column] - pred[:, finding.column])
    return int(np.nanargmax(np.where(np.isfinite(gap), gap, -1.0)))


def _window_rows(t: np.ndarray, t_imu: np.ndarray, window_s: float = WINDOW_S) -> np.ndarray:
    """Rows of a table about ``window_s`` apart (every row if it is sparser) within the IMU's span."""
    idx = np.flatnonzero((t >= t_imu[0]) & (t <= t_imu[-1]))
    if idx.size < 2:
        return idx
    step = max(1, round(window_s / float(np.median(np.diff(t[idx])))))
    return idx[::step]


def _imu_change(log: Log, increments: np.ndarray, t: np.ndarray) -> np.ndarray:
    """What the IMU measured between successive times ``t``: its cumulative increments,
    interpolated in time (the rows are integrals over their intervals), differenced. (W-1, 3)."""
    total = np.cumsum(increments, axis=0)
    at = np.column_stack([np.interp(t, log.imu_t_s, total[:, i]) for i in range(3)])
    return np.diff(at, axis=0)


def _euler_at(t_rows: np.ndarray, euler: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Euler angles at times ``t``, linear between rows (yaw unwrapped first)."""
    e = euler.copy()
    e[:, 2] = np.unwrap(e[:, 2])
    return np.column_stack([np.interp(t, t_rows, e[:, i]) for i in range(3)])


def _name(files: Mapping[str, Path], log: Log, table: str) -> Path:
    return Path(files[table]) if table in files else Path(log.source) / f"{table}.csv"


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
        ("depth", log.depth_t_s),
        ("attitude", log.attitude_t_s),
        ("reference", log.ref_t_s),
    ):
        if t is None or t.size == 0:
            continue
        path = show_path(str(_name(files, log, table)))
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
    also turns faster than :data:`MAX_TURN_RATE_RPS` from one row to the next (a heading in
    degrees: 57 times its rate, and a jump of 360 where it wraps); a smooth one is an unwrapped
    heading in radians, which the format allows (a heading in degrees that turns too slowly to
    tell is left to the gyro's comparison, :func:`_check_gyro`)."""
    sets = []
    for table, t, euler in (
        ("reference", log.ref_t_s, log.ref_euler),
        ("attitude", log.attitude_t_s, log.attitude_euler),
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
        path = _name(files, log, table)
        column = _angle_columns(path, bases)[axis]
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
            path = _name(files, log, "reference")
            column = "depth_m" if log.ref_geodetic else "down_m"
            raise LogError(
                f"{show_path(str(path))}: column {show(column)}, row {row}: {float(ref_depth[row - 1]):.6g} m, above "
                f"the sea surface (a depth is positive down, and above {MIN_DEPTH_M:g} m a vehicle is out of the "
                "water): a height or altitude given as depth? Negate it"
            )
    if log.depth_t_s is None or log.depth_m is None or log.depth_m.size == 0:
        return
    path = _name(files, log, "depth")
    d = log.depth_m
    compare = None
    if ref_t is not None and ref_depth is not None:
        inside = (log.depth_t_s >= ref_t[0]) & (log.depth_t_s <= ref_t[-1])
        if inside.any():
            compare = d[inside] - np.interp(log.depth_t_s[inside], ref_t, ref_depth)
    if float(np.median(d)) < MIN_DEPTH_M:
        row = int(np.argmax(d < MIN_DEPTH_M)) + 1
        against = ""
        if ref_t is not None and ref_depth is not None:
            at = float(np.interp(log.depth_t_s[row - 1], ref_t, ref_depth))
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


# ---------------------------------------------------------------------------------------- velocity
def _check_velocity(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """The reference velocity against its own position differences in NED metres (check 5):
    ``dN = dlat (R_N + h)``, ``dE = dlon (R_E + h) cos(lat)`` on WGS-84 (h = -depth)."""
    if log.ref_t_s is None or log.ref_position is None or log.ref_vel_n is None:
        return
    idx = _window_rows(log.ref_t_s, log.ref_t_s)
    if idx.size < 3:
        return
    t = log.ref_t_s[idx]
    p = log.ref_position[idx]
    dt = np.diff(t)[:, None]
    if log.ref_geodetic:
        lat = 0.5 * (p[1:, 0] + p[:-1, 0])
        h = -0.5 * (p[1:, 2] + p[:-1, 2])
        r_n, r_e = radii_of_curvature_m(lat)
        dlon = np.angle(np.exp(1j * np.diff(p[:, 1])))
        moved = np.column_stack(
            [np.diff(p[:, 0]) * (r_n + h), dlon * (r_e + h) * np.cos(lat), np.diff(p[:, 2])]
        )
    else:
        moved = np.diff(p, axis=0)
    pred = moved / dt
    v = log.ref_vel_n[idx]
    meas = 0.5 * (v[1:] + v[:-1])
    fit = _Fit.of(pred, meas)
    path = _name(files, log, "reference")
    columns = [f"vel_{a}_mps" for a in _NED]
    position = "lat/lon/depth_m" if log.ref_geodetic else "north_m/east_m/down_m"
    for f in _judge(fit, MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, (-1.0, KNOTS, KM_PER_H)):
        w = _worst(pred, meas, f)
        row = int(idx[w + 1]) + 1
        head = (
            f"{show_path(str(path))}: column {show(columns[f.column])}, row {row}: "
            f"{float(log.ref_vel_n[row - 1, f.column]):.6g} m/s, where the position ({position}) moves "
            f"{pred[w, f.column]:+.4g} m/s {_NED[f.column]} over the {dt[w, 0]:.3g} s to it"
        )
        if f.kind == "swap":
            raise LogError(
                f"{head} (and {pred[w, f.axis]:+.4g} {_NED[f.axis]}): it follows the {_NED[f.axis]} motion "
                f"(match {f.match:.2f} over {fit.count} windows): {columns[f.axis]} and {columns[f.column]} "
                "swapped? Give north, east, down"
            )
        if f.kind == "factor":
            raise LogError(
                f"{head}: {f.slope:.4g} times the position's rate over {fit.count} windows: "
                f"{_velocity_units(f.factor)}"
            )
        notes.append(_note(path, columns[f.axis], f, "its position differences"))
    for i in range(3):
        gap = meas[:, i] - pred[:, i]
        residual = float(np.sqrt(np.nanmean(gap**2)))
        if max(fit.rms_pred[i], fit.rms_meas[i]) >= MIN_SPEED_MPS and residual > MAX_VELOCITY_RESIDUAL_MPS:
            notes.append(
                f"{show_path(str(path))}: column {show(columns[i])} differs from the reference's position "
                f"differences by {residual:.3g} m/s RMS (more than {MAX_VELOCITY_RESIDUAL_MPS:g}): not the "
                "velocity over ground of that position?"
            )


def _velocity_units(factor: float) -> str:
    if factor < 0:
        return "the sign is flipped? Negate the column"
    unit = {KNOTS: "knots", KM_PER_H: "km/h", CM_PER_S: "cm/s", MM_PER_S: "mm/s"}[factor]
    return f"in {unit} under _mps? Give m/s (divide by {factor:.4g})"


def _note(path: Path, column: str, f: _Finding, against: str, what: str = "its units and sign") -> str:
    """The note for an axis that could not be judged (``unmatched``) or whose slope no unit explains."""
    if f.kind == "unmatched":
        return (
            f"{show_path(str(path))}: column {show(column)}: does not follow {against} well enough to check "
            f"{what} (match {f.match:.2f}, below {MIN_MATCH:g})"
        )
    return (
        f"{show_path(str(path))}: column {show(column)}: {f.slope:.4g} times {against} (match {f.match:.2f}), "
        "which no unit explains; check its scale"
    )


# -------------------------------------------------------------------------------------------- gyro
def _attitude_source(log: Log) -> tuple[str, np.ndarray, np.ndarray] | None:
    """The attitude the gyro is judged against: the reference's, else the attitude table's."""
    if log.ref_t_s is not None and log.ref_euler is not None:
        return "reference", log.ref_t_s, log.ref_euler
    if log.attitude_t_s is not None and log.attitude_euler is not None:
        return "attitude", log.attitude_t_s, log.attitude_euler
    return None


def _check_gyro(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """The gyro against the attitude (checks 2 and 4): over each window, the body rotation of the
    reference ``log(C_k^T C_k+1)`` against the sum of the angle increments over the same span,
    less the earth's rate ``C_nb^T omega_ie_n`` where the latitude is known. Per axis: a slope
    near 57.3 (gyro in deg/s), 1/57.3 (attitude in degrees), -1 (a flipped axis), or a better
    match with another axis (swapped axes) is refused."""
    source = _attitude_source(log)
    if source is None:
        return
    table, t_rows, euler = source
    idx = _window_rows(t_rows, log.imu_t_s)
    att_path = _name(files, log, table)
    if idx.size < 3:
        notes.append(
            f"{show_path(str(att_path))}: roll/pitch/yaw columns: {idx.size} rows within the IMU's span, too few to "
            "check the gyro against"
        )
        return
    t = t_rows[idx]
    dt = np.diff(t)[:, None]
    C = C_nb_from_euler(euler[idx])
    turned = log_so3(np.swapaxes(C[:-1], -1, -2) @ C[1:])
    measured = _imu_change(log, log.dtheta_b, t)
    if table == "reference" and log.ref_geodetic and log.ref_position is not None:
        lat = log.ref_position[idx[:-1], 0]
        omega_ie_n = OMEGA_IE_RPS * np.column_stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)])
        measured = measured - np.einsum("kji,kj->ki", C[:-1], omega_ie_n) * dt
    pred, meas = turned / dt, measured / dt
    fit = _Fit.of(pred, meas)
    imu_path = _name(files, log, "imu")
    for f in _judge(fit, MIN_TURN_RATE_RPS, GYRO_SLOPE_FACTOR, (-1.0, DEGREES, 1.0 / DEGREES)):
        gyro = _columns(imu_path, *((f"gyro_{a}_rps", f"dtheta_{a}_rad") for a in _AXES))
        w = _worst(pred, meas, f)
        if f.kind == "factor" and f.factor == 1.0 / DEGREES:
            columns = _angle_columns(att_path, ("roll", "pitch", "yaw"))
            row = int(idx[w + 1]) + 1
            values = [
                v / units.DEG if c.endswith("_deg") else v
                for v, c in zip(euler[row - 1], columns, strict=True)
            ]
            raise LogError(
                f"{show_path(str(att_path))}: columns {', '.join(columns)}, row {row}: "
                f"{', '.join(f'{v:.6g}' for v in values)}: over {fit.count} windows the {table} turns "
                f"{1.0 / f.slope:.4g} times as fast as the gyro about {_AXES[f.axis]}: in degrees under _rad? "
                "Name the columns _deg, or give radians"
            )
        row = _row_at(imu_path, float(t[w + 1]))
        column = gyro[f.column]
        head = (
            f"{show_path(str(imu_path))}: column {show(column)}, row {row}: {_value(imu_path, column, row)} "
            f"({meas[w, f.column]:+.4g} rad/s over the {dt[w, 0]:.3g} s to it, where the {table} turns "
            f"{pred[w, f.column]:+.4g} about {_AXES[f.column]}"
        )
        if f.kind == "swap":
            raise LogError(
                f"{head} and {pred[w, f.axis]:+.4g} about {_AXES[f.axis]}): it follows the {_AXES[f.axis]} "
                f"rotation (match {f.match:.2f} over {fit.count} windows): {gyro[f.axis]} and {column} "
                "swapped? Give the axes forward-right-down"
            )
        if f.kind == "factor" and f.factor < 0:
            raise LogError(
                f"{head}): {f.slope:.3g} times the {table} over {fit.count} windows: its sign is flipped? "
                "Negate the column (and check the accelerometer's)"
            )
        if f.kind == "factor":
            raise LogError(
                f"{head}): {f.slope:.4g} times the {table} over {fit.count} windows: in deg/s (or "
                "degrees) under a radian name? Give radians (multiply by pi/180)"
            )
        what = (
            f"the {table}'s rotation"
            if fit.rms_pred[f.axis] >= MIN_TURN_RATE_RPS
            else f"the {table}, which turns too little about {_AXES[f.axis]} to check it "
            f"({fit.rms_pred[f.axis] / units.DEG:.2g} deg/s RMS)"
        )
        notes.append(
            _note(
                imu_path,
                column,
                f,
                what,
                "its scale and sign (a gyro bias, a noisy attitude, too little turning?)",
            )
        )


def _check_gyro_bound(log: Log, files: Mapping[str, Path]) -> None:
    """No turn faster than :data:`MAX_TURN_RATE_RPS` sustained over :data:`WINDOW_S` (check 2,
    without any attitude to compare with): a gyro in deg/s reads an ordinary 5 deg/s turn as 5."""
    n = max(1, round(WINDOW_S / log.dt_s))
    if log.imu_t_s.size <= n:
        return
    total = np.cumsum(log.dtheta_b, axis=0)
    turned = np.abs(total[n:] - total[:-n]) / (log.imu_t_s[n:] - log.imu_t_s[:-n])[:, None]
    k, axis = np.unravel_index(int(np.argmax(turned)), turned.shape)
    rate = float(turned[k, axis])
    if rate <= MAX_TURN_RATE_RPS:
        return
    path = _name(files, log, "imu")
    column = _columns(path, (f"gyro_{_AXES[axis]}_rps", f"dtheta_{_AXES[axis]}_rad"))[0]
    row = _row_at(path, float(log.imu_t_s[k + n]))
    raise LogError(
        f"{show_path(str(path))}: column {show(column)}, row {row}: {_value(path, column, row)}; the gyro turns "
        f"{rate:.4g} rad/s about {_AXES[axis]} over the {WINDOW_S:g} s to it, beyond the {MAX_TURN_RATE_RPS:g} rad/s an AUV "
        "turns: in deg/s (or degrees) under a radian name? Give radians (multiply by pi/180)"
    )


# ----------------------------------------------------------------------------------- accelerometer
def _check_accel(log: Log, files: Mapping[str, Path]) -> None:
    """The accelerometer against ``f_b = C_nb^T (a_n - g_n)`` (check 3), ``g_n = (0, 0, g)``:
    the mean over the first :data:`GRAVITY_WINDOW_S` within :data:`MAX_GRAVITY_ANGLE_RAD` of the
    prediction (without attitude: down and within :data:`MAX_TILT_RAD` of level); then, with a
    reference, per axis over the log (a flipped or swapped horizontal axis, which gravity alone
    cannot show on a level vehicle)."""
    g_n = np.array([0.0, 0.0, units.G0])
    path = _name(files, log, "imu")
    t0 = float(log.imu_t_s[0])
    t1 = min(t0 + GRAVITY_WINDOW_S, float(log.imu_t_s[-1]))
    source = _attitude_source(log)
    predicted, what = None, ""
    if source is not None:
        table, t_rows, euler = source
        rows = np.flatnonzero((t_rows >= t0) & (t_rows <= t1))
        if table == "reference" and rows.size >= 2 and log.ref_vel_n is not None:
            t = t_rows[rows]
            C = C_nb_from_euler(euler[rows])
            C_mid = 0.5 * (C[1:] + C[:-1])
            dv_n = np.diff(log.ref_vel_n[rows], axis=0)
            f = np.einsum("kji,kj->ki", C_mid, dv_n - g_n * np.diff(t)[:, None])
            predicted, t0, t1 = f.sum(axis=0) / (t[-1] - t[0]), float(t[0]), float(t[-1])
            what = "gravity and the reference's acceleration"
        elif rows.size:
            C = C_nb_from_euler(euler[rows])
            predicted = np.einsum("kji,j->ki", C, -g_n).mean(axis=0)
            what = f"gravity with the {table}'s attitude"
    if t1 <= t0:
        return
    measured = _imu_change(log, log.dv_b, np.array([t0, t1]))[0] / (t1 - t0)
    shown = f"({', '.join(f'{v:+.3g}' for v in measured)}) m/s^2"
    if predicted is None:
        if measured[2] < 0 and -measured[2] >= np.cos(MAX_TILT_RAD) * np.linalg.norm(measured):
            return
        accel = _accel_columns(path)
        first, last = _row_at(path, t0), _row_at(path, t1)
        raise LogError(
            f"{show_path(str(path))}: column {show(accel[2])}, rows {first}-{last}: the specific force averages "
            f"{shown} over the first {t1 - t0:.3g} s; a vehicle within {MAX_TILT_RAD / units.DEG:g} deg of level reads "
            "mostly down-negative (FRD: -9.8 m/s^2 at rest): its sign flipped or axes in another order? Give x "
            "forward, y right, z down"
        )
    angle = _angle(measured, predicted)
    if angle > MAX_GRAVITY_ANGLE_RAD:
        accel = _accel_columns(path)
        first, last = _row_at(path, t0), _row_at(path, t1)
        # which one flipped or swapped column would bring the mean onto the prediction
        fixes = [
            (f"{accel[i]} has its sign flipped? Negate it", np.where(np.arange(3) == i, -1.0, 1.0), [0, 1, 2])
            for i in range(3)
        ]
        fixes += [
            (
                f"{accel[i]} and {accel[j]} swapped? Give the axes forward-right-down",
                np.ones(3),
                _swapped((i, j)),
            )
            for i, j in ((0, 1), (0, 2), (1, 2))
        ]
        best, best_angle = None, angle
        for text, sign, order in fixes:
            a = _angle(measured[order] * sign, predicted)
            if a < best_angle:
                best, best_angle = text, a
        worst = int(np.argmax(np.abs(measured - predicted)))
        looks = (
            best
            if best is not None and best_angle <= MAX_GRAVITY_ANGLE_RAD
            else ("sign flipped or axes swapped? Give x forward, y right, z down")
        )
        raise LogError(
            f"{show_path(str(path))}: column {show(accel[worst])}, rows {first}-{last}: the specific force averages "
            f"{shown} over the first {t1 - t0:.3g} s, {angle / units.DEG:.0f} deg from the "
            f"({', '.join(f'{v:+.3g}' for v in predicted)}) of {what}: {looks}"
        )
    if source is None or source[0] != "reference" or log.ref_vel_n is None:
        return
    _check_accel_axes(log, path, g_n, source[1], source[2], log.ref_vel_n)


def _accel_columns(path: Path) -> list[str]:
    return _columns(path, *((f"accel_{a}_mps2", f"dv_{a}_mps") for a in _AXES))


def _check_accel_axes(
    log: Log, path: Path, g_n: np.ndarray, ref_t: np.ndarray, ref_euler: np.ndarray, ref_vel_n: np.ndarray
) -> None:
    """Per accelerometer axis over the whole log, windows of :data:`WINDOW_S`: the measured
    velocity change against ``C_nb^T (dv_n - g_n dt)`` from the reference (the mean of the two
    ends' attitudes)."""
    idx = _window_rows(ref_t, log.imu_t_s)
    if idx.size < 3:
        return
    t = ref_t[idx]
    dt = np.diff(t)[:, None]
    C = C_nb_from_euler(ref_euler[idx])
    C_mid = 0.5 * (C[1:] + C[:-1])
    pred = np.einsum("kji,kj->ki", C_mid, np.diff(ref_vel_n[idx], axis=0) - g_n * dt) / dt
    meas = _imu_change(log, log.dv_b, t) / dt
    fit = _Fit.of(pred, meas)
    for f in _judge(fit, MIN_SPECIFIC_FORCE_MPS2, ACCEL_SLOPE_FACTOR, (-1.0,)):
        if f.kind not in ("swap", "factor"):
            continue  # an axis that barely feels a force cannot be misread in a way that matters
        w = _worst(pred, meas, f)
        row = _row_at(path, float(t[w + 1]))
        accel = _accel_columns(path)
        column = accel[f.column]
        head = (
            f"{show_path(str(path))}: column {show(column)}, row {row}: {_value(path, column, row)} "
            f"({meas[w, f.column]:+.4g} m/s^2 over the {dt[w, 0]:.3g} s to it, where the reference's attitude and "
            f"acceleration give {pred[w, f.column]:+.4g} on {_AXES[f.column]}"
        )
        if f.kind == "swap":
            raise LogError(
                f"{head} and {pred[w, f.axis]:+.4g} on {_AXES[f.axis]}): it follows the {_AXES[f.axis]} axis "
                f"(match {f.match:.2f} over {fit.count} windows): {accel[f.axis]} and {column} swapped? "
                "Give the axes forward-right-down"
            )
        raise LogError(
            f"{head}): {f.slope:.3g} times the prediction over {fit.count} windows: its sign is flipped? "
            "Negate the column"
        )


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.arccos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b) + 1e-300), -1.0, 1.0)))


def _swapped(pair: tuple[int, int]) -> list[int]:
    """The axis order with the pair exchanged."""
    order = [0, 1, 2]
    order[pair[0]], order[pair[1]] = pair[1], pair[0]
    return order


# --------------------------------------------------------------------------------------------- DVL
def _check_dvl(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """The DVL against the reference velocity resolved in the body, ``v_b = C_nb^T v_n`` at each
    ping, projected on the Janus beams of :class:`~tauvcore.sensors.dvl.DvlConfig` for beam
    velocities (check 7): a slope near 1.944 (knots), 3.6 (km/h), 100 (cm/s), 1000 (mm/s) or -1
    (a sign), or columns in another order, is refused. The DVL head's own motion ``omega x l``
    (0.16 m/s on a 1.9 m lever arm turning at 5 deg/s) can put a slow axis's slope off 1: a lever
    arm fitted to the pings (:func:`_with_lever_arm`) is allowed for before such an axis is
    noted, never before one is refused."""
    if log.dvl_t_s is None or log.ref_t_s is None or log.ref_vel_n is None or log.ref_euler is None:
        return
    inside = (log.dvl_t_s >= log.ref_t_s[0]) & (log.dvl_t_s <= log.ref_t_s[-1])
    rows = np.flatnonzero(inside)
    if rows.size < 3:
        return
    t = log.dvl_t_s[rows]
    vel_n = np.column_stack([np.interp(t, log.ref_t_s, log.ref_vel_n[:, i]) for i in range(3)])
    C = C_nb_from_euler(_euler_at(log.ref_t_s, log.ref_euler, t))
    vel_b = np.einsum("kji,kj->ki", C, vel_n)
    path = _name(files, log, "dvl")
    if log.dvl_beams_mps is not None:
        pred, meas = vel_b @ DvlConfig().A_b.T, log.dvl_beams_mps[rows]
        columns, axes = [f"beam{k + 1}_mps" for k in range(4)], [f"beam {k + 1}" for k in range(4)]
    elif log.dvl_body_mps is not None:
        pred, meas = vel_b, log.dvl_body_mps[rows]
        columns, axes = [f"vel_{a}_mps" for a in _AXES], list(_AXES)
    else:
        return
    fit = _Fit.of(pred, meas)
    factors = (-1.0, KNOTS, KM_PER_H, CM_PER_S, MM_PER_S)
    findings = _judge(fit, MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, factors)
    if any(f.kind in ("unmatched", "unexplained") for f in findings):
        # what the lever arm explains is no doubt about the units: judged again with the best
        # lever arm, for the notes only (a lever arm must not talk a refusal away)
        lever = _with_lever_arm(
            log, t, pred, meas, DvlConfig().A_b if log.dvl_beams_mps is not None else None
        )
        if lever is not None:
            still = {
                f.axis for f in _judge(_Fit.of(lever, meas), MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, factors)
            }
            findings = [f for f in findings if f.kind in ("swap", "factor") or f.axis in still]
    for f in findings:
        w = _worst(pred, meas, f)
        row = int(rows[w]) + 1
        head = (
            f"{show_path(str(path))}: column {show(columns[f.column])}, row {row}: {float(meas[w, f.column]):.6g} "
            f"m/s, where the reference's velocity gives {pred[w, f.column]:+.4g} along {axes[f.column]}"
        )
        if f.kind == "swap":
            raise LogError(
                f"{head} (and {pred[w, f.axis]:+.4g} along {axes[f.axis]}): it follows {axes[f.axis]} "
                f"(match {f.match:.2f} over {fit.count} pings): {columns[f.axis]} and {columns[f.column]} "
                "swapped? Give the columns in the format's order"
            )
        if f.kind == "factor":
            order = (
                " (or the beams numbered otherwise?)"
                if f.factor < 0 and log.dvl_beams_mps is not None
                else ""
            )
            raise LogError(
                f"{head}: {f.slope:.4g} times the reference over {fit.count} pings: "
                f"{_velocity_units(f.factor)}{order}"
            )
        notes.append(_note(path, columns[f.axis], f, "the reference's velocity in the body"))


def _with_lever_arm(
    log: Log, t: np.ndarray, pred: np.ndarray, meas: np.ndarray, A_b: np.ndarray | None
) -> np.ndarray | None:
    """The prediction with the DVL head's own motion ``omega_nb_b x l`` added, ``l`` the lever arm
    that fits the pings best (least squares; the gyro's rate over :data:`LEVER_RATE_SPAN_S` about
    each ping), or None if that lever arm is longer than :data:`MAX_LEVER_ARM_M`."""
    half = 0.5 * LEVER_RATE_SPAN_S
    omega = _imu_change(log, log.dtheta_b, np.concatenate([t - half, t + half]).reshape(2, -1).T.ravel())[::2]
    omega = omega / LEVER_RATE_SPAN_S
    # omega x l = -[l x] omega = [omega x] l: linear in l
    J = np.zeros(omega.shape[:1] + (3, 3))
    J[:, 0, 1], J[:, 0, 2] = -omega[:, 2], omega[:, 1]
    J[:, 1, 0], J[:, 1, 2] = omega[:, 2], -omega[:, 0]
    J[:, 2, 0], J[:, 2, 1] = -omega[:, 1], omega[:, 0]
    if A_b is not None:
        J = A_b @ J
    gap = meas - pred
    ok = np.isfinite(gap)
    if ok.sum() < 6:
        return None
    lever = np.linalg.lstsq(J[ok], gap[ok], rcond=None)[0]
    if np.linalg.norm(lever) > MAX_LEVER_ARM_M:
        return None
    return pred + J @ lever


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
    check_imu_clock(log.imu_t_s, _name(files, log, "imu"))
    _check_clocks(log, files, notes)
    _check_ranges(log, files)
    _check_depth(log, files, notes)
    _check_velocity(log, files, notes)
    _check_gyro(log, files, notes)
    _check_gyro_bound(log, files)
    _check_accel(log, files)
    _check_dvl(log, files, notes)
    return notes


__all__ = ["check_imu_clock", "check_plausible"]
