"""Yoo 2014's velocity Kalman filter (eq. 20-29) in numpy and in filterpy: the references the
product's compiled step (tauvcore.filter.families.yoo.model_kernels.vkf_step) is held equal to
(test_vkf.py, beside this file), and the filter of tests/statistical/test_vkf_nees.py. The model
and its tuning are tauvcore.filter.vkf's."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.filter.vkf import DIM_X, SF, B, V, VkfConfig


@dataclass(frozen=True)
class VkfRun:
    """Per-step posteriors of the VKF, time first: ``(K, ...)`` with ``...`` = () for one run
    (:func:`vkf_filterpy`) or (R,) for a batch (:func:`run_vkf_batch`)."""

    x: np.ndarray  # (K, ..., 3) posterior [V m/s, sf m/s/rpm, b m/s]
    P: np.ndarray  # (K, ..., 3, 3) posterior covariance
    innovation: np.ndarray  # (K, ...) z - V_prior [m/s]; NaN where not updated
    innovation_var: np.ndarray  # (K, ...) S = P_VV_prior + R [m^2/s^2]; NaN where not updated

    @property
    def nis(self) -> np.ndarray:
        """Normalised innovation squared ``y^2 / S`` (K, ...); NaN where not updated."""
        return self.innovation**2 / self.innovation_var


def _check_inputs(rpm: np.ndarray, z_fwd: np.ndarray, dvl_valid: np.ndarray) -> tuple[np.ndarray, ...]:
    rpm = np.asarray(rpm, dtype=float)
    z_fwd = np.asarray(z_fwd, dtype=float)
    dvl_valid = np.asarray(dvl_valid)
    if rpm.shape != z_fwd.shape or rpm.shape != dvl_valid.shape or rpm.ndim < 1:
        raise ValueError(
            f"rpm {rpm.shape}, z_fwd {z_fwd.shape} and dvl_valid {dvl_valid.shape} must share "
            "one shape, time first"
        )
    if dvl_valid.dtype != bool:
        raise ValueError(f"dvl_valid must be boolean, got {dvl_valid.dtype}")
    if not np.isfinite(rpm).all():
        raise ValueError("rpm must be finite at every step (the prediction needs it)")
    if not np.isfinite(z_fwd[dvl_valid]).all():
        raise ValueError("z_fwd must be finite wherever dvl_valid is true")
    return rpm, z_fwd, dvl_valid


def vkf_filterpy(rpm: np.ndarray, z_fwd: np.ndarray, dvl_valid: np.ndarray, cfg: VkfConfig) -> VkfRun:
    """Reference VKF for ONE run with ``filterpy.kalman.KalmanFilter``, written the plain way.

    Step k: ``F`` from ``rpm[k]`` (eq. 24), ``predict()``, then ``update(z_fwd[k])`` if
    ``dvl_valid[k]``. ``rpm``, ``z_fwd`` [m/s], ``dvl_valid`` (K,) -> :class:`VkfRun` of shapes
    (K, 3), (K, 3, 3), (K,), (K,).
    """
    from filterpy.kalman import KalmanFilter

    rpm, z_fwd, dvl_valid = _check_inputs(rpm, z_fwd, dvl_valid)
    if rpm.ndim != 1:
        raise ValueError(f"vkf_filterpy runs one run: inputs (K,), got {rpm.shape}")
    kf = KalmanFilter(dim_x=DIM_X, dim_z=1)
    kf.x = cfg.x0.reshape(DIM_X, 1)
    kf.P = cfg.P0
    kf.Q = cfg.Q
    kf.R = np.array([[cfg.R]])
    kf.H = np.array([[1.0, 0.0, 0.0]])
    K = rpm.size
    xs, Ps = np.empty((K, DIM_X)), np.empty((K, DIM_X, DIM_X))
    ys, Ss = np.full(K, np.nan), np.full(K, np.nan)
    for k in range(K):
        kf.F = np.array([[0.0, rpm[k], -1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        kf.predict()
        if dvl_valid[k]:
            kf.update(z_fwd[k])
            ys[k], Ss[k] = kf.y[0, 0], kf.S[0, 0]
        xs[k], Ps[k] = kf.x[:, 0], kf.P
    return VkfRun(xs, Ps, ys, Ss)


def transition(rpm: np.ndarray) -> np.ndarray:
    """Eq. 24's ``F`` for each RPM: rpm (...) -> (..., 3, 3)."""
    rpm = np.asarray(rpm, dtype=float)
    F = np.zeros(rpm.shape + (DIM_X, DIM_X))
    F[..., V, SF] = rpm
    F[..., V, B] = -1.0
    F[..., SF, SF] = 1.0
    F[..., B, B] = 1.0
    return F


def predict(x: np.ndarray, P: np.ndarray, rpm: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``x <- F x``, ``P <- F P F^T + Q`` with F from ``rpm``. x (R, 3), P (R, 3, 3), rpm (R,),
    Q (3, 3) -> (x, P), P symmetrised."""
    F = transition(rpm)
    x = np.einsum("rij,rj->ri", F, x)
    P = np.einsum("rij,rjk,rlk->ril", F, P, F) + Q
    return x, 0.5 * (P + P.swapaxes(-1, -2))


def update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, valid: np.ndarray, noise_var: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Scalar update ``z = V + v`` (eq. 25-26) where ``valid``; elsewhere x, P unchanged.

    x (R, 3), P (R, 3, 3), z (R,) [m/s] (any value where not valid), valid (R,) bool, noise_var
    (the filter's R) [m^2/s^2] -> (x, P, innovation (R,), S (R,)), innovation and S NaN where not
    valid.

    Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T``: it stays symmetric positive
    semi-definite under round-off and for a non-optimal K, where ``(I - K H) P`` does not; the
    sf-b block is nearly singular while the RPM is constant (only ``rpm sf - b`` is observed), just
    where the short form's cancellation would hurt. It is also what filterpy's update computes.
    """
    y = np.where(valid, z, 0.0) - x[:, V]
    S = P[:, V, V] + noise_var
    gain = P[:, :, V] / S[:, None]  # K = P H^T / S, (R, 3)
    I_KH = np.eye(DIM_X) - gain[:, :, None] * np.eye(DIM_X)[V][None, None, :]
    P_new = np.einsum("rij,rjk,rlk->ril", I_KH, P, I_KH) + noise_var * gain[:, :, None] * gain[:, None, :]
    P_new = 0.5 * (P_new + P_new.swapaxes(-1, -2))
    x_new = x + gain * y[:, None]
    use = np.asarray(valid, dtype=bool)
    return (
        np.where(use[:, None], x_new, x),
        np.where(use[:, None, None], P_new, P),
        np.where(use, y, np.nan),
        np.where(use, S, np.nan),
    )


def run_vkf_batch(rpm: np.ndarray, z_fwd: np.ndarray, dvl_valid: np.ndarray, cfg: VkfConfig) -> VkfRun:
    """The VKF over R runs at once (numpy, vectorised over runs), step by step as
    :func:`vkf_filterpy`: predict with each run's RPM, update where its DVL is valid.

    rpm [rpm], z_fwd [m/s] (NaN allowed where not valid), dvl_valid (bool): (K, R) ->
    :class:`VkfRun` with x (K, R, 3), P (K, R, 3, 3), innovation and its variance (K, R).
    """
    rpm, z_fwd, dvl_valid = _check_inputs(rpm, z_fwd, dvl_valid)
    if rpm.ndim != 2:
        raise ValueError(f"run_vkf_batch takes (K, R) inputs, got {rpm.shape}")
    K, num_runs = rpm.shape
    x = np.broadcast_to(cfg.x0, (num_runs, DIM_X)).copy()
    P = np.broadcast_to(cfg.P0, (num_runs, DIM_X, DIM_X)).copy()
    Q, R = cfg.Q, cfg.R
    xs, Ps = np.empty((K, num_runs, DIM_X)), np.empty((K, num_runs, DIM_X, DIM_X))
    ys, Ss = np.empty((K, num_runs)), np.empty((K, num_runs))
    for k in range(K):
        x, P = predict(x, P, rpm[k], Q)
        x, P, ys[k], Ss[k] = update(x, P, z_fwd[k], dvl_valid[k], R)
        xs[k], Ps[k] = x, P
    return VkfRun(xs, Ps, ys, Ss)


def dvl_forward_speed(v_dvl_n: np.ndarray, C_nb: np.ndarray, cfg: VkfConfig) -> np.ndarray:
    """The VKF's measurement from the DVL velocity in NED (eq. 21 and its departure).

    ``"body_x"``: ``(C_nb^T v_dvl_n)_x = C_nb[:, 0] . v_dvl_n``; ``"norm"`` (the paper's eq. 21):
    ``|v_dvl_n|``. v_dvl_n (..., 3) [m/s], C_nb (..., 3, 3) -> (...) [m/s]; NaN where the DVL
    velocity is NaN (no bottom lock).
    """
    v_dvl_n = np.asarray(v_dvl_n, dtype=float)
    if cfg.forward_speed == "norm":
        return np.linalg.norm(v_dvl_n, axis=-1)
    return np.einsum("...i,...i->...", np.asarray(C_nb, dtype=float)[..., :, 0], v_dvl_n)


def rpm_velocity_n(x: np.ndarray, C_nb: np.ndarray) -> np.ndarray:
    """Eq. 27-28: ``v_rpm_n = C_nb [V_rpm, 0, 0]^T``, V_rpm the state's first entry.

    x (..., 3) VKF state, C_nb (..., 3, 3) -> (..., 3) [m/s] NED.
    """
    x = np.asarray(x, dtype=float)
    return np.asarray(C_nb, dtype=float)[..., :, 0] * x[..., V, None]


def rpm_selected(altitude_m: np.ndarray, cfg: VkfConfig) -> np.ndarray:
    """Eq. 29's condition ``ES > alpha``: True where the RPM velocity is used. A NaN altitude (the
    echo sounder sees no bottom: the vehicle is beyond its range, so beyond the DVL's) counts as
    above alpha. altitude_m (...) -> (...) bool."""
    return ~(np.asarray(altitude_m, dtype=float) <= cfg.switch_altitude_m)  # NaN <= a is False


def switched_velocity_n(
    altitude_m: np.ndarray, v_rpm_n: np.ndarray, v_dvl_n: np.ndarray, cfg: VkfConfig
) -> np.ndarray:
    """Eq. 29: the aiding velocity in NED: ``v_rpm_n`` where the echo sounder's altitude is above
    ``switch_altitude_m`` or NaN, else ``v_dvl_n`` (at alpha exactly: the DVL, as ``ES > alpha``
    reads). altitude_m (...), v_rpm_n and v_dvl_n (..., 3) [m/s] -> (..., 3)."""
    return np.where(rpm_selected(altitude_m, cfg)[..., None], v_rpm_n, v_dvl_n)
