"""Recorded sensor logs: the format, a validating reader, and a writer for simulated missions.

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
dropped synthetically (``--beams``, ``--outage``) as on simulated data.

``depth`` (optional): ``depth_m``. ``attitude`` (optional, a magnetometer/AHRS attitude):
``roll``, ``pitch``, ``yaw`` each as ``_deg`` or ``_rad``.

``reference`` (optional: its first row is the filters' starting point, and errors are computed
against it; without it the filters start from the log's own sensors, see
tauvcore.eval.replay, and no error can be computed): position as ``lat`` and ``lon`` (``_deg`` or ``_rad``) with ``depth_m``, or as
``north_m``, ``east_m``, ``down_m`` from the sea-surface point above the mission origin
(``[earth] latitude_deg, longitude_deg``); attitude ``roll``, ``pitch``, ``yaw`` (``_deg`` or
``_rad``); NED velocity ``vel_north_mps``, ``vel_east_mps``, ``vel_down_mps``. It may be
sampled at any rate: it is interpolated to the IMU's times (linearly; attitude along the
shortest rotation). With a geodetic reference the mission origin is its first point.

Aiding epochs are taken at the IMU sample nearest in time; rows outside the IMU's time span are
left out. Every problem is reported as one :class:`LogError` naming the file, the column and
the row (data rows count from 1, the header not included) and the value.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tauvcore import units
from tauvcore.validation import show, show_path

TABLES = ("imu", "dvl", "depth", "attitude", "reference")
IMU_INCREMENTS = ("dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_mps", "dv_y_mps", "dv_z_mps")
IMU_RATES = ("gyro_x_rps", "gyro_y_rps", "gyro_z_rps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2")
DVL_BEAMS = ("beam1_mps", "beam2_mps", "beam3_mps", "beam4_mps")
DVL_BODY = ("vel_x_mps", "vel_y_mps", "vel_z_mps")
REF_VEL = ("vel_north_mps", "vel_east_mps", "vel_down_mps")
REF_LOCAL = ("north_m", "east_m", "down_m")
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
MAX_LOG_BYTES = 4 << 30
"""Largest table read [bytes] (4 GiB; ten hours at 1 kHz in CSV is about 1.5 GB)."""


class LogError(ValueError):
    """A log that cannot be read as it is: the message names the file, column, row and value."""


@dataclass(frozen=True)
class Log:
    """A validated log, in SI units and the frames of tauvcore.conventions."""

    source: str  # the directory it was read from
    imu_t_s: np.ndarray  # (K,) IMU sample times [s], uniform
    dtheta_b: np.ndarray  # (K, 3) angle increments over (t_k-1, t_k] [rad]; row 0 zero
    dv_b: np.ndarray  # (K, 3) velocity increments [m/s]; row 0 zero
    ref_t_s: np.ndarray | None = None  # (N,) reference times [s]; None: the log has no reference
    ref_position: np.ndarray | None = None  # (N, 3) latitude [rad], longitude [rad], depth [m]; or NED [m]
    ref_geodetic: bool = False  # whether ref_position is geodetic
    ref_euler: np.ndarray | None = None  # (N, 3) roll, pitch, yaw [rad]
    ref_vel_n: np.ndarray | None = None  # (N, 3) NED velocity [m/s]
    dvl_t_s: np.ndarray | None = None  # (M,) ping times [s]
    dvl_beams_mps: np.ndarray | None = None  # (M, 4) beam velocities, NaN where not returned
    dvl_body_mps: np.ndarray | None = None  # (M, 3) body velocity (NaN rows: invalid), if the log has that
    depth_t_s: np.ndarray | None = None
    depth_m: np.ndarray | None = None
    attitude_t_s: np.ndarray | None = None
    attitude_euler: np.ndarray | None = None  # (A, 3) [rad]
    notes: tuple[str, ...] = ()  # what the reader changed (a resampled IMU), for the user

    @property
    def dt_s(self) -> float:
        """The IMU's sample interval [s] (the median of the log's)."""
        return float(np.median(np.diff(self.imu_t_s)))

    @property
    def duration_s(self) -> float:
        return float(self.imu_t_s[-1] - self.imu_t_s[0])


# ---------------------------------------------------------------------------------------- reading
def _table_path(directory: Path, table: str) -> Path | None:
    found = [p for p in (directory / f"{table}.csv", directory / f"{table}.parquet") if p.exists()]
    if len(found) > 1:
        raise LogError(f"{show_path(str(directory))}: both {table}.csv and {table}.parquet; keep one")
    return found[0] if found else None


def _read_table(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV or Parquet table as float arrays (``valid`` may be boolean); LogError
    naming the file for anything unreadable."""
    import pyarrow as pa

    name = show_path(str(path))
    try:
        if not path.is_file():
            raise LogError(f"{name}: not a regular file")
        if path.stat().st_size > MAX_LOG_BYTES:
            raise LogError(
                f"{name}: {path.stat().st_size} bytes, more than the {MAX_LOG_BYTES >> 30} GiB a table may have"
            )
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            table = pq.read_table(path)
        else:
            import pyarrow.csv as pcsv

            table = pcsv.read_csv(path, convert_options=pcsv.ConvertOptions(strings_can_be_null=True))
    except LogError:
        raise
    except (OSError, pa.ArrowException) as exc:
        raise LogError(
            f"{name}: cannot be read as a {path.suffix[1:].upper()} table: {show_path(str(exc))}"
        ) from None
    columns = {}
    for column in table.column_names:
        col = table.column(column)
        if pa.types.is_boolean(col.type):
            columns[column] = col.to_numpy(zero_copy_only=False).astype(float)
            continue
        if not (
            pa.types.is_integer(col.type) or pa.types.is_floating(col.type) or pa.types.is_null(col.type)
        ):
            values = col.to_pylist()
            bad = next((i for i, v in enumerate(values) if v is not None and not _is_number(v)), None)
            if bad is None:
                raise LogError(f"{name}: column {show(column)} is not numeric")
            raise LogError(
                f"{name}: column {show(column)}, row {bad + 1}: {show(values[bad])} is not a number"
            )
        columns[column] = col.to_numpy(zero_copy_only=False).astype(float)
    return columns


def _is_number(value: object) -> bool:
    try:
        float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    return True


def _need(path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str) -> np.ndarray:
    missing = [n for n in names if n not in columns]
    if missing:
        raise LogError(
            f"{show_path(str(path))}: missing column {show(missing[0])} ({what}: {', '.join(names)})"
        )
    return np.stack([columns[n] for n in names], axis=-1)


def _angles(path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], what: str) -> np.ndarray:
    """Angle columns, each as ``<name>_deg`` or ``<name>_rad``, in radians."""
    out = []
    for n in names:
        if f"{n}_rad" in columns:
            out.append(columns[f"{n}_rad"])
        elif f"{n}_deg" in columns:
            out.append(columns[f"{n}_deg"] * units.DEG)
        else:
            raise LogError(
                f"{show_path(str(path))}: missing column {show(n + '_deg')} or {show(n + '_rad')} ({what})"
            )
    return np.stack(out, axis=-1)


def _finite(
    path: Path, columns: dict[str, np.ndarray], names: tuple[str, ...], allow_nan: bool = False
) -> None:
    """Every value of ``names`` finite (or NaN where allowed): the first offender by row and column."""
    for n in names:
        if n not in columns:
            continue
        v = columns[n]
        bad = ~np.isfinite(v) if not allow_nan else np.isinf(v)
        if bad.any():
            row = int(np.argmax(bad))
            value = "empty" if np.isnan(v[row]) else show(float(v[row]))
            raise LogError(
                f"{show_path(str(path))}: column {show(n)}, row {row + 1}: {value} is not a finite number"
            )


def _times(path: Path, columns: dict[str, np.ndarray]) -> np.ndarray:
    if "t_s" not in columns:
        raise LogError(f"{show_path(str(path))}: missing column 't_s' (time [s])")
    _finite(path, columns, ("t_s",))
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
    """Read and check the log in ``directory`` (module docstring). LogError on any problem."""
    root = Path(directory)
    if not root.is_dir():
        raise LogError(f"{show_path(str(root))}: not a directory (a log is a directory of sensor tables)")
    paths = {t: _table_path(root, t) for t in TABLES}
    if paths["imu"] is None:
        raise LogError(f"{show_path(str(root))}: no imu.csv or imu.parquet")
    if paths["reference"] is None and paths["attitude"] is None:
        raise LogError(
            f"{show_path(str(root))}: no reference.csv or attitude.csv (or .parquet): the filters need a "
            "starting attitude, from a reference or from an attitude sensor"
        )
    imu_path = paths["imu"]
    imu = _read_table(imu_path)
    t = _times(imu_path, imu)
    if t.size < 3:
        raise LogError(f"{show_path(str(imu_path))}: {t.size} rows; an IMU log needs at least 3")
    dt = np.diff(t)
    median = float(np.median(dt))
    gap = dt > MAX_GAP_STEPS * median
    if gap.any():
        row = int(np.argmax(dt)) + 2
        raise LogError(
            f"{show_path(str(imu_path))}: column 't_s', row {row}: {float(t[row - 1])!r} is {dt[row - 2]:.6g} s "
            f"after the row before, a gap of more than {MAX_GAP_STEPS} of the log's {median:.6g} s "
            "intervals: no inertial record bridges it (cut the log there)"
        )
    if all(n in imu for n in IMU_INCREMENTS):
        _finite(imu_path, imu, IMU_INCREMENTS)
        inc = _need(imu_path, imu, IMU_INCREMENTS, "increments")
        dtheta, dv = inc[:, :3].copy(), inc[:, 3:].copy()
        accel_columns = IMU_INCREMENTS[3:]
    elif all(n in imu for n in IMU_RATES):
        _finite(imu_path, imu, IMU_RATES)
        rates = _need(imu_path, imu, IMU_RATES, "rates")
        mid = 0.5 * (rates[1:] + rates[:-1]) * dt[:, None]
        inc = np.concatenate([np.zeros((1, 6)), mid])
        dtheta, dv = inc[:, :3], inc[:, 3:]
        accel_columns = IMU_RATES[3:]
    else:
        missing = next(n for n in IMU_INCREMENTS if n not in imu)
        raise LogError(
            f"{show_path(str(imu_path))}: missing column {show(missing)} (the IMU as increments: "
            f"{', '.join(IMU_INCREMENTS)}; or as rates: {', '.join(IMU_RATES)})"
        )
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
    first = t[1:] <= t[0] + 10.0
    mean_f = float(np.mean(f_mag[first]))
    if not GRAVITY_BAND_MPS2[0] <= mean_f <= GRAVITY_BAND_MPS2[1]:
        raise LogError(
            f"{show_path(str(imu_path))}: columns {', '.join(accel_columns)}: the specific force averages "
            f"{mean_f:.6g} m/s^2 over the first 10 s, not gravity's 9.8 (in mg, g or mm/s^2? "
            "the columns must be SI, m/s^2 or m/s)"
        )

    out: dict = {"source": str(root), "imu_t_s": t, "dtheta_b": dtheta, "dv_b": dv, "notes": tuple(notes)}
    if paths["reference"] is not None:
        out.update(_read_reference(paths["reference"], t, median))
    _read_aiding(paths, out)
    return Log(**out)


def _read_reference(ref_path: Path, t: np.ndarray, median: float) -> dict:
    ref = _read_table(ref_path)
    ref_t = _times(ref_path, ref)
    if any(f"lat_{u}" in ref for u in ("deg", "rad")):
        lat_lon = _angles(ref_path, ref, ("lat", "lon"), "geodetic position")
        depth = _need(ref_path, ref, ("depth_m",), "geodetic position: lat, lon and depth_m")
        position, geodetic = np.column_stack([lat_lon, depth]), True
        _finite(
            ref_path,
            {"lat": position[:, 0], "lon": position[:, 1], "depth_m": position[:, 2]},
            ("lat", "lon", "depth_m"),
        )
    elif all(n in ref for n in REF_LOCAL):
        _finite(ref_path, ref, REF_LOCAL)
        position, geodetic = _need(ref_path, ref, REF_LOCAL, "local position"), False
    else:
        raise LogError(
            f"{show_path(str(ref_path))}: missing column 'lat_deg' or 'north_m' (the reference position: "
            "lat, lon (_deg or _rad) and depth_m; or north_m, east_m, down_m)"
        )
    euler = _angles(ref_path, ref, ("roll", "pitch", "yaw"), "the reference attitude")
    _finite(
        ref_path,
        {f"{n}": euler[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))},
        ("roll", "pitch", "yaw"),
    )
    _finite(ref_path, ref, REF_VEL)
    vel = _need(ref_path, ref, REF_VEL, "the reference NED velocity")
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


def _read_aiding(paths: dict[str, Path | None], out: dict) -> None:
    """The optional aiding tables into ``out``."""
    if paths["dvl"] is not None:
        p = paths["dvl"]
        cols = _read_table(p)
        out["dvl_t_s"] = _times(p, cols)
        if all(n in cols for n in DVL_BEAMS):
            _finite(p, cols, DVL_BEAMS, allow_nan=True)
            out["dvl_beams_mps"] = _need(p, cols, DVL_BEAMS, "beam velocities")
        else:
            body = _need(p, cols, DVL_BODY, "a body velocity (or beam1_mps .. beam4_mps)")
            valid = cols.get("valid", np.ones(body.shape[0]))
            _finite(p, {"valid": valid}, ("valid",))
            bad = ~np.isin(valid, (0.0, 1.0))
            if bad.any():
                row = int(np.argmax(bad))
                raise LogError(
                    f"{show_path(str(p))}: column 'valid', row {row + 1}: {show(float(valid[row]))} is not 0 or 1"
                )
            body = body.copy()
            body[valid == 0.0] = np.nan
            _finite(p, {n: body[:, i] for i, n in enumerate(DVL_BODY)}, DVL_BODY, allow_nan=True)
            partial = np.isnan(body).any(axis=1) & ~np.isnan(body).all(axis=1)
            if partial.any():
                row = int(np.argmax(partial))
                raise LogError(
                    f"{show_path(str(p))}: row {row + 1}: a body velocity with some components empty "
                    "(leave all three empty, or set valid = 0)"
                )
            out["dvl_body_mps"] = body
    if paths["depth"] is not None:
        p = paths["depth"]
        cols = _read_table(p)
        out["depth_t_s"] = _times(p, cols)
        _finite(p, cols, ("depth_m",))
        out["depth_m"] = _need(p, cols, ("depth_m",), "depth")[:, 0]
    if paths["attitude"] is not None:
        p = paths["attitude"]
        cols = _read_table(p)
        out["attitude_t_s"] = _times(p, cols)
        euler_a = _angles(p, cols, ("roll", "pitch", "yaw"), "attitude")
        _finite(
            p, {n: euler_a[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))}, ("roll", "pitch", "yaw")
        )
        out["attitude_euler"] = euler_a


def find_logs(directory: str | os.PathLike) -> dict[str, str]:
    """The logs in ``directory`` by name: the directory itself if it is one (it holds an ``imu``
    table), and each of its subdirectories that is; sorted by name. Only their presence is
    checked here (:func:`read_log` checks the rest when one is replayed)."""
    root = Path(directory)
    found = {}
    for candidate in [root, *sorted(p for p in root.iterdir() if p.is_dir())]:
        if any((candidate / f"imu.{ext}").is_file() for ext in ("csv", "parquet")):
            found[candidate.name or str(candidate)] = str(candidate)
    return found


# ---------------------------------------------------------------------------------------- writing
def write_log(
    directory: str | os.PathLike, tables: dict[str, dict[str, np.ndarray]], fmt: str = "csv"
) -> None:
    """Write ``tables`` (table -> column -> 1-D array) as a log in ``directory`` (created if need
    be), CSV with every float written to its last digit (``repr``, so reading back is exact) or
    Parquet. Each file is written under a temporary name and renamed when complete."""
    if fmt not in ("csv", "parquet"):
        raise ValueError(f"fmt must be 'csv' or 'parquet', got {fmt!r}")
    root = Path(directory)
    root.mkdir(parents=True, exist_ok=True)
    for table, columns in tables.items():
        if table not in TABLES:
            raise ValueError(f"unknown table {table!r} (tables: {', '.join(TABLES)})")
        final = root / f"{table}.{fmt}"
        tmp = root / f".{table}.{fmt}.partial"
        names = list(columns)
        if fmt == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            pq.write_table(pa.table({n: np.asarray(columns[n], dtype=float) for n in names}), tmp)
        else:
            data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
            with open(tmp, "w", encoding="utf-8") as fh:
                fh.write(",".join(names) + "\n")
                fh.writelines(
                    ",".join("" if np.isnan(v) else repr(float(v)) for v in row) + "\n" for row in data
                )
        os.replace(tmp, final)


def simulation_tables(chunks: list, run_index: int = 0) -> dict[str, dict[str, np.ndarray]]:
    """The tables of a log holding one run of a simulation given as its chunks in order
    (tauvcore.eval.runner.SimChunk; ``[SimChunk.whole(sim)]`` for a whole one): the IMU as
    increments, the DVL as beams (NaN where not returned), depth, the magnetometer's attitude,
    and the truth as the reference (at the IMU rate; geodetic in radians on WGS-84, else NED)."""
    r = run_index

    def run_of(a: np.ndarray, time_axis_dims: int) -> np.ndarray:
        return a[:, r] if a.ndim > time_axis_dims else a

    parts: dict[str, dict[str, list[np.ndarray]]] = {t: {} for t in TABLES}

    def add(table: str, column: str, values: np.ndarray) -> None:
        parts[table].setdefault(column, []).append(np.asarray(values, dtype=float))

    for chunk in chunks:
        truth, imu, dvl, pressure, mag = chunk.truth, chunk.imu, chunk.dvl, chunk.pressure, chunk.mag
        add("imu", "t_s", truth.t_s)
        dth, dv = run_of(imu.dtheta_b, 2), run_of(imu.dv_b, 2)
        for i in range(3):
            add("imu", IMU_INCREMENTS[i], dth[:, i])
            add("imu", IMU_INCREMENTS[3 + i], dv[:, i])
        y = np.where(run_of(dvl.available, 2), run_of(dvl.y_beam_mps, 2), np.nan)
        add("dvl", "t_s", dvl.t_s)
        for i, n in enumerate(DVL_BEAMS):
            add("dvl", n, y[:, i])
        add("depth", "t_s", pressure.t_s)
        add("depth", "depth_m", run_of(pressure.depth_m, 1))
        e = run_of(mag.euler, 2)
        add("attitude", "t_s", mag.t_s)
        for i, n in enumerate(("roll_rad", "pitch_rad", "yaw_rad")):
            add("attitude", n, e[:, i])
        add("reference", "t_s", truth.t_s)
        if truth.earth.geodetic:
            for i, n in enumerate(("lat_rad", "lon_rad", "depth_m")):
                add("reference", n, truth.pos_nav[:, i])
        else:
            for i, n in enumerate(REF_LOCAL):
                add("reference", n, truth.pos_n[:, i])
        for i, n in enumerate(("roll_rad", "pitch_rad", "yaw_rad")):
            add("reference", n, truth.euler[:, i])
        for i, n in enumerate(REF_VEL):
            add("reference", n, truth.vel_n[:, i])
    return {t: {c: np.concatenate(v) for c, v in cols.items()} for t, cols in parts.items() if cols}


__all__ = ["TABLES", "Log", "LogError", "find_logs", "read_log", "simulation_tables", "write_log"]
