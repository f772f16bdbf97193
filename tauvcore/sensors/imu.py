"""IMU: accelerometer and gyro triads delivering increments over each sample interval, as a
strapdown IMU does: ``dv = (I + M_a) int f dt + b_a dt + n_a``,
``dtheta = (I + M_g) int omega dt + b_g dt + n_g``, with a turn-on bias, a bias random walk, white
noise (density N: increment std N sqrt(dt)), and ``M`` the axes' errors (Groves 2013 eq. 4.16):
scale factors on its diagonal, and off it the misalignment of each sensing axis towards the
other two (six small angles, the axes need not stay orthogonal), each drawn once per run.

Table 2 of Tal et al. 2017. Its accelerometer bias "0.5 mg/h" cannot be a bias (an acceleration
per hour is a drift rate, and 0.5 mg/h would be negligible next to the 1e-5 m/s^2/sqrt(s) random
walk): we read it as a 0.5 mg turn-on bias, the usual figure for a tactical MEMS IMU like the
TAUV's Ekinox, and as the 34 m/s standalone drift of section 4.2 also requires.
"""

from __future__ import annotations

import dataclasses
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
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import require_choice, require_range

RATE_RANGE_HZ = (50.0, 2000.0)
"""IMU rate bounds [Hz]. Below 50 Hz the two-sample coning/sculling correction and the
covariance steps do not follow a manoeuvring AUV (and 0.001 Hz leaves no sample at all); no
navigation IMU delivers increments above 2 kHz, and the run time grows with the rate (at 1e5 Hz a
5 s mission takes 31 s)."""

ERROR_LIMITS = {
    "accel_bias_mg": 100.0,  # 200x Table 2; an uncalibrated consumer MEMS is ~50 mg
    "gyro_bias_deg_per_h": 3600.0,  # 1 deg/s, 1200x Table 2; an uncalibrated MEMS gyro
    "accel_noise_mps_per_sqrt_h": 10.0,  # 140x Table 2; consumer MEMS is ~0.5 m/s/sqrt(h)
    "gyro_noise_deg_per_sqrt_h": 30.0,  # 90x Table 2; consumer MEMS is ~1 deg/sqrt(h)
    "accel_bias_rw_mps2_per_sqrt_s": 1e-2,  # 1000x Table 2: 0.6 m/s^2 of wander per hour
    "gyro_bias_rw_deg_per_s_per_sqrt_s": 1e-2,  # 360x Table 2: 0.6 deg/s of wander per hour
    "accel_scale_factor_ppm": 1e4,  # 1 %: an uncalibrated consumer MEMS part
    "gyro_scale_factor_ppm": 1e4,
    "accel_misalignment_mrad": 20.0,  # 1.1 deg: a board-mounted MEMS triad is ~2-10 mrad
    "gyro_misalignment_mrad": 20.0,
}
"""Upper bound of each error field [its unit]; the lower bound is zero (an ideal sensor)."""


@dataclass(frozen=True)
class ImuConfig:
    """IMU error model; every field 1-sigma, defaults Table 2 of Tal et al. 2017."""

    # Ranges: zero error is legal everywhere (verification, --ideal); the upper bounds are a few
    # hundred times Table 2, past the worst uncalibrated consumer MEMS part, where a
    # navigation-grade filter and its linearisation have nothing left to say.
    rate_hz: float = 150.0  # IMU rate [Hz], within [50, 2000] (RATE_RANGE_HZ)
    accel_bias_mg: float = 0.5  # turn-on bias per axis [mg] (Table 2 "mg/h", see module doc), <= 100
    gyro_bias_deg_per_h: float = 3.0  # turn-on bias per axis [deg/h], <= 3600 (1 deg/s)
    accel_noise_mps_per_sqrt_h: float = 0.072  # velocity random walk [m/s/sqrt(h)], <= 10
    gyro_noise_deg_per_sqrt_h: float = 0.34  # angle random walk [deg/sqrt(h)], <= 30
    accel_bias_rw_mps2_per_sqrt_s: float = 1e-5  # accelerometer bias random walk [m/s^2/sqrt(s)], <= 1e-2
    gyro_bias_rw_deg_per_s_per_sqrt_s: float = 2.8e-5  # gyro bias random walk [deg/s/sqrt(s)], <= 1e-2
    accel_scale_factor_ppm: float = 0.0  # scale factor per axis [ppm], <= 1e4; Table 2 has none
    gyro_scale_factor_ppm: float = 0.0  # scale factor per axis [ppm], <= 1e4; Table 2 has none
    accel_misalignment_mrad: float = 0.0  # misalignment per axis pair [mrad], <= 20; Table 2 has none
    gyro_misalignment_mrad: float = 0.0  # misalignment per axis pair [mrad], <= 20; Table 2 has none

    def __post_init__(self) -> None:
        require_range("imu.rate_hz", self.rate_hz, *RATE_RANGE_HZ)
        for name, high in ERROR_LIMITS.items():
            require_range(f"imu.{name}", getattr(self, name), 0.0, high)

    def ideal(self) -> ImuConfig:
        """The same IMU with every error set to zero.

        Returns
        -------
        ImuConfig
            This configuration's ``rate_hz`` [Hz] with every field of :data:`ERROR_LIMITS` (biases,
            noise densities, bias walks, scale factors, misalignments) zero.
        """
        return ImuConfig(rate_hz=self.rate_hz, **{name: 0.0 for name in ERROR_LIMITS})

    @property
    def has_axis_errors(self) -> bool:
        """Whether any scale factor or misalignment is drawn.

        None: nothing is drawn for them, and the other draws are those of an IMU without axis errors.
        """
        return any(getattr(self, name) > 0.0 for name in AXIS_ERROR_FIELDS)

    # SI views, used by the simulation and by the filter's Q
    @property
    def accel_bias_mps2(self) -> float:
        """1-sigma accelerometer turn-on bias per axis [m/s^2]."""
        return self.accel_bias_mg * units.MG

    @property
    def gyro_bias_rps(self) -> float:
        """1-sigma gyro turn-on bias per axis [rad/s]."""
        return self.gyro_bias_deg_per_h * units.DEG_PER_HOUR

    @property
    def accel_noise_mps_per_sqrt_s(self) -> float:
        """Accelerometer white noise density (velocity random walk) [m/s/sqrt(s)]."""
        return self.accel_noise_mps_per_sqrt_h * units.MPS_PER_SQRT_HOUR

    @property
    def gyro_noise_rad_per_sqrt_s(self) -> float:
        """Gyro white noise density (angle random walk) [rad/sqrt(s)]."""
        return self.gyro_noise_deg_per_sqrt_h * units.DEG_PER_SQRT_HOUR

    @property
    def gyro_bias_rw_rps_per_sqrt_s(self) -> float:
        """Gyro bias random walk density [rad/s/sqrt(s)]."""
        return self.gyro_bias_rw_deg_per_s_per_sqrt_s * units.DEG

    @property
    def accel_scale_factor(self) -> float:
        """1-sigma accelerometer scale factor error per axis [-] (a fraction)."""
        return self.accel_scale_factor_ppm * 1e-6

    @property
    def gyro_scale_factor(self) -> float:
        """1-sigma gyro scale factor error per axis [-] (a fraction)."""
        return self.gyro_scale_factor_ppm * 1e-6

    @property
    def accel_misalignment_rad(self) -> float:
        """1-sigma accelerometer misalignment per axis pair [rad]."""
        return self.accel_misalignment_mrad * 1e-3

    @property
    def gyro_misalignment_rad(self) -> float:
        """1-sigma gyro misalignment per axis pair [rad]."""
        return self.gyro_misalignment_mrad * 1e-3


AXIS_ERROR_FIELDS = (
    "accel_scale_factor_ppm",
    "gyro_scale_factor_ppm",
    "accel_misalignment_mrad",
    "gyro_misalignment_mrad",
)

_BIAS_STABILITY_WINDOW_S = 3600.0
"""A datasheet's "bias stability" read as the 1-sigma growth of the in-run bias random walk over
one hour: density = stability / sqrt(3600 s)."""

IMU_PROFILES: dict[str, ImuConfig] = {
    "table2": ImuConfig(),
    # Yoo 2014 Table 1: "1 deg/h" class, Honeywell HG1700's error characteristics, at the paper's
    # 100 Hz (section 3.2). "Repeatability" is the turn-on bias; "bias stability" the in-run
    # walk (read as above: 1 deg/h in an hour, 1 mg in an hour). Its accelerometer "VRW 0.1 mg"
    # cannot be a random walk in mg: read as 0.1 mg/sqrt(Hz), i.e. 0.0588 m/s/sqrt(h).
    "yoo-table1": ImuConfig(
        rate_hz=100.0,
        accel_bias_mg=1.0,
        gyro_bias_deg_per_h=1.0,
        accel_noise_mps_per_sqrt_h=0.1 * units.MG * units.SQRT_HOUR,
        gyro_noise_deg_per_sqrt_h=0.125,
        accel_bias_rw_mps2_per_sqrt_s=1.0 * units.MG / np.sqrt(_BIAS_STABILITY_WINDOW_S),
        gyro_bias_rw_deg_per_s_per_sqrt_s=1.0 / units.HOUR / np.sqrt(_BIAS_STABILITY_WINDOW_S),
        accel_scale_factor_ppm=300.0,
        gyro_scale_factor_ppm=150.0,
        accel_misalignment_mrad=0.5,
        gyro_misalignment_mrad=0.5,
    ),
    # A navigation-grade fibre-optic IMU of the iXblue PHINS class (the A-KIT data's IMU, whose output
    # is already compensated by the unit's own calibration: no scale factor or misalignment is
    # modelled). Gyro: 0.01 deg/h turn-on bias and bias stability (read as above), the figure of the
    # class's published free-inertial drift (0.6 NM/h is R * 0.01 deg/h); angle random walk
    # 0.0025 deg/sqrt(h). Accelerometer: 50 ug turn-on bias and stability, velocity random walk
    # 50 ug/sqrt(Hz) (0.029 m/s/sqrt(h)). Verify against a unit's own datasheet before relying on it.
    "phins": ImuConfig(
        rate_hz=100.0,
        accel_bias_mg=0.05,
        gyro_bias_deg_per_h=0.01,
        accel_noise_mps_per_sqrt_h=0.05 * units.MG * units.SQRT_HOUR,
        gyro_noise_deg_per_sqrt_h=0.0025,
        accel_bias_rw_mps2_per_sqrt_s=0.05 * units.MG / np.sqrt(_BIAS_STABILITY_WINDOW_S),
        gyro_bias_rw_deg_per_s_per_sqrt_s=0.01 / units.HOUR / np.sqrt(_BIAS_STABILITY_WINDOW_S),
    ),
}
"""Named IMUs (``--imu NAME``): Tal et al. 2017 Table 2 (the default), Yoo 2014 Table 1, and a
navigation-grade fibre-optic IMU of the PHINS class (``phins``, for real data of that class)."""


def imu_profile(name: str) -> ImuConfig:
    """The IMU named ``name`` (:data:`IMU_PROFILES`).

    Parameters
    ----------
    name : str
        Profile name, a key of :data:`IMU_PROFILES` (``"table2"``, ``"yoo-table1"``).

    Returns
    -------
    ImuConfig
        The named IMU's error model (its fields in the units their names carry).

    Raises
    ------
    ConfigError
        Naming the choices, if ``name`` is not one of them.
    """
    require_choice("imu profile", name, tuple(IMU_PROFILES))
    return IMU_PROFILES[name]


@dataclass(frozen=True)
class ImuData:
    """Simulated IMU increments at the truth epochs, with the true error states for evaluation.

    Row k covers the interval (t_k-1, t_k]; row 0 is zero (no interval before the first sample).
    """

    t_s: np.ndarray  # (K,) sample times [s]
    dtheta_b: np.ndarray  # (K, [R,] 3) measured angle increments [rad]
    dv_b: np.ndarray  # (K, [R,] 3) measured velocity increments [m/s]
    accel_bias: np.ndarray  # (K, [R,] 3) true accelerometer bias [m/s^2]: the error the filter's bias state
    # stands for, the turn-on bias and its walk plus M_a f_b (axis errors) at the sample
    gyro_bias: np.ndarray  # (K, [R,] 3) true gyro bias [rad/s]: likewise, plus M_g omega_ib_b


@dataclass(frozen=True)
class ImuStreams:
    """The IMU's random streams (tauvcore.sensors.stream.SensorStreams' of those names, ``axes``
    its ``imu_axes``), each one generator or one per run (tauvcore.sensors.timing.Rng)."""

    accel_bias: Rng  # accelerometer bias: turn-on value and walk
    gyro_bias: Rng  # gyro bias: turn-on value and walk
    accel_noise: Rng  # accelerometer white noise
    gyro_noise: Rng  # gyro white noise
    axes: Rng | None = None  # axis errors M_a and M_g: needed only if the IMU has any and they are
    # not drawn yet (first chunk)


@dataclass(frozen=True)
class ImuState:
    """What an IMU simulated chunk by chunk carries from one chunk to the next."""

    accel_bias: WalkState = field(default_factory=WalkState)  # accelerometer bias walk
    gyro_bias: WalkState = field(default_factory=WalkState)  # gyro bias walk
    axes_drawn: bool = False  # whether M_a and M_g below were drawn
    accel_axes: np.ndarray | None = None  # M_a ([R,] 3, 3), None if the IMU has no axis errors
    gyro_axes: np.ndarray | None = None  # M_g ([R,] 3, 3)


def simulate(
    truth: Truth, config: ImuConfig, rng: np.random.Generator, num_runs: int | None = None
) -> ImuData:
    """IMU increments at every truth epoch: the whole mission as one chunk, every draw from ``rng``.

    The truth must be generated at ``config.rate_hz``; the mission's sample interval is
    ``truth.dt_s``. See :func:`simulate_chunk` for the model and the order of the draws.

    Parameters
    ----------
    truth : Truth
        The whole mission's true motion, K samples at ``config.rate_hz``; its increments
        ``dtheta_ib_b`` (K, 3) [rad] and ``dv_b`` (K, 3) [m/s], body frame b (FRD), are the
        error-free IMU outputs.
    config : ImuConfig
        The IMU's rate [Hz] and error model (1-sigma values).
    rng : numpy.random.Generator
        Generator of every draw (biases, noise, axis errors).
    num_runs : int or None, optional
        Number of Monte Carlo runs R, drawn as an array axis after time; None: a single run
        (no run axis).

    Returns
    -------
    ImuData
        Measured increments ``dtheta_b`` [rad] and ``dv_b`` [m/s] and the true biases
        ``gyro_bias`` [rad/s] and ``accel_bias`` [m/s^2], each (K, [R,] 3) in the body frame b (FRD),
        at the truth's times ``t_s`` (K,) [s]; row 0 is zero.

    Raises
    ------
    ValueError
        If the truth is not sampled at ``config.rate_hz``.
    """
    data, _ = simulate_chunk(
        truth, 0, config, ImuState(), ImuStreams(rng, rng, rng, rng, rng), num_runs, truth.dt_s
    )
    return data


def axis_error_matrices(
    rng: Rng, shape: tuple[int, ...], scale_factor: float, misalignment_rad: float
) -> np.ndarray:
    """``M`` of one triad for each run: ``diag(s) + off-diagonal m``.

    ``s ~ N(0, scale_factor^2)`` per axis and ``m_ij ~ N(0, misalignment_rad^2)`` for each sensing
    axis i leaning towards j (Groves 2013 eq. 4.16). Draws 9 numbers per run: s_x, s_y, s_z, then
    m_xy, m_xz, m_yx, m_yz, m_zx, m_zy.

    Parameters
    ----------
    rng : Rng
        One generator for every run, or one per run (:data:`tauvcore.sensors.timing.Rng`; the run
        axis is then the first of ``shape``).
    shape : tuple of int
        The run axes (possibly empty): ``()`` for a single run, ``(R,)`` for R runs.
    scale_factor : float
        1-sigma scale factor error per axis [-] (a fraction, not ppm).
    misalignment_rad : float
        1-sigma misalignment of a sensing axis towards each other axis [rad].

    Returns
    -------
    numpy.ndarray
        ``M``, shape (*shape, 3, 3) [-], body frame b (FRD): row i the errors of sensing axis i.
    """
    z = standard_normal(rng, shape + (9,))
    M = np.zeros(shape + (3, 3))
    for i in range(3):
        M[..., i, i] = z[..., i] * scale_factor
    for n, (i, j) in enumerate(((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))):
        M[..., i, j] = z[..., 3 + n] * misalignment_rad
    return M


def simulate_chunk(
    truth: Truth,
    k0: int,
    config: ImuConfig,
    state: ImuState,
    streams: ImuStreams,
    num_runs: int | None,
    dt_s: float,
) -> tuple[ImuData, ImuState]:
    """IMU increments at the samples ``k0 .. k0 + K - 1`` of the mission, ``truth`` holding those K.

    ``dv_k = dv_true_k + b_a,k dt + n_a,k``, ``dtheta_k = dtheta_true_k + b_g,k dt + n_g,k`` with
    ``n ~ N(0, N^2 dt)`` (N the noise density) and the biases random walks from a turn-on value
    (:func:`~tauvcore.sensors.timing.random_walk_chunk`); row k = 0 of the mission is zero.
    The true increments are first multiplied by ``I + M`` (the axes' errors, drawn once at the
    first chunk from ``streams.axes``, accelerometer then gyro, only if the IMU has any:
    :attr:`ImuConfig.has_axis_errors`). Draws, in order: accelerometer bias (turn-on value at the
    first chunk, then its walk), gyro bias, accelerometer noise, gyro noise, axes, each from its
    generator. Each generator may be one per run (tauvcore.sensors.timing.Rng).

    Parameters
    ----------
    truth : Truth
        True motion at the mission's samples ``k0 .. k0 + K - 1``: increments ``dtheta_ib_b``
        (K, 3) [rad] and ``dv_b`` (K, 3) [m/s], rate ``omega_ib_b`` (K, 3) [rad/s] and specific
        force ``f_b`` (K, 3) [m/s^2], body frame b (FRD).
    k0 : int
        The mission's index of the chunk's first sample (0 for the first chunk).
    config : ImuConfig
        The IMU's rate [Hz] and error model (1-sigma values).
    state : ImuState
        What the chunk before left (bias walks, axis errors); ``ImuState()`` for the first chunk.
    streams : ImuStreams
        Generator(s) of each error: biases (turn-on value and walk), white noises, axis errors.
    num_runs : int or None
        Number of Monte Carlo runs R, an array axis after time; None: a single run (no run axis).
    dt_s : float
        The mission's sample interval [s]; ``1 / dt_s`` must equal ``config.rate_hz``.

    Returns
    -------
    data : ImuData
        The chunk's measured increments ``dtheta_b`` [rad] and ``dv_b`` [m/s] and true biases
        ``gyro_bias`` [rad/s] and ``accel_bias`` [m/s^2] (the turn-on bias and its walk plus
        ``M f_b`` / ``M omega_ib_b``), each (K, [R,] 3), body frame b (FRD); ``t_s`` (K,) [s] the
        truth's.
    state : ImuState
        The state for the next chunk.

    Raises
    ------
    ValueError
        If ``1 / dt_s`` is not ``config.rate_hz`` ("truth is sampled at ... Hz but imu.rate_hz
        is ..."), or if the IMU has scale factor or misalignment errors and ``streams.axes`` is
        None when they are drawn ("simulate_chunk needs streams.axes").
    """
    if abs(1.0 / dt_s - config.rate_hz) > 1e-6 * config.rate_hz:
        raise ValueError(f"truth is sampled at {1.0 / dt_s:g} Hz but imu.rate_hz is {config.rate_hz:g}")
    k = truth.num_samples
    runs = batch_shape(num_runs)
    shape = runs + (3,)
    ba, accel_state = random_walk_chunk(
        streams.accel_bias,
        state.accel_bias,
        shape,
        config.accel_bias_mps2,
        config.accel_bias_rw_mps2_per_sqrt_s,
        dt_s,
        k,
    )
    bg, gyro_state = random_walk_chunk(
        streams.gyro_bias,
        state.gyro_bias,
        shape,
        config.gyro_bias_rps,
        config.gyro_bias_rw_rps_per_sqrt_s,
        dt_s,
        k,
    )
    expand = (slice(None),) + (None,) * len(runs)
    sqrt_dt = np.sqrt(dt_s)
    dv = (
        truth.dv_b[expand]
        + ba * dt_s
        + standard_normal(streams.accel_noise, (k,) + shape, 1)
        * (config.accel_noise_mps_per_sqrt_s * sqrt_dt)
    )
    dth = (
        truth.dtheta_ib_b[expand]
        + bg * dt_s
        + standard_normal(streams.gyro_noise, (k,) + shape, 1) * (config.gyro_noise_rad_per_sqrt_s * sqrt_dt)
    )
    if not state.axes_drawn:
        M_a = M_g = None
        if config.has_axis_errors:
            if streams.axes is None:
                raise ValueError(
                    "the IMU has scale factor or misalignment errors: simulate_chunk needs streams.axes"
                )
            M_a = axis_error_matrices(
                streams.axes, runs, config.accel_scale_factor, config.accel_misalignment_rad
            )
            M_g = axis_error_matrices(
                streams.axes, runs, config.gyro_scale_factor, config.gyro_misalignment_rad
            )
        state = dataclasses.replace(state, axes_drawn=True, accel_axes=M_a, gyro_axes=M_g)
    if state.accel_axes is not None:
        assert state.gyro_axes is not None  # drawn together with accel_axes (above)
        dv = dv + np.einsum("...ij,k...j->k...i", state.accel_axes, truth.dv_b[expand])
        dth = dth + np.einsum("...ij,k...j->k...i", state.gyro_axes, truth.dtheta_ib_b[expand])
        # what the 20-state filter's bias states can absorb of them: their value at the sample
        ba = ba + np.einsum("...ij,k...j->k...i", state.accel_axes, truth.f_b[expand])
        bg = bg + np.einsum("...ij,k...j->k...i", state.gyro_axes, truth.omega_ib_b[expand])
    if k0 == 0 and k > 0:
        dv[0] = 0.0
        dth[0] = 0.0
    return (
        ImuData(t_s=truth.t_s, dtheta_b=dth, dv_b=dv, accel_bias=ba, gyro_bias=bg),
        dataclasses.replace(state, accel_bias=accel_state, gyro_bias=gyro_state),
    )
