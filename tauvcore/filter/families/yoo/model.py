"""The error model of Yoo 2014's 12-state indirect feedback filter (section 2.1, eq. 7-18).

State (eq. 12), in tauvcore's sign convention (every error is *true minus estimate*, and the
attitude error ``rho`` is the left, n-frame one of tauvcore.conventions: ``C_nb_true =
exp([rho x]) C_nb_est``)::

    dx = [dv_n (3), rho (3), d_ba (3), d_bg (3)]     velocity error in NED [m/s], attitude [rad],
                                                    accelerometer and gyro bias errors (body)

No position states: "the velocity information is the only one as the external sensor", so the
paper leaves position out of the filter (its eq. 9-10 drop the position-dependent terms); the
position follows from the corrected velocity. The error dynamics ``dx' = F dx + G w`` on the
geodetic mechanization of eq. 1 and 6 (NED frame turning at ``omega_in = omega_ie + omega_en``)::

    dv'  = -(f_n x) rho - C_nb d_ba - (2 omega_ie + omega_en) x dv + (v x) J_en dv
    rho' = -omega_in x rho - C_nb d_bg - J_en dv
    d_ba' = 0,  d_bg' = 0   (plus their random walks)

with ``J_en = d omega_en / d v_n`` (omega_en = (v_E / (R_E + h), -v_N / (R_N + h), -v_E tan(L) /
(R_E + h))). :func:`F_matrix` is that; tests/unit/tauvcore/filter/test_yoo.py holds it to finite differences of
the exact nonlinear error dynamics.

Against the paper's printed F (eq. 13-15, :func:`F_paper`): the paper writes the velocity error
as *estimate minus true* (eq. 17: ``z = v_INS - v_VKF``), its sensor errors ``delta f``,
``delta omega`` as the corrected measurement's error, i.e. our bias errors (true minus estimate),
and uses one earth radius R. Under that change of sign of the velocity its blocks are ours: F11
(velocity-velocity, Titterton's full form, which the paper prints although its eq. 9 shows only
the Coriolis part), F12 = [f_n x], F13 = C_nb, F22 = -[omega_in x],
F24 = -C_nb, except one entry: F21's (3, 2), d(rho_D')/d(dv_E), is printed ``tan L / R``; the
derivative of ``omega_en,D = -v_E tan L / R`` is ``-tan L / R``, so the paper's sign is a typo (our
finite-difference test fails with it). The paper also keeps F21 (its 1/R terms) although eq. 10
drops ``delta omega_in``; we keep them, as its matrix does.
"""

from __future__ import annotations

import numpy as np

from tauvcore.geo.earth import OMEGA_IE_RPS, radii_of_curvature_m
from tauvcore.geo.rotations import skew

VEL, ATT, BA, BG = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
DIM = 12


def rates(lat_rad: float, h_m: float, vel_n: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The earth and transport rates and the transport rate's Jacobian at a position and velocity.

    Parameters
    ----------
    lat_rad : float
        Geodetic latitude [rad] (WGS-84).
    h_m : float
        Height above the WGS-84 ellipsoid [m] (minus the depth).
    vel_n : numpy.ndarray
        Velocity relative to the earth, shape (3,) [m/s], NED n-frame.

    Returns
    -------
    omega_ie_n : numpy.ndarray
        Earth rate, shape (3,) [rad/s], NED n-frame.
    omega_en_n : numpy.ndarray
        Transport rate, shape (3,) [rad/s], NED n-frame.
    J_en : numpy.ndarray
        ``d omega_en / d v_n``, shape (3, 3) [rad/m].
    """
    R_N, R_E = radii_of_curvature_m(lat_rad)
    rn, re = R_N + h_m, R_E + h_m
    w_ie = OMEGA_IE_RPS * np.array([np.cos(lat_rad), 0.0, -np.sin(lat_rad)])
    t = np.tan(lat_rad)
    w_en = np.array([vel_n[1] / re, -vel_n[0] / rn, -vel_n[1] * t / re])
    J_en = np.array([[0.0, 1.0 / re, 0.0], [-1.0 / rn, 0.0, 0.0], [0.0, -t / re, 0.0]])
    return w_ie, w_en, J_en


def F_matrix(lat_rad: float, h_m: float, vel_n: np.ndarray, f_n: np.ndarray, C_nb: np.ndarray) -> np.ndarray:
    """The error dynamics ``F`` of the module docstring at the estimated state.

    Parameters
    ----------
    lat_rad : float
        Geodetic latitude [rad] (WGS-84).
    h_m : float
        Height above the WGS-84 ellipsoid [m] (minus the depth).
    vel_n : numpy.ndarray
        Estimated velocity relative to the earth, shape (3,) [m/s], NED n-frame.
    f_n : numpy.ndarray
        Specific force, shape (3,) [m/s^2], NED n-frame.
    C_nb : numpy.ndarray
        Estimated attitude, shape (3, 3), body (FRD) to NED.

    Returns
    -------
    numpy.ndarray
        ``F``, shape (12, 12), over ``dx = [dv_n, rho, d_ba, d_bg]`` (velocity error [m/s] and
        misalignment [rad] in NED, bias errors [m/s^2], [rad/s] in the body frame); each entry in
        its row's state unit per second over its column's.
    """
    w_ie, w_en, J_en = rates(lat_rad, h_m, vel_n)
    F = np.zeros((DIM, DIM))
    F[VEL, VEL] = -skew(2.0 * w_ie + w_en) + skew(vel_n) @ J_en
    F[VEL, ATT] = -skew(f_n)
    F[VEL, BA] = -C_nb
    F[ATT, VEL] = -J_en
    F[ATT, ATT] = -skew(w_ie + w_en)
    F[ATT, BG] = -C_nb
    return F


def F_paper(
    lat_rad: float, vel_n: np.ndarray, f_n: np.ndarray, C_nb: np.ndarray, R_m: float, typo: bool = True
) -> np.ndarray:
    """The paper's F (eq. 13-15) as printed, in its convention (velocity and bias errors estimate
    minus true) and with one radius ``R_m``.

    Parameters
    ----------
    lat_rad : float
        Geodetic latitude [rad].
    vel_n : numpy.ndarray
        Velocity relative to the earth, shape (3,) [m/s], NED n-frame.
    f_n : numpy.ndarray
        Specific force, shape (3,) [m/s^2], NED n-frame.
    C_nb : numpy.ndarray
        Attitude, shape (3, 3), body (FRD) to NED.
    R_m : float
        The one earth radius the paper uses for both ``R_N`` and ``R_E`` [m].
    typo : bool
        True: F21's (3, 2) entry as printed, ``tan L / R``; False: its sign corrected, ``-tan L / R``.

    Returns
    -------
    numpy.ndarray
        The paper's ``F``, shape (12, 12), over its error state: velocity error (estimate minus
        true) in NED [m/s], attitude error [rad], sensor errors ``delta f`` [m/s^2] and ``delta
        omega`` [rad/s] of the corrected measurements (tauvcore's bias errors, :func:`paper_convention`);
        each entry in its row's state unit per second over its column's.
    """
    vN, vE, vD = vel_n
    fN, fE, fD = f_n
    W, L = OMEGA_IE_RPS, lat_rad
    s, c, t = np.sin(L), np.cos(L), np.tan(L)
    F = np.zeros((DIM, DIM))
    F[VEL, VEL] = [
        [vD / R_m, -2.0 * (W * s + vE * t / R_m), vN / R_m],
        [2.0 * W * s + vE * t / R_m, (vN * t + vD) / R_m, 2.0 * W * c + vE / R_m],
        [-2.0 * vN / R_m, -2.0 * (W * c + vE / R_m), 0.0],
    ]
    F[VEL, ATT] = [[0.0, -fD, fE], [fD, 0.0, -fN], [-fE, fN, 0.0]]
    F[ATT, VEL] = [
        [0.0, 1.0 / R_m, 0.0],
        [-1.0 / R_m, 0.0, 0.0],
        [0.0, (1.0 if typo else -1.0) * t / R_m, 0.0],
    ]
    F[ATT, ATT] = [
        [0.0, -(W * s + vE * t / R_m), vN / R_m],
        [W * s + vE * t / R_m, 0.0, W * c + vE / R_m],
        [-vN / R_m, -(W * c + vE / R_m), 0.0],
    ]
    F[VEL, BA] = C_nb
    F[ATT, BG] = -C_nb
    return F


def paper_convention() -> np.ndarray:
    """The diagonal sign change ``S`` from tauvcore's error state to the paper's.

    The velocity error flips (estimate minus true), attitude and bias errors do not.
    ``F_paper = S F S``.

    Returns
    -------
    numpy.ndarray
        ``S``, shape (12, 12), diagonal, entries -1 (velocity) and +1 (attitude, biases) [-].
    """
    return np.diag(np.r_[-np.ones(3), np.ones(9)])


def F_batch(
    lat: np.ndarray,
    h: np.ndarray,
    vel_n: np.ndarray,
    f_n: np.ndarray,
    C: np.ndarray,
    geodetic: bool,
    w_ie_flat: np.ndarray,
) -> np.ndarray:
    """:func:`F_matrix` for a batch (B,) of states.

    On the flat earth the transport rate is zero and the earth rate constant (``w_ie_flat``).

    Parameters
    ----------
    lat : numpy.ndarray
        Geodetic latitudes, shape (B,) [rad] (WGS-84); used only if ``geodetic``.
    h : numpy.ndarray
        Heights above the WGS-84 ellipsoid, shape (B,) [m] (minus the depths); used only if
        ``geodetic``.
    vel_n : numpy.ndarray
        Estimated velocities relative to the earth, shape (B, 3) [m/s], NED n-frame.
    f_n : numpy.ndarray
        Specific forces, shape (B, 3) [m/s^2], NED n-frame.
    C : numpy.ndarray
        Estimated attitudes ``C_nb``, shape (B, 3, 3), body (FRD) to NED.
    geodetic : bool
        WGS-84 (the rates of :func:`rates` at each state) rather than the flat earth.
    w_ie_flat : numpy.ndarray
        The flat earth's earth rate, shape (3,) [rad/s], NED n-frame; used only if not ``geodetic``.

    Returns
    -------
    numpy.ndarray
        ``F``, shape (B, 12, 12), in the units of :func:`F_matrix`'s.
    """
    B = vel_n.shape[0]
    F = np.zeros((B, DIM, DIM))
    if geodetic:
        R_N, R_E = radii_of_curvature_m(lat)
        rn, re = R_N + h, R_E + h
        t = np.tan(lat)
        w_ie = OMEGA_IE_RPS * np.stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)], axis=-1)
        w_en = np.stack([vel_n[:, 1] / re, -vel_n[:, 0] / rn, -vel_n[:, 1] * t / re], axis=-1)
        J = np.zeros((B, 3, 3))
        J[:, 0, 1], J[:, 1, 0], J[:, 2, 1] = 1.0 / re, -1.0 / rn, -t / re
    else:
        w_ie = np.broadcast_to(w_ie_flat, (B, 3))
        w_en = np.zeros((B, 3))
        J = np.zeros((B, 3, 3))
    F[:, VEL, VEL] = -skew(2.0 * w_ie + w_en) + skew(vel_n) @ J
    F[:, VEL, ATT] = -skew(f_n)
    F[:, VEL, BA] = -C
    F[:, ATT, VEL] = -J
    F[:, ATT, ATT] = -skew(w_ie + w_en)
    F[:, ATT, BG] = -C
    return F


def correct_consider(
    P: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: bool,
    gate_sigma: float,
    consider: slice = slice(DIM, None),
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, ...]]:
    """A gated Joseph-form update of the 12 states with consider states after them (and, after
    those, the states the sources add, which are estimated): the one compiled correction of every
    filter family (tauvcore.filter.kernels.correction.correct_into) with the consider states' gain
    zero.

    Schmidt-Kalman: the consider rows of K are zero. An inactive row is dropped exactly. The gate
    is the 20-state correction's (tauvcore.filter.eskf.correct): a row must lie within
    ``gate_sigma`` standard deviations of its prediction, a vector failing in any row is refused
    whole (``gate_rows`` False) or loses its failing rows; an entry whose S over its rows is not
    finite or not positive definite fuses nothing (unusable).

    Parameters
    ----------
    P : numpy.ndarray
        Covariance, shape (B, N, N): the 12 states (velocity error [m/s] and misalignment [rad] in
        NED, accelerometer [m/s^2] and gyro [rad/s] bias errors in the body frame) then the
        consider states, in their SI units squared; not modified.
    H : numpy.ndarray
        Measurement Jacobians, shape (B, m, N), in the measurement's SI unit over each state's.
    Rm : numpy.ndarray
        Measurement noise covariances, shape (B, m, m), in the measurement's SI unit squared.
    nu : numpy.ndarray
        Innovations, shape (B, m), in the measurement's SI unit.
    active : numpy.ndarray
        Shape (B, m) bool: the rows measured.
    gate_rows : bool
        Gate each row on its own (True) or the whole vector at once (False).
    gate_sigma : float
        Gate width in standard deviations of the innovation [-].
    consider : slice
        The consider states: every state after the 12 (the default), or those of the slice.

    Returns
    -------
    P : numpy.ndarray
        Updated covariance, shape (B, N, N), in the states' SI units squared.
    dx : numpy.ndarray
        Correction to inject, shape (B, N), in the states' units (m/s, rad, m/s^2, rad/s, ...);
        zero on the consider states.
    outcome : tuple of numpy.ndarray
        The arguments of tauvcore.filter.eskf.make_outcome after ``z``, ``innovation`` and
        ``active``: S's diagonal (B, m) in the measurement's SI unit squared (NaN off the active
        rows), the rows kept (B, m) bool, the NIS over the active rows before the gate (B,), the test
        ratio (B,) and whether the entry was unusable (B,) bool.
    """
    from tauvcore.filter.kernels.correction import correct_batch

    batch, (N, m) = nu.shape[:-1], (P.shape[-1], nu.shape[-1])
    n = int(np.prod(batch, dtype=np.int64))
    P_new = np.array(np.broadcast_to(P, batch + (N, N)), dtype=float, order="C").reshape(n, N, N)
    start, stop, _ = consider.indices(N)

    def flat(a: np.ndarray, tail: tuple[int, ...], dtype: type = float) -> np.ndarray:
        return np.ascontiguousarray(np.broadcast_to(a, batch + tail), dtype=dtype).reshape((n,) + tail)

    dx, s_diag, keep, nis, ratio, unusable, _ = correct_batch(
        P_new,
        flat(H, (m, N)),
        flat(Rm, (m, m)),
        flat(nu, (m,)),
        flat(active, (m,), bool),
        np.full(n, gate_rows),
        float(gate_sigma),
        start,
        stop,
    )
    return (
        P_new.reshape(batch + (N, N)),
        dx.reshape(batch + (N,)),
        tuple(a.reshape(batch + a.shape[1:]) for a in (s_diag, keep, nis, ratio, unusable)),
    )
