"""Rotation algebra on stacks: skew, SO(3) exp/log, ZYX Euler angles (tauvcore.conventions).

All functions accept a leading batch shape: vectors ``(..., 3)``, matrices ``(..., 3, 3)``.
"""

from __future__ import annotations

import numpy as np

_SMALL_ANGLE_RAD = 1e-6
_I3 = np.eye(3)
_SERIES_ANGLE_RAD = 1e-2


# skew(v) = v @ _SKEW_MAP reshaped: one product instead of six indexed writes (hot path)
_SKEW_MAP = np.zeros((3, 9))
_SKEW_MAP[2, 1], _SKEW_MAP[1, 2] = -1.0, 1.0  # row 0: [0, -z, y]
_SKEW_MAP[2, 3], _SKEW_MAP[0, 5] = 1.0, -1.0  # row 1: [z, 0, -x]
_SKEW_MAP[1, 6], _SKEW_MAP[0, 7] = -1.0, 1.0  # row 2: [-y, x, 0]


def mv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Batched matrix-vector product ``M @ v``: (..., m, n), (..., n) -> (..., m)."""
    return (M @ v[..., None])[..., 0]


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrix ``[v x]`` with ``skew(a) @ b == cross(a, b)``. (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, dtype=float)
    return (v @ _SKEW_MAP).reshape(v.shape[:-1] + (3, 3))


def vee(m: np.ndarray) -> np.ndarray:
    """Inverse of :func:`skew` (antisymmetric part). (..., 3, 3) -> (..., 3)."""
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]],
        axis=-1,
    )


def exp_so3(phi: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation matrix ``exp([phi x])`` for rotation vector phi [rad]. (..., 3) -> (..., 3, 3).

    Written as ``(1 - b a^2) I + a [phi x] + b phi phi^T`` (using ``[phi x]^2 = phi phi^T - a^2 I``)
    with ``a = sin(t)/t``, ``b = (1 - cos t)/t^2``, t = |phi|: no matrix product on the hot path.
    """
    phi = np.asarray(phi, dtype=float)
    angle2 = np.einsum("...i,...i->...", phi, phi)[..., None, None]
    if np.all(angle2 < _SERIES_ANGLE_RAD**2):
        # Taylor series; the first omitted terms are t^6/5040 and t^6/40320 < 2e-16 for t < 1e-2
        # (IMU increments are ~1e-3 rad), so this is exact to double precision and cheaper
        a = 1.0 - angle2 / 6.0 * (1.0 - angle2 / 20.0)
        b = 0.5 - angle2 / 24.0 * (1.0 - angle2 / 30.0)
    else:
        angle = np.sqrt(angle2)
        small = angle < _SMALL_ANGLE_RAD
        safe = np.where(small, 1.0, angle)
        a = np.where(small, 1.0 - angle2 / 6.0, np.sin(safe) / safe)
        b = np.where(small, 0.5 - angle2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    return (1.0 - b * angle2) * _I3 + a * skew(phi) + b * (phi[..., :, None] * phi[..., None, :])


def log_so3(C: np.ndarray) -> np.ndarray:
    """Rotation vector of a rotation matrix (inverse of :func:`exp_so3`, angle < pi). (..., 3, 3) -> (..., 3)."""
    C = np.asarray(C, dtype=float)
    cos_angle = np.clip((np.trace(C, axis1=-2, axis2=-1) - 1.0) * 0.5, -1.0, 1.0)
    angle = np.arccos(cos_angle)[..., None]
    small = angle < _SMALL_ANGLE_RAD
    safe = np.where(small, 1.0, angle)
    scale = np.where(small, 1.0 + angle**2 / 6.0, safe / np.sin(safe))
    return scale * vee(C)


def left_jacobian_inv_so3(phi: np.ndarray) -> np.ndarray:
    """Inverse left Jacobian of SO(3): ``d exp([phi x]) = [(J_l(phi) dphi) x] exp([phi x])``.

    ``J_l^{-1} = I - [phi x]/2 + (1/a^2 - (1 + cos a)/(2 a sin a)) [phi x]^2``, a = |phi|.
    """
    phi = np.asarray(phi, dtype=float)
    angle = np.linalg.norm(phi, axis=-1)[..., None, None]
    small = angle < 1e-4
    safe = np.where(small, 1.0, angle)
    c = np.where(
        small,
        1.0 / 12.0 + angle**2 / 720.0,
        1.0 / safe**2 - (1.0 + np.cos(safe)) / (2.0 * safe * np.sin(safe)),
    )
    k = skew(phi)
    return np.eye(3) - 0.5 * k + c * (k @ k)


def C_nb_from_euler(euler: np.ndarray) -> np.ndarray:
    """ZYX: ``C_nb = Rz(yaw) Ry(pitch) Rx(roll)`` from ``euler = [roll, pitch, yaw]`` [rad]."""
    euler = np.asarray(euler, dtype=float)
    cr, sr = np.cos(euler[..., 0]), np.sin(euler[..., 0])
    cp, sp = np.cos(euler[..., 1]), np.sin(euler[..., 1])
    cy, sy = np.cos(euler[..., 2]), np.sin(euler[..., 2])
    C = np.empty(euler.shape[:-1] + (3, 3))
    C[..., 0, 0] = cy * cp
    C[..., 0, 1] = cy * sp * sr - sy * cr
    C[..., 0, 2] = cy * sp * cr + sy * sr
    C[..., 1, 0] = sy * cp
    C[..., 1, 1] = sy * sp * sr + cy * cr
    C[..., 1, 2] = sy * sp * cr - cy * sr
    C[..., 2, 0] = -sp
    C[..., 2, 1] = cp * sr
    C[..., 2, 2] = cp * cr
    return C


def euler_from_C_nb(C_nb: np.ndarray) -> np.ndarray:
    """ZYX Euler angles ``[roll, pitch, yaw]`` [rad] of ``C_nb``; yaw in (-pi, pi]."""
    C_nb = np.asarray(C_nb, dtype=float)
    roll = np.arctan2(C_nb[..., 2, 1], C_nb[..., 2, 2])
    pitch = -np.arcsin(np.clip(C_nb[..., 2, 0], -1.0, 1.0))
    yaw = wrap_angle(np.arctan2(C_nb[..., 1, 0], C_nb[..., 0, 0]))  # arctan2 may return -pi
    return np.stack([roll, pitch, yaw], axis=-1)


def euler_rates_to_omega_nb_b(euler: np.ndarray, euler_dot: np.ndarray) -> np.ndarray:
    """Body rate ``omega_nb_b`` [rad/s] from ZYX Euler angles and their time derivatives.

    ``p = roll_dot - yaw_dot sin(pitch)``,
    ``q = pitch_dot cos(roll) + yaw_dot cos(pitch) sin(roll)``,
    ``r = -pitch_dot sin(roll) + yaw_dot cos(pitch) cos(roll)``.
    """
    roll, pitch = euler[..., 0], euler[..., 1]
    droll, dpitch, dyaw = euler_dot[..., 0], euler_dot[..., 1], euler_dot[..., 2]
    p = droll - dyaw * np.sin(pitch)
    q = dpitch * np.cos(roll) + dyaw * np.cos(pitch) * np.sin(roll)
    r = -dpitch * np.sin(roll) + dyaw * np.cos(pitch) * np.cos(roll)
    return np.stack([p, q, r], axis=-1)


def euler_from_misalignment_jacobian(euler: np.ndarray) -> np.ndarray:
    """d(euler)/d(rho) for the left n-frame misalignment ``C_true = exp([rho x]) C_hat``.

    A small n-frame rotation rho equals the body rotation ``C_nb.T rho``, and body rates map to
    Euler rates through ``E_b^{-1}`` (the inverse of :func:`euler_rates_to_omega_nb_b`), so
    ``d euler = E_b^{-1} C_nb.T rho``. Singular at pitch = +-90 deg. (..., 3) -> (..., 3, 3).
    """
    roll, pitch = euler[..., 0], euler[..., 1]
    sr, cr = np.sin(roll), np.cos(roll)
    tp, cp = np.tan(pitch), np.cos(pitch)
    E_inv = np.zeros(euler.shape[:-1] + (3, 3))
    E_inv[..., 0, 0] = 1.0
    E_inv[..., 0, 1] = sr * tp
    E_inv[..., 0, 2] = cr * tp
    E_inv[..., 1, 1] = cr
    E_inv[..., 1, 2] = -sr
    E_inv[..., 2, 1] = sr / cp
    E_inv[..., 2, 2] = cr / cp
    return E_inv @ np.swapaxes(C_nb_from_euler(euler), -1, -2)


def wrap_angle(angle_rad: np.ndarray) -> np.ndarray:
    """Wrap to (-pi, pi]."""
    return -(np.mod(-np.asarray(angle_rad) + np.pi, 2.0 * np.pi) - np.pi)
