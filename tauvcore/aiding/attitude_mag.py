"""Magnetometer attitude: ``z = euler(C_nb) + n`` (roll, pitch, yaw), innovation wrapped to (-pi, pi].

With ``C_true = exp([rho x]) C_hat``, ``d euler = E_b^-1 C_hat^T rho``
(tauvcore.geo.rotations.euler_from_misalignment_jacobian), so ``H = [0 E_b^-1 C^T 0 ...]``.
R is diagonal, each configured noise floored at
:data:`~tauvcore.aiding.noise_floors.MAG_ATTITUDE_NOISE_FLOOR_RAD`.

The sensor (tauvcore.sensors.magnetometer) is aboard every vehicle of the lab: ``[magnetometer]``
configures it, its log table is ``attitude`` (``t_s``, ``roll``, ``pitch``, ``yaw``, each as
``_rad`` or ``_deg``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.fusion_method import Sections
from tauvcore.aiding.noise_floors import mag_attitude_sigma_rad
from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import (
    euler_from_C_nb,
    euler_from_misalignment_jacobian,
    wrap_angle,
)
from tauvcore.sensors import magnetometer
from tauvcore.sensors.magnetometer import MagnetometerConfig
from tauvcore.sensors.timing import Rng
from tauvcore.truth.truth_record import Truth

EULER = ("roll_rad", "pitch_rad", "yaw_rad")
"""The attitude's columns [rad]."""


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

    def measure(self, nom: Nominal, data: SourceData, j: int) -> Measurement:
        """The attitude of epoch ``j`` of ``data``."""
        batch = nom.vel_b.shape[:-1]
        setup = self.prepare(data.row(EULER, j), batch)
        return Measurement(
            z=setup.z,
            innovation=self.innovation(setup.z, self.predict(nom, setup)),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.ones(batch, dtype=bool),
        )


class MagSource(AidingSource):
    name = "mag"
    section_name = "magnetometer"
    table = "attitude"
    aboard = True
    label = "Magnetometer"
    summary = "roll, pitch and yaw from a magnetometer with its own tilt sensing"
    config_type = MagnetometerConfig
    streams = ("magnetometer",)  # tauvcore.sensors.stream.SensorStreams.magnetometer
    columns = tuple(Column(n, "rad", -1e4, 1e4, "no attitude angle", angle=True) for n in EULER)
    # as tauvcore.logs.columns.MAX_ANGLE_RAD
    row_labels = ("roll", "pitch", "yaw")
    observes = ("att",)  # H weighs the misalignment alone

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: MagnetometerConfig,
        state: None,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, None]:
        data = magnetometer.simulate_chunk(truth, k0, epochs, section, rngs["magnetometer"], num_runs)
        return SourceData(
            t_s=data.t_s, index=data.index, values={n: data.euler[..., i] for i, n in enumerate(EULER)}
        ), None

    def model(self, section: MagnetometerConfig, config: Sections) -> MagAttitude:
        return MagAttitude(section)


SOURCE = MagSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
