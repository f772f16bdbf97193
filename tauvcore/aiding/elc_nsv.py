"""Nullified sway velocity, NSV (Tal et al. 2017 section 3.2, eq. 31-36).

Assume ``v = 0`` and solve surge and heave from the two beams, ``[u, w] = A_0^-1 [y1, y2]``
with ``A_0`` the pair's (x, z) beam components (eq. 31-33; eq. 35 names it ``A_zero``, the
same matrix). The sway row is the assumption itself, ``v = 0`` with variance epsilon (eq. 36).
The true sway also enters the heave row: ``w = [A_0^-1 y]_w`` absorbs ``-(b_k,y / b_k,z) v``
through the pair's beam sum (0.26 v for the 20-degree Janus). Eq. 36 leaves the heave variance
at the beams' noise; we add the assumption to both rows, fully correlated:
``a = sqrt(epsilon) (C A - I) e_v`` (tauvcore.aiding.dvl_partial), so that a sway the
assumption misses is not fused into heave as news.
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

EPSILON_FLOOR_M2_PER_S2 = 1e-4
"""Smallest derived epsilon: 1 cm/s of sway, which no hull holds tighter (a vehicle configured with
zero sideslip would otherwise state ``v = 0`` with zero variance)."""


def epsilon_from_vehicle(
    speed_mps: float, sideslip_deg: float, turn_radius_m: float, dvl_rate_hz: float
) -> float:
    """Default epsilon of eq. 36 from the vehicle and its mission [m^2/s^2] (the paper gives none).

    The assumption's error is the true sway, which is not white: it keeps its sign through a
    turn. The hull slips ``sigma_v = U tan(beta_max)`` at its tightest turn (the trajectory's
    ``turn_sideslip_deg``; 0.105 m/s for 2 m/s and 3 deg) and a tightest half-turn lasts
    ``tau = pi R / U`` (23.6 s for R = 15 m). The ``N = tau f_DVL`` pings of one turn share one
    sway error and so carry one ping's worth of information about it; fused as independent
    pings, each must carry N times the variance: ``epsilon = sigma_v^2 tau f_DVL`` (0.26 m^2/s^2
    for the defaults), floored at :data:`EPSILON_FLOOR_M2_PER_S2`.
    """
    sway_mps = speed_mps * np.tan(np.radians(abs(sideslip_deg)))
    turn_s = np.pi * turn_radius_m / speed_mps
    return float(max(sway_mps**2 * turn_s * dvl_rate_hz, EPSILON_FLOOR_M2_PER_S2))


@lru_cache(maxsize=64)
def solve(beam_pitch_rad: float, pattern: tuple[bool, ...], epsilon_m2_per_s2: float) -> PartialSolution:
    beams = np.flatnonzero(pattern)
    if beams.size != 2:
        return cannot(NAME, f"needs exactly two beams, has {beams.size}")
    A_0 = beam_directions_b(beam_pitch_rad)[beams][:, [0, 2]]
    if abs(np.linalg.det(A_0)) < 1e-9:
        return cannot(NAME, "the pair differs only in its sway components: surge and heave are not separable")
    inv = np.linalg.inv(A_0)  # rows: u, w
    rows = np.zeros((3, 2))
    rows[0], rows[2] = inv[0], inv[1]
    C = embed(rows, beams)
    sensitivity = (C @ beam_directions_b(beam_pitch_rad) - np.eye(3))[:, SWAY]  # d(v_meas - v_true) / d sway
    return PartialSolution(
        method=NAME,
        ok=True,
        C=C,
        measured=np.ones(3, dtype=bool),
        assumption_sd=np.sqrt(epsilon_m2_per_s2) * sensitivity,
    )
