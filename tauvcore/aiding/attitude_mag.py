"""Magnetometer attitude: ``z = euler(C_nb) + n`` (roll, pitch, yaw), innovation wrapped to (-pi, pi].

With ``C_true = exp([rho x]) C_hat``, ``d euler = E_b^-1 C_hat^T rho``
(tauvcore.geo.rotations.euler_from_misalignment_jacobian), so ``H = [0 E_b^-1 C^T 0 ...]``.
R is diagonal, each configured noise floored at
:data:`~tauvcore.aiding.noise_floors.MAG_ATTITUDE_NOISE_FLOOR_RAD`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.noise_floors import mag_attitude_sigma_rad
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import (
    euler_from_C_nb,
    euler_from_misalignment_jacobian,
    wrap_angle,
)
from tauvcore.sensors.magnetometer import MagnetometerConfig


@dataclass(frozen=True)
class MagSetup:
    z: np.ndarray  # (B, 3) measured roll, pitch, yaw [rad]
    R: np.ndarray  # (B, 3, 3)


@dataclass(frozen=True)
class MagAttitude:
    config: MagnetometerConfig  # filter tuning

    name = "mag"

    def prepare(self, euler: np.ndarray, batch: tuple[int, ...]) -> MagSetup:
        z = np.broadcast_to(np.asarray(euler, dtype=float), batch + (3,))
        R = np.broadcast_to(np.diag(mag_attitude_sigma_rad(self.config.noise_rad) ** 2), batch + (3, 3))
        return MagSetup(z=z, R=R)

    def predict(self, nom: Nominal, setup: MagSetup) -> np.ndarray:
        return euler_from_C_nb(nom.nav.C_nb)

    def innovation(self, z: np.ndarray, h: np.ndarray) -> np.ndarray:
        return wrap_angle(z - h)

    def jacobian(self, nom: Nominal, setup: MagSetup) -> np.ndarray:
        H = np.zeros(setup.R.shape[:-2] + (3, STATE.dim))
        H[..., STATE.att] = euler_from_misalignment_jacobian(euler_from_C_nb(nom.nav.C_nb))
        return H

    def measure(self, nom: Nominal, euler: np.ndarray) -> Measurement:
        batch = nom.vel_b.shape[:-1]
        setup = self.prepare(euler, batch)
        return Measurement(
            z=setup.z,
            innovation=self.innovation(setup.z, self.predict(nom, setup)),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.ones(batch, dtype=bool),
        )
