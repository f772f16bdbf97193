"""What the Sensors tab draws of a run's raw data: one run's IMU and every aiding source's
measurements, thinned for a browser, gathered chunk by chunk as the engine generates them (or
from a replayed log whole).

The IMU is sampled at the output epochs (every ``step``-th IMU sample, as the truth the 3-D view
draws; at most :data:`MAX_SOURCE_EPOCHS` of them): its angular rate ``dtheta / dt`` [rad/s] and specific force ``dv / dt`` [m/s^2] in the body
frame (FRD), the sample's own increment, not an average (what the filter integrates, aliased as a
10 Hz look at a 200 Hz sensor is). Every source of the registry (tauvcore.aiding.sources: the DVL,
depth, the magnetometer, the echo sounder, the RPM, a plug-in's) gives its log columns at its own
epochs, at most :data:`MAX_SOURCE_EPOCHS` of them (evenly thinned, the last kept), with the
columns of its truth where the simulation (or the log) has them. The DVL's beams also carry their
state at each ping (app.figures.scene.beam_states: returning, lost, switched off).
"""

from __future__ import annotations

from typing import Any, NotRequired, TypedDict

import numpy as np

from app.figures.scene import BEAM_OUTAGE, BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_WATER
from tauvcore.aiding.dvl_beams import WATER_BEAMS, WATER_TRACK
from tauvcore.aiding.sources import SOURCES
from tauvcore.engine.simulation import SimChunk

MAX_SOURCE_EPOCHS = 4000
"""A source's epochs (and the IMU's output epochs) kept for the tab: a 1 Hz DVL over an hour, the
IMU over 400 s at 10 Hz; longer ones evenly thinned, the last kept (the figure draws 800 points)."""
BEAM_STATE_CODES = (BEAM_RETURNING, BEAM_OUTAGE, BEAM_SWITCHED_OFF, BEAM_WATER)
"""The DVL beam states of :attr:`SourceView.beam_state`, by their code (index)."""


class SourceView(TypedDict):
    """One aiding source's measurements of one run."""

    label: str  # the registry's label ("DVL, 4 beams", ...)
    t_s: np.ndarray  # (E,) its epochs [s]
    columns: dict[str, np.ndarray]  # log column name -> (E,) in the column's SI unit (NaN: none)
    units: dict[str, str]  # column name (and truth column name) -> its unit ("m", "m/s", "rad")
    truth: dict[str, np.ndarray]  # truth column name -> (E,) (absent where unknown)
    beam_state: np.ndarray | None  # (E, 4) int8 code into BEAM_STATE_CODES; DVL only
    # (E, 4) bool: the beam water-tracked beside its bottom-track (water_track "both"); DVL only
    water_beside: NotRequired[np.ndarray | None]


class SensorView(TypedDict):
    """The run's raw data as the Sensors tab draws it (see the module docstring)."""

    run: int  # which Monte Carlo run (0-based)
    runs: int  # of how many
    t_s: np.ndarray  # (T,) the IMU samples shown [s]
    gyro_b_radps: np.ndarray  # (T, 3) measured angular rate, body frame [rad/s]
    accel_b_mps2: np.ndarray  # (T, 3) measured specific force, body frame [m/s^2]
    sources: dict[str, SourceView]  # source name -> its measurements


def _run_of(a: np.ndarray, run: int) -> np.ndarray:
    """Column ``run`` of an (E, R) array (an (E,) one as it is)."""
    a = np.asarray(a)
    return a[:, run] if a.ndim >= 2 else a


class SensorViewBuilder:
    """Gathers :class:`SensorView` of run ``run`` from the chunks of a mission, in order.

    Parameters
    ----------
    step : output epochs every ``step`` IMU samples (the IMU rows kept).
    beam_mask : (4,) bool, the DVL beams switched on (``config.dvl.beam_mask``).
    run : the run shown (0-based).
    compact : thin what is kept as it comes, whenever a source holds more than twice
        MAX_SOURCE_EPOCHS epochs, so that memory does not grow with a long mission (the view is
        then thinned twice: still about evenly, the last epoch kept); False: thinned once, in
        :meth:`view`.
    """

    def __init__(self, step: int, beam_mask: np.ndarray, run: int = 0, compact: bool = False) -> None:
        self.step, self.run, self.compact = max(1, int(step)), int(run), compact
        self.beam_mask = np.asarray(beam_mask, dtype=bool)
        self.runs = 1
        self._t: list[np.ndarray] = []
        self._gyro: list[np.ndarray] = []
        self._accel: list[np.ndarray] = []
        self._sources: dict[str, dict[str, Any]] = {}

    def add(self, chunk: SimChunk) -> None:
        """Keep what the tab shows of ``chunk`` (chunks in mission order)."""
        imu, truth = chunk.imu, chunk.truth
        dt_s = float(truth.dt_s)
        self.runs = int(imu.dtheta_b.shape[1]) if imu.dtheta_b.ndim == 3 else 1
        run = min(self.run, self.runs - 1)
        rows = np.arange((-chunk.k0) % self.step, truth.num_samples, self.step)
        rows = rows[(rows + chunk.k0) > 0]  # sample 0 has no increment before it
        dtheta, dv = imu.dtheta_b[rows], imu.dv_b[rows]
        if dtheta.ndim == 3:
            dtheta, dv = dtheta[:, run], dv[:, run]
        self._t.append(np.asarray(truth.t_s)[rows])
        self._gyro.append(dtheta / dt_s)
        self._accel.append(dv / dt_s)
        for name, data in chunk.sources.items():
            source = SOURCES.get(name)
            if source is None or len(data.t_s) == 0:
                continue
            kept = self._sources.setdefault(name, {"t_s": [], "columns": {}, "truth": {}, "water": {}})
            kept["t_s"].append(np.asarray(data.t_s, float))
            for column in source.columns:
                if column.name in data.values:
                    kept["columns"].setdefault(column.name, []).append(_run_of(data.values[column.name], run))
            for column in source.truth_columns:
                if column.name in data.truth:
                    kept["truth"].setdefault(column.name, []).append(_run_of(data.truth[column.name], run))
            for column in (*WATER_TRACK, *WATER_BEAMS) if name == "dvl" else ():  # the beams' mode
                if column in data.values:
                    kept["water"].setdefault(column, []).append(_run_of(data.values[column], run))
            if self.compact:
                _compact(kept)
        if self.compact and sum(len(t) for t in self._t) > 2 * MAX_SOURCE_EPOCHS:
            keep = _thinned(sum(len(t) for t in self._t), MAX_SOURCE_EPOCHS)
            self._t, self._gyro, self._accel = (
                [np.concatenate(parts)[keep]] for parts in (self._t, self._gyro, self._accel)
            )

    def view(self) -> SensorView:
        """What was gathered so far."""
        empty3 = np.zeros((0, 3))
        sources: dict[str, SourceView] = {}
        for name, kept in self._sources.items():
            source = SOURCES[name]
            t_s = np.concatenate(kept["t_s"])
            keep = _thinned(t_s.size, MAX_SOURCE_EPOCHS)
            columns = {c: np.concatenate(parts)[keep] for c, parts in kept["columns"].items()}
            truth = {c: np.concatenate(parts)[keep] for c, parts in kept["truth"].items()}
            truth = {c: v for c, v in truth.items() if np.isfinite(v).any()}
            units = {c.name: c.unit for c in (*source.columns, *source.truth_columns)}
            beam_state = beside = None
            if name == "dvl" and columns:
                returned = np.stack([np.isfinite(v) for v in columns.values()], axis=1)
                modes = {c: np.concatenate(parts)[keep] for c, parts in kept["water"].items()}
                water = np.zeros_like(returned)
                if all(c in modes for c in WATER_TRACK):  # the beam's velocity is water-track
                    water = np.stack([modes[c] == 1.0 for c in WATER_TRACK], axis=1)
                    returned &= ~water
                elif all(c in modes for c in WATER_BEAMS):  # a water-track of its own beside it
                    water = np.stack([np.isfinite(modes[c]) for c in WATER_BEAMS], axis=1)
                    beside = returned & water
                beam_state = beam_state_codes(self.beam_mask, returned, water)
            sources[name] = {
                "label": source.label,
                "t_s": t_s[keep],
                "columns": columns,
                "units": units,
                "truth": truth,
                "beam_state": beam_state,
                "water_beside": beside,
            }
        t_s = np.concatenate(self._t) if self._t else np.zeros(0)
        keep = _thinned(t_s.size, MAX_SOURCE_EPOCHS)  # a long mission's IMU too: each message carries it
        return {
            "run": min(self.run, self.runs - 1),
            "runs": self.runs,
            "t_s": t_s[keep],
            "gyro_b_radps": (np.concatenate(self._gyro) if self._gyro else empty3)[keep],
            "accel_b_mps2": (np.concatenate(self._accel) if self._accel else empty3)[keep],
            "sources": sources,
        }


def _compact(kept: dict[str, Any]) -> None:
    """One source's kept epochs thinned to MAX_SOURCE_EPOCHS once they exceed twice that."""
    n = sum(len(t) for t in kept["t_s"])
    if n <= 2 * MAX_SOURCE_EPOCHS:
        return
    keep = _thinned(n, MAX_SOURCE_EPOCHS)
    kept["t_s"] = [np.concatenate(kept["t_s"])[keep]]
    for group in ("columns", "truth", "water"):
        kept[group] = {c: [np.concatenate(parts)[keep]] for c, parts in kept[group].items()}


def beam_state_codes(
    beam_mask: np.ndarray, returned: np.ndarray, water: np.ndarray | None = None
) -> np.ndarray:
    """(E, 4) int8 codes into :data:`BEAM_STATE_CODES` of each beam at each ping: switched off
    where ``beam_mask`` (4,) is False, else returning where ``returned`` (E, 4) is True (a
    bottom-track measurement in the row), else water-tracking where ``water`` (E, 4) is True,
    else lost (an outage, a drop-out, beyond the DVL's range)."""
    returned = np.asarray(returned, dtype=bool)
    lost = BEAM_STATE_CODES.index(BEAM_OUTAGE)
    if water is not None:
        lost = np.where(np.asarray(water, dtype=bool), BEAM_STATE_CODES.index(BEAM_WATER), lost)
    codes = np.where(returned, BEAM_STATE_CODES.index(BEAM_RETURNING), lost)
    codes = np.where(
        np.asarray(beam_mask, dtype=bool)[None, :], codes, BEAM_STATE_CODES.index(BEAM_SWITCHED_OFF)
    )
    return codes.astype(np.int8)


def _thinned(n: int, max_points: int) -> np.ndarray:
    """Indices of every k-th of ``n`` epochs and the last, at most about ``max_points``."""
    if n <= max_points:
        return np.arange(n)
    step = int(np.ceil(n / max_points))
    return np.r_[np.arange(0, n - 1, step), n - 1]


def sensor_view(chunk: SimChunk, step: int, beam_mask: np.ndarray, run: int = 0) -> SensorView:
    """:class:`SensorView` of a whole mission (a replayed log: ``SimChunk.whole(sim)``)."""
    builder = SensorViewBuilder(step, beam_mask, run)
    builder.add(chunk)
    return builder.view()
