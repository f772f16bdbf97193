"""IMU: accelerometer and gyro triads delivering increments over each sample interval, as a
strapdown IMU does: ``dv = int f dt + b_a dt + n_a``, ``dtheta = int omega dt + b_g dt + n_g``,
with a turn-on bias, a bias random walk and white noise (density N: increment std N sqrt(dt)).

Table 2 of Tal et al. 2017. Its accelerometer bias "0.5 mg/h" cannot be a bias (an acceleration
per hour is a drift rate, and 0.5 mg/h would be negligible next to the 1e-5 m/s^2/sqrt(s) random
walk): we read it as a 0.5 mg turn-on bias, the usual figure for a tactical MEMS IMU like the
TAUV's Ekinox, and as the 34 m/s standalone drift of section 4.2 also requires.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore import units
from tauvcore.sensors.timing import (
    Rng,
    WalkState,
    batch_shape,
    random_walk_chunk,
    standard_normal,
)
from tauvcore.truth.record import Truth
from tauvcore.validation import require_range

RATE_RANGE_HZ = (50.0, 2000.0)
"""IMU rate bounds [Hz]. Below 50 Hz the two-sample coning/sculling correction and the
covariance steps no longer follow a manoeuvring AUV (and 0.001 Hz left no sample at all); no
navigation IMU delivers increments above 2 kHz, and the run time grows with the rate (1e5 Hz made
a 5 s mission take 31 s)."""

ERROR_LIMITS = {
    "accel_bias_mg": 100.0,                      # 200x Table 2; an uncalibrated consumer MEMS is ~50 mg
    "gyro_bias_deg_per_h": 3600.0,               # 1 deg/s, 1200x Table 2; an uncalibrated MEMS gyro
    "accel_noise_mps_per_sqrt_h": 10.0,          # 140x Table 2; consumer MEMS is ~0.5 m/s/sqrt(h)
    "gyro_noise_deg_per_sqrt_h": 30.0,           # 90x Table 2; consumer MEMS is ~1 deg/sqrt(h)
    "accel_bias_rw_mps2_per_sqrt_s": 1e-2,       # 1000x Table 2: 0.6 m/s^2 of wander per hour
    "gyro_bias_rw_deg_per_s_per_sqrt_s": 1e-2,   # 360x Table 2: 0.6 deg/s of wander per hour
}
"""Upper bound of each error field [its unit]; the lower bound is zero (an ideal sensor)."""


@dataclass(frozen=True)
class ImuConfig:
    """IMU error model; every field 1-sigma, defaults Table 2 of Tal et al. 2017."""

    # Ranges: zero error is legal everywhere (verification, --ideal); the upper bounds are a few
    # hundred times Table 2, past the worst uncalibrated consumer MEMS part, where a
    # navigation-grade filter and its linearisation have nothing left to say.
    rate_hz: float = 150.0                          # IMU rate [Hz], within [50, 2000] (RATE_RANGE_HZ)
    accel_bias_mg: float = 0.5                      # turn-on bias per axis [mg] (Table 2 "mg/h", see module doc), <= 100
    gyro_bias_deg_per_h: float = 3.0                # turn-on bias per axis [deg/h], <= 3600 (1 deg/s)
    accel_noise_mps_per_sqrt_h: float = 0.072       # velocity random walk [m/s/sqrt(h)], <= 10
    gyro_noise_deg_per_sqrt_h: float = 0.34         # angle random walk [deg/sqrt(h)], <= 30
    accel_bias_rw_mps2_per_sqrt_s: float = 1e-5     # accelerometer bias random walk [m/s^2/sqrt(s)], <= 1e-2
    gyro_bias_rw_deg_per_s_per_sqrt_s: float = 2.8e-5  # gyro bias random walk [deg/s/sqrt(s)], <= 1e-2

    def __post_init__(self) -> None:
        require_range("imu.rate_hz", self.rate_hz, *RATE_RANGE_HZ)
        for name, high in ERROR_LIMITS.items():
            require_range(f"imu.{name}", getattr(self, name), 0.0, high)

    def ideal(self) -> ImuConfig:
        """The same IMU with every error set to zero."""
        return ImuConfig(rate_hz=self.rate_hz, accel_bias_mg=0.0, gyro_bias_deg_per_h=0.0,
                         accel_noise_mps_per_sqrt_h=0.0, gyro_noise_deg_per_sqrt_h=0.0,
                         accel_bias_rw_mps2_per_sqrt_s=0.0, gyro_bias_rw_deg_per_s_per_sqrt_s=0.0)

    # SI views, used by the simulation and by the filter's Q
    @property
    def accel_bias_mps2(self) -> float:
        return self.accel_bias_mg * units.MG

    @property
    def gyro_bias_rps(self) -> float:
        return self.gyro_bias_deg_per_h * units.DEG_PER_HOUR

    @property
    def accel_noise_mps_per_sqrt_s(self) -> float:
        return self.accel_noise_mps_per_sqrt_h * units.MPS_PER_SQRT_HOUR

    @property
    def gyro_noise_rad_per_sqrt_s(self) -> float:
        return self.gyro_noise_deg_per_sqrt_h * units.DEG_PER_SQRT_HOUR

    @property
    def gyro_bias_rw_rps_per_sqrt_s(self) -> float:
        return self.gyro_bias_rw_deg_per_s_per_sqrt_s * units.DEG


@dataclass(frozen=True)
class ImuData:
    """Simulated IMU increments at the truth epochs, with the true error states for evaluation.

    Row k covers the interval (t_k-1, t_k]; row 0 is zero (no interval before the first sample).
    """

    t_s: np.ndarray          # (K,) sample times [s]
    dtheta_b: np.ndarray     # (K, [R,] 3) measured angle increments [rad]
    dv_b: np.ndarray         # (K, [R,] 3) measured velocity increments [m/s]
    accel_bias: np.ndarray   # (K, [R,] 3) true accelerometer bias [m/s^2]
    gyro_bias: np.ndarray    # (K, [R,] 3) true gyro bias [rad/s]


@dataclass(frozen=True)
class ImuState:
    """What an IMU simulated chunk by chunk carries from one chunk to the next."""

    accel_bias: WalkState = field(default_factory=WalkState)   # accelerometer bias walk
    gyro_bias: WalkState = field(default_factory=WalkState)    # gyro bias walk


def simulate(truth: Truth, config: ImuConfig, rng: np.random.Generator, num_runs: int | None = None) -> ImuData:
    """IMU increments at every truth epoch (the truth must be generated at ``config.rate_hz``):
    the whole mission as one chunk, every draw from ``rng``."""
    data, _ = simulate_chunk(truth, 0, config, ImuState(), rng, rng, rng, rng, num_runs, truth.dt_s)
    return data


def simulate_chunk(truth: Truth, k0: int, config: ImuConfig, state: ImuState,
                   accel_bias_rng: Rng, gyro_bias_rng: Rng, accel_noise_rng: Rng, gyro_noise_rng: Rng,
                   num_runs: int | None, dt_s: float) -> tuple[ImuData, ImuState]:
    """IMU increments at the samples ``k0 .. k0 + K - 1`` of the mission, ``truth`` holding those K.

    ``dv_k = dv_true_k + b_a,k dt + n_a,k``, ``dtheta_k = dtheta_true_k + b_g,k dt + n_g,k`` with
    ``n ~ N(0, N^2 dt)`` (N the noise density) and the biases random walks from a turn-on value
    (:func:`~tauvcore.sensors.timing.random_walk_chunk`); row k = 0 of the mission is zero.
    Draws, in order: accelerometer bias (turn-on value at the first chunk, then its walk), gyro
    bias, accelerometer noise, gyro noise, each from its generator. ``dt_s`` is the mission's
    sample interval. Each generator may be one per run (tauvcore.sensors.timing.Rng). -> (data with
    arrays (K, [R,] 3), state for the next chunk).
    """
    if abs(1.0 / dt_s - config.rate_hz) > 1e-6 * config.rate_hz:
        raise ValueError(f"truth is sampled at {1.0 / dt_s:g} Hz but imu.rate_hz is {config.rate_hz:g}")
    k = truth.num_samples
    runs = batch_shape(num_runs)
    shape = runs + (3,)
    ba, accel_state = random_walk_chunk(accel_bias_rng, state.accel_bias, shape, config.accel_bias_mps2,
                                        config.accel_bias_rw_mps2_per_sqrt_s, dt_s, k)
    bg, gyro_state = random_walk_chunk(gyro_bias_rng, state.gyro_bias, shape, config.gyro_bias_rps,
                                       config.gyro_bias_rw_rps_per_sqrt_s, dt_s, k)
    expand = (slice(None),) + (None,) * len(runs)
    sqrt_dt = np.sqrt(dt_s)
    dv = (truth.dv_b[expand] + ba * dt_s
          + standard_normal(accel_noise_rng, (k,) + shape, 1) * (config.accel_noise_mps_per_sqrt_s * sqrt_dt))
    dth = (truth.dtheta_ib_b[expand] + bg * dt_s
           + standard_normal(gyro_noise_rng, (k,) + shape, 1) * (config.gyro_noise_rad_per_sqrt_s * sqrt_dt))
    if k0 == 0 and k > 0:
        dv[0] = 0.0
        dth[0] = 0.0
    return (ImuData(t_s=truth.t_s, dtheta_b=dth, dv_b=dv, accel_bias=ba, gyro_bias=bg),
            ImuState(accel_bias=accel_state, gyro_bias=gyro_state))
