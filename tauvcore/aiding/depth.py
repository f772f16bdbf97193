"""Pressure depth: ``z = depth = pos_n[2] + n``, H = [0 0 1] on the position block.

R is the configured depth noise floored at :data:`~tauvcore.aiding.noise_floors.DEPTH_NOISE_FLOOR_M`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.noise_floors import depth_sigma_m
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.sensors.pressure import PressureConfig


@dataclass(frozen=True)
class DepthSetup:
    z: np.ndarray  # (B, 1) measured depth [m]
    R: np.ndarray  # (B, 1, 1)


@dataclass(frozen=True)
class Depth:
    config: PressureConfig  # filter tuning

    name = "depth"

    def prepare(self, depth_m: np.ndarray, batch: tuple[int, ...]) -> DepthSetup:
        z = np.broadcast_to(np.asarray(depth_m, dtype=float), batch)[..., None]
        return DepthSetup(z=z, R=np.full(batch + (1, 1), depth_sigma_m(self.config.depth_noise_m) ** 2))

    def predict(self, nom: Nominal, setup: DepthSetup) -> np.ndarray:
        return nom.nav.pos_n[..., 2:3]

    def jacobian(self, nom: Nominal, setup: DepthSetup) -> np.ndarray:
        H = np.zeros(setup.R.shape[:-2] + (1, STATE.dim))
        H[..., 0, STATE.pos.start + 2] = 1.0
        return H

    def measure(self, nom: Nominal, depth_m: np.ndarray) -> Measurement:
        batch = nom.vel_b.shape[:-1]
        setup = self.prepare(depth_m, batch)
        return Measurement(
            z=setup.z,
            innovation=setup.z - self.predict(nom, setup),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.ones(batch, dtype=bool),
        )
