"""Virtual beam, VB (Tal et al. 2017 section 3.1, eq. 23-30).

The first missing beam k is replaced by the prediction ``y_k = b_k^T v_hat`` (eq. 24) and the
three beams are inverted: ``v = A_s^-1 [y_i, y_j, b_k^T v_hat]`` (eq. 25, printed as ``[A]^-1``;
it is the 3x3 ``A_s``). The virtual beam's variance is ``n_f^2 b_k^T P_vel b_k``. Eq. 28's
``sum (b_k,j sigma_j)^2`` is its approximation with P's diagonal, not an error; we keep the full
quadratic form because the velocity errors are correlated after a turn. n_f inflates it
for the neglected correlation between prediction and state error (eq. 26). With the x Janus,
any three beams are independent, so VB works for every pair.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tauvcore.aiding.dvl_partial import PartialSolution, cannot, embed
from tauvcore.sensors.dvl import beam_directions_b

NAME = "vb"


@lru_cache(maxsize=64)
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...], n_f: float) -> PartialSolution:
    beams = np.flatnonzero(pattern)
    if beams.size != 2:
        return cannot(NAME, f"needs exactly two beams, has {beams.size}")
    A = beam_directions_b(beam_pitch_rad)
    virtual = int(np.flatnonzero(~np.asarray(pattern))[0])
    inv = np.linalg.inv(np.vstack([A[beams], A[virtual]]))
    C = embed(inv[:, :2], beams)
    D = np.outer(inv[:, 2], A[virtual])
    return PartialSolution(
        method=NAME, ok=True, C=C, D=D, measured=np.ones(3, dtype=bool), pred_gain=np.full(3, n_f)
    )
