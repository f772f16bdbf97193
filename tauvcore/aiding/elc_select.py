"""ELC selector (Tal et al. 2017 section 3.6, eq. 48-49): per velocity axis, the component of
the method with the smallest variance among VB, NSV, PLCF and VHV.

Eq. 49 passes ``diag(R_u, R_v, R_w)`` to the filter. Because every method is affine in the same
beams and the same prediction (tauvcore.aiding.dvl_partial), the covariance of the selected
rows is known exactly, cross terms included; we fuse that full R. Eq. 49's diagonal is an
approximation of it (the paper's choice), not an error.
Which method each axis took is recorded per epoch.
"""

from __future__ import annotations

import numpy as np

from tauvcore.aiding import elc_nsv, elc_plcf, elc_vb, elc_vhv
from tauvcore.aiding.dvl_partial import PartialSolution

CANDIDATES = ("vb", "nsv", "plcf", "vhv")
"""Method codes of the per-axis choice record (index into this tuple; -1: no method)."""


def candidate_solutions(
    beam_pitch_rad: float, pattern: tuple[bool, ...], n_f: float, epsilon_m2_per_s2: float
) -> list[PartialSolution]:
    return [
        elc_vb.solve(beam_pitch_rad, pattern, n_f),
        elc_nsv.solve(beam_pitch_rad, pattern, epsilon_m2_per_s2),
        elc_plcf.solve(beam_pitch_rad, pattern),
        elc_vhv.solve(beam_pitch_rad, pattern, n_f),
    ]


def select(
    solutions: list[PartialSolution], y_c: np.ndarray, S_y: np.ndarray, v_hat: np.ndarray, P_vel: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-axis minimum-variance choice for a batch sharing one availability pattern (the kernel
    :func:`tauvcore.filter.kernels.two_beam.partial_into`, which the filter bank runs).

    Returns ``v`` (n, 3), ``R`` (n, 3, 3), ``measured`` (n, 3) and ``choice`` (n, 3) codes.
    """
    from tauvcore.filter.kernels.common import flat as f
    from tauvcore.filter.kernels.two_beam import select_batch

    n = np.shape(y_c)[0]
    ok = np.array([s.ok for s in solutions])
    C, D, pred_gain, assumption_sd = (
        np.stack([getattr(s, name) for s in solutions]).astype(float)
        for name in ("C", "D", "pred_gain", "assumption_sd")
    )
    measured = np.stack([s.measured for s in solutions]).astype(bool)
    return select_batch(
        ok,
        C,
        D,
        pred_gain,
        assumption_sd,
        measured,
        f(y_c, (n,), (4,)),
        f(S_y, (n,), (4, 4)),
        f(v_hat, (n,), (3,)),
        f(P_vel, (n,), (3, 3)),
    )
