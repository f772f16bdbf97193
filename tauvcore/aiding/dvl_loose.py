"""Loosely coupled DVL: least-squares body velocity from 3 or 4 beams (Tal et al. 2017 eq. 17-21).

Beams ``y = A (v_b (1 + SF) + omega_nb_b x l) + b_dvl + n`` (eq. 15). Weighted least squares over
the returned beams (eq. 17, written in the paper with its factors in the wrong order,
``y (A^T A)^-1 A^T``; the product that type-checks is ``(A^T W A)^-1 A^T W y``):

    v_head = A+ y,   A+ = (A^T W A)^-1 A^T W,   W = diag(1 / sigma_k^2) over returned beams

(eq. 19, 21). The lever-arm velocity is removed with the gyro: ``z = v_head - omega_hat_nb x l``.
The measurement model keeps every state the velocity solution depends on:

    z = (1 + SF) v_b + (omega_nb - omega_hat_nb) x l + A+ b_dvl + A+ n
    H = [0, [l x] C^T [omega_ie x], (1 + SF_hat) I, 0, [l x], A+, v_hat_b]   (pos, att, vel, ba, bg, b_dvl, sf)

The paper's eq. 18 keeps only the velocity column (and gives H as 20x3; it is 3x20, the
transpose); the scale factor (0.7 % = 1.4 cm/s at 2 m/s)
and beam biases would then be unmodelled errors that bias the velocity and break consistency,
while the states are there to absorb them. ``R = (A^T W A)^-1 + sigma_w^2 [l x][l x]^T`` with
``sigma_w`` the noise of the gyro rate used for the lever arm (eq. 20's gyro term). Fewer than
three returned beams: no measurement (``valid`` false).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.earth import Earth
from tauvcore.sensors.dvl import DvlConfig

MIN_BEAMS_LC = 3


def solve_velocity(
    A_b: np.ndarray, y_beam: np.ndarray, available: np.ndarray, noise_mps: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least squares over the returned beams (eq. 17, 19, 21).

    A_b (4, 3); y_beam (B, 4) with anything (NaN allowed) where ``available`` (B, 4) is false.
    Returns ``v`` (B, 3), its covariance (B, 3, 3), ``A+`` (B, 3, 4) with zero columns for the
    missing beams, and ``valid`` (B,) = at least three beams returned. ``noise_mps`` is floored
    at :data:`~tauvcore.aiding.noise_floors.DVL_BEAM_NOISE_FLOOR_MPS` (a zero noise is legal).
    The kernel :func:`tauvcore.filter.kernels.dvl_kernels.lc_solve_into` (the one the filter bank runs).
    """
    from tauvcore.filter.kernels.common import flat
    from tauvcore.filter.kernels.dvl_kernels import lc_solve_batch

    batch = np.broadcast_shapes(np.shape(y_beam)[:-1], np.shape(available)[:-1])
    v, cov, A_pinv, valid = lc_solve_batch(
        flat(A_b, (), (4, 3))[0],
        flat(y_beam, batch, (4,)),
        flat(available, batch, (4,), bool),
        dvl_beam_sigma_mps(noise_mps) ** 2,
    )
    return (
        v.reshape(batch + (3,)),
        cov.reshape(batch + (3, 3)),
        A_pinv.reshape(batch + (3, 4)),
        valid.reshape(batch),
    )


@dataclass(frozen=True)
class DvlLooseSetup:
    z: np.ndarray  # (B, 3) lever-arm compensated LS velocity [m/s]
    R: np.ndarray  # (B, 3, 3)
    A_pinv: np.ndarray  # (B, 3, 4)
    omega_meas_b: np.ndarray  # (B, 3) measured (uncorrected) gyro rate at the ping [rad/s]
    omega_comp_b: np.ndarray  # (B, 3) omega_hat_nb used for the lever-arm compensation [rad/s]
    valid: np.ndarray  # (B,)


@dataclass(frozen=True)
class DvlLoose:
    dvl: DvlConfig  # filter tuning (noise, geometry, lever arm)
    earth: Earth
    gyro_rate_noise_rps: float  # 1-sigma noise of the gyro rate at the ping [rad/s]

    name = "dvl"

    def prepare(
        self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray, omega_meas_b: np.ndarray
    ) -> DvlLooseSetup:
        """The measurement side (the kernel :func:`tauvcore.filter.kernels.dvl_kernels.lc_prepare_into`)."""
        from tauvcore.filter.kernels.common import flat as f
        from tauvcore.filter.kernels.dvl_kernels import lc_prepare_batch

        batch = np.broadcast_shapes(
            np.shape(y_beam)[:-1],
            np.shape(available)[:-1],
            np.shape(omega_meas_b)[:-1],
            nom.nav.C_nb.shape[:-2],
            nom.gyro_bias.shape[:-1],
        )
        z, R, A_pinv, omega_comp, valid = lc_prepare_batch(
            f(self.dvl.A_b, (), (4, 3))[0],
            f(self.dvl.l_dvl_b, (), (3,))[0],
            dvl_beam_sigma_mps(self.dvl.noise_mps) ** 2,
            self.gyro_rate_noise_rps**2,
            f(self.earth.omega_ie_n, (), (3,))[0],
            f(y_beam, batch, (4,)),
            f(available, batch, (4,), bool),
            f(omega_meas_b, batch, (3,)),
            f(nom.nav.C_nb, batch, (3, 3)),
            f(nom.gyro_bias, batch, (3,)),
        )
        return DvlLooseSetup(
            z=z.reshape(batch + (3,)),
            R=R.reshape(batch + (3, 3)),
            A_pinv=A_pinv.reshape(batch + (3, 4)),
            omega_meas_b=np.broadcast_to(omega_meas_b, batch + (3,)),
            omega_comp_b=omega_comp.reshape(batch + (3,)),
            valid=valid.reshape(batch),
        )

    def predict(self, nom: Nominal, setup: DvlLooseSetup) -> np.ndarray:
        """Nonlinear h(x) for the state ``nom``, with the measurement-side quantities held fixed
        (the kernel :func:`tauvcore.filter.kernels.dvl_kernels.lc_predict_into`)."""
        from tauvcore.filter.kernels.common import flat as f
        from tauvcore.filter.kernels.dvl_kernels import lc_predict_batch

        batch = np.broadcast_shapes(setup.z.shape[:-1], nom.vel_b.shape[:-1])
        h = lc_predict_batch(
            f(nom.nav.C_nb, batch, (3, 3)),
            f(nom.nav.vel_n, batch, (3,)),
            f(nom.dvl_sf, batch, ()),
            f(nom.dvl_bias, batch, (4,)),
            f(nom.gyro_bias, batch, (3,)),
            f(setup.A_pinv, batch, (3, 4)),
            f(setup.omega_meas_b, batch, (3,)),
            f(setup.omega_comp_b, batch, (3,)),
            f(self.earth.omega_ie_n, (), (3,))[0],
            f(self.dvl.l_dvl_b, (), (3,))[0],
        )
        return h.reshape(batch + (3,))

    def jacobian(self, nom: Nominal, setup: DvlLooseSetup) -> np.ndarray:
        """H (the kernel :func:`tauvcore.filter.kernels.dvl_kernels.lc_jacobian_into`)."""
        from tauvcore.filter.kernels.common import flat as f
        from tauvcore.filter.kernels.dvl_kernels import lc_jacobian_batch

        batch = np.broadcast_shapes(setup.z.shape[:-1], nom.vel_b.shape[:-1])
        H = lc_jacobian_batch(
            f(nom.nav.C_nb, batch, (3, 3)),
            f(nom.nav.vel_n, batch, (3,)),
            f(nom.dvl_sf, batch, ()),
            f(setup.A_pinv, batch, (3, 4)),
            f(self.earth.omega_ie_n, (), (3,))[0],
            f(self.dvl.l_dvl_b, (), (3,))[0],
        )
        return H.reshape(batch + (3, STATE.dim))

    def measure(
        self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray, omega_meas_b: np.ndarray
    ) -> Measurement:
        setup = self.prepare(nom, y_beam, available, omega_meas_b)
        return Measurement(
            z=setup.z,
            innovation=setup.z - self.predict(nom, setup),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=setup.valid,
        )
