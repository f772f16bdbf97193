"""The seabed's compiled kernels: where a DVL beam meets a terrain or trenched seabed, marched
along the ray and bisected (tauvcore.truth.seabed, whose module docstring gives the method).

A module of its own so that numba is imported only when a beam meets a seabed that is not a
plane, not when a configuration or ``tauv --help`` imports the seabed's description.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def height_along(
    head: np.ndarray,
    d: np.ndarray,
    r: float,
    mean: float,
    slope: np.ndarray,
    k: np.ndarray,
    phase: np.ndarray,
    amp: float,
    trenches: np.ndarray,
) -> float:
    """Height above the seabed of the point ``head + r d`` (tauvcore.truth.seabed.Bathymetry.depth_m, one point)."""
    n, e, down = head[0] + r * d[0], head[1] + r * d[1], head[2] + r * d[2]
    depth = mean + slope[0] * n + slope[1] * e
    if k.shape[0]:
        waves = 0.0
        for w in range(k.shape[0]):
            waves += math.sin(n * k[w, 0] + e * k[w, 1] + phase[w])
        depth += amp * waves
    for t in range(trenches.shape[0]):
        start, end, deeper, wall = trenches[t, 0], trenches[t, 1], trenches[t, 2], trenches[t, 3]
        up = min(1.0, max(0.0, (n - start) / wall + 0.5))
        down_wall = min(1.0, max(0.0, (end - n) / wall + 0.5))
        depth += (
            deeper * (0.5 * (1.0 - math.cos(math.pi * up))) * (0.5 * (1.0 - math.cos(math.pi * down_wall)))
        )
    return depth - down


@numba.njit(cache=True, nogil=True)
def march_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    head: np.ndarray,
    d: np.ndarray,
    altitude: np.ndarray,
    max_range_m: float,
    step: float,
    mean: float,
    slope: np.ndarray,
    k: np.ndarray,
    phase: np.ndarray,
    amp: float,
    trenches: np.ndarray,
    out: np.ndarray,
) -> None:
    """Range along each ray (n, 3) to the seabed into ``out`` (n,): march in ``step`` to the first
    point at or below it, then bisect the last step until the bracket is under 1e-9 m; ``inf``
    where the head is not above the seabed or nothing is met within ``max_range_m``. Trenches
    (T, 4): north start, north end, extra depth, wall length."""
    for j in range(head.shape[0]):
        out[j] = np.inf
        if not altitude[j] > 0.0:
            continue
        r = 0.0
        while r < max_range_m:
            r_next = min(r + step, max_range_m)
            if height_along(head[j], d[j], r_next, mean, slope, k, phase, amp, trenches) <= 0.0:
                a, b = r, r_next
                for _ in range(60):
                    mid = 0.5 * (a + b)
                    if height_along(head[j], d[j], mid, mean, slope, k, phase, amp, trenches) <= 0.0:
                        b = mid
                    else:
                        a = mid
                    if b - a < 1e-9:
                        break
                out[j] = b
                break
            r = r_next


__all__ = ["height_along", "march_into"]
