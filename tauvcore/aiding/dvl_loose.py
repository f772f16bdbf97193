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
from tauvcore.geo.rotations import skew
from tauvcore.ins.strapdown import mv
from tauvcore.sensors.dvl import DvlConfig

MIN_BEAMS_LC = 3


def solve_velocity(A_b: np.ndarray, y_beam: np.ndarray, available: np.ndarray, noise_mps: float
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least squares over the returned beams (eq. 17, 19, 21).

    A_b (4, 3); y_beam (B, 4) with anything (NaN allowed) where ``available`` (B, 4) is false.
    Returns ``v`` (B, 3), its covariance (B, 3, 3), ``A+`` (B, 3, 4) with zero columns for the
    missing beams, and ``valid`` (B,) = at least three beams returned. ``noise_mps`` is floored
    at :data:`~tauvcore.aiding.noise_floors.DVL_BEAM_NOISE_FLOOR_MPS` (a zero noise is legal).
    """
    w = available / dvl_beam_sigma_mps(noise_mps)**2
    AtWA = np.einsum("ki,...k,kj->...ij", A_b, w, A_b)
    valid = available.sum(axis=-1) >= MIN_BEAMS_LC
    AtWA = np.where(valid[..., None, None], AtWA, np.eye(3))
    cov = np.linalg.inv(AtWA)
    A_pinv = cov @ (A_b.T * w[..., None, :])
    y0 = np.where(available, y_beam, 0.0)
    return mv(A_pinv, y0), cov, A_pinv, valid


@dataclass(frozen=True)
class DvlLooseSetup:
    z: np.ndarray            # (B, 3) lever-arm compensated LS velocity [m/s]
    R: np.ndarray            # (B, 3, 3)
    A_pinv: np.ndarray       # (B, 3, 4)
    omega_meas_b: np.ndarray  # (B, 3) measured (uncorrected) gyro rate at the ping [rad/s]
    omega_comp_b: np.ndarray  # (B, 3) omega_hat_nb used for the lever-arm compensation [rad/s]
    valid: np.ndarray        # (B,)


@dataclass(frozen=True)
class DvlLoose:
    dvl: DvlConfig               # filter tuning (noise, geometry, lever arm)
    earth: Earth
    gyro_rate_noise_rps: float   # 1-sigma noise of the gyro rate at the ping [rad/s]

    name = "dvl"

    def prepare(self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray,
                omega_meas_b: np.ndarray) -> DvlLooseSetup:
        v_head, cov, A_pinv, valid = solve_velocity(self.dvl.A_b, y_beam, available, self.dvl.noise_mps)
        C_bn = np.swapaxes(nom.nav.C_nb, -1, -2)
        omega_comp = omega_meas_b - nom.gyro_bias - mv(C_bn, self.earth.omega_ie_n)
        l_x = skew(self.dvl.l_dvl_b)
        z = v_head - np.cross(omega_comp, self.dvl.l_dvl_b)
        R = cov + self.gyro_rate_noise_rps**2 * (l_x @ l_x.T)
        return DvlLooseSetup(z=z, R=R, A_pinv=A_pinv, omega_meas_b=np.broadcast_to(omega_meas_b, z.shape),
                             omega_comp_b=omega_comp, valid=valid)

    def predict(self, nom: Nominal, setup: DvlLooseSetup) -> np.ndarray:
        """Nonlinear h(x) for the state ``nom``, with the measurement-side quantities held fixed."""
        C_bn = np.swapaxes(nom.nav.C_nb, -1, -2)
        omega_nb = setup.omega_meas_b - nom.gyro_bias - mv(C_bn, self.earth.omega_ie_n)
        return ((1.0 + nom.dvl_sf)[..., None] * nom.vel_b
                + np.cross(omega_nb - setup.omega_comp_b, self.dvl.l_dvl_b)
                + mv(setup.A_pinv, nom.dvl_bias))

    def jacobian(self, nom: Nominal, setup: DvlLooseSetup) -> np.ndarray:
        batch = setup.z.shape[:-1]
        l_x = skew(self.dvl.l_dvl_b)
        C_bn = np.swapaxes(nom.nav.C_nb, -1, -2)
        H = np.zeros(batch + (3, STATE.dim))
        H[..., STATE.att] = l_x @ C_bn @ skew(self.earth.omega_ie_n)
        H[..., STATE.vel] = (1.0 + nom.dvl_sf)[..., None, None] * np.eye(3)
        H[..., STATE.bg] = l_x
        H[..., STATE.b_dvl] = setup.A_pinv
        H[..., STATE.sf_dvl] = nom.vel_b[..., None]
        return H

    def measure(self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray, omega_meas_b: np.ndarray) -> Measurement:
        setup = self.prepare(nom, y_beam, available, omega_meas_b)
        return Measurement(z=setup.z, innovation=setup.z - self.predict(nom, setup), H=self.jacobian(nom, setup),
                           R=setup.R, valid=setup.valid)
