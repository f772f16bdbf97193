"""Echo sounder: the altitude above the seabed straight below the vehicle (Yoo 2014 section 2.2:
"ES"; it tells the velocity filter when the DVL is out of range, eq. 29).

``altitude = depth(seabed under the vehicle) - depth(vehicle) + n``, white noise of
``noise_m``; nothing (NaN) where the true altitude exceeds ``max_range_m`` (no echo) or the
vehicle is below the seabed. The paper gives no figures: the defaults are a typical altimeter's
(a 200 kHz single beam reaches a few hundred metres with decimetre noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.sensors.timing import Rng, batch_shape, epoch_indices, standard_normal
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import check_settings, setting


@dataclass(frozen=True)
class EchoSounderConfig:
    """Single-beam altimeter looking straight down; 1-sigma white noise."""

    rate_hz: float = setting(5.0, "rate", "Hz", 0.01, 100.0, hint="altitudes per second")
    # the DVL rate of Yoo 2014, so every ping has an altitude; [0.01, 100]: altimeters ping up to ~100 Hz
    noise_m: float = setting(0.2, "noise", "m", 0.0, 100.0, hint="1-sigma white noise of the altitude")
    # [0, 100]: zero is an ideal sensor
    max_range_m: float = setting(
        500.0, "range", "m", 0.0, 11000.0, low_open=True, hint="longest altitude with an echo"
    )  # (0, 11000]: the deepest ocean

    def __post_init__(self) -> None:
        check_settings("echo_sounder", self)

    def ideal(self) -> EchoSounderConfig:
        return EchoSounderConfig(rate_hz=self.rate_hz, noise_m=0.0, max_range_m=self.max_range_m)


@dataclass(frozen=True)
class EchoSounderData:
    t_s: np.ndarray  # (M,) [s]
    index: np.ndarray  # (M,) IMU sample index
    altitude_m: np.ndarray  # (M, [R]) measured altitude, NaN without an echo [m]
    true_altitude_m: np.ndarray  # (M,) true altitude [m]


def simulate(
    truth: Truth,
    config: EchoSounderConfig,
    seabed: Bathymetry,
    rng: np.random.Generator,
    num_runs: int | None = None,
) -> EchoSounderData:
    """Altitudes of the whole mission as one chunk."""
    return simulate_chunk(truth, 0, epoch_indices(truth, config.rate_hz), config, seabed, rng, num_runs)


def simulate_chunk(
    truth: Truth,
    k0: int,
    index: np.ndarray,
    config: EchoSounderConfig,
    seabed: Bathymetry,
    rng: Rng,
    num_runs: int | None,
) -> EchoSounderData:
    """Altitudes at the mission's IMU samples ``index`` (within ``truth``, whose sample 0 is the
    mission's sample ``k0``). The noise is drawn for every epoch, echo or not (a run's numbers do
    not depend on where a chunk ends)."""
    rows = index - k0
    runs = batch_shape(num_runs)
    true = seabed.depth_m(truth.pos_n[rows, 0], truth.pos_n[rows, 1]) - truth.depth_m[rows]
    expand = (slice(None),) + (None,) * len(runs)
    measured = true[expand] + standard_normal(rng, (index.size,) + runs, 1) * config.noise_m
    echo = (true > 0.0) & (true <= config.max_range_m)
    measured = np.where(echo[expand], measured, np.nan)
    return EchoSounderData(t_s=truth.t_s[rows], index=index, altitude_m=measured, true_altitude_m=true)
