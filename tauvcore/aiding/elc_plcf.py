"""Partial LC fusing, PLCF (Tal et al. 2017 section 3.3, eq. 37-43).

The velocity axis that the two beams see exactly: ``e_i`` in the row space of the pair's beam
matrix. For beams 1-2 the difference gives surge, ``u = (y1 - y2) / (2 b_11)`` (eq. 40, which
the paper calls "the sway velocity": a slip, it is surge), with
``R_u = (s1^2 + s2^2) / (4 b_11^2)`` (eq. 41). Adjacent pairs 1-4 and 2-3 isolate sway instead;
diagonal pairs 1-3 and 2-4 isolate heave through their sum. The other two axes are not fused
(the paper's infinite variance, eq. 43).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tauvcore.aiding.dvl_partial import (
    PartialSolution,
    cannot,
    embed,
    exact_combination,
)
from tauvcore.sensors.dvl import beam_directions_b

NAME = "plcf"


@lru_cache(maxsize=64)
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...]) -> PartialSolution:
    beams = np.flatnonzero(pattern)
    if beams.size != 2:
        return cannot(NAME, f"needs exactly two beams, has {beams.size}")
    A_s = beam_directions_b(beam_pitch_rad)[beams]
    rows, measured = np.zeros((3, 2)), np.zeros(3, dtype=bool)
    for axis in range(3):
        c = exact_combination(A_s, np.eye(3)[axis])
        if c is not None:
            rows[axis], measured[axis] = c, True
    if not measured.any():
        return cannot(NAME, "the pair sees no velocity axis on its own")
    return PartialSolution(method=NAME, ok=True, C=embed(rows, beams), measured=measured)
