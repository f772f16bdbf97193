"""Geodetic position along a path from its NED velocity (compiled: a sequential recurrence).

The truth generator knows the NED velocity in closed form at any time; its geodetic position is
the solution of ``lat' = v_N / (R_N(lat) + h)``, ``lon' = v_E / ((R_E(lat) + h) cos lat)``,
``depth' = v_D`` (tauvcore.geo.earth.geodetic_rates, with depth = -h). Over each sample interval
the right-hand sides are integrated by the same 4-point Gauss-Legendre rule as the rest of the
truth, with the slowly varying factors (radii, height, cos lat) evaluated at each node from a
first-order estimate of the position there: their relative change over an interval is below
1e-9, so the rule's error is of the order 1e-19 rad per interval, far below what any test sees.
Sample after sample, so a mission cut into chunks gives the same numbers as one drawn whole.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from tauvcore.geo import earth

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
_radii = _jit(earth.radii_of_curvature_m)


@_jit
def integrate_geodetic(
    lat0: float,
    lon0: float,
    depth0: float,
    vel_nodes: np.ndarray,
    nodes: np.ndarray,
    weights: np.ndarray,
    dt: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions at the ends of n intervals from the start (lat0 [rad], lon0 [rad], depth0 [m]).

    vel_nodes (n, G, 3): NED velocity at the G Gauss nodes of each interval (``nodes`` in [-1, 1],
    ``weights`` summing to 2). Returns the positions (n, 3) = (lat, lon, depth) at the interval
    ends, and the estimates of latitude and depth at the nodes (n, G) that the IMU quantities at
    the nodes are evaluated with (gravity and earth rate change by 1e-8 of themselves per metre,
    so the estimates' micrometres do not matter).
    """
    n, G = vel_nodes.shape[0], vel_nodes.shape[1]
    out = np.empty((n, 3))
    node_lat = np.empty((n, G))
    node_depth = np.empty((n, G))
    lat, lon, depth = lat0, lon0, depth0
    for k in range(n):
        R_N, _ = _radii(lat)
        s_n = s_e = s_d = 0.0
        for g in range(G):
            tau = 0.5 * (1.0 + nodes[g]) * dt
            v_n, v_e, v_d = vel_nodes[k, g, 0], vel_nodes[k, g, 1], vel_nodes[k, g, 2]
            lat_g = lat + v_n * tau / (R_N - depth)
            depth_g = depth + v_d * tau
            node_lat[k, g], node_depth[k, g] = lat_g, depth_g
            R_N_g, R_E_g = _radii(lat_g)
            s_n += weights[g] * v_n / (R_N_g - depth_g)
            s_e += weights[g] * v_e / ((R_E_g - depth_g) * math.cos(lat_g))
            s_d += weights[g] * v_d
        lat += 0.5 * dt * s_n
        lon += 0.5 * dt * s_e
        depth += 0.5 * dt * s_d
        out[k, 0], out[k, 1], out[k, 2] = lat, lon, depth
    return out, node_lat, node_depth
