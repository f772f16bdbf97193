"""Virtual heave velocity, VHV (Tal et al. 2017 section 3.4, eq. 44-47).

PLCF's axis plus a second one from the other beam combination, resolved with the filter's
predicted heave: for beams 1-2, ``2 b_12 v + 2 b_13 w = y1 + y2`` (eq. 44) gives
``v = (y1 + y2) / (2 b_12) - (b_13 / b_12) w_hat`` (eq. 45), generally ``A_s^T c = e_j + d e_w``.
Its variance ADDS the prediction's: ``R_v = (s1^2 + s2^2) / (4 b_12^2) + (b_13 / b_12)^2 s_w^2``.
Eq. 46 prints a minus sign; a difference of independent errors has the sum of their variances
(our Monte Carlo test of the formula confirms the plus; the minus can even go negative).
Heave is not fused (eq. 47).

Like VB's virtual beam (eq. 26), the predicted heave is correlated with the state error the
update corrects, and the paper neglects it: each ping then fuses the same heave error, times
``b_13 / b_12`` (3.9 for the 20-degree Janus), into sway as if it were news, and VHV is
over-confident (velocity NEES/dim 3.4-7.7 on our trajectories with 20 runs). We inflate the
prediction's part of R by the same ``n_f`` as VB (``R_v = beams + (n_f b_13 / b_12)^2 s_w^2``):
with the default n_f = 20 VB and VHV are both consistent (benchmarks/consistency_table.py). Kept
exactly instead (the measurement error ``-d dw`` is part of the state error), the update is
the beams' own information and VHV becomes tightly coupled fusion of the same two beams
(tests/unit/tauvcore/aiding/test_partial.py proves it to 1e-9): the paper's construction has nothing to add
that is consistent. Diagonal pairs (1-3, 2-4) measure heave directly, so there is no
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
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...], n_f: float = 1.0) -> PartialSolution:
    """n_f inflates the predicted heave's sigma in R (1: the paper's eq. 46)."""
    plcf = elc_plcf.solve(beam_pitch_rad, pattern)
    if not plcf.ok:
        return cannot(NAME, plcf.reason)
    if plcf.measured[HEAVE]:
        return cannot(NAME, "a diagonal pair measures heave directly: no heave for a prediction to replace")
    beams = np.flatnonzero(pattern)
    A_s = beam_directions_b(beam_pitch_rad)[beams]
    (axis_measured,) = np.flatnonzero(plcf.measured)
    other = next(a for a in range(3) if a not in (axis_measured, HEAVE))
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
    gain = np.ones(3)
    gain[other] = n_f
    return PartialSolution(method=NAME, ok=True, C=C, D=D, measured=measured, pred_gain=gain)
