"""How the 20-state bank fuses the DVL: which construction each method uses, the compiled DVL
kernel's tables of two-beam constructions, and the RPM velocity that stands in for the DVL's
(``run.rpm_fallback``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tauvcore.aiding import elc_select
from tauvcore.aiding.dvl_extended import (
    ELC_METHODS,
    MODE_COAST,
    MODE_LC,
    MODE_PARTIAL,
    MODE_TC,
    DvlExtended,
)
from tauvcore.config import Config
from tauvcore.filter.kernels.dvl import TwoBeamTables
from tauvcore.filter.kernels.two_beam import MAX_CANDIDATES
from tauvcore.filter.layout import STATE

DVL_FUSION = {"ins": None, "lc": "lc", "tc": "tc", **{m: "elc" for m in ELC_METHODS}, "iekf": "tc"}
"""How each method fuses the DVL (None: not at all; a registered method, tauvcore.aiding.registry,
is not in it and takes no DVL). The invariant EKF fuses the returned beams one row each, as the
tightly coupled filter: four beams are the body velocity of Potokar et al., two or three what they
see of it."""
INVARIANT_METHODS = frozenset({"iekf"})
"""The methods that are the right-invariant EKF (tauvcore.filter.invariant): the filter bank corrects
them on SE_2(3) and carries their covariance in the invariant error's coordinates."""


DVL_ROWS = 4
"""The widest DVL measurement (tightly coupled: one row per beam); narrower ones are padded with
inactive rows so that one compiled correction fuses every DVL method of a ping."""


DVL_MODE_CODES = np.array([MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC], dtype=np.int64)
"""The record's DVL mode codes in the order the compiled DVL kernel takes them."""


def partial_tables(methods: Sequence[str], config: Config) -> TwoBeamTables:
    """The two-beam constructions of each DVL method, for every pattern of two returned beams
    (index: the sum of 2^k over the beams k), from the methods' own ``solve`` functions
    (tauvcore.aiding.elc_*): candidates (1, or the selector's 4), ok, C, D, gain, assumption
    error and measured rows, as :func:`tauvcore.filter.kernels.dvl.dvl_measure_bank` takes them."""
    n, K = len(methods), MAX_CANDIDATES
    n_cand = np.ones(n, np.int64)
    ok = np.zeros((n, 16, K), bool)
    Cc, Dc = np.zeros((n, 16, K, 3, 4)), np.zeros((n, 16, K, 3, 3))
    gc, ac, mc = np.ones((n, 16, K, 3)), np.zeros((n, 16, K, 3)), np.zeros((n, 16, K, 3), bool)
    pitch, n_f, eps = config.dvl.beam_pitch_rad, config.partial.vb_nf, config.nsv_epsilon_value_m2_per_s2()
    for i, method in enumerate(methods):
        if DVL_FUSION[method] != "elc":
            continue
        for code in range(16):
            pattern = tuple(bool(code >> k & 1) for k in range(4))
            if sum(pattern) != 2:
                continue
            if method == "elc":
                solutions = elc_select.candidate_solutions(pitch, pattern, n_f, eps)
                n_cand[i] = len(solutions)
            else:
                solutions = [DvlExtended(method, config.dvl, config.earth, 0.0, n_f, eps)._solution(pattern)]
            for c, sol in enumerate(solutions):
                ok[i, code, c] = sol.ok
                Cc[i, code, c], Dc[i, code, c] = sol.C, sol.D
                gc[i, code, c], ac[i, code, c], mc[i, code, c] = (
                    sol.pred_gain,
                    sol.assumption_sd,
                    sol.measured,
                )
    return TwoBeamTables(n_cand, ok, Cc, Dc, gc, ac, mc)


def rpm_measurement(
    v_b: np.ndarray, sf: np.ndarray, b_dvl: np.ndarray, A_pinv: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The RPM velocity's prediction ``h`` (..., 3) and Jacobian ``H`` (..., 3, 20) at a state of
    body velocity ``v_b`` (..., 3) [m/s], DVL scale factor ``sf`` (...) and beam biases ``b_dvl``
    (..., 4) [m/s] (``--rpm-fallback``, FilterBank._rpm_fallback). Surge is the speed the VKF
    learned from the DVL, ``(1 + SF) v_b1 + A+_1 . b`` (the first row of the LC measurement, with
    ``A_pinv`` (3, 4) the DVL's A+); sway and heave are the body velocity (taken as zero)."""
    h = np.array(v_b, dtype=float, copy=True)
    h[..., 0] = (1.0 + sf) * v_b[..., 0] + b_dvl @ A_pinv[0]
    H = np.zeros(np.shape(v_b)[:-1] + (3, STATE.dim))
    H[..., STATE.vel] = np.eye(3)
    H[..., 0, STATE.vel.start] = 1.0 + sf
    H[..., 0, STATE.b_dvl] = A_pinv[0]
    H[..., 0, STATE.sf_dvl.start] = v_b[..., 0]
    return h, H
