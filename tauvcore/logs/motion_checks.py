"""The physical checks of a log that compare a sensor with the vehicle's motion (checks 2, 3, 5 and 7
of tauvcore.logs.checks): the gyro against the rotation between successive attitudes and no turn
faster than an AUV turns; the accelerometer against gravity and the reference's acceleration in the
body; the reference velocity against its own position differences; the DVL against the reference
velocity resolved in the body. Each is a comparison of tauvcore.logs.evidence, refusing swapped axes
and a known unit factor or sign with one :class:`~tauvcore.validation.LogError`, and noting what it
cannot be sure of.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.aiding.attitude_mag import EULER
from tauvcore.aiding.sources import SOURCES
from tauvcore.geo.earth import OMEGA_IE_RPS, radii_of_curvature_m
from tauvcore.geo.rotations import C_nb_from_euler, log_so3
from tauvcore.logs.evidence import (
    MIN_MATCH,
    WINDOW_S,
    Finding,
    Fit,
    euler_at,
    file_angle_columns,
    file_columns,
    imu_change,
    judge,
    row_at,
    table_file,
    value_at,
    window_rows,
    worst_window,
)
from tauvcore.logs.log_record import Log
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.validation import LogError, show, show_path

MIN_TURN_RATE_RPS = 0.2 * units.DEG
"""RMS turn rate about an axis [rad/s] from which the gyro's scale on it is judged: well above a
navigation-grade reference's noise and a MEMS gyro's bias (3 deg/h = 0.0008 deg/s) and earth rate
(0.004 deg/s), yet below what any manoeuvre or a hull's roll in a swell shows."""
GYRO_SLOPE_FACTOR = 3.0
"""A gyro slope within this factor of 1 (or of a unit factor) is taken as that: wide enough for
the attenuation an AHRS's noise brings to a fitted slope (to half), and the bands about 1 and
about the degree's 57.3 (up to 3, down to 19) stay far apart."""
MIN_TILT_RAD = 1.0 * units.DEG
"""RMS roll or pitch [rad] from which an attitude's tilt is judged against the accelerometer's
(:func:`check_attitude_units`): five times the tilt an AUV's own accelerations (0.1 m/s^2 in a
turn) lend gravity over a window, so a slope of 1/57.3 (radians under _deg) stands far out."""
MAX_TILT_RAD = 60.0 * units.DEG
"""Median roll or pitch [rad] of the accelerometer's gravity beyond which
:func:`check_attitude_units` does not judge the attitude: no AUV cruises so tilted, so the
accelerometer's axes are at fault (swapped or of the wrong sign, which the IMU's checks name), not
the attitude's unit."""
TILT_SLOPE_FACTOR = 3.0
"""An attitude's tilt slope against the accelerometer's within this factor of 1 (or of 1/57.3) is
taken as that: the vehicle's accelerations and an AHRS's noise move it by tens of percent."""
EARTH_RATE_MATCH = 0.7
"""Smallest match (the cosine between the means over the log) of what the gyro measures and the
earth's rate plus the reference's turn for a gyro that reads 57.3 times that (within
:data:`GYRO_SLOPE_FACTOR`) to be refused as in deg/s on a log that turns too little to judge its
axes (:func:`check_gyro_earth_rate`). A Table 2 gyro in deg/s on a straight run matches to 0.84
(its bias turns the mean by some 30 deg); a gyro in rad/s would need a bias of 300 to 3500 deg/h
lined up within 45 deg of the earth's axis to fake it (an uncalibrated MEMS gyro's 1 deg/s reads
hundreds of times the earth's rate, beyond the band)."""
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


# ---------------------------------------------------------------------------------------- velocity
def check_velocity(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """The reference velocity against its own position differences in NED metres (check 5):
    ``dN = dlat (R_N + h)``, ``dE = dlon (R_E + h) cos(lat)`` on WGS-84 (h = -depth)."""
    if log.ref_t_s is None or log.ref_position is None or log.ref_vel_n is None:
        return
    idx = window_rows(log.ref_t_s, log.ref_t_s)
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
    fit = Fit.of(pred, meas)
    path = table_file(files, log, "reference")
    columns = [f"vel_{a}_mps" for a in _NED]
    position = "lat/lon/depth_m" if log.ref_geodetic else "north_m/east_m/down_m"
    for f in judge(fit, MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, (-1.0, KNOTS, KM_PER_H)):
        w = worst_window(pred, meas, f)
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


def _note(path: Path, column: str, f: Finding, against: str, what: str = "its units and sign") -> str:
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
    attitude = log.table("mag", EULER)
    if attitude is not None:
        return SOURCES["mag"].table, *attitude
    return None


def check_gyro(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
    """The gyro against the attitude (checks 2 and 4): over each window, the body rotation of the
    reference ``log(C_k^T C_k+1)`` against the sum of the angle increments over the same span,
    less the earth's rate ``C_nb^T omega_ie_n`` where the latitude is known. Per axis: a slope
    near 57.3 (gyro in deg/s), 1/57.3 (attitude in degrees), -1 (a flipped axis), or a better
    match with another axis (swapped axes) is refused."""
    source = _attitude_source(log)
    if source is None:
        return
    table, t_rows, euler = source
    idx = window_rows(t_rows, log.imu_t_s)
    att_path = table_file(files, log, table)
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
    measured = imu_change(log, log.dtheta_b, t)
    if table == "reference" and log.ref_geodetic and log.ref_position is not None:
        lat = log.ref_position[idx[:-1], 0]
        omega_ie_n = OMEGA_IE_RPS * np.column_stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)])
        measured = measured - np.einsum("kji,kj->ki", C[:-1], omega_ie_n) * dt
    pred, meas = turned / dt, measured / dt
    fit = Fit.of(pred, meas)
    imu_path = table_file(files, log, "imu")
    for f in judge(fit, MIN_TURN_RATE_RPS, GYRO_SLOPE_FACTOR, (-1.0, DEGREES, 1.0 / DEGREES)):
        gyro = file_columns(imu_path, *((f"gyro_{a}_rps", f"dtheta_{a}_rad") for a in _AXES))
        w = worst_window(pred, meas, f)
        if f.kind == "factor" and f.factor == 1.0 / DEGREES:
            columns = file_angle_columns(att_path, ("roll", "pitch", "yaw"))
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
        row = row_at(imu_path, float(t[w + 1]))
        column = gyro[f.column]
        head = (
            f"{show_path(str(imu_path))}: column {show(column)}, row {row}: {value_at(imu_path, column, row)} "
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


def check_attitude_units(log: Log, files: Mapping[str, Path]) -> None:
    """An attitude given in degrees (``roll_deg``, ``pitch_deg``) against the tilt the accelerometer
    shows under gravity, ``roll = atan2(-f_y, -f_z)``, ``pitch = atan2(f_x, hypot(f_y, f_z))`` of
    the mean specific force over each window: a slope near 1/57.3 is radians under a _deg name,
    refused. It runs before the gyro's comparison (check 2), which sees such an attitude turn 57.3
    times too slowly and would blame the gyro. Judged on an axis whose tilt RMS reaches
    :data:`MIN_TILT_RAD`, within :data:`TILT_SLOPE_FACTOR`; not where the accelerometer's tilt is beyond
    :data:`MAX_TILT_RAD`."""
    attitude = log.table("mag", EULER)
    for table, t_rows, euler in (
        ("reference", log.ref_t_s, log.ref_euler),
        (SOURCES["mag"].table, *(attitude or (None, None))),
    ):
        if t_rows is None or euler is None:
            continue
        path = table_file(files, log, table)
        columns = file_angle_columns(path, ("roll", "pitch"))
        if not all(c.endswith("_deg") for c in columns):
            continue
        idx = window_rows(log.imu_t_s, log.imu_t_s)
        if idx.size < 3:
            continue
        t = log.imu_t_s[idx]
        f = imu_change(log, log.dv_b, t) / np.diff(t)[:, None]
        measured = np.column_stack(
            [np.arctan2(-f[:, 1], -f[:, 2]), np.arctan2(f[:, 0], np.hypot(f[:, 1], f[:, 2]))]
        )
        mid = 0.5 * (t[1:] + t[:-1])
        inside = (mid >= t_rows[0]) & (mid <= t_rows[-1])
        if inside.sum() < 3:
            continue
        if float(np.max(np.median(np.abs(measured[inside]), axis=0))) > MAX_TILT_RAD:
            continue
        given = euler_at(t_rows, euler, mid[inside])[:, :2]
        fit = Fit.of(measured[inside], given)
        for finding in judge(fit, MIN_TILT_RAD, TILT_SLOPE_FACTOR, (1.0 / DEGREES,)):
            if finding.kind != "factor":
                continue
            w = worst_window(measured[inside], given, finding)
            row = row_at(path, float(mid[inside][w]))
            column = columns[finding.column]
            raise LogError(
                f"{show_path(str(path))}: column {show(column)}, row {row}: {value_at(path, column, row)}: over "
                f"{fit.count} windows the accelerometer's gravity tilts the vehicle {1.0 / finding.slope:.4g} times "
                f"as far ({measured[inside][w, finding.column] / units.DEG:+.3g} deg there): radians under _deg? "
                "Name the columns _rad, or give degrees"
            )


def check_gyro_earth_rate(log: Log, files: Mapping[str, Path]) -> None:
    """A gyro in deg/s on a log that turns too little to judge its axes (check 2): what it measures
    over each window against what it should, the earth's rate in the body ``C_nb^T omega_ie_n``
    (the reference's latitude) plus the reference's turn, their means over the log's windows
    compared as vectors: a slope (the measured mean's projection on the predicted, over its length)
    and a match (the cosine of the angle between them).
    A gyro at rest or going straight still measures the earth's rate (15 deg/h); in deg/s it reads
    57.3 times that. Refused where the slope is within :data:`GYRO_SLOPE_FACTOR` of 57.3 and the two
    match to :data:`EARTH_RATE_MATCH`."""
    if log.ref_t_s is None or log.ref_euler is None or not log.ref_geodetic or log.ref_position is None:
        return
    idx = window_rows(log.ref_t_s, log.imu_t_s)
    if idx.size < 3:
        return
    t = log.ref_t_s[idx]
    dt = np.diff(t)[:, None]
    C = C_nb_from_euler(log.ref_euler[idx])
    lat = log.ref_position[idx[:-1], 0]
    omega_ie_n = OMEGA_IE_RPS * np.column_stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)])
    pred = log_so3(np.swapaxes(C[:-1], -1, -2) @ C[1:]) / dt + np.einsum("kji,kj->ki", C[:-1], omega_ie_n)
    meas = imu_change(log, log.dtheta_b, t) / dt
    # the means over the log: the gyro's noise (a MEMS gyro's is many times the earth's rate over
    # a window) averages out; what the vehicle barely turns, the earth's rate in the body hardly moves
    p, m = pred.mean(axis=0), meas.mean(axis=0)
    pp, mm = float(p @ p), float(m @ m)
    if pp <= 0.0 or mm <= 0.0:
        return
    slope, match = float(p @ m) / pp, float(p @ m) / np.sqrt(pp * mm)
    if match < EARTH_RATE_MATCH or abs(np.log(slope / DEGREES)) > np.log(GYRO_SLOPE_FACTOR):
        return
    path = table_file(files, log, "imu")
    gyro = file_columns(path, *((f"gyro_{a}_rps", f"dtheta_{a}_rad") for a in _AXES))
    axis = int(np.argmax(np.abs(meas).mean(axis=0)))
    row = row_at(path, float(t[-1]))
    raise LogError(
        f"{show_path(str(path))}: column {show(gyro[axis])}, row {row}: {value_at(path, gyro[axis], row)}: over "
        f"{meas.shape[0]} windows the gyro reads {slope:.4g} times the earth's rate and the reference's turn "
        f"(match {match:.3f}; {np.linalg.norm(meas.mean(axis=0)) / units.DEG * 3600:.4g} deg/h where the earth "
        f"turns {OMEGA_IE_RPS / units.DEG * 3600:.3g}): in deg/s (or degrees) under a radian name? Give radians "
        "(multiply by pi/180)"
    )


def check_gyro_bound(log: Log, files: Mapping[str, Path]) -> None:
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
    path = table_file(files, log, "imu")
    column = file_columns(path, (f"gyro_{_AXES[axis]}_rps", f"dtheta_{_AXES[axis]}_rad"))[0]
    row = row_at(path, float(log.imu_t_s[k + n]))
    raise LogError(
        f"{show_path(str(path))}: column {show(column)}, row {row}: {value_at(path, column, row)}; the gyro turns "
        f"{rate:.4g} rad/s about {_AXES[axis]} over the {WINDOW_S:g} s to it, beyond the {MAX_TURN_RATE_RPS:g} rad/s an AUV "
        "turns: in deg/s (or degrees) under a radian name? Give radians (multiply by pi/180)"
    )


# ----------------------------------------------------------------------------------- accelerometer
def check_accel(log: Log, files: Mapping[str, Path]) -> None:
    """The accelerometer against ``f_b = C_nb^T (a_n - g_n)`` (check 3), ``g_n = (0, 0, g)``:
    the mean over the first :data:`GRAVITY_WINDOW_S` within :data:`MAX_GRAVITY_ANGLE_RAD` of the
    prediction (without attitude: down and within :data:`MAX_TILT_RAD` of level); then, with a
    reference, per axis over the log (a flipped or swapped horizontal axis, which gravity alone
    cannot show on a level vehicle)."""
    g_n = np.array([0.0, 0.0, units.G0])
    path = table_file(files, log, "imu")
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
    measured = imu_change(log, log.dv_b, np.array([t0, t1]))[0] / (t1 - t0)
    shown = f"({', '.join(f'{v:+.3g}' for v in measured)}) m/s^2"
    if predicted is None:
        if measured[2] < 0 and -measured[2] >= np.cos(MAX_TILT_RAD) * np.linalg.norm(measured):
            return
        accel = _accel_columns(path)
        first, last = row_at(path, t0), row_at(path, t1)
        raise LogError(
            f"{show_path(str(path))}: column {show(accel[2])}, rows {first}-{last}: the specific force averages "
            f"{shown} over the first {t1 - t0:.3g} s; a vehicle within {MAX_TILT_RAD / units.DEG:g} deg of level reads "
            "mostly down-negative (FRD: -9.8 m/s^2 at rest): its sign flipped or axes in another order? Give x "
            "forward, y right, z down"
        )
    angle = _angle(measured, predicted)
    if angle > MAX_GRAVITY_ANGLE_RAD:
        accel = _accel_columns(path)
        first, last = row_at(path, t0), row_at(path, t1)
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
    return file_columns(path, *((f"accel_{a}_mps2", f"dv_{a}_mps") for a in _AXES))


def _check_accel_axes(
    log: Log, path: Path, g_n: np.ndarray, ref_t: np.ndarray, ref_euler: np.ndarray, ref_vel_n: np.ndarray
) -> None:
    """Per accelerometer axis over the whole log, windows of :data:`WINDOW_S`: the measured
    velocity change against ``C_nb^T (dv_n - g_n dt)`` from the reference (the mean of the two
    ends' attitudes)."""
    idx = window_rows(ref_t, log.imu_t_s)
    if idx.size < 3:
        return
    t = ref_t[idx]
    dt = np.diff(t)[:, None]
    C = C_nb_from_euler(ref_euler[idx])
    C_mid = 0.5 * (C[1:] + C[:-1])
    pred = np.einsum("kji,kj->ki", C_mid, np.diff(ref_vel_n[idx], axis=0) - g_n * dt) / dt
    meas = imu_change(log, log.dv_b, t) / dt
    fit = Fit.of(pred, meas)
    for f in judge(fit, MIN_SPECIFIC_FORCE_MPS2, ACCEL_SLOPE_FACTOR, (-1.0,)):
        if f.kind not in ("swap", "factor"):
            continue  # an axis that barely feels a force cannot be misread in a way that matters
        w = worst_window(pred, meas, f)
        row = row_at(path, float(t[w + 1]))
        accel = _accel_columns(path)
        column = accel[f.column]
        head = (
            f"{show_path(str(path))}: column {show(column)}, row {row}: {value_at(path, column, row)} "
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
def check_dvl(log: Log, files: Mapping[str, Path], notes: list[str]) -> None:
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
    C = C_nb_from_euler(euler_at(log.ref_t_s, log.ref_euler, t))
    vel_b = np.einsum("kji,kj->ki", C, vel_n)
    path = table_file(files, log, "dvl")
    if log.dvl_beams_mps is not None:
        pred, meas = vel_b @ DvlConfig().A_b.T, log.dvl_beams_mps[rows]
        columns, axes = [f"beam{k + 1}_mps" for k in range(4)], [f"beam {k + 1}" for k in range(4)]
    elif log.dvl_body_mps is not None:
        pred, meas = vel_b, log.dvl_body_mps[rows]
        columns, axes = [f"vel_{a}_mps" for a in _AXES], list(_AXES)
    else:
        return
    if log.dvl_water_track is not None:
        # a water-track velocity differs from the reference's over ground by the current: left out
        water = log.dvl_water_track[rows]
        meas = np.where(water if log.dvl_beams_mps is not None else water[:, :1], np.nan, meas)
    fit = Fit.of(pred, meas)
    factors = (-1.0, KNOTS, KM_PER_H, CM_PER_S, MM_PER_S)
    findings = judge(fit, MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, factors)
    if any(f.kind in ("unmatched", "unexplained") for f in findings):
        # what the lever arm explains is no doubt about the units: judged again with the best
        # lever arm, for the notes only (a lever arm must not talk a refusal away)
        lever = _with_lever_arm(
            log, t, pred, meas, DvlConfig().A_b if log.dvl_beams_mps is not None else None
        )
        if lever is not None:
            still = {
                f.axis for f in judge(Fit.of(lever, meas), MIN_SPEED_MPS, VELOCITY_SLOPE_FACTOR, factors)
            }
            findings = [f for f in findings if f.kind in ("swap", "factor") or f.axis in still]
    for f in findings:
        w = worst_window(pred, meas, f)
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
    omega = imu_change(log, log.dtheta_b, np.concatenate([t - half, t + half]).reshape(2, -1).T.ravel())[::2]
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
