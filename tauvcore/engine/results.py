"""What the engine hands out: each method's results over R runs, with a record of every update of
every aiding source, the degrees of freedom of the NEES they carry and, on request, the columns of
the estimated sensor errors (:data:`SENSOR_STATES`).

Plain arrays and dataclasses (numpy only): judging results (tauvcore.eval) and drawing them (app)
does not load the compiled engine."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import NamedTuple

import numpy as np

from tauvcore.filter.families import FAMILIES, family_of
from tauvcore.filter.layout import STATE

BLOCK_DIMS: dict[str, int] = FAMILIES["eskf"].block_dims
"""Degrees of freedom of every NEES the 20-state filter's results carry: the full state and each
block (each family's: tauvcore.filter.families, :func:`block_dims`)."""


def block_dims(method: str) -> dict[str, int]:
    """NEES dimensions of a method's results, by the method's name.

    By name, not from a :class:`MethodResult`: a study's chunks carry only series.

    Parameters
    ----------
    method : str
        The method's name (a key of ``config.run.methods``).

    Returns
    -------
    dict[str, int]
        Block name ("full" and each NEES block) -> its degrees of freedom: those of the method's
        family (tauvcore.filter.families.family_of).
    """
    return family_of(method).block_dims


class SensorState(NamedTuple):
    """One column of the sensor-error records (``MethodResult.sensor_est``, ``sensor_sigma``,
    ``sensor_true``): a component of a sensor-error block of the error state."""

    name: str  # the column's name, e.g. "ba_x", "bg_z", "b_dvl_1", "sf_dvl"
    block: str  # its block of tauvcore.filter.layout.STATE: "ba", "bg", "b_dvl" or "sf_dvl"
    component: int  # its place within the block (0 for the first)
    unit: str  # its SI unit: "m/s^2", "rad/s", "m/s"; "-" for the dimensionless scale factor
    label: str  # how a person reads it, e.g. "accelerometer bias x (body)"


_SENSOR_BLOCKS: dict[str, tuple[str, str, tuple[str, ...]]] = {
    "ba": ("m/s^2", "accelerometer bias {} (body)", ("x", "y", "z")),
    "bg": ("rad/s", "gyro bias {} (body)", ("x", "y", "z")),
    "b_dvl": ("m/s", "DVL beam {} bias", ("1", "2", "3", "4")),
    "sf_dvl": ("-", "DVL scale factor error", ("",)),
}
"""Each sensor-error block of the 20-state filter, in state order: its unit, its label and the
names of its components (as many as the block's slice in tauvcore.filter.layout.STATE has)."""


def _sensor_columns(blocks: tuple[str, ...]) -> tuple[SensorState, ...]:
    columns = []
    for block in blocks:
        unit, label, components = _SENSOR_BLOCKS[block]
        size = len(range(*getattr(STATE, block).indices(STATE.dim)))
        if size != len(components):
            raise ValueError(f"STATE.{block} has {size} states, the sensor columns name {len(components)}")
        for j, c in enumerate(components):
            columns.append(SensorState(f"{block}_{c}" if c else block, block, j, unit, label.format(c)))
    return tuple(columns)


SENSOR_COLUMNS: dict[str, tuple[SensorState, ...]] = {
    name: _sensor_columns(family.sensor_blocks) for name, family in FAMILIES.items()
}
"""Each family's columns of the sensor-error records (its ``sensor_blocks``, in state order)."""
SENSOR_STATES: tuple[SensorState, ...] = SENSOR_COLUMNS["eskf"]
"""The columns S = 11 of the 20-state filter's sensor-error records, in the order of the state
(and of the NEES block "sensor", tauvcore.filter.layout.NEES_BLOCKS): accelerometer bias x, y, z
[m/s^2] and gyro bias x, y, z [rad/s] in the body frame b, the four DVL beam biases [m/s] along
their beams, the DVL scale factor error [-]. Yoo 2014's filter has the first six (its biases: it
carries the DVL's scale factor and beam biases as consider states, never estimated)."""


def sensor_states(method: str) -> tuple[SensorState, ...]:
    """The columns of a method's sensor-error records, by the method's name.

    Parameters
    ----------
    method : str
        The method's name (a key of ``config.run.methods``).

    Returns
    -------
    tuple[SensorState, ...]
        One entry per column S of ``MethodResult.sensor_est``, ``sensor_sigma`` and
        ``sensor_true``: those of the method's family (:data:`SENSOR_COLUMNS`; S = 11 for the
        20-state filter, 6 for Yoo 2014's).
    """
    return SENSOR_COLUMNS[family_of(method).name]


@dataclass(frozen=True)
class UpdateRecord:
    """Every update of one aiding source for one method: U epochs x R runs."""

    t_s: np.ndarray  # (U,)
    z: np.ndarray  # (U, R, m) observation
    innovation: np.ndarray  # (U, R, m)
    innovation_var: np.ndarray  # (U, R, m) diagonal of S
    test_ratio: np.ndarray  # (U, R) max_i nu_i^2 / (gate^2 S_ii)
    fused: np.ndarray  # (U, R) bool
    rejected: np.ndarray  # (U, R) bool (failed the gate)
    valid: np.ndarray  # (U, R) bool (the source produced a measurement)
    fused_rows: np.ndarray  # (U, R, m) bool
    rejected_rows: np.ndarray  # (U, R, m) bool
    nis: np.ndarray  # (U, R) normalised innovation squared over the active rows, before the gate
    nis_dof: np.ndarray  # (U, R) int: its degrees of freedom (active rows)
    unusable: np.ndarray  # (U, R) bool: S not finite or not positive definite, nothing fused
    beams_available: np.ndarray | None = None  # (U, R, 4) DVL only: beams that returned
    mode: np.ndarray | None = None  # (U, R) DVL only: MODE_* code (coast, lc, partial, tc)
    measured_axes: np.ndarray | None = None  # (U, R, 3) DVL only: body axes the velocity carried
    elc_choice: np.ndarray | None = None  # (U, R, 3) ELC only: index into elc_select.CANDIDATES
    reset: np.ndarray | None = None  # (U, R) bool DVL only: the velocity reset to this ping after a
    #                                  lock-out (tauvcore.engine.lockout)
    log_det_s: np.ndarray | None = None  # (U, R) log det S over the active rows, before the gate (NaN
    #                                  where nis is NaN): the innovations' log-likelihood is
    #                                  -(nis + log_det_s + nis_dof log 2 pi) / 2 (tauvcore.eval.tuning);
    #                                  None: not recorded (Yoo 2014's bank)

    def until(self, t_end_s: float) -> UpdateRecord:
        """The updates up to a time: a stopped run's, or a batch cut to the epochs another reached.

        Parameters
        ----------
        t_end_s : float
            The last time kept [s] (inclusive).

        Returns
        -------
        UpdateRecord
            The updates at or before ``t_end_s``: every array cut after the last of them.
        """
        count = int(np.searchsorted(self.t_s, t_end_s, side="right"))
        return UpdateRecord(
            **{
                f.name: v[:count] if isinstance(v := getattr(self, f.name), np.ndarray) else v
                for f in fields(self)
            }
        )


@dataclass(frozen=True)
class MethodResult:
    """Per-epoch results of one method over R runs (time first)."""

    method: str
    t_s: np.ndarray  # (T,) output epochs [s]
    vel_err_mps: np.ndarray  # (T, R) |body velocity error|
    att_err_deg: np.ndarray  # (T, R) |misalignment| (tilt and heading together)
    pos_err_m: np.ndarray  # (T, R) |position error|
    vel_sigma_mps: np.ndarray  # (T, R) sqrt(trace P_vel), the filter's own 1-sigma of the norm
    att_sigma_deg: np.ndarray  # (T, R)
    pos_sigma_m: np.ndarray  # (T, R)
    nees: np.ndarray  # (T, R) full 20-state NEES against truth
    tilt_err_deg: np.ndarray  # (T, R) |(rho_N, rho_E)|: roll/pitch (levelling) error
    heading_err_deg: np.ndarray  # (T, R) |rho_D|: heading (azimuth) error
    tilt_sigma_deg: np.ndarray  # (T, R) sqrt(P_NN + P_EE) of the misalignment
    heading_sigma_deg: np.ndarray  # (T, R) sqrt(P_DD) of the misalignment
    nees_block: np.ndarray  # (T, R, B) NEES of each block of layout.NEES_BLOCKS (in its order)
    est_pos_n: np.ndarray  # (T, R, 3) estimated position, NED [m] from the sea-surface point above the start
    # (on WGS-84 in that point's tangent frame: tauvcore.geo.earth.geodetic_from_ned)
    diverged: np.ndarray  # (R,) bool: the divergence monitor flagged this run's solution
    diverged_at_s: np.ndarray  # (R,) time of the first flag [s], NaN if never
    p_floor_count: np.ndarray  # (R,) times an eigenvalue of P was raised to the floor
    updates: dict[str, UpdateRecord] = field(default_factory=dict)
    est_vel_n: np.ndarray | None = None  # (T, R, 3) estimated NED velocity [m/s]
    est_euler_rad: np.ndarray | None = None  # (T, R, 3) estimated roll, pitch, yaw [rad]
    block_dims: dict[str, int] | None = None  # NEES dimensions when not the 20-state filter's (Yoo 2014's
    # 12: tauvcore.engine.yoo_bank.BLOCK_DIMS); None: BLOCK_DIMS (the 20-state filter's)
    vkf_trace: dict[str, np.ndarray] | None = None  # the velocity Kalman filter at every ping (method vkf:
    # tauvcore.engine.yoo_bank.YooBank._vkf_series)
    sensor_est: np.ndarray | None = None  # (T, R, S) the filter's estimate of each sensor error, column j
    # in sensor_states(method)[j].unit (SI; biases in the body frame b, DVL beam biases along their beams);
    # None unless the run asked for them (mission.run(..., sensor_errors=True))
    sensor_sigma: np.ndarray | None = None  # (T, R, S) its 1-sigma, sqrt of P's diagonal, same units
    sensor_true: np.ndarray | None = None  # (T, R, S) the simulation's true value, same units: the IMU's
    # biases at the epoch's sample, the DVL's beam biases and scale factor of the latest ping (the first
    # ping's before it); NaN where the truth is unknown (a log's IMU; the DVL's of a mission without pings)
    state_labels: tuple[str, ...] | None = None  # the states the sources add (tauvcore.filter.layout.Layout),
    # each named with its unit ("current_north_mps"); None: none
    state_est: np.ndarray | None = None  # (T, R, E) their estimates, in the labels' units
    state_sigma: np.ndarray | None = None  # (T, R, E) their 1-sigma
    state_true: np.ndarray | None = None  # (T, R, E) their true values (NaN where unknown)
    smoothed: MethodResult | None = None  # the fixed-interval smoother's results over the same epochs (no
    # updates: the filter's), None unless the run asked for them (mission.run(..., smooth=...))
    smoother_cuts: np.ndarray | None = None  # (R,) with ``smoothed``: steps where the backward pass
    # started afresh (a prior not positive definite; tauvcore.filter.kernels.smoother)
    pos_cov_ne_m2: np.ndarray | None = None  # (T, R, 3) the horizontal position error's covariance
    # P_NN, P_NE, P_EE [m^2] (north, east of the error state, metres on both earths; the ellipses of a
    # map); None: the family has no position state (Yoo 2014's), or not recorded. Not part of the
    # JSON payload (SERIES_FIELDS)


SERIES_FIELDS = {
    "vel_err": "vel_err_mps",
    "att_err": "att_err_deg",
    "pos_err": "pos_err_m",
    "vel_sigma": "vel_sigma_mps",
    "att_sigma": "att_sigma_deg",
    "pos_sigma": "pos_sigma_m",
    "nees": "nees",
    "tilt_err": "tilt_err_deg",
    "heading_err": "heading_err_deg",
    "tilt_sigma": "tilt_sigma_deg",
    "heading_sigma": "heading_sigma_deg",
}
"""The per-epoch series both banks record, in the order of their rows (tauvcore.engine.loop.
SERIES_NAMES, tauvcore.engine.yoo_loop), and the MethodResult field each becomes."""
STATE_FIELDS = ("state_est", "state_sigma", "state_true")
"""The records of the states the sources add: the names of the 20-state bank's stores (T, M, R, E)
and of the MethodResult fields (T, R, E) they become (None without such states)."""
SENSOR_FIELDS = ("sensor_est", "sensor_sigma", "sensor_true")
"""The sensor-error records: the names of the banks' stores (T, M, R, S; no rows when not asked
for) and of the MethodResult fields (T, R, S) they become."""


def method_result(
    method: str,
    m: int,
    t_s: np.ndarray,
    series: np.ndarray,
    epochs: dict[str, np.ndarray],
    diverged_at_s: np.ndarray,
    sensor_errors: bool = False,
    **fields,
) -> MethodResult:
    """Method ``m``'s result from a bank's arrays over methods and runs.

    Parameters
    ----------
    method : str
        The method's name.
    m : int
        The method's index along the bank's method axis M.
    t_s : numpy.ndarray
        Output epochs, shape (T,) [s].
    series : numpy.ndarray
        The per-epoch series, shape (S, T, M, R), rows in :data:`SERIES_FIELDS` order (each in the
        unit its field's name carries: [m/s], [deg], [m]; NEES dimensionless).
    epochs : dict[str, numpy.ndarray]
        The other per-epoch arrays (T, M, R, ...) by name: ``nees_block`` (T, M, R, B),
        ``est_pos_n`` (T, M, R, 3) [m] NED, ``pos_cov_ne_m2`` (T, M, R, 3) [m^2] P_NN, P_NE, P_EE
        (absent: the family has no position state; the result's is None), ``est_vel_n`` (T, M, R, 3) [m/s] NED and
        ``est_euler`` (T, M, R, 3) roll, pitch, yaw [rad]; with ``sensor_errors`` also
        ``sensor_est``, ``sensor_sigma`` and ``sensor_true`` (T, M, R, S), in the units of
        :func:`sensor_states`.
    diverged_at_s : numpy.ndarray
        The monitor's first flag per run, shape (R,) [s] (NaN: none).
    sensor_errors : bool
        Whether the bank recorded the sensor errors; False: the result's ``sensor_est``,
        ``sensor_sigma`` and ``sensor_true`` are None.
    **fields
        The rest of :class:`MethodResult` as they are (``p_floor_count``, ``updates``,
        ``block_dims``, ``vkf_trace``).

    Returns
    -------
    MethodResult
        Method ``m``'s results: series (T, R), estimates (T, R, 3), sensor errors (T, R, S) or
        None, ``diverged`` (R,) where ``diverged_at_s`` is not NaN.
    """
    sensor = {name: epochs[name][:, m] if sensor_errors else None for name in SENSOR_FIELDS}
    pos_cov = epochs.get("pos_cov_ne_m2")
    if fields.get("state_labels"):
        sensor.update({name: epochs[name][:, m] for name in STATE_FIELDS})
    return MethodResult(
        method=method,
        t_s=t_s,
        **{name: series[j][:, m] for j, name in enumerate(SERIES_FIELDS.values())},
        nees_block=epochs["nees_block"][:, m],
        est_pos_n=epochs["est_pos_n"][:, m],
        pos_cov_ne_m2=None if pos_cov is None else pos_cov[:, m],
        est_vel_n=epochs["est_vel_n"][:, m],
        est_euler_rad=epochs["est_euler"][:, m],
        diverged=~np.isnan(diverged_at_s),
        diverged_at_s=diverged_at_s,
        **sensor,
        **fields,
    )
