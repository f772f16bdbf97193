"""The IMU-to-reference boresight (tauvcore.eval.calibration): Wahba's problem between the IMU's and
the reference's rates and specific forces over the reference's intervals, its covariance and parts."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.config import Config
from tauvcore.eval.calibration.estimate import OUTLIER_SIGMAS, Estimate, newey_west, rms, robust_sigma, weight
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

INTERVAL_S = 1.0
"""Shortest interval of the boresight's pairs [s]: the reference's rows thinned to this spacing
(a simulated log's reference is at the IMU's rate; one IMU sample's increments are mostly noise)."""

BORESIGHT_NAMES = ("IMU boresight roll", "IMU boresight pitch", "IMU boresight yaw")


def earth_rates(
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


def gravity_n(log: Log, config: Config, pos: np.ndarray) -> np.ndarray:
    """Plumb-bob gravity [m/s^2] in n, (N, 3): along a geodetic reference, else the origin's."""
    if log.ref_geodetic:
        return np.column_stack(gravity_n_mps2(pos[:, 0], -pos[:, 2]))
    return np.broadcast_to(config.earth.g_n, pos.shape).copy()


@dataclass(frozen=True)
class Pairs:
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


def boresight_pairs(log: Log, config: Config, interval_s: float = INTERVAL_S) -> Pairs:
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
    Pairs
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
    rate_b, force_b = imu_over_intervals(log.dtheta_b, log.dv_b, j0, count, span)
    # what a constant bias does to them, by differences: it turns with the body within an interval,
    # and a gyro's turns gravity in the IMU's own attitude, so it is not the bias itself
    gyro_rate, gyro_force, accel_force = (np.empty((a.size, 3, 3)) for _ in range(3))
    for i in range(3):
        step = np.zeros(3)
        step[i] = _GYRO_STEP_RPS
        r, f = imu_over_intervals(log.dtheta_b + step * dt, log.dv_b, j0, count, span)
        gyro_rate[:, :, i], gyro_force[:, :, i] = (r - rate_b) / step[i], (f - force_b) / step[i]
        step[i] = _ACCEL_STEP_MPS2
        accel_force[:, :, i] = (
            imu_over_intervals(log.dtheta_b, log.dv_b + step * dt, j0, count, span)[1] - force_b
        ) / step[i]
    pos, euler, vel = log.ref_position, log.ref_euler, log.ref_vel_n
    C_a, C_b = C_nb_from_euler(euler[a]), C_nb_from_euler(euler[b])
    ie, in_n = earth_rates(log, config, pos[a], vel[a])
    Ct_a = np.swapaxes(C_a, -1, -2)
    turn_r = np.einsum("nij,nj->ni", Ct_a, in_n) * span[:, None]  # the n frame's own turn, in r_a
    rate_r = log_so3(exp_so3(turn_r) @ Ct_a @ C_b) / span[:, None]
    v_mid = 0.5 * (vel[a] + vel[b])
    accel_n = (vel[b] - vel[a]) / span[:, None] - gravity_n(log, config, pos[a])
    accel_n = accel_n + np.cross(2.0 * ie + (in_n - ie), v_mid)
    force_n = np.einsum("nij,nj->ni", exp_so3(0.5 * in_n * span[:, None]), accel_n)
    force_r = np.einsum("nij,nj->ni", Ct_a, force_n)
    # the biases' walks over the log, as the spread of their mean over it (q^2 T / 3 for a walk of
    # density q over T), beside the turn-on value
    imu, length_s = config.imu, float(rt[-1] - rt[0])
    gyro_walk = imu.gyro_bias_rw_deg_per_s_per_sqrt_s * units.DEG * np.sqrt(length_s / 3.0)
    accel_walk = imu.accel_bias_rw_mps2_per_sqrt_s * np.sqrt(length_s / 3.0)
    return Pairs(
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


def imu_over_intervals(
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


def wahba(ref: np.ndarray, body: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``C`` minimising ``sum w_i |ref_i - C body_i|^2`` over rotations (SVD; Markley 1988)."""
    B = np.einsum("n,ni,nj->ij", w, ref, body)
    U, _, Vt = np.linalg.svd(B)
    d = np.sign(np.linalg.det(U) * np.linalg.det(Vt))
    return U @ np.diag([1.0, 1.0, d]) @ Vt


@dataclass(frozen=True)
class BoresightFit:
    C_rb: np.ndarray  # (3, 3)
    estimate: Estimate
    keep: list[tuple[np.ndarray, np.ndarray]]  # per log: rate rows kept, force rows kept
    sigma: list[tuple[float, float]]  # per log: rate [rad/s], force [m/s^2] residual 1-sigma per axis


def fit_boresight(pairs: Sequence[Pairs]) -> BoresightFit:
    """The boresight of ``pairs`` (one vehicle), its covariance and parts (module docstring)."""
    keep = [(np.ones(len(p.rate_r), bool), np.ones(len(p.force_r), bool)) for p in pairs]
    C = np.eye(3)
    sigma: list[tuple[float, float]] = []
    for fit in range(2):
        sigma = []
        for p, (kr, kf) in zip(pairs, keep, strict=True):
            er, ef = p.rate_r - p.rate_b @ C.T, p.force_r - p.force_b @ C.T
            if fit == 1:  # outliers of the first fit, by each vector's largest component
                kr &= np.abs(er).max(axis=1) <= OUTLIER_SIGMAS * max(robust_sigma(er[kr].ravel()), 1e-12)
                kf &= np.abs(ef).max(axis=1) <= OUTLIER_SIGMAS * max(robust_sigma(ef[kf].ravel()), 1e-12)
            sigma.append((rms(er[kr]), rms(ef[kf])))
        ref = np.concatenate(
            [np.concatenate([p.rate_r[kr], p.force_r[kf]]) for p, (kr, kf) in zip(pairs, keep)]
        )
        body = np.concatenate(
            [np.concatenate([p.rate_b[kr], p.force_b[kf]]) for p, (kr, kf) in zip(pairs, keep)]
        )
        w = np.concatenate(
            [
                np.concatenate([np.full(kr.sum(), weight(sr)), np.full(kf.sum(), weight(sf))])
                for (kr, kf), (sr, sf) in zip(keep, sigma, strict=True)
            ]
        )
        C = wahba(ref, body, w)
    # the residual sigmas at the solution, and the information: e = r - exp([d x]) C b ~ e0 + [Cb x] d
    info0, omega = np.zeros((3, 3)), np.zeros((3, 3))
    grads: list[tuple[np.ndarray, np.ndarray]] = []  # per log: sum w H^T C (rates), (forces)
    sigma = []
    for p, (kr, kf) in zip(pairs, keep, strict=True):
        er, ef = p.rate_r - p.rate_b @ C.T, p.force_r - p.force_b @ C.T
        sr, sf = rms(er[kr]), rms(ef[kf])  # three unknowns against thousands of residuals: no dof left
        sigma.append((sr, sf))
        by_gyro, by_accel, score = np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((len(er), 3))
        for vec_b, e, s, k, d_gyro, d_accel in (
            (p.rate_b, er, sr, kr, p.rate_by_gyro_bias, None),
            (p.force_b, ef, sf, kf, p.force_by_gyro_bias, p.force_by_accel_bias),
        ):
            H = skew(vec_b @ C.T)[k]  # (n, 3, 3)
            info0 += weight(s) * np.einsum("nki,nkj->ij", H, H)
            score[k] += weight(s) * np.einsum("nki,nk->ni", H, e[k])
            # a bias moves e by -C d(vec_b)/d(bias) d(bias): its sum of w H^T C d(vec_b)/d(bias)
            by_gyro += weight(s) * np.einsum("nki,kl,nlj->ij", H, C, d_gyro[k])
            if d_accel is not None:
                by_accel += weight(s) * np.einsum("nki,kl,nlj->ij", H, C, d_accel[k])
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
    return BoresightFit(C_rb=C, estimate=estimate, keep=keep, sigma=sigma)
