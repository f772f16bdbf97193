"""A bag's frames into tauvcore's: FLU/ENU (ROS REP-103 and REP-105) to FRD/NED, quaternions to
rotation matrices, and a DVL's mounting rotation.

Conventions (tauvcore.conventions: b is forward-right-down, n is north-east-down, ``v_n = C_nb @ v_b``):

- ``frd_ned``: the message is in tauvcore's frames already; a vector is taken as it is, and an
  orientation quaternion ``q`` (ROS order x, y, z, w; Hamilton, active, body to world) is
  ``C_nb = R(q)``.
- ``flu_enu``: body vectors are forward-left-up and world vectors east-north-up (REP-103):
  ``v_b = D v_flu`` with ``D = diag(1, -1, -1)`` (x stays, y and z flip) and
  ``v_n = T v_enu`` with ``T = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` (north = y, east = x,
  down = -z). An orientation ``q`` rotates FLU into ENU, ``v_enu = R(q) v_flu``, so
  ``C_nb = T R(q) D`` (both ``T`` and ``D`` are their own inverses). Euler angles follow from
  ``C_nb`` (ZYX, :func:`tauvcore.geo.rotations.euler_from_C_nb`): a vehicle heading east in ENU
  (yaw 0 about up) heads east in NED too (yaw +90 deg about down).

``R(q)`` is the rotation matrix of the unit quaternion ``q / |q|``:
``R = I + 2 w [u x] + 2 [u x]^2`` with ``u = (x, y, z)``.
"""

from __future__ import annotations

import numpy as np

from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.units import DEG

FRAMES = ("flu_enu", "frd_ned")
"""The frame conventions a topic may be in (module docstring)."""
D_FLU = np.diag([1.0, -1.0, -1.0])
"""FLU to FRD (and back): x stays, y and z flip."""
T_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
"""ENU to NED (and back): x and y swap, z flips."""


def body_vectors(v: np.ndarray, frame: str) -> np.ndarray:
    """Body vectors (K, 3) in the topic's ``frame`` -> FRD (K, 3): ``D v`` for ``flu_enu``."""
    return v * np.array([1.0, -1.0, -1.0]) if frame == "flu_enu" else v


def world_vectors(v: np.ndarray, frame: str) -> np.ndarray:
    """World vectors (K, 3) in the topic's ``frame`` -> NED (K, 3): ``T v`` for ``flu_enu``."""
    return np.stack([v[:, 1], v[:, 0], -v[:, 2]], axis=-1) if frame == "flu_enu" else v


def body_vectors_in_place(v: np.ndarray, frame: str) -> np.ndarray:
    """:func:`body_vectors` of ``v`` (K, 3) written over it (a view of a topic's rows); returns ``v``."""
    if frame == "flu_enu":
        v[:, 1:] *= -1.0
    return v


def world_vectors_in_place(v: np.ndarray, frame: str) -> np.ndarray:
    """:func:`world_vectors` of ``v`` (K, 3) written over it (a view of a topic's rows); returns ``v``."""
    if frame == "flu_enu":
        east = v[:, 0].copy()
        v[:, 0] = v[:, 1]
        v[:, 1] = east
        v[:, 2] *= -1.0
    return v


def matrix_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (K, 3, 3) of quaternions (K, 4) in ROS order (x, y, z, w), normalised
    (module docstring); a zero quaternion gives NaN."""
    with np.errstate(invalid="ignore", divide="ignore"):
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[:, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[:, 0, 1] = 2.0 * (x * y - w * z)
    R[:, 0, 2] = 2.0 * (x * z + w * y)
    R[:, 1, 0] = 2.0 * (x * y + w * z)
    R[:, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[:, 1, 2] = 2.0 * (y * z - w * x)
    R[:, 2, 0] = 2.0 * (x * z - w * y)
    R[:, 2, 1] = 2.0 * (y * z + w * x)
    R[:, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R


def C_nb_from_quaternion(q: np.ndarray, frame: str) -> np.ndarray:
    """``C_nb`` (K, 3, 3) of orientation quaternions (K, 4) (x, y, z, w) in the topic's ``frame``:
    ``R(q)``, or ``T R(q) D`` for ``flu_enu`` (module docstring)."""
    R = matrix_from_quaternion(q)
    return T_ENU @ R @ D_FLU if frame == "flu_enu" else R


def mounting_matrix(rpy_deg: tuple[float, float, float]) -> np.ndarray:
    """The rotation (3, 3) from a DVL's own frame to the body frame, ``v_b = C_b_dvl v_dvl``, of its
    mounting angles roll, pitch, yaw [deg] (ZYX, as ``C_nb`` of Euler angles)."""
    return C_nb_from_euler(np.asarray(rpy_deg, dtype=float) * DEG)
