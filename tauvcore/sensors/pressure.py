"""Pressure sensor giving depth (Tal et al. 2017, Table 2: 0.25 Hz).

Table 2 gives the noise as "194 Mpa". That is a typo: 194 MPa is the pressure of 19 km of sea
water, and the TAUV is rated to 200 m. We read it as 194 Pa. The TAUV's 200 m rating means a
full scale of about 2 MPa, and 194 Pa is 0.01 % of that, the accuracy class of a good
piezo-resistive or quartz depth sensor; it is 1.9 cm of sea water.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.sensors.timing import Rng, batch_shape, epoch_indices, standard_normal
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import check_settings, setting


@dataclass(frozen=True)
class PressureConfig:
    """Depth from pressure, ``depth = p / (rho g0)``; 1-sigma white noise."""

    rate_hz: float = setting(0.25, "rate", "Hz", 0.01, 100.0, hint="samples per second")
    # Table 2; [0.01, 100]: depth sensors sample up to ~100 Hz
    noise_pa: float = setting(194.0, "noise", "Pa", 0.0, 1e5, hint="1-sigma white noise of the pressure")
    # Table 2 "194 Mpa", read as 194 Pa (module doc); [0, 1e5]: 1 bar, i.e. 10 m of water, half the
    # TAUV's rated depth; zero is an ideal sensor
    water_density_kg_m3: float = setting(
        1025.0, "water density", "kg/m^3", 950.0, 1250.0, hint="turns pressure into depth"
    )  # sea water; [950, 1250]: hot fresh water to the Dead Sea

    def __post_init__(self) -> None:
        check_settings("pressure", self)

    def ideal(self) -> PressureConfig:
        return PressureConfig(
            rate_hz=self.rate_hz, noise_pa=0.0, water_density_kg_m3=self.water_density_kg_m3
        )

    @property
    def depth_noise_m(self) -> float:
        return self.noise_pa / (self.water_density_kg_m3 * units.G0)


@dataclass(frozen=True)
class PressureData:
    t_s: np.ndarray  # (M,) [s]
    index: np.ndarray  # (M,) IMU sample index
    depth_m: np.ndarray  # (M, [R]) measured depth [m]


def simulate(
    truth: Truth, config: PressureConfig, rng: np.random.Generator, num_runs: int | None = None
) -> PressureData:
    """Depths of the whole mission as one chunk."""
    return simulate_chunk(truth, 0, epoch_indices(truth, config.rate_hz), config, rng, num_runs)


def simulate_chunk(
    truth: Truth, k0: int, index: np.ndarray, config: PressureConfig, rng: Rng, num_runs: int | None
) -> PressureData:
    """Depth ``truth.depth_m[k] + n``, ``n ~ N(0, depth_noise_m^2)``, at the mission's IMU samples
    ``index`` (all within ``truth``, whose sample 0 is the mission's sample ``k0``)."""
    rows = index - k0
    runs = batch_shape(num_runs)
    depth = truth.depth_m[rows][(slice(None),) + (None,) * len(runs)]
    depth = depth + standard_normal(rng, (index.size,) + runs, 1) * config.depth_noise_m
    return PressureData(t_s=truth.t_s[rows], index=index, depth_m=depth)
