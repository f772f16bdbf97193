"""Propeller RPM (Yoo 2014 section 2.2: the velocity filter's input, eq. 20).

What the propeller turns at:

- dynamic truth (tauvcore.truth.dynamic): the simulated thruster's RPM (``Truth.vehicle``), which
  the 6-DOF model relates to its speed through the water by its thrust and drag (steady speed
  proportional to RPM, transients on top);
- kinematic truth: a speed model inverting eq. 20, ``rpm = (u_w + b) / sf`` with ``u_w`` the surge
  through the water (``Truth.vel_water_b``: the surge over ground less the current's body-x part;
  the surge itself in still water), where the scale factor ``sf`` [m/s per rpm] and bias ``b``
  [m/s] are slow random walks from their nominal values (a hull fouling, a propeller nicked):
  what the velocity filter must learn, and recorded as its truth.

Either way a propeller measures speed through the water: in a current the speed over ground
differs by the current's along-hull part, which a filter that learns eq. 20 from bottom-track
takes for a bias (tauvcore.filter.vkf).

The sensor adds white noise ``noise_rpm`` (a shaft encoder's quantisation and jitter).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore.sensors.timing import (
    Rng,
    WalkState,
    batch_shape,
    epoch_indices,
    random_walk_chunk,
    standard_normal,
)
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import check_settings, setting


@dataclass(frozen=True)
class RpmConfig:
    """Propeller shaft speed sensor and the kinematic truth's speed model (module docstring)."""

    rate_hz: float = setting(5.0, "rate", "Hz", 0.01, 100.0, hint="readings per second")
    # the DVL rate of Yoo 2014; [0.01, 100]
    noise_rpm: float = setting(2.0, "noise", "rev/min", 0.0, 1000.0, hint="white noise of the shaft speed")
    # a shaft encoder's quantisation and jitter; [0, 1000]: zero is an ideal sensor
    mps_per_rpm: float = setting(
        2.3525e-3,
        "scale factor",
        "m/s per rev/min",
        0.0,
        1.0,
        low_open=True,
        hint="nominal speed per propeller rpm (the kinematic truth's speed model)",
    )  # the TAUV's steady speed per rpm (tauvcore.truth.vehicle, 2 m/s at 850 rpm); (0, 1]
    bias_mps: float = setting(
        0.05, "bias", "m/s", -5.0, 5.0, hint="nominal speed at zero rpm (the kinematic truth's speed model)"
    )  # [-5, 5]: beyond any propeller's slip
    scale_factor_rw_per_sqrt_s: float = setting(
        2e-7,
        "scale factor walk",
        "m/s per rev/min per sqrt(s)",
        0.0,
        1e-3,
        hint="random walk of the scale factor (kinematic truth)",
    )  # 0.4 % of the scale factor in an hour; [0, 1e-3]
    bias_rw_mps_per_sqrt_s: float = setting(
        1e-4, "bias walk", "m/s/sqrt(s)", 0.0, 1.0, hint="random walk of the bias (kinematic truth)"
    )  # 6 mm/s in an hour, the velocity filter's own model (tauvcore.filter.vkf); [0, 1]

    def __post_init__(self) -> None:
        check_settings("rpm", self)

    def ideal(self) -> RpmConfig:
        """No noise and no walks (the nominal sf and b stay)."""
        return RpmConfig(
            rate_hz=self.rate_hz,
            noise_rpm=0.0,
            mps_per_rpm=self.mps_per_rpm,
            bias_mps=self.bias_mps,
            scale_factor_rw_per_sqrt_s=0.0,
            bias_rw_mps_per_sqrt_s=0.0,
        )


@dataclass(frozen=True)
class RpmData:
    t_s: np.ndarray  # (M,) [s]
    index: np.ndarray  # (M,) IMU sample index
    rpm: np.ndarray  # (M, [R]) measured propeller speed [rev/min]
    true_rpm: np.ndarray  # (M, [R]) what the propeller turned at [rev/min]
    scale_factor: (
        np.ndarray
    )  # (M, [R]) true sf of eq. 20 [m/s per rpm]; NaN on the dynamic truth (no such map)
    bias_mps: np.ndarray  # (M, [R]) true b of eq. 20 [m/s]; NaN on the dynamic truth


@dataclass(frozen=True)
class RpmState:
    scale_factor: WalkState = field(default_factory=WalkState)
    bias: WalkState = field(default_factory=WalkState)


def simulate(
    truth: Truth, config: RpmConfig, rng: np.random.Generator, num_runs: int | None = None
) -> RpmData:
    """RPM of the whole mission as one chunk, every draw from ``rng``."""
    data, _ = simulate_chunk(
        truth, 0, epoch_indices(truth, config.rate_hz), config, RpmState(), rng, rng, rng, num_runs
    )
    return data


def simulate_chunk(
    truth: Truth,
    k0: int,
    index: np.ndarray,
    config: RpmConfig,
    state: RpmState,
    sf_rng: Rng,
    bias_rng: Rng,
    noise_rng: Rng,
    num_runs: int | None,
) -> tuple[RpmData, RpmState]:
    """RPM at the mission's IMU samples ``index`` (within ``truth``, whose sample 0 is the mission's
    sample ``k0``). Draws: the sf walk and the b walk, each from its own generator (both start at
    their nominal values; one step per epoch; kinematic truth only), then the noise. -> (data,
    next state)."""
    rows = index - k0
    runs = batch_shape(num_runs)
    expand = (slice(None),) + (None,) * len(runs)
    shape = (index.size,) + runs
    if truth.vehicle is not None:
        true_rpm = np.broadcast_to(truth.vehicle.propeller_rpm[rows][expand], shape)
        sf = b = np.full(shape, np.nan)
        new_state = state
    else:
        period = 1.0 / config.rate_hz
        d_sf, sf_state = random_walk_chunk(
            sf_rng, state.scale_factor, runs, 0.0, config.scale_factor_rw_per_sqrt_s, period, index.size
        )
        d_b, b_state = random_walk_chunk(
            bias_rng, state.bias, runs, 0.0, config.bias_rw_mps_per_sqrt_s, period, index.size
        )
        sf, b = config.mps_per_rpm + d_sf, config.bias_mps + d_b
        true_rpm = (truth.vel_water_b[rows, 0][expand] + b) / sf
        new_state = RpmState(scale_factor=sf_state, bias=b_state)
    rpm = true_rpm + standard_normal(noise_rng, shape, 1) * config.noise_rpm
    return (
        RpmData(
            t_s=truth.t_s[rows],
            index=index,
            rpm=rpm,
            true_rpm=np.array(true_rpm),
            scale_factor=sf,
            bias_mps=b,
        ),
        new_state,
    )
