"""Recorded sensor logs: the format and its validating reader (tauvcore.logs.writer writes it).

A log is a directory with one table per sensor, each a CSV file (a header line, then one row
per sample) or a Parquet file, ``<table>.csv`` or ``<table>.parquet``. Every table has a time
column ``t_s`` [s] (one clock for all tables, strictly increasing). Units and frames are in the
column names, as everywhere in tauvcore (b: body forward-right-down; NED: north-east-down).

``imu`` (required), at a nominal constant rate (an irregular clock or holes of up to
:data:`MAX_GAP_STEPS` intervals are resampled onto a constant rate and noted), either

- increments over the interval ending at the row, ``dtheta_x_rad``, ``dtheta_y_rad``,
  ``dtheta_z_rad``, ``dv_x_mps``, ``dv_y_mps``, ``dv_z_mps`` (the first row's are not used), or
- rates at the row's time, ``gyro_x_rps``, ``gyro_y_rps``, ``gyro_z_rps``, ``accel_x_mps2``,
  ``accel_y_mps2``, ``accel_z_mps2`` (integrated over each interval by the trapezoid rule).

``dvl`` (optional), either the beam velocities ``beam1_mps`` .. ``beam4_mps`` along the
configured Janus beams (empty or NaN: the beam did not return), or a body-frame velocity
``vel_x_mps``, ``vel_y_mps``, ``vel_z_mps`` with an optional ``valid`` (1/0, or true/false),
which is projected onto the configured beams (``[dvl]`` of the configuration), so beams can be
dropped synthetically (``--beams``, ``--outage``) as on simulated data. Each velocity is
bottom-track (over ground) unless the table says it is water-track (relative to a layer of water
below the DVL): beams by ``beam1_water_track`` .. ``beam4_water_track`` (all four, each 1 or 0,
empty: 0), a body velocity by ``water_track`` (1 or 0). A DVL that outputs both from one ping
gives instead ``beam1_water_mps`` .. ``beam4_water_mps`` (all four; empty: no water-track),
each beam's water-track velocity beside the bottom-track one, and no mode column. The filters
fuse water-track only against the current states (tauvcore.aiding.dvl_water).

``depth`` (optional): ``depth_m``. ``attitude`` (optional, a magnetometer/AHRS attitude):
``roll``, ``pitch``, ``yaw`` each as ``_deg`` or ``_rad``.

``reference`` (optional: its first row is the filters' starting point, and errors are computed
against it; without it the filters start from the log's own sensors, see
tauvcore.eval.replay, and no error can be computed): position as ``lat`` and ``lon`` (``_deg``
or ``_rad``) with ``depth_m``, or as ``north_m``, ``east_m``, ``down_m`` from the sea-surface
point above the mission origin (``[earth] latitude_deg, longitude_deg``); attitude ``roll``,
``pitch``, ``yaw`` (``_deg`` or ``_rad``); NED velocity ``vel_north_mps``, ``vel_east_mps``,
``vel_down_mps``. It may be sampled at any rate: it is interpolated to the IMU's times
(linearly; attitude along the shortest rotation). With a geodetic reference the mission origin
is its first point.

Aiding epochs are taken at the IMU sample nearest in time; rows outside the IMU's time span are
left out. A CSV table is UTF-8 text, its header naming each column once; every cell is a number
(empty only where a table allows it: a DVL beam that did not return, a body velocity marked
invalid), within what the physics allows (a latitude within 90 deg, a DVL velocity within
:data:`~tauvcore.conventions.MAX_SPEED_MPS`, ...: the bounds of tauvcore.logs.columns). Every
problem is reported as one :class:`LogError` naming the file, the column and the row (data rows
count from 1, the header not included) and the value.

Here the tables are assembled into one :class:`~tauvcore.logs.log_record.Log` (the IMU's increments,
resampled onto a constant rate where its clock is irregular; the reference, the aiding tables and
the plug-in sources' tables), then judged physically (tauvcore.logs.checks); a single table is read
by tauvcore.logs.table_io and its columns checked by tauvcore.logs.columns.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from tauvcore.aiding.source import AidingSource, Column
from tauvcore.aiding.sources import SOURCES
from tauvcore.logs.columns import (
    DVL_BEAMS,
    DVL_BODY,
    DVL_BODY_WATER_TRACK,
    DVL_WATER_BEAMS,
    DVL_WATER_TRACK,
    IMU_INCREMENTS,
    IMU_RATES,
    REF_LOCAL,
    REF_VEL,
    angle_columns,
    check_finite,
    check_within,
    need_columns,
    time_column,
)
from tauvcore.logs.log_record import Log
from tauvcore.logs.table_io import held, read_table, table_path, written_nan
from tauvcore.validation import LogError, show, show_path

TABLES = ("imu", "dvl", "reference")
"""The log's own tables; each aiding source has its own besides
(:attr:`~tauvcore.aiding.source.AidingSource.table`: ``depth``, ``attitude``, ``usbl``)."""
SOURCE_TABLES = {name: source.table for name, source in SOURCES.items() if source.table not in TABLES}
"""Each aiding source's table, by source name, but the DVL's: a log's ``dvl`` table has two forms
(beams, or a body velocity), read here (:func:`_read_dvl`) and made the source's pings by the
replay (tauvcore.aiding.dvl_beams.from_log)."""
TIME_JITTER = 0.01
"""Largest relative departure of an IMU interval from the log's median interval (1 %) taken as
it is; beyond it (an irregular clock, dropped samples) the IMU is resampled onto a constant
rate (:func:`_resample`) and the reader says so in :attr:`Log.notes`."""
MAX_GAP_STEPS = 50
"""Longest hole in the IMU record the resampling bridges, in intervals of the log (0.5 s at
100 Hz); a longer one is refused: the INS would fly blind through it."""
GRAVITY_BAND_MPS2 = (5.0, 15.0)
"""Average specific-force magnitude an IMU log must show over its first 10 s (a vehicle at sea
feels gravity, 9.8 m/s^2): outside it the accelerometer columns are in other units (mg, mm/s^2,
g) or are not specific force."""
MIN_IMU_SPAN_S = 1.0
"""Shortest IMU record a log may have [s]: one window of the physical checks
(tauvcore.logs.evidence.WINDOW_S) and one interval of a 1 Hz DVL or reference; a shorter one
leaves every other table outside its span."""
CONFIG_FILE = "log.toml"
"""The configuration a log carries with it, in its directory (the DVL's lever arm and geometry,
the sensors' tuning: partial TOML as for ``--config``). ``tauv replay`` and the dashboard lay
it under ``--config`` and the flags (or the dashboard's controls); the A-KIT converter writes one."""


def _resample(
    t: np.ndarray, dtheta: np.ndarray, dv: np.ndarray, dt: float, off: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """The IMU on the constant grid ``t_0 + k dt`` up to the last sample: the cumulative angle and
    velocity increments (the integrals the IMU measured) interpolated linearly in time and
    differenced, so every interval of the grid gets the average rate of the log's interval(s) it
    overlaps and nothing measured is lost or counted twice. Returns the grid, its increments
    (row 0 zero) and a note on what was done."""
    steps = np.diff(t)
    grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1) * dt
    total = np.cumsum(np.concatenate([dtheta, dv], axis=1), axis=0)
    moved = np.column_stack([np.interp(grid, t, total[:, i]) for i in range(6)])
    inc = np.concatenate([np.zeros((1, 6)), np.diff(moved, axis=0)])
    worst = int(np.argmax(np.abs(steps - dt)))
    note = (
        f"{int(off.sum())} of {steps.size} intervals differ from {dt:.6g} s by more than {TIME_JITTER:.0%} "
        f"(row {worst + 2}: {steps[worst]:.6g} s); resampled to a constant {1.0 / dt:.6g} Hz, "
        f"{grid.size} samples"
    )
    return grid, inc[:, :3], inc[:, 3:], note


def read_log(directory: str | os.PathLike) -> Log:
    """Read and check the log in ``directory`` (module docstring), then its physical plausibility.

    The plausibility checks are tauvcore.logs.checks'; their notes join :attr:`Log.notes`.

    Parameters
    ----------
    directory : str or os.PathLike
        The log's directory, holding its tables (``imu.csv`` or ``imu.parquet``, ...).

    Returns
    -------
    Log
        The validated log in SI units and the frames of tauvcore.conventions: IMU times (K,) [s] on
        a constant rate, angle increments (K, 3) [rad] and velocity increments (K, 3) [m/s] in the
        body b-frame (FRD), the reference (N, ...) [rad, m, m/s; NED], the DVL (M, 4) or (M, 3)
        [m/s] and the aiding sources' tables, when the log has them.

    Raises
    ------
    LogError
        On any problem, naming the file, the column, the row and the value.
    """
    if not os.fspath(directory).strip():  # Path('') is the current directory
        raise LogError(
            f"{show_path(os.fspath(directory))} is not a log's name (the current directory is '.')"
        )
    root = Path(directory)
    if not root.is_dir():
        raise LogError(f"{show_path(str(root))}: not a directory (a log is a directory of sensor tables)")
    paths = {t: table_path(root, t) for t in TABLES + tuple(SOURCE_TABLES.values())}
    if paths["imu"] is None:
        raise LogError(f"{show_path(str(root))}: no imu.csv or imu.parquet{raw_layout_hint(root)}")
    if paths["reference"] is None and paths["attitude"] is None:
        raise LogError(
            f"{show_path(str(root))}: no reference.csv or attitude.csv (or .parquet): the filters need a "
            "starting attitude, from a reference or from an attitude sensor"
        )
    return _assemble(str(root), paths, read_table)


Load = Callable[[Path], dict[str, np.ndarray]]
"""How a table's columns are had from its path: read from the file (:func:`read_log`), or looked
up among tables already in memory (:func:`log_from_tables`)."""


def log_from_tables(
    tables: Mapping[str, Mapping[str, np.ndarray]],
    source: str,
    names: Mapping[str, str],
    release: bool = False,
) -> Log:
    """A log from tables already in memory (a ROS bag's topics, tauvcore.logs.bags), read and checked
    exactly as :func:`read_log` reads and checks a log's files.

    Parameters
    ----------
    tables : Mapping of str to Mapping of str to numpy.ndarray
        Table name (``imu``, ``dvl``, ``reference`` or an aiding source's table) -> column name ->
        column (K,), as a log's file holds them (the module docstring): data row k is element k.
    source : str
        What the tables were read from (a bag's path), for :attr:`Log.source` and the messages.
    names : Mapping of str to str
        Each table's name in messages, in place of a file's path (``'mission.bag:/imu/data'``);
        a table without one is named ``<source>:<table>``.
    release : bool
        Take each table out of ``tables`` (a dict) as it is read, so that its arrays are freed
        once the log holds what it needs of them (as a log's files are read one at a time).

    Returns
    -------
    Log
        As :func:`read_log` returns it.

    Raises
    ------
    LogError
        On any problem, naming the table (``names``), the column, the row and the value.
    """
    known = TABLES + tuple(SOURCE_TABLES.values())
    unknown = [t for t in tables if t not in known]
    if unknown:
        raise LogError(f"{show_path(source)}: unknown table {show(unknown[0])} (tables: {', '.join(known)})")
    paths: dict[str, Path | None] = {
        t: Path(names.get(t, f"{source}:{t}")) if t in tables else None for t in known
    }
    if paths["imu"] is None:
        raise LogError(f"{show_path(source)}: no imu table")
    if paths["reference"] is None and paths["attitude"] is None:
        raise LogError(
            f"{show_path(source)}: no reference or attitude table: the filters need a starting attitude, "
            "from a reference or from an attitude sensor"
        )
    by_path = {paths[t]: t for t in tables}

    def load(path: Path) -> dict[str, np.ndarray]:
        table = by_path[path]
        columns = tables.pop(table) if release and isinstance(tables, dict) else tables[table]  # pyright: ignore[reportAttributeAccessIssue]
        return {n: np.asarray(v, dtype=float) for n, v in columns.items()}

    return _assemble(source, paths, load)


def _assemble(source: str, paths: dict[str, Path | None], load: Load) -> Log:
    """The log of the tables at ``paths`` (None: the log has no such table; ``imu`` present),
    each had by ``load``: the IMU's increments (resampled where its clock is irregular), the
    reference, the DVL and the sources' tables, then the physical checks (tauvcore.logs.checks)."""
    imu_path = paths["imu"]
    assert imu_path is not None  # both callers refuse a log without one first
    t, dtheta, dv, median, notes = _read_imu(imu_path, load)
    out: dict = {"source": source, "imu_t_s": t, "dtheta_b": dtheta, "dv_b": dv, "notes": notes}
    if paths["reference"] is not None:
        out.update(_read_reference(paths["reference"], t, median, load))
    _read_dvl(paths, out, load)
    out["sources"] = {
        name: _read_source(path, SOURCES[name], load)
        for name, table in SOURCE_TABLES.items()
        if (path := paths[table]) is not None
    }
    log = Log(**out)
    from tauvcore.logs import checks as log_checks  # cross-table plausibility (time and sensor units, signs)

    return dataclasses.replace(
        log,
        notes=log.notes
        + tuple(log_checks.check_plausible(log, {t: p for t, p in paths.items() if p is not None})),
    )


def _read_imu(
    imu_path: Path, load: Load
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, tuple[str, ...]]:
    """The IMU table at ``imu_path``: its times (K,) [s] on a constant rate, its angle (K, 3) [rad]
    and velocity (K, 3) [m/s] increments (row 0 zero; resampled where its clock is irregular),
    the median interval of its clock [s] and a note if resampled. Refused (LogError) unless its
    columns, length and clock make an inertial record and its specific force is gravity's."""
    imu = load(imu_path)
    t = time_column(imu_path, imu)
    dt, median = _imu_clock(imu_path, imu, t)
    if all(n in imu for n in IMU_INCREMENTS):
        check_finite(imu_path, imu, IMU_INCREMENTS)
        check_within(imu_path, imu, IMU_INCREMENTS)
        dtheta = need_columns(imu_path, imu, IMU_INCREMENTS[:3], "increments")
        dv = need_columns(imu_path, imu, IMU_INCREMENTS[3:], "increments")
        accel_columns = IMU_INCREMENTS[3:]
    elif all(n in imu for n in IMU_RATES):
        check_finite(imu_path, imu, IMU_RATES)
        check_within(imu_path, imu, IMU_RATES)
        dtheta = _trapezoid([imu[n] for n in IMU_RATES[:3]], dt)
        dv = _trapezoid([imu[n] for n in IMU_RATES[3:]], dt)
        accel_columns = IMU_RATES[3:]
    else:
        raise AssertionError("the IMU's columns were checked above")
    del imu  # its columns are t, dtheta and dv now
    dtheta[0] = 0.0
    dv[0] = 0.0
    notes: list[str] = []
    off = np.abs(dt - median) > TIME_JITTER * median
    if off.any():
        # the rate: the mean of the ordinary intervals (jitter cancels in their sum; the median of
        # jittered intervals is off by a fraction of the jitter)
        ordinary = np.abs(dt - median) < 0.5 * median
        t, dtheta, dv, note = _resample(t, dtheta, dv, float(np.mean(dt[ordinary])), off)
        notes.append(f"{imu_path.name}: {note}")
        dt = np.diff(t)
    f_mag = np.linalg.norm(dv[1:], axis=1) / dt
    first = t[1:] <= max(t[0] + 10.0, t[1])  # the first 10 s, at least one interval
    mean_f = float(np.mean(f_mag[first]))
    if not GRAVITY_BAND_MPS2[0] <= mean_f <= GRAVITY_BAND_MPS2[1]:
        raise LogError(
            f"{show_path(str(imu_path))}: columns {', '.join(accel_columns)}: the specific force averages "
            f"{mean_f:.6g} m/s^2 over the first 10 s, not gravity's 9.8 (in mg, g or mm/s^2? "
            "the columns must be SI, m/s^2 or m/s)"
        )
    return t, dtheta, dv, median, tuple(notes)


def _imu_clock(imu_path: Path, imu: dict[str, np.ndarray], t: np.ndarray) -> tuple[np.ndarray, float]:
    """The intervals (K - 1,) [s] of the IMU table ``imu`` at ``imu_path``, its times ``t``, and
    their median [s], once the table has its columns, rows enough and no gap (else LogError)."""
    if not (all(n in imu for n in IMU_INCREMENTS) or all(n in imu for n in IMU_RATES)):
        missing = next(n for n in IMU_INCREMENTS if n not in imu)  # what the table is, before how long
        raise LogError(
            f"{show_path(str(imu_path))}: missing column {show(missing)} (the IMU as increments: "
            f"{', '.join(IMU_INCREMENTS)}; or as rates: {', '.join(IMU_RATES)})"
        )
    if t.size < 3:
        raise LogError(f"{show_path(str(imu_path))}: {t.size} rows; an IMU log needs at least 3")
    from tauvcore.logs import checks as log_checks

    log_checks.check_imu_clock(t, imu_path)  # a clock in ms also spoils the gravity check after
    dt = np.diff(t)
    median = float(np.median(dt))
    need = int(np.floor(MIN_IMU_SPAN_S / median + 1e-9)) + 1
    if t.size < need:
        raise LogError(
            f"{show_path(str(imu_path))}: {t.size} rows ({float(t[-1] - t[0]):.6g} s at {1.0 / median:.6g} Hz); "
            f"at least {need} needed ({MIN_IMU_SPAN_S:g} s of IMU)"
        )
    gap = dt > MAX_GAP_STEPS * median
    if gap.any():
        row = int(np.argmax(dt)) + 2
        raise LogError(
            f"{show_path(str(imu_path))}: column 't_s', row {row}: {float(t[row - 1])!r} is {dt[row - 2]:.6g} s "
            f"after the row before, a gap of more than {MAX_GAP_STEPS} of the log's {median:.6g} s "
            "intervals: no inertial record bridges it (cut the log there)"
        )
    return dt, median


def _trapezoid(rates: list[np.ndarray], dt: np.ndarray) -> np.ndarray:
    """Each interval's increment of three rate columns (K,) by the trapezoid rule,
    ``0.5 (w_k-1 + w_k) dt_k`` with ``dt`` (K - 1,), after a first row of zeros: (K, 3), made
    column by column so that no other (K, 3) array is."""
    out = np.empty((dt.size + 1, 3))
    out[0] = 0.0
    for j, rate in enumerate(rates):
        step = rate[1:] + rate[:-1]
        step *= 0.5
        step *= dt
        out[1:, j] = step
    return out


def _read_reference(ref_path: Path, t: np.ndarray, median: float, load: Load) -> dict:
    ref = load(ref_path)
    ref_t = time_column(ref_path, ref)
    if any(f"lat_{u}" in ref for u in ("deg", "rad")):
        lat_lon, _ = angle_columns(ref_path, ref, ("lat", "lon"), "geodetic position")
        depth = need_columns(ref_path, ref, ("depth_m",), "geodetic position: lat, lon and depth_m")
        check_finite(ref_path, ref, ("depth_m",))
        check_within(ref_path, ref, ("depth_m",))
        position, geodetic = np.column_stack([lat_lon, depth]), True
    elif all(n in ref for n in REF_LOCAL):
        check_finite(ref_path, ref, REF_LOCAL)
        check_within(ref_path, ref, REF_LOCAL)
        position, geodetic = need_columns(ref_path, ref, REF_LOCAL, "local position"), False
    else:
        raise LogError(
            f"{show_path(str(ref_path))}: missing column 'lat_deg' or 'north_m' (the reference position: "
            "lat, lon (_deg or _rad) and depth_m; or north_m, east_m, down_m)"
        )
    euler, _ = angle_columns(ref_path, ref, ("roll", "pitch", "yaw"), "the reference attitude")
    vel = need_columns(ref_path, ref, REF_VEL, "the reference NED velocity")
    check_finite(ref_path, ref, REF_VEL)
    check_within(ref_path, ref, REF_VEL)
    if ref_t[0] > t[0] + 0.5 * median or ref_t[-1] < t[0]:
        raise LogError(
            f"{show_path(str(ref_path))}: column 't_s', row 1: the reference starts at {float(ref_t[0])!r} s, "
            f"after the IMU's first sample ({float(t[0])!r} s): the filters start from the reference"
        )

    return {
        "ref_t_s": ref_t,
        "ref_position": position,
        "ref_geodetic": geodetic,
        "ref_euler": euler,
        "ref_vel_n": vel,
    }


def _read_dvl(paths: dict[str, Path | None], out: dict, load: Load) -> None:
    """The optional DVL table into ``out``."""
    if paths["dvl"] is not None:
        p = paths["dvl"]
        cols = load(p)
        out["dvl_t_s"] = time_column(p, cols)
        beams = [n in cols for n in DVL_BEAMS]
        if all(beams) or (any(beams) and not all(n in cols for n in DVL_BODY)):  # the missing one named
            check_finite(p, cols, DVL_BEAMS, allow_nan=True)
            check_within(p, cols, DVL_BEAMS)
            out["dvl_beams_mps"] = need_columns(p, cols, DVL_BEAMS, "beam velocities")
            if any(n in cols for n in DVL_WATER_TRACK):
                need_columns(p, cols, DVL_WATER_TRACK, "the beams' modes, 1 water-track or 0 bottom-track")
                out["dvl_water_track"] = np.stack([_zero_one(p, cols, n) for n in DVL_WATER_TRACK], axis=-1)
        else:
            body = need_columns(p, cols, DVL_BODY, "a body velocity (or beam1_mps .. beam4_mps)")
            check_finite(p, cols, DVL_BODY, allow_nan=True)
            check_within(p, cols, DVL_BODY)
            valid = _zero_one(p, cols, "valid") if "valid" in cols else np.ones(body.shape[0], dtype=bool)
            if DVL_BODY_WATER_TRACK in cols:
                water = _zero_one(p, cols, DVL_BODY_WATER_TRACK)
                out["dvl_water_track"] = np.repeat(water[:, None], len(DVL_BEAMS), axis=1)
            body = body.copy()
            body[~valid] = np.nan
            partial = np.isnan(body).any(axis=1) & ~np.isnan(body).all(axis=1)
            if partial.any():
                row = int(np.argmax(partial))
                column = DVL_BODY[int(np.argmax(np.isnan(body[row])))]
                raise LogError(
                    f"{show_path(str(p))}: column {show(column)}, row {row + 1}: "
                    f"{held(p, column, row + 1, float(body[row, DVL_BODY.index(column)]))} where the row's "
                    "other components are numbers (a body velocity is all three or none: leave all three "
                    "empty, or set valid = 0)"
                )
            out["dvl_body_mps"] = body
        if any(n in cols for n in DVL_WATER_BEAMS):
            out["dvl_water_mps"] = _water_beams(p, cols)
        out["dvl_truth"] = {  # a simulated log's true errors; NaN in a recorded one
            c.name: _column_of(p, cols, c) if c.name in cols else np.full(out["dvl_t_s"].shape, np.nan)
            for c in SOURCES["dvl"].truth_columns
        }


def _water_beams(path: Path, cols: dict[str, np.ndarray]) -> np.ndarray:
    """The water-track velocities beside the bottom-track ones (M, 4) [m/s], NaN where empty: all
    four columns, never beside a mode column (which says what ``beam1_mps`` .. hold instead)."""
    flags = [n for n in (*DVL_WATER_TRACK, DVL_BODY_WATER_TRACK) if n in cols]
    if flags:
        raise LogError(
            f"{show_path(str(path))}: column {show(flags[0])} beside {show(DVL_WATER_BEAMS[0])}: a table gives "
            f"water-track either by the mode columns or in {DVL_WATER_BEAMS[0]} .. {DVL_WATER_BEAMS[-1]} "
            "(beside bottom-track), not both"
        )
    check_finite(path, cols, DVL_WATER_BEAMS, allow_nan=True)
    check_within(path, cols, DVL_WATER_BEAMS)
    return need_columns(path, cols, DVL_WATER_BEAMS, "the water-track beam velocities")


def _zero_one(path: Path, cols: dict[str, np.ndarray], name: str) -> np.ndarray:
    """Column ``name`` of the table ``cols`` (of ``path``) as a flag, each cell 1 or 0 (a mode
    column's may be empty: 0); LogError at the first other value."""
    mode = name != "valid"
    check_finite(path, cols, (name,), allow_nan=mode)
    if mode:
        _refuse_written_nan(path, cols, name, "1, 0 or an empty cell (0)")
    v = cols[name]
    bad = ~np.isin(v, (0.0, 1.0)) & ~(mode & np.isnan(v))
    if bad.any():
        row = int(np.argmax(bad))
        raise LogError(
            f"{show_path(str(path))}: column {show(name)}, row {row + 1}: {show(float(v[row]))} is not 0 or 1"
        )
    return v == 1.0


def _column_of(path: Path, cols: dict[str, np.ndarray], column: Column) -> np.ndarray:
    """Column ``column`` of the table ``cols`` (of ``path``), finite (or empty where it may be) and
    within its bounds."""
    check_finite(path, cols, (column.name,), allow_nan=column.allow_nan)
    check_within(
        path, cols, (column.name,), {column.name: (column.low, column.high, column.unit, column.what)}
    )
    if column.allow_nan:
        _refuse_written_nan(path, cols, column.name, "a number, or an empty cell (no reading)")
    return cols[column.name]


def _refuse_written_nan(path: Path, cols: dict[str, np.ndarray], name: str, needed: str) -> None:
    """LogError at the first cell of column ``name`` that is not empty yet no number ('nan', 'N/A'):
    an empty cell is the format's "no reading", anything else in it is no value of the column."""
    row = written_nan(path, name, cols[name])
    if row is not None:
        raise LogError(
            f"{show_path(str(path))}: column {show(name)}, row {row}: {held(path, name, row, float('nan'))} is not "
            f"a number; {needed} is needed here"
        )


def _read_source(path: Path, source: AidingSource, load: Load) -> dict[str, np.ndarray]:
    """A source's table (``t_s`` and :attr:`~tauvcore.aiding.source.AidingSource.columns`), each
    column finite (or empty where the source allows it) and within its bounds; an angle column as
    ``<stem>_rad`` or ``<stem>_deg`` (in radians here). Its truth columns
    (:attr:`~tauvcore.aiding.source.AidingSource.truth_columns`, a simulated log's) are checked the
    same way where the table has them, NaN where it does not."""
    cols = load(path)
    out = {"t_s": time_column(path, cols)}
    angles = tuple(c for c in source.columns if c.angle)
    if angles:
        values, _ = angle_columns(path, cols, tuple(c.stem for c in angles), source.table)
        out.update({c.name: values[:, i] for i, c in enumerate(angles)})
    names = tuple(c.name for c in source.columns if not c.angle)
    if names:
        need_columns(path, cols, names, f"the {source.table} table: {source.summary}")
    for column in source.columns + source.truth_columns:
        if column.angle:
            continue
        if column.name not in cols:  # a truth column the table does not have
            out[column.name] = np.full(out["t_s"].shape, np.nan)
            continue
        out[column.name] = _column_of(path, cols, column)
    return out


def _has_imu(directory: Path) -> bool:
    """Whether ``directory`` has an entry named ``imu.csv`` or ``imu.parquet`` (of any kind: a
    file, a directory, a dangling link); False if it cannot be searched."""
    return any(os.path.lexists(directory / f"imu.{ext}") for ext in ("csv", "parquet"))


def find_logs(directory: str | os.PathLike) -> dict[str, str]:
    """The logs in ``directory`` by name.

    The directory itself if it is one (it has an ``imu`` table), and each of its subdirectories
    that is; sorted by name. Only the ``imu`` entry's presence is checked here: one that is a
    directory, a dangling link or a loop counts, so that choosing the log gives :func:`read_log`'s
    message; a subdirectory that cannot be searched, or whose name starts with a dot, is left out.

    Parameters
    ----------
    directory : str or os.PathLike
        The directory to search (a log, or a directory of logs).

    Returns
    -------
    dict of str to str
        Each log's directory name -> its path, ``directory`` itself first if it is a log, then its
        subdirectories in name order.

    Raises
    ------
    OSError
        If ``directory`` itself cannot be listed.
    """
    root = Path(directory)
    subdirectories = []
    for entry in root.iterdir():
        try:
            if entry.is_dir() and not entry.name.startswith("."):  # a writer's hidden temporary is no log
                subdirectories.append(entry)
        except OSError:  # an entry that cannot be looked at is no log to offer
            continue
    found = {}
    for candidate in [root, *sorted(subdirectories)]:
        if _has_imu(candidate):
            found[candidate.name or str(candidate)] = str(candidate)
    return found


RAW_LAYOUTS = {
    "an A-KIT segment (Snapir AUV)": (
        ("IMU.csv", "DVL.csv", "GT.csv"),
        "python scripts/akit_to_log.py DIR OUT",
    ),
}
"""Vendors' own layouts a log directory may be mistaken for: what they are -> (their files, the
converter that writes them as a log)."""


def raw_layout_hint(directory: str | os.PathLike) -> str:
    """The end of a "no imu table" message: how to convert a vendor's raw layout, if it is one.

    Parameters
    ----------
    directory : str or os.PathLike
        The directory that has no ``imu`` table.

    Returns
    -------
    str
        ``"; it holds ..., <what>: convert it to a log first with `<converter>`, then replay OUT"``
        when ``directory`` holds every file of a vendor's raw layout (:data:`RAW_LAYOUTS`), else
        ``""``.
    """
    root = Path(directory)
    for what, (files, converter) in RAW_LAYOUTS.items():
        try:
            if all((root / name).is_file() for name in files):
                return (
                    f"; it holds {', '.join(files)}, {what}: convert it to a log first with "
                    f"`{converter}`, then replay OUT"
                )
        except OSError:
            continue
    return ""


__all__ = [
    "CONFIG_FILE",
    "TABLES",
    "Log",
    "LogError",
    "find_logs",
    "log_from_tables",
    "raw_layout_hint",
    "read_log",
]
