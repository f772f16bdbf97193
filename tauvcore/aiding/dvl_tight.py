"""Tightly coupled DVL, TC (Tal et al. 2017 eq. 15 and 22): every returned beam is its own
scalar measurement, so any number of beams from one to four aids the filter.

    y_k = b_k^T ((1 + SF) v_b + (omega_nb - omega_hat_nb) x l + omega_hat_nb x l) + b_dvl,k + n_k
    H_k = [0, b_k^T [l x] C^T [omega_ie x], (1 + SF_hat) b_k^T, 0, b_k^T [l x], e_k^T, b_k^T v_hat]

Eq. 22 writes the scale-factor column as ``A x v_hat``: the paper's notation for a product (eq. 7,
15 and 23 write products so), i.e. ``A v_hat``, not a typo. Eq. 22 gives H as 20x4; it is 4x20
(one row per beam), the transpose. The gyro column ``A [l x]`` matches eq. 22. ``R = diag(sigma^2) + sigma_w^2 A [l x][l x]^T A^T`` (eq. 20,
with the cross terms the shared gyro sample creates). Beams are gated one by one (section 2.1.1:
"for each measurement"), so one bad beam does not throw away the other three.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.dvl_partial import beam_noise_cov
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import mv
from tauvcore.sensors.dvl import DvlConfig


@dataclass(frozen=True)
class DvlTightSetup:
    z: np.ndarray  # (B, 4) beam velocities, 0 where not returned [m/s]
    R: np.ndarray  # (B, 4, 4)
    available: np.ndarray  # (B, 4)
    omega_meas_b: np.ndarray  # (B, 3) measured gyro rate at the ping
    omega_comp_b: np.ndarray  # (B, 3) omega_hat_nb at the nominal state


@dataclass(frozen=True)
class DvlTight:
    dvl: DvlConfig
    earth: Earth
    gyro_rate_noise_rps: float

    name = "dvl"

    def prepare(
        self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray, omega_meas_b: np.ndarray
    ) -> DvlTightSetup:
        C_bn = np.swapaxes(nom.nav.C_nb, -1, -2)
        omega_comp = omega_meas_b - nom.gyro_bias - mv(C_bn, self.earth.omega_ie_n)
        z = np.where(available, y_beam, 0.0)
        R = beam_noise_cov(
            self.dvl.A_b,
            self.dvl.noise_mps,
            self.gyro_rate_noise_rps,
            self.dvl.l_dvl_b,
            np.zeros(z.shape[:-1]),
        )
        return DvlTightSetup(
            z=z,
            R=R,
            available=available,
            omega_meas_b=np.broadcast_to(omega_meas_b, omega_comp.shape),
            omega_comp_b=omega_comp,
        )

    def predict(self, nom: Nominal, setup: DvlTightSetup) -> np.ndarray:
        """Nonlinear h(x) per beam (the kernel :func:`tauvcore.filter.kernels.dvl_kernels.tc_predict_into`)."""
        from tauvcore.filter.kernels.common import flat as f
        from tauvcore.filter.kernels.dvl_kernels import tc_predict_batch

        batch = np.broadcast_shapes(setup.z.shape[:-1], nom.vel_b.shape[:-1])
        h = tc_predict_batch(
            f(self.dvl.A_b, (), (4, 3))[0],
            f(nom.nav.C_nb, batch, (3, 3)),
            f(nom.nav.vel_n, batch, (3,)),
            f(nom.dvl_sf, batch, ()),
            f(nom.dvl_bias, batch, (4,)),
            f(nom.gyro_bias, batch, (3,)),
            f(setup.omega_meas_b, batch, (3,)),
            f(self.earth.omega_ie_n, (), (3,))[0],
            f(self.dvl.l_dvl_b, (), (3,))[0],
        )
        return h.reshape(batch + (4,))

    def jacobian(self, nom: Nominal, setup: DvlTightSetup) -> np.ndarray:
        """H, one row per beam (the kernel :func:`tauvcore.filter.kernels.dvl_kernels.tc_jacobian_into`)."""
        from tauvcore.filter.kernels.common import flat as f
        from tauvcore.filter.kernels.dvl_kernels import tc_jacobian_batch

        batch = np.broadcast_shapes(setup.z.shape[:-1], nom.vel_b.shape[:-1])
        H = tc_jacobian_batch(
            f(self.dvl.A_b, (), (4, 3))[0],
            f(nom.nav.C_nb, batch, (3, 3)),
            f(nom.nav.vel_n, batch, (3,)),
            f(nom.dvl_sf, batch, ()),
            f(self.earth.omega_ie_n, (), (3,))[0],
            f(self.dvl.l_dvl_b, (), (3,))[0],
        )
        return H.reshape(batch + (4, STATE.dim))

    def measure(
        self, nom: Nominal, y_beam: np.ndarray, available: np.ndarray, omega_meas_b: np.ndarray
    ) -> Measurement:
        setup = self.prepare(nom, y_beam, available, omega_meas_b)
        return Measurement(
            z=setup.z,
            innovation=np.where(available, setup.z - self.predict(nom, setup), 0.0),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.any(available, axis=-1),
            active=available,
            gate_rows=True,
        )
