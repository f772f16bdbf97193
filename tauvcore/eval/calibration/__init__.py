"""Calibration from logs with a reference (``tauv calibrate``): the DVL's mounting misalignment and
scale factor, and the IMU-to-reference boresight, each with its uncertainty.

Frames and angles are those of tauvcore.conventions: the DVL head's ``C_bh`` and the boresight
``C_rb``, each from ZYX angles (roll, pitch, yaw); the result is a ``[calibration]`` section
(tauvcore.config.CalibrationConfig) that the replay applies (tauvcore.eval.corrections).
docs/calibration.md states the method and what is observable; in short:

Boresight (first, since the DVL's reference velocity is resolved in the IMU's body): Wahba's
problem between the IMU and the reference over each interval of the reference's rows (thinned to
:data:`INTERVAL_S` apart). The reference's rotation over the interval relative to inertial space,
``log(exp([C_nr_a^T omega_in_n dt x]) C_nr_a^T C_nr_b) / dt``, against the IMU's, the coning-compensated
gyro increments composed over the interval (tauvcore.ins.strapdown.body_increments); and the
reference's mean specific force ``C_nr_a^T exp([omega_in_n dt/2 x]) ((v_b - v_a) / dt - g_n + (2
omega_ie_n + omega_en_n) x v)`` against the IMU's velocity increments rotated into the body at the
interval's start. The model ``r = C_rb b`` is solved by SVD (Markley's solution of Wahba's
problem), each kind weighted by its residual variance, twice (the weights of the first fit).

DVL: per ping (at the IMU sample nearest it, as the replay fuses it), the reference's velocity at
the DVL head in the IMU's body, ``v_ref_b = C_nb^T v_ref_n + omega_nb_b x l_dvl_b`` with
``C_nb = C_nr C_rb`` and ``omega_nb_b`` the gyro's rate over the two IMU intervals around the ping
less the earth and transport rates; the DVL measures ``v_h = (1 + s) C_bh^T v_ref_b`` (+ noise,
beam biases), each returned bottom-track beam ``y_k = b_k . v_h + bias_k`` (a beam table) or each
component of a logged head velocity (a body-velocity table, the biases seen through the configured
beams) one residual. The unknowns are the angles, ``s`` and each log's four beam biases under
their turn-on 1-sigma (``dvl.bias_mps``) as a prior: the least-squares solution
(scipy.optimize.least_squares, Levenberg-Marquardt with the analytic Jacobian), started from the
scaled Procrustes solution (SVD) of the pings' head velocities and from zero, the lower cost kept;
each log's residuals weighted by their own RMS; residuals beyond :data:`OUTLIER_SIGMAS` robust
sigmas left out. This is the velocity-based in-situ alignment of Kinsey & Whitcomb (2007, IEEE J.
Oceanic Eng. 32(2)) in the least-squares-on-SO(3) form of Troni & Whitcomb (2015, "Advances in in
situ alignment calibration of Doppler and high/low-end attitude sensors for underwater vehicle
navigation", J. Field Robotics 32(5)), with the scale factor as a fourth unknown.

Uncertainty, in parts that add up: the residuals' ("noise"), for the DVL the Gauss-Newton
covariance with the biases known, each log's information divided by the integrated
autocorrelation time ``tau`` of its residuals (each beam's or axis's series in ping order:
``1 + 2 sum rho_k`` over the lags before the first non-positive ``rho_k``; ``n`` residuals count
as ``n / tau``), for the boresight the sandwich ``F^-1 Omega F^-1`` with ``Omega`` the Newey-West
long-run covariance of each interval's score (its rate and force residuals share the gyro's noise,
which tilts gravity within the interval); "beam biases", what not knowing them adds (the marginal
covariance with them estimated, less the noise part: at constant speed a constant bias and a
misalignment are confounded, and this part then dominates); "boresight", the boresight's own
covariance through the DVL estimate's sensitivity to it; "IMU biases", the consider covariance
``S Sigma S^T`` of the IMU's turn-on biases (``imu.accel_bias_mg``, ``imu.gyro_bias_deg_per_h``,
with their walks' spread over the log), their effect on the pairs found by differences.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.config import CALIBRATION_BOUND_DEG, CalibrationConfig, Config
from tauvcore.eval.calibration.boresight import (
    INTERVAL_S,
    BoresightFit,
    Pairs,
    boresight_pairs,
    fit_boresight,
)
from tauvcore.eval.calibration.dvl_alignment import (
    DvlFit,
    DvlRows,
    dvl_rows,
    fit_dvl,
    predicted,
    zyx_partials,
)
from tauvcore.eval.calibration.estimate import (
    OUTLIER_SIGMAS,
    CalibrationError,
    Estimate,
    correlation_time,
    newey_west,
    rms,
)
from tauvcore.logs import Log
from tauvcore.validation import show_path

__all__ = [
    "INTERVAL_S",
    "OUTLIER_SIGMAS",
    "Calibration",
    "CalibrationError",
    "Estimate",
    "LogFit",
    "boresight_pairs",
    "calibrate",
    "correlation_time",
    "dvl_rows",
    "newey_west",
    "zyx_partials",
]

MIN_PINGS = 10
"""Fewest DVL pings (over all logs) the DVL's four unknowns are estimated from."""
MIN_INTERVALS = 10
"""Fewest reference intervals (over all logs) the boresight's three angles are estimated from."""


@dataclass(frozen=True)
class LogFit:
    """One log's share: its data, its residuals before and after the calibration of all logs, and
    its own estimates (the log alone; the DVL's with the boresight of all logs)."""

    name: str  # the log's name as given
    pings: int  # DVL pings used
    dvl_residuals: int  # DVL residuals used (beams, or three per ping of a body velocity)
    dvl_outliers: int  # DVL residuals left out (OUTLIER_SIGMAS)
    dvl_rms_before_mps: float  # RMS of the DVL residuals with no calibration, the beam biases that fit
    # them best taken out (as the filters' bias states would) [m/s]
    dvl_rms_after_mps: float  # ... with the calibration of all logs [m/s]
    dvl_tau: float  # integrated autocorrelation time of the DVL residuals [pings]
    intervals: int  # reference intervals used for the boresight
    rate_rms_before_dps: float  # RMS per axis of the rate residuals, no calibration [deg/s]
    rate_rms_after_dps: float  # ... with the boresight of all logs [deg/s]
    force_rms_before_mps2: float  # RMS per axis of the specific-force residuals, no calibration [m/s^2]
    force_rms_after_mps2: float  # ... with the boresight of all logs [m/s^2]
    dvl: Estimate | None  # this log's own DVL estimate; None without pings enough
    boresight: Estimate | None  # this log's own boresight; None without intervals enough


@dataclass(frozen=True)
class Calibration:
    """The calibration of all logs together (one vehicle: one mounting) and each log's share."""

    dvl: Estimate  # DVL_NAMES: roll, pitch, yaw [deg], scale factor [%]
    boresight: Estimate  # BORESIGHT_NAMES: roll, pitch, yaw [deg]
    logs: tuple[LogFit, ...]

    @property
    def config(self) -> CalibrationConfig:
        """The ``[calibration]`` section of the estimates."""
        v, b = self.dvl.value, self.boresight.value
        return CalibrationConfig(
            dvl_misalignment_deg=(float(v[0]), float(v[1]), float(v[2])),
            dvl_scale_factor_pct=float(v[3]),
            imu_boresight_deg=(float(b[0]), float(b[1]), float(b[2])),
        )


def _name(name: str, log: Log) -> str:
    """The log's name for a message: as given, else its source."""
    return name or log.source


def calibrate(logs: Sequence[tuple[str, Log, Config]], interval_s: float = INTERVAL_S) -> Calibration:
    """The DVL's misalignment and scale factor and the IMU's boresight from ``logs`` together
    (one vehicle), and each log's share (module docstring for the method).

    Parameters
    ----------
    logs : Sequence[tuple[str, Log, Config]]
        Each log's name (for messages and the table), the log (with a reference; a DVL table in
        one at least), and its configuration (its own ``log.toml`` under ``--config``: the DVL's
        beams, lever arm and bias 1-sigma, the IMU's turn-on biases, the earth).
    interval_s : float
        The boresight's shortest reference interval [s].

    Returns
    -------
    Calibration
        The estimates (angles [deg], scale factor [%]) with their covariances, and per log.

    Raises
    ------
    CalibrationError
        A log without a reference; no DVL pings or reference intervals enough; an estimated angle
        beyond :data:`~tauvcore.config.CALIBRATION_BOUND_DEG`.
    """
    if not logs:
        raise CalibrationError("no log to calibrate from")
    for name, log, _ in logs:
        if log.ref_t_s is None or log.ref_t_s.size < 2:
            raise CalibrationError(
                f"{show_path(_name(name, log))}: the log has no reference (a reference table of two rows or more): "
                "nothing to calibrate against"
            )
    pairs = [boresight_pairs(log, config, interval_s) for _, log, config in logs]
    intervals = sum(len(p.rate_r) for p in pairs)
    if intervals < MIN_INTERVALS:
        raise CalibrationError(
            f"{intervals} reference intervals of {interval_s:g} s that the IMU covers in all the logs: the "
            f"boresight needs {MIN_INTERVALS} at least"
        )
    bore = fit_boresight(pairs)
    with_dvl = [
        (i, dvl_rows(log, config)) for i, (_, log, config) in enumerate(logs) if log.dvl_t_s is not None
    ]
    pings = sum(np.unique(r.ping).size for _, r in with_dvl)
    if pings < MIN_PINGS:
        raise CalibrationError(
            f"{pings} DVL pings with a bottom-track velocity inside the reference's span in all the logs: "
            f"the DVL's misalignment and scale factor need {MIN_PINGS} at least"
        )
    P_beta = bore.estimate.cov * units.DEG**2
    dvl = fit_dvl([r for _, r in with_dvl], bore.C_rb, P_beta)
    _check_bound(dvl.estimate, "the DVL head's axes are not the IMU's body's")
    _check_bound(bore.estimate, "the IMU's axes are not the reference's body's")
    fits = [
        _boresight_share(_name(name, log), p, bore, i)
        for i, ((name, log, _), p) in enumerate(zip(logs, pairs, strict=True))
    ]
    for j, (i, rows) in enumerate(with_dvl):
        fits[i] = _with_dvl_share(fits[i], rows, dvl, j, bore.C_rb, P_beta)
    return Calibration(dvl=dvl.estimate, boresight=bore.estimate, logs=tuple(fits))


def _boresight_share(name: str, p: Pairs, bore: BoresightFit, i: int) -> LogFit:
    """Log ``i``'s share (named ``name``) of the boresight ``bore`` of all logs, ``p`` its pairs, and
    its own boresight; as yet without a DVL."""
    kr, kf = bore.keep[i]
    return LogFit(
        name=name,
        pings=0,
        dvl_residuals=0,
        dvl_outliers=0,
        dvl_rms_before_mps=np.nan,
        dvl_rms_after_mps=np.nan,
        dvl_tau=np.nan,
        intervals=len(p.rate_r),
        rate_rms_before_dps=rms((p.rate_r - p.rate_b)[kr]) / units.DEG,
        rate_rms_after_dps=rms((p.rate_r - p.rate_b @ bore.C_rb.T)[kr]) / units.DEG,
        force_rms_before_mps2=rms((p.force_r - p.force_b)[kf]),
        force_rms_after_mps2=rms((p.force_r - p.force_b @ bore.C_rb.T)[kf]),
        dvl=None,
        boresight=fit_boresight([p]).estimate if len(p.rate_r) >= MIN_INTERVALS else None,
    )


def _with_dvl_share(
    fit: LogFit, rows: DvlRows, dvl: DvlFit, j: int, C_rb: np.ndarray, P_beta: np.ndarray
) -> LogFit:
    """``fit`` with its log's share of the DVL's calibration ``dvl`` of all logs (``rows`` the
    ``j``-th of its logs, ``C_rb`` and ``P_beta`` the boresight and its covariance [rad^2]), and its
    own DVL estimate."""
    k = dvl.keep[j]
    e_before = _debiased((rows.z - predicted(np.zeros(4), rows, rows.v_ref_b(np.eye(3)))[0])[k], rows, k)
    e_after = _debiased((rows.z - predicted(dvl.theta, rows, rows.v_ref_b(C_rb))[0])[k], rows, k)
    n_pings = int(np.unique(rows.ping[k]).size)
    return dataclasses.replace(
        fit,
        pings=n_pings,
        dvl_residuals=int(k.sum()),
        dvl_outliers=int((~k).sum()),
        dvl_rms_before_mps=rms(e_before),
        dvl_rms_after_mps=rms(e_after),
        dvl_tau=dvl.tau[j],
        dvl=fit_dvl([rows], C_rb, P_beta).estimate if n_pings >= MIN_PINGS else None,
    )


def _debiased(e: np.ndarray, rows: DvlRows, keep: np.ndarray) -> np.ndarray:
    """Residuals ``e`` (n,) [m/s] of ``rows``' kept rows less the beam biases that fit them best
    under their prior (``min |e - D b|^2 / sigma_e^2 + |b|^2 / bias^2``): the residuals the
    calibration leaves once the filters' own bias states have done their part."""
    if rows.bias_sigma_mps <= 0.0 or e.size == 0:
        return e
    D = rows.D[keep]
    ratio = (rms(e) / rows.bias_sigma_mps) ** 2
    b = np.linalg.solve(D.T @ D + ratio * np.eye(4), D.T @ e)
    return e - D @ b


def _check_bound(estimate: Estimate, what: str) -> None:
    """CalibrationError if an estimated angle is beyond CALIBRATION_BOUND_DEG (a mounting, not a
    misalignment), naming it."""
    for name, unit, value in zip(estimate.names, estimate.units, estimate.value, strict=True):
        if unit == "deg" and abs(value) > CALIBRATION_BOUND_DEG:
            raise CalibrationError(
                f"{name} came out {value:.1f} deg, beyond the +-{CALIBRATION_BOUND_DEG:g} deg a calibration "
                f"corrects: {what} (describe the mounting first: the DVL's beam geometry, a bag's "
                "mounting_rpy_deg)"
            )
        if unit == "%" and abs(value) > 10.0:
            raise CalibrationError(
                f"{name} came out {value:.1f} %, beyond the +-10 % a calibration corrects: the DVL's velocity "
                "is not in metres per second, or not the vehicle's"
            )
