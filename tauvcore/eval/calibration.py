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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from tauvcore import units
from tauvcore.config import CALIBRATION_BOUND_DEG, CalibrationConfig, Config
from tauvcore.eval.replay import _epochs, _reference_at
from tauvcore.geo.earth import earth_rate_n_rps, gravity_n_mps2, transport_rate_n_rps
from tauvcore.geo.rotations import (
    C_nb_from_euler,
    euler_from_C_nb,
    euler_from_misalignment_jacobian,
    exp_so3,
    log_so3,
    skew,
)
from tauvcore.ins.strapdown import body_increments
from tauvcore.logs import Log
from tauvcore.validation import show_path

INTERVAL_S = 1.0
"""Shortest interval of the boresight's pairs [s]: the reference's rows thinned to this spacing
(a simulated log's reference is at the IMU's rate; one IMU sample's increments are mostly noise)."""
OUTLIER_SIGMAS = 5.0
"""A residual beyond this many robust sigmas (1.4826 times the median absolute deviation, per log)
of the first fit is left out of the second (a lost lock, a fish, a reference's jump)."""
MIN_PINGS = 10
"""Fewest DVL pings (over all logs) the DVL's four unknowns are estimated from."""
MIN_INTERVALS = 10
"""Fewest reference intervals (over all logs) the boresight's three angles are estimated from."""
DVL_NAMES = ("DVL misalignment roll", "DVL misalignment pitch", "DVL misalignment yaw", "DVL scale factor")
DVL_UNITS = ("deg", "deg", "deg", "%")
BORESIGHT_NAMES = ("IMU boresight roll", "IMU boresight pitch", "IMU boresight yaw")


class CalibrationError(ValueError):
    """A log cannot be calibrated from (no reference, no DVL pings, too short); one line naming it."""


@dataclass(frozen=True)
class Estimate:
    """Estimated quantities with their covariance and its parts."""

    names: tuple[str, ...]  # what each is (DVL_NAMES, BORESIGHT_NAMES)
    units: tuple[str, ...]  # the unit of each: "deg" or "%"
    value: np.ndarray  # (n,) in those units
    cov: np.ndarray  # (n, n) total covariance, in those units squared
    parts: dict[str, np.ndarray]  # name -> (n, n): "noise" (the residuals', correlation included) and
    # each consider part ("beam biases", "boresight", "IMU biases"); they add up to cov

    @property
    def sigma(self) -> np.ndarray:
        """(n,) 1-sigma of each, in its unit."""
        return np.sqrt(np.diag(self.cov))

    def part_sigma(self, name: str) -> np.ndarray:
        """(n,) the 1-sigma the part ``name`` alone gives, in each quantity's unit."""
        return np.sqrt(np.diag(self.parts[name]))


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


# ------------------------------------------------------------------------------------ helpers


def zyx_partials(euler: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``C = Rz(yaw) Ry(pitch) Rx(roll)`` and its derivatives by roll, pitch and yaw.

    Parameters
    ----------
    euler : numpy.ndarray
        ``[roll, pitch, yaw]`` [rad], shape (3,).

    Returns
    -------
    C : numpy.ndarray
        Shape (3, 3) [-] (tauvcore.geo.rotations.C_nb_from_euler).
    dC : numpy.ndarray
        Shape (3, 3, 3) [1/rad]: ``dC[j]`` is ``dC / d euler[j]`` (``dR_a / d t = R_a [e_a x]``).
    """
    r, p, y = (float(a) for a in euler)
    Rx = C_nb_from_euler(np.array([r, 0.0, 0.0]))
    Ry = C_nb_from_euler(np.array([0.0, p, 0.0]))
    Rz = C_nb_from_euler(np.array([0.0, 0.0, y]))
    ex, ey, ez = skew(np.eye(3))
    dC = np.stack([Rz @ Ry @ Rx @ ex, Rz @ Ry @ ey @ Rx, Rz @ ez @ Ry @ Rx])
    return Rz @ Ry @ Rx, dC


def correlation_time(series: np.ndarray) -> float:
    """Integrated autocorrelation time of a series about its mean: ``1 + 2 sum_{k>=1} rho_k`` over
    the lags before the first non-positive ``rho_k`` (at most a quarter of its length); 1 for a
    series of fewer than 8 values or no variance. ``n`` correlated values weigh as ``n / tau``
    independent ones.

    Parameters
    ----------
    series : numpy.ndarray
        Shape (n,), in time order.

    Returns
    -------
    float
        ``tau`` >= 1 [samples].
    """
    x = np.asarray(series, dtype=float) - np.mean(series)
    n = x.size
    if n < 8:
        return 1.0
    spectrum = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(spectrum * np.conj(spectrum), 2 * n)[: n // 4]
    if acf[0] <= 0.0:
        return 1.0
    rho = acf[1:] / acf[0]
    stop = np.flatnonzero(rho <= 0.0)
    kept = rho[: stop[0]] if stop.size else rho
    return float(1.0 + 2.0 * kept.sum())


def _robust_sigma(r: np.ndarray) -> float:
    """1.4826 times the median absolute deviation: a standard deviation that outliers leave alone."""
    return float(1.4826 * np.median(np.abs(r - np.median(r)))) if r.size else 0.0


def _earth_rates(
    log: Log, config: Config, pos: np.ndarray, vel_n: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The earth rate and the n frame's rate ``omega_in_n = omega_ie_n + omega_en_n`` [rad/s], (N, 3)
    each, along a geodetic reference (latitude, longitude, depth); a local one's at the configured
    origin, without transport rate (its frame is the flat earth's tangent plane)."""
    if log.ref_geodetic:
        lat, height = pos[:, 0], -pos[:, 2]
        ie = np.column_stack(earth_rate_n_rps(lat))
        en = np.column_stack(transport_rate_n_rps(lat, height, vel_n[:, 0], vel_n[:, 1]))
        return ie, ie + en
    ie = np.broadcast_to(config.earth.omega_ie_n, pos.shape).copy()
    return ie, ie


def _gravity_n(log: Log, config: Config, pos: np.ndarray) -> np.ndarray:
    """Plumb-bob gravity [m/s^2] in n, (N, 3): along a geodetic reference, else the origin's."""
    if log.ref_geodetic:
        return np.column_stack(gravity_n_mps2(pos[:, 0], -pos[:, 2]))
    return np.broadcast_to(config.earth.g_n, pos.shape).copy()


def _name(name: str, log: Log) -> str:
    """The log's name for a message: as given, else its source."""
    return name or log.source


# --------------------------------------------------------------------------------- boresight


@dataclass(frozen=True)
class _Pairs:
    """One log's boresight pairs: the reference's and the IMU's rate and specific force per interval."""

    rate_r: np.ndarray  # (n, 3) reference's rate relative to inertial space, its body r [rad/s]
    rate_b: np.ndarray  # (n, 3) the IMU's over the same interval, its body b [rad/s]
    force_r: np.ndarray  # (n, 3) reference's mean specific force, r at the interval's start [m/s^2]
    force_b: np.ndarray  # (n, 3) the IMU's, b at the interval's start [m/s^2]
    rate_by_gyro_bias: np.ndarray  # (n, 3, 3) d rate_b / d (gyro bias) [-]
    force_by_gyro_bias: np.ndarray  # (n, 3, 3) d force_b / d (gyro bias) [m/s]
    force_by_accel_bias: np.ndarray  # (n, 3, 3) d force_b / d (accelerometer bias) [-]
    gyro_bias_sigma_rps: float  # the IMU's gyro bias over the log, 1-sigma [rad/s]: turn-on and walk
    accel_bias_sigma_mps2: float  # ... accelerometer bias [m/s^2]


def boresight_pairs(log: Log, config: Config, interval_s: float = INTERVAL_S) -> _Pairs:
    """The boresight's vector pairs of one log (module docstring), one per interval between the
    reference's rows thinned to ``interval_s`` apart that the IMU covers.

    Parameters
    ----------
    log : Log
        A log with a reference (rows at times ``ref_t_s`` [s]) and IMU increments.
    config : Config
        Its configuration: the earth (origin, model) and the IMU's turn-on biases (1-sigma).
    interval_s : float
        Shortest interval [s].

    Returns
    -------
    _Pairs
        Rates [rad/s] and specific forces [m/s^2] of the reference (in its body r) and of the IMU
        (in b), (n, 3) each.
    """
    rt = log.ref_t_s
    assert rt is not None and log.ref_euler is not None and log.ref_vel_n is not None
    assert log.ref_position is not None
    chosen = [0]
    for i in range(1, rt.size):
        if rt[i] - rt[chosen[-1]] >= interval_s - 1e-9:
            chosen.append(i)
    rows = np.asarray(chosen)
    t_imu, dt = log.imu_t_s, log.dt_s
    a, b = rows[:-1], rows[1:]
    span = rt[b] - rt[a]
    j0 = np.searchsorted(t_imu, rt[a] + 0.5 * dt)  # first sample whose interval ends after t_a
    j1 = np.searchsorted(t_imu, rt[b] + 0.5 * dt)  # one past the last ending by t_b
    count = j1 - j0
    ok = (span <= 2.5 * max(interval_s, np.median(span) if span.size else interval_s)) & (j0 >= 1)
    ok &= (j1 <= t_imu.size) & (np.abs(count * dt - span) <= 0.5 * dt + 1e-9 * span)
    a, b, span, j0, count = a[ok], b[ok], span[ok], j0[ok], count[ok]
    rate_b, force_b = _imu_over_intervals(log.dtheta_b, log.dv_b, j0, count, span)
    # what a constant bias does to them, by differences: it turns with the body within an interval,
    # and a gyro's turns gravity in the IMU's own attitude, so it is not the bias itself
    gyro_rate, gyro_force, accel_force = (np.empty((a.size, 3, 3)) for _ in range(3))
    for i in range(3):
        step = np.zeros(3)
        step[i] = _GYRO_STEP_RPS
        r, f = _imu_over_intervals(log.dtheta_b + step * dt, log.dv_b, j0, count, span)
        gyro_rate[:, :, i], gyro_force[:, :, i] = (r - rate_b) / step[i], (f - force_b) / step[i]
        step[i] = _ACCEL_STEP_MPS2
        accel_force[:, :, i] = (
            _imu_over_intervals(log.dtheta_b, log.dv_b + step * dt, j0, count, span)[1] - force_b
        ) / step[i]
    pos, euler, vel = log.ref_position, log.ref_euler, log.ref_vel_n
    C_a, C_b = C_nb_from_euler(euler[a]), C_nb_from_euler(euler[b])
    ie, in_n = _earth_rates(log, config, pos[a], vel[a])
    Ct_a = np.swapaxes(C_a, -1, -2)
    turn_r = np.einsum("nij,nj->ni", Ct_a, in_n) * span[:, None]  # the n frame's own turn, in r_a
    rate_r = log_so3(exp_so3(turn_r) @ Ct_a @ C_b) / span[:, None]
    v_mid = 0.5 * (vel[a] + vel[b])
    accel_n = (vel[b] - vel[a]) / span[:, None] - _gravity_n(log, config, pos[a])
    accel_n = accel_n + np.cross(2.0 * ie + (in_n - ie), v_mid)
    force_n = np.einsum("nij,nj->ni", exp_so3(0.5 * in_n * span[:, None]), accel_n)
    force_r = np.einsum("nij,nj->ni", Ct_a, force_n)
    # the biases' walks over the log, as the spread of their mean over it (q^2 T / 3 for a walk of
    # density q over T), beside the turn-on value
    imu, length_s = config.imu, float(rt[-1] - rt[0])
    gyro_walk = imu.gyro_bias_rw_deg_per_s_per_sqrt_s * units.DEG * np.sqrt(length_s / 3.0)
    accel_walk = imu.accel_bias_rw_mps2_per_sqrt_s * np.sqrt(length_s / 3.0)
    return _Pairs(
        rate_r=rate_r,
        rate_b=rate_b,
        force_r=force_r,
        force_b=force_b,
        rate_by_gyro_bias=gyro_rate,
        force_by_gyro_bias=gyro_force,
        force_by_accel_bias=accel_force,
        gyro_bias_sigma_rps=float(np.hypot(imu.gyro_bias_deg_per_h * units.DEG_PER_HOUR, gyro_walk)),
        accel_bias_sigma_mps2=float(np.hypot(imu.accel_bias_mg * units.MG, accel_walk)),
    )


_GYRO_STEP_RPS = 1e-5
"""The gyro bias step of the sensitivities' differences [rad/s] (2 deg/h: the effect is linear)."""
_ACCEL_STEP_MPS2 = 1e-3
"""The accelerometer bias step [m/s^2]."""


def _imu_over_intervals(
    dtheta_b: np.ndarray, dv_b: np.ndarray, j0: np.ndarray, count: np.ndarray, span: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The IMU's mean rate relative to inertial space (n, 3) [rad/s] and mean specific force in the
    body at the interval's start (n, 3) [m/s^2] over each interval of ``count`` samples from ``j0``
    (``span`` [s] long): the coning- and sculling-compensated increments
    (tauvcore.ins.strapdown.body_increments) composed along the IMU's own attitude."""
    phi, dv_rot = body_increments(dtheta_b, dv_b)
    n = j0.size
    C = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()  # b at the interval's start <- b now
    dv = np.zeros((n, 3))
    for m in range(int(count.max()) if n else 0):
        active = m < count
        j = np.where(active, j0 + m, 0)
        dv += np.where(active[:, None], np.einsum("nij,nj->ni", C, dv_rot[j]), 0.0)
        C = np.where(active[:, None, None], C @ exp_so3(phi[j]), C)
    return log_so3(C) / span[:, None], dv / span[:, None]


def _wahba(ref: np.ndarray, body: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``C`` minimising ``sum w_i |ref_i - C body_i|^2`` over rotations (SVD; Markley 1988)."""
    B = np.einsum("n,ni,nj->ij", w, ref, body)
    U, _, Vt = np.linalg.svd(B)
    d = np.sign(np.linalg.det(U) * np.linalg.det(Vt))
    return U @ np.diag([1.0, 1.0, d]) @ Vt


@dataclass(frozen=True)
class _BoresightFit:
    C_rb: np.ndarray  # (3, 3)
    estimate: Estimate
    keep: list[tuple[np.ndarray, np.ndarray]]  # per log: rate rows kept, force rows kept
    sigma: list[tuple[float, float]]  # per log: rate [rad/s], force [m/s^2] residual 1-sigma per axis


def _fit_boresight(pairs: Sequence[_Pairs]) -> _BoresightFit:
    """The boresight of ``pairs`` (one vehicle), its covariance and parts (module docstring)."""
    keep = [(np.ones(len(p.rate_r), bool), np.ones(len(p.force_r), bool)) for p in pairs]
    C = np.eye(3)
    sigma: list[tuple[float, float]] = []
    for fit in range(2):
        sigma = []
        for p, (kr, kf) in zip(pairs, keep, strict=True):
            er, ef = p.rate_r - p.rate_b @ C.T, p.force_r - p.force_b @ C.T
            if fit == 1:  # outliers of the first fit, by each vector's largest component
                kr &= np.abs(er).max(axis=1) <= OUTLIER_SIGMAS * max(_robust_sigma(er[kr].ravel()), 1e-12)
                kf &= np.abs(ef).max(axis=1) <= OUTLIER_SIGMAS * max(_robust_sigma(ef[kf].ravel()), 1e-12)
            sigma.append((_rms(er[kr]), _rms(ef[kf])))
        ref = np.concatenate(
            [np.concatenate([p.rate_r[kr], p.force_r[kf]]) for p, (kr, kf) in zip(pairs, keep)]
        )
        body = np.concatenate(
            [np.concatenate([p.rate_b[kr], p.force_b[kf]]) for p, (kr, kf) in zip(pairs, keep)]
        )
        w = np.concatenate(
            [
                np.concatenate([np.full(kr.sum(), _weight(sr)), np.full(kf.sum(), _weight(sf))])
                for (kr, kf), (sr, sf) in zip(keep, sigma, strict=True)
            ]
        )
        C = _wahba(ref, body, w)
    # the residual sigmas at the solution, and the information: e = r - exp([d x]) C b ~ e0 + [Cb x] d
    info0, omega = np.zeros((3, 3)), np.zeros((3, 3))
    grads: list[tuple[np.ndarray, np.ndarray]] = []  # per log: sum w H^T C (rates), (forces)
    sigma = []
    for p, (kr, kf) in zip(pairs, keep, strict=True):
        er, ef = p.rate_r - p.rate_b @ C.T, p.force_r - p.force_b @ C.T
        sr, sf = _rms(er[kr]), _rms(ef[kf])  # three unknowns against thousands of residuals: no dof left
        sigma.append((sr, sf))
        by_gyro, by_accel, score = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((len(er), 3))
        for vec_b, e, s, k, d_gyro, d_accel in (
            (p.rate_b, er, sr, kr, p.rate_by_gyro_bias, None),
            (p.force_b, ef, sf, kf, p.force_by_gyro_bias, p.force_by_accel_bias),
        ):
            H = skew(vec_b @ C.T)[k]  # (n, 3, 3)
            info0 += _weight(s) * np.einsum("nki,nkj->ij", H, H)
            score[k] += _weight(s) * np.einsum("nki,nk->ni", H, e[k])
            # a bias moves e by -C d(vec_b)/d(bias) d(bias): its sum of w H^T C d(vec_b)/d(bias)
            by_gyro += _weight(s) * np.einsum("nki,kl,nlj->ij", H, C, d_gyro[k])
            if d_accel is not None:
                by_accel += _weight(s) * np.einsum("nki,kl,nlj->ij", H, C, d_accel[k])
        omega += newey_west(score)
        grads.append((by_gyro, by_accel))
    H0_inv = np.linalg.inv(info0)
    P_noise = H0_inv @ omega @ H0_inv
    P_bias = np.zeros((3, 3))
    for p, (g_rate, g_force) in zip(pairs, grads, strict=True):
        S_g, S_a = H0_inv @ g_rate, H0_inv @ g_force
        P_bias += p.gyro_bias_sigma_rps**2 * S_g @ S_g.T + p.accel_bias_sigma_mps2**2 * S_a @ S_a.T
    euler = euler_from_C_nb(C)
    G = euler_from_misalignment_jacobian(euler) / units.DEG  # rho [rad] -> euler [deg]
    parts_deg = {"noise": G @ P_noise @ G.T, "IMU biases": G @ P_bias @ G.T}
    estimate = Estimate(
        names=BORESIGHT_NAMES,
        units=("deg",) * 3,
        value=euler / units.DEG,
        cov=parts_deg["noise"] + parts_deg["IMU biases"],
        parts=parts_deg,
    )
    return _BoresightFit(C_rb=C, estimate=estimate, keep=keep, sigma=sigma)


def newey_west(score: np.ndarray) -> np.ndarray:
    """The long-run covariance of a series of scores (n, k) in time order (Newey & West 1987):
    ``sum_t g_t g_t^T`` plus each lag l <= L's ``(1 - l / (L + 1)) (G_l + G_l^T)``,
    ``L = floor(4 (n / 100)^(2/9))`` (their rule of the thumb: 5 lags at n = 400)."""
    n = len(score)
    lags = int(np.floor(4.0 * (n / 100.0) ** (2.0 / 9.0))) if n else 0
    out = score.T @ score
    for lag in range(1, min(lags, n - 1) + 1):
        G = score[lag:].T @ score[:-lag]
        out += (1.0 - lag / (lags + 1.0)) * (G + G.T)
    return out


def _rms(e: np.ndarray, dof: float = 1.0) -> float:
    """Root mean square of every entry of ``e`` (0 for none), divided by ``dof`` under the root."""
    return float(np.sqrt(np.mean(np.square(e)) / dof)) if e.size else 0.0


def _weight(sigma: float) -> float:
    return 1.0 / sigma**2 if sigma > 0.0 else 0.0


# ---------------------------------------------------------------------------------------- DVL


@dataclass(frozen=True)
class _DvlRows:
    """One log's DVL residual rows and what its reference velocity at the head is made of."""

    z: np.ndarray  # (n,) measured: a beam velocity, or a head-velocity component [m/s]
    d: np.ndarray  # (n, 3) the direction z is along, in the head frame h [-]
    ping: np.ndarray  # (n,) the row's ping (index into the arrays below)
    group: np.ndarray  # (n,) its beam (0-3) or axis (0-2): one series each for the correlation
    D: np.ndarray  # (n, 4) d z / d (beam biases) [-]
    v_head: np.ndarray  # (m, 3) each ping's head velocity (least squares of >= 3 beams), NaN if none
    C_nr: np.ndarray  # (m, 3, 3) reference attitude at the ping
    vel_n: np.ndarray  # (m, 3) reference velocity [m/s]
    omega_ib_b: np.ndarray  # (m, 3) gyro rate around the ping [rad/s]
    omega_in_n: np.ndarray  # (m, 3) n frame's rate [rad/s]
    l_dvl_b: np.ndarray  # (3,) lever arm [m]
    bias_sigma_mps: float  # the beams' turn-on bias, 1-sigma [m/s]

    def v_ref_b(self, C_rb: np.ndarray) -> np.ndarray:
        """(m, 3) the reference's velocity at the DVL head in the IMU's body [m/s]."""
        C_nb = self.C_nr @ C_rb
        v_b = np.einsum("mji,mj->mi", C_nb, self.vel_n)
        omega_nb_b = self.omega_ib_b - np.einsum("mji,mj->mi", C_nb, self.omega_in_n)
        return v_b + np.cross(omega_nb_b, self.l_dvl_b)


def dvl_rows(log: Log, config: Config) -> _DvlRows:
    """One log's DVL residual rows (module docstring): each returned bottom-track beam, or each
    component of a bottom-track head velocity, at pings within the reference's span whose IMU
    sample has a neighbour on either side.

    Parameters
    ----------
    log : Log
        A log with a reference and a DVL table (beams, or a body velocity taken as the head's).
    config : Config
        Its configuration: the beams ``dvl.A_b``, lever arm, beam bias 1-sigma, the earth.

    Returns
    -------
    _DvlRows
        The rows (n) and the pings' ingredients (m).
    """
    assert log.dvl_t_s is not None and log.ref_t_s is not None
    K = log.imu_t_s.size
    k, keep = _epochs(log, log.dvl_t_s)
    keep &= (k >= 1) & (k <= K - 2)
    t = log.imu_t_s[np.clip(k, 0, K - 1)]
    keep &= (t >= log.ref_t_s[0]) & (t <= log.ref_t_s[-1])
    idx = np.flatnonzero(keep)
    kk = k[idx]
    pos, euler, vel_n = _reference_at(log, log.imu_t_s[kk])
    _, in_n = _earth_rates(log, config, pos, vel_n)
    span = (log.imu_t_s[kk + 1] - log.imu_t_s[kk - 1])[:, None]
    omega_ib_b = (log.dtheta_b[kk] + log.dtheta_b[kk + 1]) / span
    A = config.dvl.A_b
    water = None if log.dvl_water_track is None else log.dvl_water_track[idx]
    if log.dvl_beams_mps is not None:
        y = log.dvl_beams_mps[idx]
        use = np.isfinite(y) & (True if water is None else ~water)
        ping, beam = np.nonzero(use)
        z, d, group = y[ping, beam], A[beam], beam
        D = np.eye(4)[beam]
        v_head = np.full((idx.size, 3), np.nan)
        for pattern in np.unique(use, axis=0):
            if pattern.sum() >= 3:
                same = (use == pattern).all(axis=1)
                v_head[same] = y[np.ix_(same, pattern)] @ np.linalg.pinv(A[pattern]).T
    else:
        v = log.dvl_body_mps[idx] if log.dvl_body_mps is not None else np.full((idx.size, 3), np.nan)
        good = np.isfinite(v).all(axis=1) & (True if water is None else ~water[:, 0])
        v_head = np.where(good[:, None], v, np.nan)
        ping = np.repeat(np.flatnonzero(good), 3)
        group = np.tile(np.arange(3), int(good.sum()))
        z, d = v[ping, group], np.eye(3)[group]
        D = np.linalg.pinv(A)[group]  # a bias pattern of the beams seen in the head velocity
    return _DvlRows(
        z=z,
        d=d,
        ping=ping,
        group=group,
        D=D,
        v_head=v_head,
        C_nr=C_nb_from_euler(euler),
        vel_n=vel_n,
        omega_ib_b=omega_ib_b,
        omega_in_n=in_n,
        l_dvl_b=config.dvl.l_dvl_b,
        bias_sigma_mps=config.dvl.bias_mps,
    )


def _predicted(theta: np.ndarray, rows: _DvlRows, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model's ``d . (1 + s) C_bh^T v_ref_b`` per row (n,) and its Jacobian (n, 4) by
    roll, pitch, yaw [rad] and s."""
    C, dC = zyx_partials(theta[:3])
    Vp = V[rows.ping]  # (n, 3)
    head = Vp @ C  # rows of C^T v
    pred = (1.0 + theta[3]) * np.einsum("ni,ni->n", rows.d, head)
    J = np.empty((pred.size, 4))
    for j in range(3):
        J[:, j] = (1.0 + theta[3]) * np.einsum("ni,ni->n", rows.d, Vp @ dC[j])
    J[:, 3] = np.einsum("ni,ni->n", rows.d, head)
    return pred, J


@dataclass(frozen=True)
class _DvlFit:
    theta: np.ndarray  # (4,) roll, pitch, yaw [rad], s [-]
    estimate: Estimate
    keep: list[np.ndarray]  # per log: rows kept
    sigma: list[float]  # per log: residual 1-sigma [m/s]
    tau: list[float]  # per log: correlation time of its residuals [pings]


def _procrustes(rows: Sequence[_DvlRows], V: Sequence[np.ndarray]) -> np.ndarray:
    """Scaled Procrustes start: ``C_bh^T``, ``s`` minimising ``sum |v_h - (1 + s) C_bh^T v_ref|^2``
    over the pings with a head velocity; zeros if none."""
    vh = np.concatenate([r.v_head for r in rows])
    vr = np.concatenate(list(V))
    ok = np.isfinite(vh).all(axis=1)
    if ok.sum() < 3:
        return np.zeros(4)
    R = _wahba(vh[ok], vr[ok], np.ones(int(ok.sum())))  # C_bh^T
    s = np.sum(vh[ok] * (vr[ok] @ R.T)) / np.sum(vr[ok] ** 2) - 1.0
    return np.concatenate([euler_from_C_nb(R.T), [s]])


def _fit_dvl(rows: Sequence[_DvlRows], C_rb: np.ndarray, P_boresight_rad: np.ndarray) -> _DvlFit:
    """The DVL's misalignment and scale factor from ``rows`` (one vehicle), with the boresight
    ``C_rb`` of covariance ``P_boresight_rad`` (its Euler angles [rad^2]); module docstring.

    The unknowns are ``x = [roll, pitch, yaw, s, b_1, ..., b_L]``: the four of the calibration
    and each log's four beam biases (a log of ``dvl.bias_mps`` zero has none), the biases with
    their turn-on 1-sigma as a prior (a row ``b / bias_mps`` each)."""
    V = [r.v_ref_b(C_rb) for r in rows]
    keep = [np.ones(r.z.size, bool) for r in rows]
    weights = [1.0] * len(rows)
    offsets, n_x = [], 4  # each log's biases' first index in x (-1: none)
    for r in rows:
        offsets.append(n_x if r.bias_sigma_mps > 0.0 else -1)
        n_x += 4 if r.bias_sigma_mps > 0.0 else 0

    def stacked(x: np.ndarray, Vs: Sequence[np.ndarray], prior: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (data rows of every log, then the biases' prior rows) and Jacobian."""
        res, jac = [], []
        for r, v, k, w, o in zip(rows, Vs, keep, weights, offsets, strict=True):
            pred, J = _predicted(x[:4], r, v)
            Jx = np.zeros((int(k.sum()), n_x))
            Jx[:, :4] = -w * J[k]
            e = r.z - pred
            if o >= 0:
                e = e - r.D @ x[o : o + 4]
                Jx[:, o : o + 4] = -w * r.D[k]
            res.append(w * e[k])
            jac.append(Jx)
        if prior:
            for r, o in zip(rows, offsets, strict=True):
                if o >= 0:
                    res.append(x[o : o + 4] / r.bias_sigma_mps)
                    Jp = np.zeros((4, n_x))
                    Jp[:, o : o + 4] = np.eye(4) / r.bias_sigma_mps
                    jac.append(Jp)
        return np.concatenate(res), np.concatenate(jac)

    def residuals(x: np.ndarray, i: int) -> np.ndarray:
        """Log ``i``'s data residuals at ``x``, unweighted, every row (n_i,) [m/s]."""
        r, o = rows[i], offsets[i]
        e = r.z - _predicted(x[:4], r, V[i])[0]
        return e - r.D @ x[o : o + 4] if o >= 0 else e

    x = np.zeros(n_x)
    for fit in range(2):
        starts = (
            [np.zeros(n_x), np.concatenate([_procrustes(rows, V), np.zeros(n_x - 4)])] if fit == 0 else [x]
        )
        best = None
        for x0 in starts:
            sol = least_squares(
                lambda x: stacked(x, V)[0],
                x0,
                jac=lambda x: stacked(x, V)[1],
                method="lm",
                xtol=1e-12,
                ftol=1e-12,
                gtol=1e-12,
            )
            if best is None or sol.cost < best.cost:
                best = sol
        assert best is not None
        x = best.x
        for i in range(len(rows)):
            e = residuals(x, i)
            if fit == 0:
                keep[i] = np.abs(e) <= OUTLIER_SIGMAS * max(_robust_sigma(e), 1e-9)
            weights[i] = 1.0 / max(_rms(e[keep[i]]), 1e-9)
    # covariance: each log's information over its correlation time, the biases' prior as it is
    n_rows = [int(k.sum()) for k in keep]
    sigma, tau = [], []
    for i in range(len(rows)):
        e = residuals(x, i)[keep[i]]
        s = _rms(e, dof=max(1.0 - (4.0 + (4 if offsets[i] >= 0 else 0)) / max(n_rows[i], 9), 0.1))
        weights[i] = 1.0 / max(s, 1e-9)
        sigma.append(s)
        tau.append(_series_tau(e, rows[i].group[keep[i]]))
    _, J_all = stacked(x, V, prior=False)
    row_tau = np.repeat(tau, n_rows)
    H_data = J_all.T @ (J_all / row_tau[:, None])
    H_prior = np.zeros((n_x, n_x))
    for r, o in zip(rows, offsets, strict=True):
        if o >= 0:
            H_prior[o : o + 4, o : o + 4] = np.eye(4) / r.bias_sigma_mps**2
    P = np.linalg.inv(H_data + H_prior)[:4, :4]
    P_known = np.linalg.inv(H_data[:4, :4])  # were the biases known
    # the boresight's share: d x / d beta = -(J^T J + prior)^-1 J^T d r / d beta, central differences
    step = 1e-6
    beta = euler_from_C_nb(C_rb)
    dr = np.zeros((J_all.shape[0], 3))
    for j in range(3):
        plus, minus = beta.copy(), beta.copy()
        plus[j] += step
        minus[j] -= step
        r_plus = stacked(x, [r.v_ref_b(C_nb_from_euler(plus)) for r in rows], prior=False)[0]
        r_minus = stacked(x, [r.v_ref_b(C_nb_from_euler(minus)) for r in rows], prior=False)[0]
        dr[:, j] = (r_plus - r_minus) / (2.0 * step)
    S_beta = (np.linalg.inv(J_all.T @ J_all + H_prior) @ J_all.T @ dr)[:4]
    scale = np.diag([1.0 / units.DEG] * 3 + [1.0 / units.PERCENT])
    parts = {
        name: scale @ Pp @ scale
        for name, Pp in (
            ("noise", P_known),
            ("beam biases", P - P_known),
            ("boresight", S_beta @ P_boresight_rad @ S_beta.T),
        )
    }
    estimate = Estimate(
        names=DVL_NAMES,
        units=DVL_UNITS,
        value=scale @ x[:4],
        cov=sum(parts.values(), np.zeros((4, 4))),
        parts=parts,
    )
    return _DvlFit(theta=x[:4], estimate=estimate, keep=keep, sigma=sigma, tau=tau)


def _series_tau(e: np.ndarray, group: np.ndarray) -> float:
    """The correlation time of residuals ``e`` (n,), each group's series (a beam's, an axis's) in
    ping order, averaged weighted by its length."""
    taus, counts = [], []
    for g in np.unique(group):
        series = e[group == g]
        taus.append(correlation_time(series))
        counts.append(series.size)
    return float(np.average(taus, weights=counts)) if counts else 1.0


# ------------------------------------------------------------------------------------- public


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
    bore = _fit_boresight(pairs)
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
    dvl = _fit_dvl([r for _, r in with_dvl], bore.C_rb, P_beta)
    _check_bound(dvl.estimate, "the DVL head's axes are not the IMU's body's")
    _check_bound(bore.estimate, "the IMU's axes are not the reference's body's")
    fits = []
    dvl_of = {i: j for j, (i, _) in enumerate(with_dvl)}
    for i, ((name, log, _), p) in enumerate(zip(logs, pairs, strict=True)):
        kr, kf = bore.keep[i]
        own_bore = _fit_boresight([p]).estimate if len(p.rate_r) >= MIN_INTERVALS else None
        rate_before = _rms((p.rate_r - p.rate_b)[kr]) / units.DEG
        rate_after = _rms((p.rate_r - p.rate_b @ bore.C_rb.T)[kr]) / units.DEG
        force_before = _rms((p.force_r - p.force_b)[kf])
        force_after = _rms((p.force_r - p.force_b @ bore.C_rb.T)[kf])
        j = dvl_of.get(i)
        if j is None:
            fits.append(
                LogFit(
                    name=_name(name, log),
                    pings=0,
                    dvl_residuals=0,
                    dvl_outliers=0,
                    dvl_rms_before_mps=np.nan,
                    dvl_rms_after_mps=np.nan,
                    dvl_tau=np.nan,
                    intervals=len(p.rate_r),
                    rate_rms_before_dps=rate_before,
                    rate_rms_after_dps=rate_after,
                    force_rms_before_mps2=force_before,
                    force_rms_after_mps2=force_after,
                    dvl=None,
                    boresight=own_bore,
                )
            )
            continue
        rows = with_dvl[j][1]
        k = dvl.keep[j]
        e_before = _debiased((rows.z - _predicted(np.zeros(4), rows, rows.v_ref_b(np.eye(3)))[0])[k], rows, k)
        e_after = _debiased((rows.z - _predicted(dvl.theta, rows, rows.v_ref_b(bore.C_rb))[0])[k], rows, k)
        n_pings = int(np.unique(rows.ping[k]).size)
        own = _fit_dvl([rows], bore.C_rb, P_beta).estimate if n_pings >= MIN_PINGS else None
        fits.append(
            LogFit(
                name=_name(name, log),
                pings=n_pings,
                dvl_residuals=int(k.sum()),
                dvl_outliers=int((~k).sum()),
                dvl_rms_before_mps=_rms(e_before),
                dvl_rms_after_mps=_rms(e_after),
                dvl_tau=dvl.tau[j],
                intervals=len(p.rate_r),
                rate_rms_before_dps=rate_before,
                rate_rms_after_dps=rate_after,
                force_rms_before_mps2=force_before,
                force_rms_after_mps2=force_after,
                dvl=own,
                boresight=own_bore,
            )
        )
    return Calibration(dvl=dvl.estimate, boresight=bore.estimate, logs=tuple(fits))


def _debiased(e: np.ndarray, rows: _DvlRows, keep: np.ndarray) -> np.ndarray:
    """Residuals ``e`` (n,) [m/s] of ``rows``' kept rows less the beam biases that fit them best
    under their prior (``min |e - D b|^2 / sigma_e^2 + |b|^2 / bias^2``): the residuals the
    calibration leaves once the filters' own bias states have done their part."""
    if rows.bias_sigma_mps <= 0.0 or e.size == 0:
        return e
    D = rows.D[keep]
    ratio = (_rms(e) / rows.bias_sigma_mps) ** 2
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
