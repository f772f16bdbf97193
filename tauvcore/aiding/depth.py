"""Pressure depth: ``z = depth = pos_n[2] + n``, H = [0 0 1] on the position block.

R is the configured depth noise floored at :data:`~tauvcore.aiding.noise_floors.DEPTH_NOISE_FLOOR_M`.
The sensor (tauvcore.sensors.pressure) is aboard every vehicle of the lab: ``[pressure]``
configures it, its log table is ``depth`` (``t_s``, ``depth_m``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.fusion_method import Sections
from tauvcore.aiding.noise_floors import depth_sigma_m
from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.sensors import pressure
from tauvcore.sensors.pressure import PressureConfig
from tauvcore.sensors.timing import Rng
from tauvcore.truth.truth_record import Truth


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

    def measure(self, nom: Nominal, data: SourceData, j: int) -> Measurement:
        """The depth of epoch ``j`` of ``data``."""
        batch = nom.vel_b.shape[:-1]
        setup = self.prepare(data.values["depth_m"][j], batch)
        return Measurement(
            z=setup.z,
            innovation=setup.z - self.predict(nom, setup),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.ones(batch, dtype=bool),
        )


class DepthSource(AidingSource):
    name = "depth"
    section_name = "pressure"
    table = "depth"
    aboard = True
    label = "Depth (pressure)"
    summary = "depth from a pressure sensor"
    config_type = PressureConfig
    streams = ("pressure",)  # tauvcore.sensors.stream.SensorStreams.pressure
    columns = (Column("depth_m", "m", -100.0, 12_000.0, "deeper than the ocean, or high above it"),)
    # as tauvcore.logs.columns.DEPTH_RANGE_M
    row_labels = ("depth",)
    observes = ("pos",)

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: PressureConfig,
        state: None,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, None]:
        data = pressure.simulate_chunk(truth, k0, epochs, section, rngs["pressure"], num_runs)
        return SourceData(t_s=data.t_s, index=data.index, values={"depth_m": data.depth_m}), None

    def model(self, section: PressureConfig, config: Sections) -> Depth:
        return Depth(section)


SOURCE = DepthSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
