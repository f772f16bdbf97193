"""The right-invariant EKF (method ``iekf``) as the 20-state filter in another error coordinate.

Barrau and Bonnabel's invariant EKF for inertial navigation, with the IMU biases and the DVL's
beam biases and scale factor as ordinary (additive) augmented states, as in Potokar, Norman and
Mangelson (IEEE RA-L 2021). Attitude ``R = C_nb``, velocity ``v`` (NED) and position ``p`` form
an element of SE_2(3), ``X = [[R, v, p], [0, 1, 0], [0, 0, 1]]``; the right-invariant error is
``eta = X X_hat^-1 = (R R_hat^T, v - R R_hat^T v_hat, p - R R_hat^T p_hat) = exp(xi)``.

The 20-state filter's error (tauvcore.filter.layout: ``dp`` NED [m], ``rho`` with
``C = exp([rho x]) C_hat``, body velocity ``dv_b``) and ``xi`` describe the same true state, and
at zero error the map between them has the Jacobian ``T`` (:func:`invariant_map`):

    xi_R = rho,   xi_v = C_hat dv_b,   xi_p = dp + [p_hat x] rho,   sensor errors unchanged,

(from ``eta_v = R dv_b`` exactly and ``eta_p = dp + (I - exp([rho x])) p_hat``). An EKF is
unchanged by a linear change of its error coordinates: ``F``, ``G``, ``H``, ``P`` and the gain
transform with ``T`` and the correction ``d xi = T dx``. So this filter propagates and corrects
exactly as the ESKF does, with the same kernels, in ``dx`` coordinates, and differs from it in
the two places where the coordinates are not interchangeable, both at each correction:

- the estimate moves on the group: ``X_hat <- exp(d xi) X_hat`` (:func:`retract`), which in
  ``dx`` coordinates is ``C <- exp([d rho x]) C``, ``v <- exp([d rho x]) v + J_l(d rho) C dv_b``,
  ``p <- p + J_l(d rho) dp`` (the rotation of ``p_hat`` about the origin and the ``[p_hat x] d rho``
  of ``d xi_p`` cancel exactly, since ``exp([a x]) - I = [a x] J_l(a)``, so the origin plays no
  part), against the ESKF's ``v_b + dv_b`` and ``p + dp``;
- the covariance is carried in ``xi`` coordinates, unchanged across the correction (the invariant
  filter's reset), so in ``dx`` coordinates it becomes ``M P M^T`` with
  ``M = T(x_hat+)^-1 T(x_hat-)`` (:func:`carry_matrix`): the identity but for the position
  against attitude block, ``-[(p_hat+ - p_hat-) x]``, and the velocity block,
  ``C_hat+^T C_hat-``. The ESKF keeps ``P`` in ``dx`` coordinates (``M = I``).

Between corrections both propagate the same ``P`` (``F`` is evaluated at the estimate in both:
``F_xi = T F T^-1 + T' T^-1``, whose navigation block is the estimate-free matrix of the invariant
filter). The invariant filter's benefit is that its linearization does not move with the
estimate, so a direction no sensor sees (global heading, horizontal position) stays unobserved
in the linearized model, where the ESKF's moves with every correction (Huang, Mourikis and
Roumeliotis's mechanism); the carry matrix above is that difference. On the WGS-84 ellipsoid the
positions are latitude, longitude and depth and the ``dp`` of the retraction is in metres at the
estimate, as the ESKF's; the group structure is then that of the local-level frame at each step
(earth rate and transport rate make the system not exactly group-affine; documented in
docs/methods.md).

The compiled twin is tauvcore.filter.kernels.invariant_kernels (the filter bank runs it); this module is
its reference, held equal to it and to the SE_2(3) group operations by tests/unit/tauvcore/filter/test_invariant.py.
"""

from __future__ import annotations

import numpy as np

from tauvcore.filter.eskf import Nominal
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import exp_so3, skew


def left_jacobian_so3(phi: np.ndarray) -> np.ndarray:
    """Left Jacobian of SO(3), ``J_l(phi) = sum_n [phi x]^n / (n + 1)!``: (..., 3) -> (..., 3, 3).

    ``exp([phi x]) = I + [phi x] J_l(phi)``, and the SE_2(3) exponential is
    ``exp(xi) = (exp([xi_R x]), J_l(xi_R) xi_v, J_l(xi_R) xi_p)``.
    """
    phi = np.asarray(phi, dtype=float)
    angle = np.linalg.norm(phi, axis=-1)[..., None, None]
    small = angle < 1e-4
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
    b = np.where(small, 1.0 / 6.0 - angle**2 / 120.0, (safe - np.sin(safe)) / safe**3)
    k = skew(phi)
    return np.eye(3) + a * k + b * (k @ k)


def invariant_map(C_nb: np.ndarray, pos_ned_m: np.ndarray) -> np.ndarray:
    """``T``, the Jacobian of the invariant error ``xi`` against the filter's ``dx`` at zero error.

    Parameters
    ----------
    C_nb : numpy.ndarray
        Estimated attitude, body to NED, shape (..., 3, 3).
    pos_ned_m : numpy.ndarray
        Estimated position, NED [m] from the origin the group is taken about, shape (..., 3).

    Returns
    -------
    numpy.ndarray
        ``T``, shape (..., 20, 20): ``xi = T dx`` to first order, in the layout of
        :data:`~tauvcore.filter.layout.STATE` (``xi_p`` [m] and ``xi_v`` [m/s] in NED, ``xi_R``
        [rad]; the sensor errors as they are).
    """
    C_nb = np.asarray(C_nb, dtype=float)
    batch = np.broadcast_shapes(C_nb.shape[:-2], np.shape(pos_ned_m)[:-1])
    T = np.broadcast_to(np.eye(STATE.dim), batch + (STATE.dim, STATE.dim)).copy()
    T[..., STATE.pos, STATE.att] = skew(np.broadcast_to(pos_ned_m, batch + (3,)))
    T[..., STATE.vel, STATE.vel] = np.broadcast_to(C_nb, batch + (3, 3))
    return T


def carry_matrix(C_before: np.ndarray, C_after: np.ndarray, dpos_ned_m: np.ndarray) -> np.ndarray:
    """``M = T(x_hat+)^-1 T(x_hat-)``: the covariance in ``dx`` coordinates after a correction is
    ``M P M^T`` when it is carried unchanged in ``xi`` coordinates.

    Parameters
    ----------
    C_before, C_after : numpy.ndarray
        The attitude before and after the correction, body to NED, shape (..., 3, 3).
    dpos_ned_m : numpy.ndarray
        The position's move ``p_hat+ - p_hat-`` [m], NED, shape (..., 3).

    Returns
    -------
    numpy.ndarray
        ``M``, shape (..., 20, 20) [the states' units over theirs]: the identity but for
        ``M[pos, att] = -[dpos x]`` and ``M[vel, vel] = C_after^T C_before``.
    """
    C_before, C_after = np.asarray(C_before, dtype=float), np.asarray(C_after, dtype=float)
    batch = np.broadcast_shapes(C_before.shape[:-2], C_after.shape[:-2], np.shape(dpos_ned_m)[:-1])
    M = np.broadcast_to(np.eye(STATE.dim), batch + (STATE.dim, STATE.dim)).copy()
    M[..., STATE.pos, STATE.att] = -skew(np.broadcast_to(dpos_ned_m, batch + (3,)))
    M[..., STATE.vel, STATE.vel] = np.swapaxes(C_after, -1, -2) @ C_before
    return M


def retract(nom: Nominal, dx: np.ndarray) -> tuple[Nominal, np.ndarray]:
    """``X_hat <- exp(T dx) X_hat`` for the navigation part, the sensor errors added; flat model.

    Parameters
    ----------
    nom : Nominal
        The estimate before the correction (positions NED [m], velocity NED [m/s], ``C_nb``),
        batch shape ``B``.
    dx : numpy.ndarray
        The correction in the filter's coordinates, shape (B, 20) (:data:`~tauvcore.filter.layout.STATE`).

    Returns
    -------
    nom : Nominal
        The corrected estimate, batch shape ``B``.
    M : numpy.ndarray
        The covariance's carry matrix (:func:`carry_matrix`), shape (B, 20, 20).
    """
    dx = np.asarray(dx, dtype=float)
    d_rho, dp, dv_b = dx[..., STATE.att], dx[..., STATE.pos], dx[..., STATE.vel]
    E, J = exp_so3(d_rho), left_jacobian_so3(d_rho)
    C = nom.nav.C_nb
    C_new = E @ C
    vel_new = np.einsum("...ij,...j->...i", E, nom.nav.vel_n) + np.einsum("...ij,...j->...i", J @ C, dv_b)
    move = np.einsum("...ij,...j->...i", J, dp)
    out = Nominal(
        NavState(nom.nav.pos_n + move, vel_new, C_new),
        nom.accel_bias + dx[..., STATE.ba],
        nom.gyro_bias + dx[..., STATE.bg],
        nom.dvl_bias + dx[..., STATE.b_dvl],
        nom.dvl_sf + dx[..., STATE.sf_dvl.start],
    )
    return out, carry_matrix(C, C_new, move)
