"""Virtual heave velocity, VHV (Tal et al. 2017 section 3.4, eq. 44-47).

PLCF's axis plus a second one from the other beam combination, resolved with the filter's
predicted heave: for beams 1-2, ``2 b_12 v + 2 b_13 w = y1 + y2`` (eq. 44) gives
``v = (y1 + y2) / (2 b_12) - (b_13 / b_12) w_hat`` (eq. 45), generally ``A_s^T c = e_j + d e_w``.
Its variance ADDS the prediction's: ``R_v = (s1^2 + s2^2) / (4 b_12^2) + (b_13 / b_12)^2 s_w^2``.
Eq. 46 prints a minus sign; a difference of independent errors has the sum of their variances
(our Monte Carlo test of the formula confirms the plus; the minus can even go negative).
Heave is not fused (eq. 47). Diagonal pairs (1-3, 2-4) measure heave directly, so there is no
heave for a prediction to stand in for: VHV reports that it cannot use them.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tauvcore.aiding import elc_plcf
from tauvcore.aiding.dvl_partial import PartialSolution, cannot, embed
from tauvcore.sensors.dvl import beam_directions_b

NAME = "vhv"
HEAVE = 2


@lru_cache(maxsize=64)
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...]) -> PartialSolution:
    plcf = elc_plcf.solve(beam_pitch_rad, pattern)
    if not plcf.ok:
        return cannot(NAME, plcf.reason)
    if plcf.measured[HEAVE]:
        return cannot(NAME, "a diagonal pair measures heave directly: no heave for a prediction to replace")
    beams = np.flatnonzero(pattern)
    A_s = beam_directions_b(beam_pitch_rad)[beams]
    (axis_measured,) = np.flatnonzero(plcf.measured)
    other = [a for a in range(3) if a not in (axis_measured, HEAVE)][0]
    # [A_s^T, -e_w] [c; d] = e_other  ->  v_other = c^T y - d w_hat
    M = np.column_stack([A_s.T, -np.eye(3)[HEAVE]])
    sol = np.linalg.solve(M, np.eye(3)[other])
    c, d = sol[:2], sol[2]
    C = plcf.C.copy()
    C[other] = embed(c[None, :], beams)[0]
    D = np.zeros((3, 3))
    D[other, HEAVE] = -d
    measured = plcf.measured.copy()
    measured[other] = True
    return PartialSolution(method=NAME, ok=True, C=C, D=D, measured=measured)
