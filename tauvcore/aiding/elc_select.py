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
from tauvcore.aiding.dvl_partial import PartialSolution, apply_solution

CANDIDATES = ("vb", "nsv", "plcf", "vhv")
"""Method codes of the per-axis choice record (index into this tuple; -1: no method)."""


def candidate_solutions(beam_pitch_rad: float, pattern: tuple[bool, ...], n_f: float,
                        epsilon_m2_per_s2: float) -> list[PartialSolution]:
    return [elc_vb.solve(beam_pitch_rad, pattern, n_f), elc_nsv.solve(beam_pitch_rad, pattern, epsilon_m2_per_s2),
            elc_plcf.solve(beam_pitch_rad, pattern), elc_vhv.solve(beam_pitch_rad, pattern, n_f)]


def select(solutions: list[PartialSolution], y_c: np.ndarray, S_y: np.ndarray, v_hat: np.ndarray,
           P_vel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-axis minimum-variance choice for a batch sharing one availability pattern.

    Returns ``v`` (n, 3), ``R`` (n, 3, 3), ``measured`` (n, 3) and ``choice`` (n, 3) codes.
    """
    n = y_c.shape[0]
    var = np.full((len(solutions), n, 3), np.inf)
    for i, sol in enumerate(solutions):
        if sol.ok:
            _, R = apply_solution(sol.C, sol.D, sol.pred_gain, sol.assumption_sd, y_c, S_y, v_hat, P_vel)
            var[i] = np.where(sol.measured, np.diagonal(R, axis1=-2, axis2=-1), np.inf)
    choice = np.argmin(var, axis=0)                      # (n, 3)
    measured = np.isfinite(np.min(var, axis=0))
    C_all = np.stack([s.C for s in solutions])           # (4, 3, 4)
    D_all = np.stack([s.D for s in solutions])
    g_all = np.stack([s.pred_gain for s in solutions])   # (4, 3)
    e_all = np.stack([s.assumption_sd for s in solutions])
    axes = np.arange(3)
    C = C_all[choice, axes]                              # (n, 3, 4): row a from method choice[:, a]
    D = D_all[choice, axes]
    gain, extra = g_all[choice, axes], e_all[choice, axes]
    v, R = apply_solution(C, D, gain, extra, y_c, S_y, v_hat, P_vel)
    return v, R, measured, np.where(measured, choice, -1)
