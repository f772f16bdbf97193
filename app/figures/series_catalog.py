"""Every series a run recorded, by name, for the Series tab's time and XY plots: a PlotJuggler-like
pick of anything the engine, the sensors or the truth gave, one run of a Monte Carlo at a time.

A name is a path, its last part carrying the unit as the other names of the package do:

- ``<method>/<field>``: each method's per-epoch series (``lc/vel_err_mps``, ``lc/pos_sigma_m``,
  ``lc/nees``), its NEES per block (``lc/nees_pos``), its estimates (``lc/est_north_m``,
  ``lc/est_vel_east_mps``, ``lc/est_yaw_deg``), the states its sources add and their 1-sigma
  (``lc/state/current_north_mps``, ``lc/state/current_north_mps_sigma``), its sensor-error estimates
  (``lc/sensor/ba_x_mps2``) and, with the smoother, the same under ``<method>/smoothed/``;
- ``<method>/<source>/<field>``: every update of an aiding source (``lc/dvl/innovation_1_mps``, its
  ``_sigma`` (the square root of S's diagonal), ``lc/dvl/z_1_mps``, ``lc/dvl/nis``,
  ``lc/dvl/test_ratio``, ``lc/dvl/rejected``, ``lc/dvl/beams_available``);
- ``vkf/vkf/<field>``: what the velocity Kalman filter learned at every ping;
- ``sensors/imu/...`` and ``sensors/<source>/<column>``: the run's raw measurements as the Sensors tab
  holds them (app.figures.sensor_view), and ``sensors/<source>/truth/<column>`` their truth;
- ``truth/...``: the truth at the output epochs (position, attitude, altitude, current).

Angles are in degrees here (an edge of the package: what the user reads). The catalogue holds only
how to get each series; :meth:`Catalog.series` cuts one out when it is plotted.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.figures.error_figures import block_dims
from tauvcore.aiding.sources import SOURCES
from tauvcore.engine.results import SERIES_FIELDS, MethodResult, UpdateRecord, sensor_states
from tauvcore.eval.consistency import nees_series

UNIT_SUFFIXES = (
    ("_mps2", "m/s^2"),
    ("_radps", "rad/s"),
    ("_mps", "m/s"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_m", "m"),
    ("_s", "s"),
    ("_rpm", "rpm"),
)
"""A name's last part ends with its unit: the suffix and the unit it means (longest first)."""
SI_SUFFIX = {"m/s^2": "_mps2", "rad/s": "_radps", "m/s": "_mps", "m": "_m", "rad": "_rad", "s": "_s", "-": ""}
"""The name suffix of a unit the registry's columns state."""
NED = ("north", "east", "down")
EULER = ("roll", "pitch", "yaw")
BODY = ("x", "y", "z")


def unit_of(name: str) -> str:
    """The unit a series' name carries in its last part ("-" for a dimensionless one)."""
    last = name.rsplit("/", 1)[-1].removesuffix("_sigma")
    for suffix, unit in UNIT_SUFFIXES:
        if last.endswith(suffix):
            return unit
    return "-"


@dataclass(frozen=True)
class Series:
    """One recorded series of one run: its name (see the module docstring), unit, epochs [s] and
    values (NaN where it has none)."""

    name: str
    unit: str
    t_s: np.ndarray  # (E,)
    value: np.ndarray  # (E,) float


Getter = Callable[[int], tuple[np.ndarray, np.ndarray]]
"""A series' epochs and values of run ``r`` (0-based)."""


def _run(a: np.ndarray, run: int) -> np.ndarray:
    """Run ``run`` of an (E, R, ...) record (the last run when it has fewer)."""
    a = np.asarray(a)
    return a[:, min(run, a.shape[1] - 1)] if a.ndim >= 2 else a


def _column(
    t_s: np.ndarray, a: np.ndarray, k: int | None = None, scale: float = 1.0, runs: bool = True
) -> Getter:
    """Column ``k`` (None: the whole series) of run r of ``a`` ((E, R, ...); ``runs`` False: of
    ``a`` itself, (E, ...), one run's record), times ``scale``."""

    def get(run: int) -> tuple[np.ndarray, np.ndarray]:
        v = _run(a, run) if runs else np.asarray(a)
        return np.asarray(t_s, float), np.asarray(v if k is None else v[:, k], float) * scale

    return get


def _nees(t_s: np.ndarray, r: MethodResult, block: str) -> Getter:
    """Run r's NEES of ``block``."""
    return lambda run: (np.asarray(t_s, float), np.asarray(_run(nees_series(r, block), run), float))


def _method_entries(method: str, r: MethodResult, prefix: str) -> dict[str, Getter]:
    """The per-epoch series of one method's results (``prefix``: "lc" or "lc/smoothed")."""
    t = r.t_s
    out = {f"{prefix}/{field}": _column(t, getattr(r, field)) for field in SERIES_FIELDS.values()}
    for block in block_dims(r):
        out[f"{prefix}/nees_{block}"] = _nees(t, r, block)
    for k, axis in enumerate(NED):
        out[f"{prefix}/est_{axis}_m"] = _column(t, r.est_pos_n, k)
        if r.est_vel_n is not None:
            out[f"{prefix}/est_vel_{axis}_mps"] = _column(t, r.est_vel_n, k)
    if r.est_euler_rad is not None:
        for k, angle in enumerate(EULER):
            out[f"{prefix}/est_{angle}_deg"] = _column(t, r.est_euler_rad, k, float(np.degrees(1.0)))
    for j, label in enumerate(r.state_labels or ()):
        if r.state_est is not None:
            out[f"{prefix}/state/{label}"] = _column(t, r.state_est, j)
        if r.state_sigma is not None:
            out[f"{prefix}/state/{label}_sigma"] = _column(t, r.state_sigma, j)
        if r.state_true is not None:
            out[f"{prefix}/state/{label}_true"] = _column(t, r.state_true, j)
    if r.sensor_est is not None:
        for j, state in enumerate(sensor_states(method)):
            name = f"{prefix}/sensor/{state.name}{SI_SUFFIX.get(state.unit, '')}"
            out[name] = _column(t, r.sensor_est, j)
            if r.sensor_sigma is not None:
                out[f"{name}_sigma"] = _column(t, r.sensor_sigma, j)
            if r.sensor_true is not None:
                out[f"{name}_true"] = _column(t, r.sensor_true, j)
    return out


def _rows(source: str, count: int) -> tuple[tuple[str, str], ...]:
    """Each measurement row of ``source``'s updates: its name (the registry's row label, else its
    number from 1) and the suffix of its unit (the source's columns' unit when they share one; the
    DVL's, the water-track's and the RPM fallback's velocities are in m/s)."""
    entry = SOURCES.get(source)
    labels = entry.row_labels if entry is not None and len(entry.row_labels) == count else ()
    units = {c.unit for c in entry.columns} if entry is not None else set()
    unit = "m/s" if source in VELOCITY_SOURCES else units.pop() if len(units) == 1 else "-"
    suffix = SI_SUFFIX.get(unit, "")
    return tuple((labels[k] if labels else str(k + 1), suffix) for k in range(count))


def _update_entries(prefix: str, source: str, rec: UpdateRecord) -> dict[str, Getter]:
    """Every update of the aiding source ``source`` (``prefix``: "lc/dvl"): each row's
    innovation, its 1-sigma (the square root of S's diagonal) and the measurement, then the
    update's NIS, test ratio and flags."""
    t = rec.t_s
    out: dict[str, Getter] = {}
    rows = rec.innovation.shape[2] if rec.innovation.ndim == 3 else 0
    sigma = np.sqrt(np.maximum(np.asarray(rec.innovation_var, float), 0.0))
    for k, (row, suffix) in enumerate(_rows(source, rows)):
        out[f"{prefix}/innovation_{row}{suffix}"] = _column(t, rec.innovation, k)
        out[f"{prefix}/innovation_{row}{suffix}_sigma"] = _column(t, sigma, k)
        out[f"{prefix}/z_{row}{suffix}"] = _column(t, rec.z, k)
    for field in ("nis", "test_ratio"):
        out[f"{prefix}/{field}"] = _column(t, getattr(rec, field))
    for field in ("fused", "rejected", "valid", "reset", "mode"):
        a = getattr(rec, field, None)
        if a is not None:
            out[f"{prefix}/{field}"] = _column(t, np.asarray(a, float))
    if rec.beams_available is not None:
        count = np.asarray(rec.beams_available, float).sum(axis=-1)
        out[f"{prefix}/beams_available"] = _column(t, count)
    return out


def _vkf_entries(method: str, trace: Mapping[str, np.ndarray]) -> dict[str, Getter]:
    """What the velocity Kalman filter learned at every ping (``MethodResult.vkf_trace``)."""
    t = trace["t_s"]
    out: dict[str, Getter] = {}
    for key, a in trace.items():
        a = np.asarray(a)
        if key == "t_s" or a.shape[:1] != np.shape(t):
            continue
        if a.ndim == 3:  # (U, R, k): the filter's state and its 1-sigma
            for k in range(a.shape[2]):
                out[f"{method}/vkf/{key}_{k + 1}"] = _column(t, a.astype(float), k)
        else:
            out[f"{method}/vkf/{key}"] = _column(t, a.astype(float))
    return out


def _sensor_entries(view: Mapping[str, Any]) -> dict[str, Getter]:
    """The run's raw measurements as app.figures.sensor_view.SensorView holds them (one run)."""
    t = view["t_s"]
    out: dict[str, Getter] = {}
    for k, axis in enumerate(BODY):
        out[f"sensors/imu/gyro_{axis}_radps"] = _column(t, view["gyro_b_radps"], k, runs=False)
        out[f"sensors/imu/accel_{axis}_mps2"] = _column(t, view["accel_b_mps2"], k, runs=False)
    for name, source in view["sources"].items():
        for part, columns in (("", source["columns"]), ("truth/", source["truth"])):
            for column, a in columns.items():
                unit = source["units"].get(column, "-")
                suffix = "" if unit_of(column) != "-" else SI_SUFFIX.get(unit, "")
                out[f"sensors/{name}/{part}{column}{suffix}"] = _column(
                    source["t_s"], np.asarray(a, float), runs=False
                )
    return out


def _truth_entries(truth: Mapping[str, Any]) -> dict[str, Getter]:
    """The truth at the output epochs (app.dashboard.truth_view.TruthView)."""
    t = truth["t_s"]
    out: dict[str, Getter] = {}
    for k, axis in enumerate(NED):
        out[f"truth/{axis}_m"] = _column(t, truth["pos_n"], k, runs=False)
    c_nb = np.asarray(truth["C_nb"], float)
    euler_deg = np.degrees(
        np.stack(
            [
                np.arctan2(c_nb[:, 2, 1], c_nb[:, 2, 2]),
                -np.arcsin(np.clip(c_nb[:, 2, 0], -1.0, 1.0)),
                np.arctan2(c_nb[:, 1, 0], c_nb[:, 0, 0]),
            ],
            axis=1,
        )
    )
    for k, angle in enumerate(EULER):
        out[f"truth/{angle}_deg"] = _column(t, euler_deg, k, runs=False)
    for key, label in (("altitude_m", "altitude_m"), ("propeller_rpm", "propeller_rpm")):
        if truth.get(key) is not None:
            out[f"truth/{label}"] = _column(t, np.asarray(truth[key], float), runs=False)
    for key, label in (("vel_n", "vel"), ("current_n_mps", "current")):
        if truth.get(key) is not None:
            for k, axis in enumerate(NED):
                out[f"truth/{label}_{axis}_mps"] = _column(t, np.asarray(truth[key], float), k, runs=False)
    return out


VELOCITY_SOURCES = ("dvl", "water", "rpm")
"""The updates whose rows are velocities [m/s] (the DVL's beams or axes, the water-track's, the RPM
fallback's body velocity), whatever their log columns' units."""


class Catalog:
    """Every series of a run (see the module docstring), by name, in the order a person reads them:
    the methods' (each: series, then its sources' updates, then smoothed), the sensors', the truth's.

    Parameters
    ----------
    results : method name -> its results (R runs)
    sensor_view : the run's raw measurements (app.figures.sensor_view.SensorView; one run), or None
    truth_view : the truth at the output epochs (app.dashboard.truth_view.TruthView), or None
    """

    def __init__(
        self,
        results: Mapping[str, MethodResult],
        sensor_view: Mapping[str, Any] | None = None,
        truth_view: Mapping[str, Any] | None = None,
    ) -> None:
        self.entries: dict[str, Getter] = {}
        self.runs = max(
            (int(np.shape(r.vel_err_mps)[1]) for r in results.values() if np.ndim(r.vel_err_mps) == 2),
            default=1,
        )
        for method, r in results.items():
            if not len(r.t_s):
                continue
            self.entries.update(_method_entries(method, r, method))
            for source, rec in r.updates.items():
                self.entries.update(_update_entries(f"{method}/{source}", source, rec))
            if r.vkf_trace is not None and len(r.vkf_trace.get("t_s", ())):
                self.entries.update(_vkf_entries(method, r.vkf_trace))
            if r.smoothed is not None and len(r.smoothed.t_s):
                self.entries.update(_method_entries(method, r.smoothed, f"{method}/smoothed"))
        self.sensor_run = None if sensor_view is None else int(sensor_view["run"])
        if sensor_view is not None and len(sensor_view["t_s"]):
            self.entries.update(_sensor_entries(sensor_view))
        if truth_view is not None and len(truth_view["t_s"]):
            self.entries.update(_truth_entries(truth_view))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.entries)

    def series(self, name: str, run: int = 0) -> Series:
        """The series ``name`` of run ``run`` (0-based; a sensor's of the run the Sensors tab holds).

        Raises
        ------
        KeyError
            ``name`` is not one of :attr:`names`; the message names it.
        """
        if name not in self.entries:
            raise KeyError(f"no series {name!r} in this run")
        t_s, value = self.entries[name](int(run))
        return Series(name, unit_of(name), t_s, value)
