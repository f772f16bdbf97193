"""What the physical checks of a log (tauvcore.logs.checks, tauvcore.logs.motion_checks) compare, and
what their messages quote.

The comparison: a sensor's series over windows of about :data:`WINDOW_S` against what physics or
another table predicts, per pair of axes, as a least-squares slope of the measured on the predicted
(1 if right) and their match (the cosine of the angle between the two series, 1 if they agree in
shape) (:class:`Fit`); then what that says (:func:`judge`): columns in another order that explain
the prediction far better (swapped axes), a slope near a known unit factor or a sign, or, where it
cannot be sure, a note. The quotes: a table's columns as the file names them and a value at a row
as the file has it, read from the file only to word a message.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tauvcore.logs.log_record import Log

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


def file_columns(path: Path, *families: tuple[str, ...]) -> list[str]:
    """For each family of spellings (``("gyro_x_rps", "dtheta_x_rad")``), the one in the file."""
    names = _header(path)
    return [next((n for n in family if n in names), family[0]) for family in families]


def file_angle_columns(path: Path, bases: tuple[str, ...]) -> list[str]:
    return file_columns(path, *((f"{b}_rad", f"{b}_deg") for b in bases))


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


def row_at(path: Path, t: float) -> int:
    """The data row (from 1) of a table whose time is nearest ``t`` [s]."""
    times = _column_values(path, "t_s")
    if times is None or times.size == 0:
        return 1
    return int(np.argmin(np.abs(times - t))) + 1


def value_at(path: Path, column: str, row: int) -> str:
    """The value at ``row`` (from 1) of a column as the file has it."""
    values = _column_values(path, column)
    if values is None or not 1 <= row <= values.size:
        return "?"
    return f"{values[row - 1]:.6g}"


# -------------------------------------------------------------------------------- the comparison
@dataclass(frozen=True)
class Fit:
    """Measured series (windows, m) against predicted ones (windows, n), per pair of axes."""

    slope: np.ndarray  # (n, m) least-squares slope of measured axis j on predicted axis i
    match: np.ndarray  # (n, m) cosine between them (uncentred correlation), 0 where undefined
    unexplained: np.ndarray  # (n, m) energy of measured j left by its slope on i: |m_j|^2 (1 - match^2)
    rms_pred: np.ndarray  # (n,) RMS of each predicted axis
    rms_meas: np.ndarray  # (m,) RMS of each measured axis
    count: int  # windows compared

    @staticmethod
    def of(pred: np.ndarray, meas: np.ndarray) -> Fit:
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
        return Fit(slope, match, unexplained, rms_pred, rms_meas, int(ok_p.all(axis=1).sum()))


@dataclass(frozen=True)
class Finding:
    """What a comparison found on one axis."""

    kind: str  # "swap", "factor" (a known factor or sign), "unmatched", "unexplained"
    axis: int  # the predicted axis
    column: int  # the measured axis (column) concerned: another one for a swap
    slope: float
    match: float
    factor: float = 1.0  # the known factor the slope is near ("factor")


def _swapped_columns(fit: Fit, floor: float) -> list[Finding]:
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
        Finding("swap", i, best[i], float(fit.slope[i, best[i]]), float(fit.match[i, best[i]])) for i in moved
    ]


def judge(fit: Fit, floor: float, tolerance: float, factors: tuple[float, ...]) -> list[Finding]:
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
            notes.append(Finding("unmatched", i, i, s, c))
            continue
        near = [
            f for f in (1.0, *factors) if np.sign(f) == np.sign(s) and abs(np.log(s / f)) <= np.log(tolerance)
        ]
        if not near:
            notes.append(Finding("unexplained", i, i, s, c))
            continue
        best = min(near, key=lambda f: abs(np.log(s / f)))
        if best != 1.0:
            factor_findings.append(Finding("factor", i, i, s, c, best))
    return factor_findings + notes


def worst_window(pred: np.ndarray, meas: np.ndarray, finding: Finding) -> int:
    """The window where the finding's column disagrees most with its own axis (the evidence a
    message quotes)."""
    gap = np.abs(meas[:, finding.column] - pred[:, finding.column])
    return int(np.nanargmax(np.where(np.isfinite(gap), gap, -1.0)))


def window_rows(t: np.ndarray, t_imu: np.ndarray, window_s: float = WINDOW_S) -> np.ndarray:
    """Rows of a table about ``window_s`` apart (every row if it is sparser) within the IMU's span."""
    idx = np.flatnonzero((t >= t_imu[0]) & (t <= t_imu[-1]))
    if idx.size < 2:
        return idx
    step = max(1, round(window_s / float(np.median(np.diff(t[idx])))))
    return idx[::step]


def imu_change(log: Log, increments: np.ndarray, t: np.ndarray) -> np.ndarray:
    """What the IMU measured between successive times ``t``: its cumulative increments,
    interpolated in time (the rows are integrals over their intervals), differenced. (W-1, 3)."""
    total = np.cumsum(increments, axis=0)
    at = np.column_stack([np.interp(t, log.imu_t_s, total[:, i]) for i in range(3)])
    return np.diff(at, axis=0)


def euler_at(t_rows: np.ndarray, euler: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Euler angles at times ``t``, linear between rows (yaw unwrapped first)."""
    e = euler.copy()
    e[:, 2] = np.unwrap(e[:, 2])
    return np.column_stack([np.interp(t, t_rows, e[:, i]) for i in range(3)])


def table_file(files: Mapping[str, Path], log: Log, table: str) -> Path:
    return Path(files[table]) if table in files else Path(log.source) / f"{table}.csv"
