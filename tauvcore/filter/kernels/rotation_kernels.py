"""Rotations for the kernels: Rodrigues' ``exp([phi x])`` and its inverse (the compiled twins of
tauvcore.geo.rotations.exp_so3 / log_so3, held equal to them by tests/unit/tauvcore/geo/test_rotations.py), and
the entries of a cross-product matrix."""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import jit

SERIES_ANGLE2 = 1e-4  # below (1e-2 rad)^2 exp_so3 uses its Taylor series (exact to double precision)
LOG_SMALL_ANGLE_RAD = 1e-6


@jit
def exp_so3_into(p0: float, p1: float, p2: float, out: np.ndarray) -> None:
    """Rodrigues ``exp([phi x])`` (tauvcore.geo.rotations.exp_so3) into ``out`` (3, 3)."""
    a2 = p0 * p0 + p1 * p1 + p2 * p2
    if a2 < SERIES_ANGLE2:
        a = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0)
        b = 0.5 - a2 / 24.0 * (1.0 - a2 / 30.0)
    else:
        angle = math.sqrt(a2)
        a = math.sin(angle) / angle
        b = (1.0 - math.cos(angle)) / a2
    d = 1.0 - b * a2
    out[0, 0] = d + b * (p0 * p0)
    out[0, 1] = a * -p2 + b * (p0 * p1)
    out[0, 2] = a * p1 + b * (p0 * p2)
    out[1, 0] = a * p2 + b * (p1 * p0)
    out[1, 1] = d + b * (p1 * p1)
    out[1, 2] = a * -p0 + b * (p1 * p2)
    out[2, 0] = a * -p1 + b * (p2 * p0)
    out[2, 1] = a * p0 + b * (p2 * p1)
    out[2, 2] = d + b * (p2 * p2)


@jit
def log_so3_into(C: np.ndarray, out: np.ndarray) -> None:
    """Rotation vector of ``C`` (angle < pi; tauvcore.geo.rotations.log_so3) into ``out`` (3,)."""
    c = (C[0, 0] + C[1, 1] + C[2, 2] - 1.0) * 0.5
    c = min(1.0, max(-1.0, c))
    angle = math.acos(c)
    scale = 1.0 + angle * angle / 6.0 if angle < LOG_SMALL_ANGLE_RAD else angle / math.sin(angle)
    out[0] = scale * 0.5 * (C[2, 1] - C[1, 2])
    out[1] = scale * 0.5 * (C[0, 2] - C[2, 0])
    out[2] = scale * 0.5 * (C[1, 0] - C[0, 1])


@jit
def exp_so3_batch(phi: np.ndarray) -> np.ndarray:
    """(n, 3) -> (n, 3, 3)."""
    out = np.empty((phi.shape[0], 3, 3))
    for i in range(phi.shape[0]):
        exp_so3_into(phi[i, 0], phi[i, 1], phi[i, 2], out[i])
    return out


@jit
def log_so3_batch(C: np.ndarray) -> np.ndarray:
    """(n, 3, 3) -> (n, 3)."""
    out = np.empty((C.shape[0], 3))
    for i in range(C.shape[0]):
        log_so3_into(C[i], out[i])
    return out


@jit
def skew_entry(a0: float, a1: float, a2: float, i: int, j: int) -> float:
    """Entry (i, j) of ``[a x]``."""
    if i == 0:
        return -a2 if j == 1 else (a1 if j == 2 else 0.0)
    if i == 1:
        return a2 if j == 0 else (-a0 if j == 2 else 0.0)
    return -a1 if j == 0 else (a0 if j == 1 else 0.0)


@jit
def skew_into(a0: float, a1: float, a2: float, out: np.ndarray) -> None:
    """``out = [a x]`` (3, 3), entry by entry (:func:`skew_entry`)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = skew_entry(a0, a1, a2, i, j)
