"""Nullified sway velocity, NSV (Tal et al. 2017 section 3.2, eq. 31-36).

Assume ``v = 0`` and solve surge and heave from the two beams, ``[u, w] = A_0^-1 [y1, y2]``
with ``A_0`` the pair's (x, z) beam components (eq. 31-33; eq. 35 names it ``A_zero``, the
same matrix). The sway row is the assumption itself, ``v = 0`` with variance epsilon (eq. 36).
The pairs 1-4 and 2-3 differ only in their y components: their ``A_0`` has two equal rows and
is singular, so NSV cannot use them (it reports so per epoch). Exact when the true sway is zero.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tauvcore.aiding.dvl_partial import PartialSolution, cannot, embed
from tauvcore.sensors.dvl import beam_directions_b

NAME = "nsv"
SWAY = 1


@lru_cache(maxsize=64)
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...], epsilon_m2_per_s2: float) -> PartialSolution:
    beams = np.flatnonzero(pattern)
    if beams.size != 2:
        return cannot(NAME, f"needs exactly two beams, has {beams.size}")
    A_0 = beam_directions_b(beam_pitch_rad)[beams][:, [0, 2]]
    if abs(np.linalg.det(A_0)) < 1e-9:
        return cannot(NAME, "the pair differs only in its sway components: surge and heave are not separable")
    inv = np.linalg.inv(A_0)                       # rows: u, w
    rows = np.zeros((3, 2))
    rows[0], rows[2] = inv[0], inv[1]
    extra = np.zeros(3)
    extra[SWAY] = epsilon_m2_per_s2
    return PartialSolution(method=NAME, ok=True, C=embed(rows, beams), measured=np.ones(3, dtype=bool),
                           extra_var=extra)
