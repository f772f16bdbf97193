"""INS error model of the 20-state filter (Tal et al. 2017 eq. 3-11): F, G, Q and discretisation.

Error state ``dx = [dpos_n, rho, dvel_b, dba, dbg, db_dvl(4), dsf]`` (tauvcore.filter.layout),
``dx = x_true - x_hat``, ``C_nb_true = exp([rho x]) C_nb_hat``. Continuous model
``dx' = F dx + G w`` with ``w = [w_a, w_g, w_ba, w_bg, w_bdvl, w_sf]`` (eq. 11).

Derivation of the velocity rows (the paper's F32, F33, "found for example in [17]")
-----------------------------------------------------------------------------------
With ``vel_n = C v_b`` in the earth-fixed n frame, ``vel_n' = C f + g - 2 W vel_n`` (W = [omega_ie_n x])
and ``C' = C [omega_ib_b x] - W C`` give the body-frame velocity equation

    v_b' = f_b + C^T g_n - (omega_ib_b + C^T omega_ie_n) x v_b .

Perturb: ``f = f_hat - dba - w_a``, ``omega = omega_hat - dbg - w_g``,
``C^T = C_hat^T (I - [rho x])`` so ``C^T g = C_hat^T g + C_hat^T [g x] rho`` and
``C^T omega_ie = C_hat^T omega_ie + C_hat^T [omega_ie x] rho``, ``v_b = v_hat + dv``. To first order

    dv' = F32 rho + F33 dv - dba - [v_hat x] dbg - w_a - [v_hat x] w_g

    F32 = C_hat^T [g_n x] + [v_hat x] C_hat^T [omega_ie_n x]
    F33 = -[(omega_ib_hat + C_hat^T omega_ie_n) x]

which reproduces the paper's -I and -[v x] columns (eq. 4) and its G (eq. 5). The attitude row
follows from ``C' = C[omega x] - W C``: ``rho' = -W rho - C_hat dbg - C_hat w_g``; the position
row from ``pos_n' = C v_b``: ``dpos' = -[(C_hat v_hat) x] rho + C_hat dv``. Gravity is constant
over the mission area (tauvcore.geo.earth), hence the zero position column.

``error_rate`` of tests/unit/tauvcore/ins/error_rate_reference.py is the exact nonlinear
error dynamics; the tests compare F and G to its central finite differences.

On the WGS-84 ellipsoid (the paper's F has a zero position column; ours does not)
--------------------------------------------------------------------------------
Position is geodetic (lat, lon, h), n is the local-level NED frame at the point itself and turns
at ``omega_in = omega_ie(lat) + omega_en(lat, h, vel_n)`` (tauvcore.geo.earth). Each quantity of
the true and of the nominal state is taken in its own local frame, and the position error is in
metres at the nominal point: ``dpos = ((R_N + h) dlat, (R_E + h) cos(lat) dlon, -dh)`` with R, h,
lat the nominal's. Then:

- velocity: ``v_b' = f_b + C^T g(lat, h) - (omega_ib_b + C^T omega_ie(lat)) x v_b`` still holds
  (the transport rate cancels from the body-frame velocity), so the velocity rows gain the
  position columns ``C^T G_p + [v x] C^T W_ie,p`` (G_p, W_ie,p: gravity's and the earth rate's
  Jacobians with respect to dpos: the free-air gradient, about 3.1e-6 s^-2, and the change with
  latitude);
- attitude: from ``C' = C [omega_ib x] - [omega_in x] C`` and ``dvel_n = C dv - [vel_n x] rho``,
  ``rho' = -[omega_in x] rho - C dbg - d omega_in``, ``d omega_in = (W_ie,p + W_en,p) dpos +
  W_en,v dvel_n``;
- position: differentiating the definition of dpos (the metric itself changes as the vehicle
  moves: meridians converge, heights change the radius),
  ``dpos_N' = dvel_N - v_D / (R_N + h) dpos_N + v_N / (R_N + h) dpos_D``,
  ``dpos_E' = dvel_E - v_E (R_E' / (R_E + h) - tan lat) dpos_N / (R_N + h)
  + (R_E' v_N / ((R_N + h)(R_E + h)) - v_D / (R_E + h) - tan(lat) v_N / (R_N + h)) dpos_E
  + v_E / (R_E + h) dpos_D`` (R_E' = dR_E / dlat), ``dpos_D' = dvel_D``; the two R_N' terms of the
  north row cancel.

These terms are of the order v / R (3e-7 s^-1 at 2 m/s) and g / R (1.5e-6 s^-2): over a
250 s mission they are below the sensors' noise, over an hour and kilometres they are not.
``error_rate_geodetic``, beside ``error_rate`` in the tests, is the exact nonlinear
counterpart they differentiate.
"""

from __future__ import annotations

import numpy as np

from tauvcore.filter.layout import NOISE, STATE
from tauvcore.geo.earth import Earth
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.sensors.imu import ImuConfig


def F_matrix(
    C_nb: np.ndarray,
    vel_b: np.ndarray,
    omega_ib_b: np.ndarray,
    earth: Earth,
    position: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Continuous-time F (eq. 4 and 9) at the nominal state. -> (..., 20, 20).

    C_nb (..., 3, 3), vel_b (..., 3) nominal body velocity, omega_ib_b (..., 3) bias-corrected rate.
    ``position``: None for the flat model of ``earth`` (its constant gravity and earth rate); or
    the nominal geodetic position (latitude [rad], longitude [rad], height [m], each (...,)) for
    the WGS-84 error model of the module docstring. The formula is the compiled kernel
    :func:`tauvcore.filter.kernels.error_model_kernels.F_into` (the one the filter bank runs); the tests compare it
    with central differences of the exact error dynamics (tests/unit/tauvcore/ins/error_rate_reference.py).
    """
    from tauvcore.filter.kernels.common import flat as f  # numba: with the engine, not for --help
    from tauvcore.filter.kernels.error_model_kernels import F_batch, flat_terms_batch, geodetic_terms_batch

    shapes = [np.shape(C_nb)[:-2], np.shape(vel_b)[:-1], np.shape(omega_ib_b)[:-1]]
    if position is not None:
        shapes += [np.shape(position[0]), np.shape(position[2])]
    batch = np.broadcast_shapes(*shapes)
    C, v = f(C_nb, batch, (3, 3)), f(vel_b, batch, (3,))
    n = C.shape[0]
    if position is None:
        T = flat_terms_batch(f(earth.g_n, (), (3,))[0], f(earth.omega_ie_n, (), (3,))[0], n)
    else:
        vel_n = np.einsum("nij,nj->ni", C, v)
        T = geodetic_terms_batch(f(position[0], batch, ()), f(position[2], batch, ()), vel_n)
    F = F_batch(C, v, f(omega_ib_b, batch, (3,)), T)
    return F.reshape(batch + (STATE.dim, STATE.dim))


def G_matrix(C_nb: np.ndarray, vel_b: np.ndarray) -> np.ndarray:
    """Continuous-time G (eq. 5 and 10), the kernel :func:`tauvcore.filter.kernels.error_model_kernels.G_into`. -> (..., 20, 17)."""
    from tauvcore.filter.kernels.common import flat
    from tauvcore.filter.kernels.error_model_kernels import G_batch

    batch = np.broadcast_shapes(np.shape(C_nb)[:-2], np.shape(vel_b)[:-1])
    G = G_batch(flat(C_nb, batch, (3, 3)), flat(vel_b, batch, (3,)), NOISE.dim)
    return G.reshape(batch + (STATE.dim, NOISE.dim))


def _psd_floor() -> np.ndarray:
    q = np.zeros(NOISE.dim)
    q[NOISE.accel] = 1e-6**2  # [m/s/sqrt(s)]: Table 2 1.2e-3 (0.072 m/s/sqrt(h))
    q[NOISE.gyro] = 1e-7**2  # [rad/sqrt(s)]: Table 2 9.9e-5 (0.34 deg/sqrt(h))
    q[NOISE.ba] = 1e-8**2  # [m/s^2/sqrt(s)]: Table 2 1e-5
    q[NOISE.bg] = 1e-10**2  # [rad/s/sqrt(s)]: Table 2 4.9e-7 (2.8e-5 deg/s/sqrt(s))
    q[NOISE.b_dvl] = 1e-8**2  # [m/s/sqrt(s)]: Table 2 5e-5
    q[NOISE.sf_dvl] = 1e-8**2  # [1/sqrt(s)]: Table 2 5e-5 (5e-3 %/sqrt(s))
    return q


PROCESS_NOISE_PSD_FLOOR = _psd_floor()
"""(17,) smallest process-noise densities the filter assumes, per element of ``w`` (eq. 11).

Zero IMU or DVL noise is a legal configuration (an ideal sensor). With Q = 0 the filter's P
on the observable states collapses without bound while the unobservable combinations keep their
initial variance, and P's condition number leaves double precision. Each floor is about 1e-3
(1e-4 for the gyro bias walk) of Table 2's density, so it never changes a realistic
configuration (a density at or above the floor is used as given) and adds, over a 10-hour run,
at most 0.2 mm/s of velocity and 0.03 deg of heading to the filter's sigmas."""


def noise_psd(imu: ImuConfig, dvl: DvlConfig) -> np.ndarray:
    """Diagonal of the continuous process-noise spectral density Q (17,), SI units^2/Hz.

    Each element is at least :data:`PROCESS_NOISE_PSD_FLOOR` (a zero noise is legal).
    """
    q = np.zeros(NOISE.dim)
    q[NOISE.accel] = imu.accel_noise_mps_per_sqrt_s**2
    q[NOISE.gyro] = imu.gyro_noise_rad_per_sqrt_s**2
    q[NOISE.ba] = imu.accel_bias_rw_mps2_per_sqrt_s**2
    q[NOISE.bg] = imu.gyro_bias_rw_rps_per_sqrt_s**2
    q[NOISE.b_dvl] = dvl.bias_rw_mps_per_sqrt_s**2
    q[NOISE.sf_dvl] = dvl.scale_factor_rw_per_sqrt_s**2
    return np.maximum(q, PROCESS_NOISE_PSD_FLOOR)


def discretise(F: np.ndarray, G: np.ndarray, q_psd: np.ndarray, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition ``Phi = expm(F dt)`` (third-order series) and ``Qd`` (trapezoid rule).

    ``Qd = (Phi G Q G^T Phi^T + G Q G^T) dt / 2`` (Van Loan to second order). F must have the
    structure of :func:`F_matrix` (zero outside rows 0-8 and columns 0-14), which the compiled
    kernels (:func:`tauvcore.filter.kernels.error_model_kernels.transition_into`, ``sandwich_into``) exploit.
    """
    from tauvcore.filter.kernels.common import CORE, NAV, flat
    from tauvcore.filter.kernels.error_model_kernels import discretise_batch

    F = np.asarray(F, dtype=float)
    if np.any(F[..., NAV:, :]) or np.any(F[..., :, CORE:]):
        raise ValueError("F must be zero outside rows 0-8 and columns 0-14 (the structure of F_matrix)")
    batch = np.broadcast_shapes(F.shape[:-2], np.shape(G)[:-2])
    Phi, Qd = discretise_batch(
        flat(F, batch, (STATE.dim, STATE.dim)),
        flat(G, batch, (STATE.dim, NOISE.dim)),
        flat(q_psd, (), (NOISE.dim,))[0],
        float(dt_s),
    )
    return Phi.reshape(batch + Phi.shape[1:]), Qd.reshape(batch + Qd.shape[1:])
