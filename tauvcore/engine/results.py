"""What the engine hands out: each method's results over R runs, with a record of every update of
every aiding source, and the degrees of freedom of the NEES they carry.

Plain arrays and dataclasses (numpy only): judging results (tauvcore.eval) and drawing them (app)
does not load the compiled engine."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore.filter.layout import NEES_BLOCKS, STATE

BLOCK_DIMS: dict[str, int] = {"full": STATE.dim, **{name: len(ix) for name, ix in NEES_BLOCKS.items()}}
"""Degrees of freedom of every NEES the results carry: the full state and each block."""
YOO_BLOCK_DIMS: dict[str, int] = {"full": 12, "pos": 3, "vel": 3, "tilt": 2, "heading": 1, "sensor": 6}
"""The same for Yoo 2014's 12-state filter (tauvcore.engine.yoo_bank; no position state, so its
position NEES is NaN throughout)."""


def block_dims(method: str) -> dict[str, int]:
    """NEES dimensions of a method's results, by the method's name.

    By name, not from a :class:`MethodResult`: a study's chunks carry only series.

    Parameters
    ----------
    method : str
        The method's name (a key of ``config.run.methods``; Yoo 2014's are those of
        ``tauvcore.config.YOO_METHODS``).

    Returns
    -------
    dict[str, int]
        Block name ("full" and each NEES block) -> its degrees of freedom: :data:`YOO_BLOCK_DIMS`
        for a Yoo 2014 method, :data:`BLOCK_DIMS` for the others.
    """
    from tauvcore.config import YOO_METHODS

    return YOO_BLOCK_DIMS if method in YOO_METHODS else BLOCK_DIMS


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


def method_result(
    method: str,
    m: int,
    t_s: np.ndarray,
    series: np.ndarray,
    epochs: dict[str, np.ndarray],
    diverged_at_s: np.ndarray,
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
        ``est_pos_n`` (T, M, R, 3) [m] NED, ``est_vel_n`` (T, M, R, 3) [m/s] NED and
        ``est_euler`` (T, M, R, 3) roll, pitch, yaw [rad].
    diverged_at_s : numpy.ndarray
        The monitor's first flag per run, shape (R,) [s] (NaN: none).
    **fields
        The rest of :class:`MethodResult` as they are (``p_floor_count``, ``updates``,
        ``block_dims``, ``vkf_trace``).

    Returns
    -------
    MethodResult
        Method ``m``'s results: series (T, R), estimates (T, R, 3), ``diverged`` (R,) where
        ``diverged_at_s`` is not NaN.
    """
    return MethodResult(
        method=method,
        t_s=t_s,
        **{name: series[j][:, m] for j, name in enumerate(SERIES_FIELDS.values())},
        nees_block=epochs["nees_block"][:, m],
        est_pos_n=epochs["est_pos_n"][:, m],
        est_vel_n=epochs["est_vel_n"][:, m],
        est_euler_rad=epochs["est_euler"][:, m],
        diverged=~np.isnan(diverged_at_s),
        diverged_at_s=diverged_at_s,
        **fields,
    )
