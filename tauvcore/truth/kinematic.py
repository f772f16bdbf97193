"""Kinematic truth generator: analytic attitude and body velocity, exact IMU outputs.

Each scenario is a *profile*: closed-form functions of time for the Euler angles, their rates,
the body velocity ``vel_b`` and its derivative. From those the generator derives, without any
numerical differentiation,

- ``omega_nb_b`` from the Euler rates, ``omega_ib_b = omega_nb_b + C_nb.T omega_ie_n``;
- ``acc_n = C_nb (vel_b_dot + omega_nb_b x vel_b)`` (derivative of ``vel_n = C_nb vel_b``);
- ``f_b = C_nb.T (acc_n - g_n + 2 omega_ie_n x vel_n)`` (earth-fixed n frame: Coriolis term;
  the centrifugal term is inside the plumb-bob ``g_n``, tauvcore.geo.earth);
- ``pos_n`` and the IMU increments ``dtheta_ib_b``, ``dv_b`` by 4-point Gauss-Legendre quadrature
  of ``vel_n``, ``omega_ib_b`` and ``f_b`` on every sample interval (error ~1e-13 for these
  smooth profiles), the only integrals involved.

Scenarios (Tal et al. 2017, section 4.1; sizes adjustable through :class:`TrajectoryConfig`):

straight   north at ``speed_mps``, constant depth, level.
figure8    heading ``psi = A sin(w t)`` with ``A = j_0,1 = 2.4048`` (first zero of the Bessel
           J0): at constant speed the north drift ``V J0(A) t`` vanishes, so the track closes
           into a figure eight (a 1:2 Lissajous). ``w`` makes the tightest turn radius equal to
           ``turn_radius_m``. Constant-rate dive until ``MIN_ALTITUDE_M`` above the seabed
           (:func:`figure8_level_off_s`), then level.
lawnmower  constant-rate dive for ``dive_duration_s``, then level; legs of ``leg_length_m``
           north and south joined by 180-degree turns of ``turn_radius_m``.
longrange  Yoo 2014 section 3: north, level, at constant depth, cruising at ``speed_mps`` (its
           preset, tauvcore.config.TRAJECTORY_PRESETS: 10 knots for 24 minutes) after starting
           at 60 % of it, with one slow-down to 70 % for a minute in the middle (the changes of
           RPM that let a velocity filter tell its scale factor from its bias); over a seabed
           whose two trenches (:func:`bathymetry`) put it out of a 100 m-altitude DVL's range
           from 5 to 8 and from 15 to 16 minutes, as in the paper's Figure 6.

In turns the vehicle rolls (``turn_roll_deg`` at the tightest turn, proportional to yaw rate)
and slips outward (``turn_sideslip_deg``), so sway is non-zero while manoeuvring, as a real
hull does, with the small heave that keeps the rolled sway from changing the depth. Rate changes are blended with half-cosines so attitude rates are continuous.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.geo.earth import (
    Earth,
    ned_from_geodetic,
)
from tauvcore.truth.current import check_current, crab_profile, current_field, with_current
from tauvcore.truth.profile import (  # the profile machinery, also reached from here
    _GL_NODES,
    _GL_WEIGHTS,
    BlendedSchedule,
    Profile,
    _kinematics,
    _motion,
    _motion_geodetic,
    num_samples,
)
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.water import (  # also reached from here
    MIN_ALTITUDE_M,
    check_in_water,
    lawnmower_level_depth_m,
    seabed_floor_m,
)
from tauvcore.validation import (
    ConfigError,
    require_choice,
    require_nonnegative,
    require_positive,
    require_range,
    show,
)

PAPER_TRAJECTORIES = ("straight", "figure8", "lawnmower")
"""The three scenarios of Tal et al. 2017 section 4.1 (its study, ``tauv reproduce``)."""
TRAJECTORIES = PAPER_TRAJECTORIES + ("longrange",)
"""Every scenario: the first paper's three and Yoo 2014's long-range mission."""
SEABED_MODELS = ("flat", "terrain")
LONGRANGE_DVL_ALTITUDE_M = 100.0
"""The DVL's range the long-range mission's trenches are cut for (Yoo 2014 section 3.2) [m]."""
LONGRANGE_OUT_OF_RANGE_S = ((300.0, 480.0), (900.0, 960.0))
"""When the long-range mission's seabed lies beyond that range: 5-8 and 15-16 minutes [s]."""
LONGRANGE_WALL_M = 200.0
"""Length of the trenches' walls along the track [m]."""
TRUTH_SOURCES = ("kinematic", "dynamic")
"""How the truth is made: ``kinematic`` closed-form profiles (this module); ``dynamic`` the 6-DOF
TAUV flown through the same scenario by its autopilot (tauvcore.truth.dynamic)."""
BESSEL_J0_FIRST_ZERO = 2.404825557695773
MAX_DURATION_S = 86400.0
"""Longest run [s]: 24 h, a survey AUV's longest missions (10 to 24 h)."""


@dataclass(frozen=True)
class TrajectoryConfig:
    """Scenario geometry. Defaults follow Tal et al. 2017 section 4 / Table 2 where it gives them."""

    name: str = "straight"  # one of TRAJECTORIES
    duration_s: float = 250.0  # Table 2: time duration 250 s; [1, 86400]: 24 h, a survey AUV's longest
    # missions
    speed_mps: float = 2.0  # Table 2: AUV velocity 2 m/s (surge); (0, 10]: no AUV cruises faster
    depth_m: float = 20.0  # initial depth [m]; [0, 11000]: the deepest ocean
    leg_length_m: float = 100.0  # lawnmower leg length [m]; [1, 10000]: beyond 10 km the flat tangent frame
    # of tauvcore.geo.earth no longer holds
    turn_radius_m: float = 15.0  # tightest turn radius (figure8) / U-turn radius (lawnmower) [m]; [1, 1000]:
    # an AUV turns in a few metres to tens; beyond 1 km it is not a manoeuvre
    dive_rate_mps: float = 0.1  # figure8 constant descent rate [m/s]; [0, speed_mps)
    lawnmower_dive_rate_mps: float = 0.3  # lawnmower initial descent rate [m/s]; [0, speed_mps)
    dive_duration_s: float = (
        30.0  # lawnmower dive phase; the paper's "first 30 s" [s]; [0, 86400] as duration_s
    )
    turn_roll_deg: float = 5.0  # roll at the tightest turn [deg]; [-45, 45]: a hull does not bank further
    turn_sideslip_deg: float = 3.0  # outward sideslip at the tightest turn [deg]; [-30, 30]: beyond, it skids
    blend_s: float = 4.0  # half-cosine blend time of rate changes [s]; [0.1, 600]: from a sharp but
    # sampled change (15 IMU samples at 150 Hz) to a 10-minute ramp
    seabed_depth_m: float = (
        60.0  # seabed depth (flat, or the terrain's mean) [m]; (0, 11000]: the deepest ocean
    )
    seabed: str = "flat"  # one of SEABED_MODELS: flat, or seeded terrain (tauvcore.truth.seabed)
    terrain_seed: int = 0  # seed of the terrain (the world: the same for every run), [0, 2**63 - 1]
    terrain_relief_m: float = 10.0  # RMS of the terrain about seabed_depth_m [m]; [0, 1000]
    terrain_wavelength_m: float = 400.0  # typical distance between ridges [m]; [10, 100000]
    truth: str = "kinematic"  # one of TRUTH_SOURCES: closed-form profile or the 6-DOF vehicle flying it
    current_n_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)  # constant ocean current at depth_m, NED
    # [m/s] (tauvcore.truth.current); each within +-3 m/s, beyond the strongest tidal streams an AUV
    # works in; its down part with the dynamic truth only
    current_shear_ne_per_s: tuple[float, float] = (0.0, 0.0)  # change of the north and east current per
    # metre of depth below depth_m [1/s]; each within +-0.1: oceanic shears are 1e-3 to 1e-2
    current_variation_mps: float = 0.0  # RMS of the slowly varying current on each horizontal axis [m/s];
    # [0, 3] as the constant
    current_variation_period_s: float = 600.0  # shortest period of the variation (1, 2, 4, 8 times it)
    # [s]; [60, 86400]: slower than the vehicle's manoeuvres, at most a day
    current_seed: int = 0  # seed of the varying current (the world: the same for every run), [0, 2**63 - 1]

    def __post_init__(self) -> None:
        require_choice("trajectory.name", self.name, TRAJECTORIES)
        require_range("trajectory.duration_s", self.duration_s, 1.0, MAX_DURATION_S)
        require_range("trajectory.speed_mps", self.speed_mps, 0.0, 10.0, low_open=True)
        require_range("trajectory.depth_m", self.depth_m, 0.0, 11000.0)
        require_range("trajectory.leg_length_m", self.leg_length_m, 1.0, 10000.0)
        require_range("trajectory.turn_radius_m", self.turn_radius_m, 1.0, 1000.0)
        require_nonnegative("trajectory.dive_rate_mps", self.dive_rate_mps)
        require_nonnegative("trajectory.lawnmower_dive_rate_mps", self.lawnmower_dive_rate_mps)
        require_range("trajectory.dive_duration_s", self.dive_duration_s, 0.0, MAX_DURATION_S)
        require_range("trajectory.turn_roll_deg", self.turn_roll_deg, -45.0, 45.0)
        require_range("trajectory.turn_sideslip_deg", self.turn_sideslip_deg, -30.0, 30.0)
        require_range("trajectory.blend_s", self.blend_s, 0.1, 600.0)
        require_range("trajectory.seabed_depth_m", self.seabed_depth_m, 0.0, 11000.0, low_open=True)
        require_choice("trajectory.truth", self.truth, TRUTH_SOURCES)
        require_choice("trajectory.seabed", self.seabed, SEABED_MODELS)
        if (
            not isinstance(self.terrain_seed, int)
            or isinstance(self.terrain_seed, bool)
            or not 0 <= self.terrain_seed <= 2**63 - 1
        ):
            raise ConfigError(
                f"trajectory.terrain_seed must be an integer within [0, 2**63 - 1], "
                f"got {show(self.terrain_seed)}"
            )
        require_range("trajectory.terrain_relief_m", self.terrain_relief_m, 0.0, 1000.0)
        require_range("trajectory.terrain_wavelength_m", self.terrain_wavelength_m, 10.0, 100000.0)
        floor = seabed_floor_m(self)
        if not floor > self.depth_m:
            relief = (
                f" less 3 x terrain_relief_m {show(self.terrain_relief_m)} m = {show(floor)} m"
                if self.seabed == "terrain"
                else ""
            )
            raise ConfigError(
                f"trajectory.seabed_depth_m must lie below the vehicle's depth trajectory.depth_m "
                f"({show(self.depth_m)} m), got {show(self.seabed_depth_m)} m{relief}: the vehicle "
                f"would start in the seabed"
            )
        check_current(self, lambda: PROFILES[self.name](self))
        for field in ("dive_rate_mps", "lawnmower_dive_rate_mps"):
            if getattr(self, field) >= self.speed_mps:
                raise ConfigError(
                    f"trajectory.{field} must be below trajectory.speed_mps ({self.speed_mps}), "
                    f"got {show(getattr(self, field))}"
                )
        if self.name == "lawnmower":
            level_m = lawnmower_level_depth_m(self)
            if level_m > floor - MIN_ALTITUDE_M:
                raise ConfigError(
                    f"trajectory.dive_duration_s {show(self.dive_duration_s)} s at "
                    f"trajectory.lawnmower_dive_rate_mps {show(self.lawnmower_dive_rate_mps)} m/s takes the "
                    f"lawnmower from {show(self.depth_m)} m to {show(round(level_m, 3))} m, within "
                    f"{show(MIN_ALTITUDE_M)} m of the seabed ({show(floor)} m): shorten the dive"
                )


def _turn_profile(
    cfg: TrajectoryConfig, yaw: Callable, yaw_rate: Callable, yaw_acc: Callable, pitch: BlendedSchedule
) -> Profile:
    """Profile from a heading law: roll and outward sway proportional to the yaw rate.

    Roll ``phi = k_r r`` and sway ``v = k_v r`` (``r`` the yaw rate). A rolled hull's sway has a
    vertical part, ``cos(theta) sin(phi) v`` in the down velocity, whose sign never changes (roll
    and sway both follow ``r``): over hours it would lift the vehicle out of the water (4.6 mm/s
    on the figure eight). The heave ``w = -tan(phi) v`` cancels it, so the down velocity is
    ``-sin(theta) u`` and the depth follows the pitch schedule alone; ``w`` is a few mm/s.
    """
    yaw_rate_max_rps = cfg.speed_mps / cfg.turn_radius_m
    roll_gain_s = cfg.turn_roll_deg * units.DEG / yaw_rate_max_rps
    sway_gain_m = -cfg.speed_mps * np.tan(cfg.turn_sideslip_deg * units.DEG) / yaw_rate_max_rps

    def euler(t: np.ndarray) -> np.ndarray:
        return np.stack([roll_gain_s * yaw_rate(t), pitch.value(t), yaw(t)], axis=-1)

    def euler_dot(t: np.ndarray) -> np.ndarray:
        return np.stack([roll_gain_s * yaw_acc(t), pitch.derivative(t), yaw_rate(t)], axis=-1)

    def vel_b(t: np.ndarray) -> np.ndarray:
        rate = yaw_rate(t)
        sway = sway_gain_m * rate
        heave = -np.tan(roll_gain_s * rate) * sway  # the rolled sway's vertical part cancelled
        return np.stack([np.full_like(t, cfg.speed_mps), sway, heave], axis=-1)

    def vel_b_dot(t: np.ndarray) -> np.ndarray:
        rate, acc = yaw_rate(t), yaw_acc(t)
        roll = roll_gain_s * rate
        heave_dot = -sway_gain_m * (roll / np.cos(roll) ** 2 + np.tan(roll)) * acc
        return np.stack([np.zeros_like(t), sway_gain_m * acc, heave_dot], axis=-1)

    return Profile(euler, euler_dot, vel_b, vel_b_dot)


def _dive_pitch_rad(cfg: TrajectoryConfig, rate_mps: float) -> float:
    """Nose-down pitch giving a descent rate with the velocity along the hull (zero heave)."""
    return -float(np.arcsin(rate_mps / cfg.speed_mps))


def straight_profile(cfg: TrajectoryConfig) -> Profile:
    """The ``straight`` scenario: north at ``speed_mps``, constant depth, level, no turn.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario geometry; this profile reads ``speed_mps`` [m/s] (and the turn gains, zero here
        as the yaw rate is zero).

    Returns
    -------
    Profile
        Euler angles [rad] zero, body velocity ``[speed_mps, 0, 0]`` [m/s] (surge, sway, heave),
        their rates zero; each a function of times (K,) [s] returning (K, 3).
    """
    zero = BlendedSchedule([0.0, 1.0], [0.0, 0.0])
    return _turn_profile(cfg, zero.integral, zero.value, zero.derivative, zero)


def figure8_level_off_s(cfg: TrajectoryConfig) -> float:
    """When the figure eight stops descending [s]: ``MIN_ALTITUDE_M`` above :func:`seabed_floor_m`.

    The paper's 250 s at 0.1 m/s from 20 m end at 45 m, far above the 60 m seabed; a longer
    mission would otherwise fly into the bottom, where no DVL beam returns.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``depth_m`` [m], ``dive_rate_mps`` [m/s] and the seabed (:func:`seabed_floor_m`).

    Returns
    -------
    float
        Time from the start at which the descent ends [s], at least 0; ``inf``: it never gets
        there (no descent, ``dive_rate_mps <= 0``).
    """
    if cfg.dive_rate_mps <= 0.0:
        return np.inf
    return max(0.0, (seabed_floor_m(cfg) - MIN_ALTITUDE_M - cfg.depth_m) / cfg.dive_rate_mps)


def figure8_profile(cfg: TrajectoryConfig) -> Profile:
    """The ``figure8`` scenario: heading ``psi = A sin(w t)``, ``A = j_0,1`` (module docstring).

    ``w = speed_mps / (turn_radius_m A)`` makes the largest yaw rate ``A w = V / R``. Pitch is the
    nose-down pitch of a ``dive_rate_mps`` descent with the velocity along the hull until
    :func:`figure8_level_off_s`, then blends to level over ``blend_s``; roll and outward sway
    follow the yaw rate (``turn_roll_deg``, ``turn_sideslip_deg`` at the tightest turn).

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``speed_mps`` [m/s], ``turn_radius_m`` [m], ``dive_rate_mps`` [m/s],
        ``duration_s`` [s], ``blend_s`` [s], ``turn_roll_deg`` [deg], ``turn_sideslip_deg`` [deg],
        depths and seabed [m].

    Returns
    -------
    Profile
        Euler angles [rad], their rates [rad/s], body velocity [m/s] (surge, sway, heave) and its
        rate [m/s^2]; each a function of times (K,) [s] returning (K, 3).
    """
    amp = BESSEL_J0_FIRST_ZERO
    w = cfg.speed_mps / (cfg.turn_radius_m * amp)  # max yaw rate amp*w = V/R
    theta = _dive_pitch_rad(cfg, cfg.dive_rate_mps)
    level_s = figure8_level_off_s(cfg)
    if level_s >= cfg.duration_s:
        pitch = BlendedSchedule([0.0, 1.0], [theta, theta])
    elif level_s > 0.0:
        pitch = BlendedSchedule([0.0, level_s, level_s + cfg.blend_s], [theta, theta, 0.0])
    else:
        pitch = BlendedSchedule([0.0, 1.0], [0.0, 0.0])
    return _turn_profile(
        cfg,
        lambda t: amp * np.sin(w * t),
        lambda t: amp * w * np.cos(w * t),
        lambda t: -amp * w * w * np.sin(w * t),
        pitch,
    )


def lawnmower_profile(cfg: TrajectoryConfig) -> Profile:
    """The ``lawnmower`` scenario: legs north and south joined by 180-degree turns.

    Legs of ``leg_length_m`` at ``speed_mps``; each turn ramps the yaw rate to ``V / R``
    (``turn_radius_m``) by a half-cosine of ``min(blend_s, pi / (2 V / R))`` (a turn must reach
    its full rate), holds it and ramps it out, turning 180 degrees, alternately to starboard and to
    port. Pitch: the nose-down pitch of a ``lawnmower_dive_rate_mps`` descent for
    ``dive_duration_s``, then blended to level over ``blend_s``.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``speed_mps`` [m/s], ``turn_radius_m`` [m], ``leg_length_m`` [m], ``duration_s``
        [s], ``blend_s`` [s], ``lawnmower_dive_rate_mps`` [m/s], ``dive_duration_s`` [s],
        ``turn_roll_deg`` [deg], ``turn_sideslip_deg`` [deg].

    Returns
    -------
    Profile
        Euler angles [rad], their rates [rad/s], body velocity [m/s] (surge, sway, heave) and its
        rate [m/s^2]; each a function of times (K,) [s] returning (K, 3).
    """
    rate = cfg.speed_mps / cfg.turn_radius_m
    blend = min(cfg.blend_s, 0.5 * np.pi / rate)  # a turn must reach its full rate
    hold = np.pi / rate - blend  # ramps in and out add rate*blend
    leg = cfg.leg_length_m / cfg.speed_mps
    t_knots, r_knots = [0.0], [0.0]
    t, sign = leg, 1.0
    while t < cfg.duration_s + leg:
        t_knots += [t, t + blend, t + blend + hold, t + 2 * blend + hold]
        r_knots += [0.0, sign * rate, sign * rate, 0.0]
        t, sign = t + 2 * blend + hold + leg, -sign
    yaw_rate = BlendedSchedule(t_knots, r_knots)
    theta = _dive_pitch_rad(cfg, cfg.lawnmower_dive_rate_mps)
    if cfg.dive_duration_s > 0:
        pitch = BlendedSchedule(
            [0.0, cfg.dive_duration_s, cfg.dive_duration_s + cfg.blend_s], [theta, theta, 0.0]
        )
    else:
        pitch = BlendedSchedule([0.0, 1.0], [0.0, 0.0])
    return _turn_profile(cfg, yaw_rate.integral, yaw_rate.value, yaw_rate.derivative, pitch)


LONGRANGE_SPEED_KNOTS = ((0.0, 0.6), (60.0, 1.0), (600.0, 1.0), (630.0, 0.7), (690.0, 0.7), (720.0, 1.0))
"""The long-range mission's surge as a fraction of ``speed_mps`` at knot times [s] (half-cosine
blends between)."""


def longrange_speed(cfg: TrajectoryConfig) -> BlendedSchedule:
    """Surge [m/s] of the long-range mission against time (its north position is the integral).

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``speed_mps`` [m/s], the cruise speed the :data:`LONGRANGE_SPEED_KNOTS` fractions
        scale.

    Returns
    -------
    BlendedSchedule
        Surge against time [s]: ``value`` [m/s], ``derivative`` [m/s^2], ``integral`` the distance
        north from the start [m].
    """
    return BlendedSchedule(
        [t for t, _ in LONGRANGE_SPEED_KNOTS], [f * cfg.speed_mps for _, f in LONGRANGE_SPEED_KNOTS]
    )


def longrange_profile(cfg: TrajectoryConfig) -> Profile:
    """The ``longrange`` scenario (Yoo 2014 section 3): north, level, at constant depth.

    The surge follows :func:`longrange_speed`; sway and heave are zero.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``speed_mps`` [m/s], the cruise speed.

    Returns
    -------
    Profile
        Euler angles [rad] and their rates [rad/s] zero, body velocity ``[surge, 0, 0]`` [m/s] and
        its rate [m/s^2]; each a function of times (K,) [s] returning (K, 3).
    """
    speed = longrange_speed(cfg)

    def zeros(t: np.ndarray) -> np.ndarray:
        return np.zeros(np.shape(t) + (3,))

    def vel_b(t: np.ndarray) -> np.ndarray:
        return np.stack([speed.value(t), np.zeros_like(t), np.zeros_like(t)], axis=-1)

    def vel_b_dot(t: np.ndarray) -> np.ndarray:
        return np.stack([speed.derivative(t), np.zeros_like(t), np.zeros_like(t)], axis=-1)

    return Profile(zeros, zeros, vel_b, vel_b_dot)


PROFILES = {
    "straight": straight_profile,
    "figure8": figure8_profile,
    "lawnmower": lawnmower_profile,
    "longrange": longrange_profile,
}


def mission_profile(cfg: TrajectoryConfig) -> Profile:
    """The profile the kinematic truth flies: the scenario's (:data:`PROFILES`), crabbing into the
    mission's current if it has one (tauvcore.truth.current.crab_profile).

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: its ``name``, geometry and current.

    Returns
    -------
    Profile
        Euler angles [rad], their rates [rad/s], body velocity [m/s] and its rate [m/s^2].
    """
    profile = PROFILES[cfg.name](cfg)
    field = current_field(cfg)
    return profile if field is None else crab_profile(profile, field, cfg.depth_m)


def bathymetry(cfg: TrajectoryConfig):
    """The seabed of the mission ``cfg`` (tauvcore.truth.seabed.Bathymetry).

    ``seabed_depth_m``, the seeded terrain if ``seabed = "terrain"``, and for ``longrange`` its two
    trenches, placed where the mission is at LONGRANGE_OUT_OF_RANGE_S and deep enough that the
    altitude crosses LONGRANGE_DVL_ALTITUDE_M at the middle of each wall (floor
    ``2 (depth_m + 100) - seabed_depth_m``, at least ``seabed_depth_m``), walls
    ``LONGRANGE_WALL_M`` long.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: ``name``, ``depth_m`` [m], ``speed_mps`` [m/s], ``seabed``, ``seabed_depth_m`` [m],
        ``terrain_seed``, ``terrain_relief_m`` [m], ``terrain_wavelength_m`` [m].

    Returns
    -------
    tauvcore.truth.seabed.Bathymetry
        The seabed, depths positive down in the n frame (NED) [m]; trench ends at north
        positions [m] along the track.
    """
    from tauvcore.truth.seabed import Bathymetry, Trench

    trenches = ()
    if cfg.name == "longrange":
        north = longrange_speed(cfg).integral
        floor = max(2.0 * (cfg.depth_m + LONGRANGE_DVL_ALTITUDE_M) - cfg.seabed_depth_m, cfg.seabed_depth_m)
        trenches = tuple(
            Trench(float(north(np.array(a))), float(north(np.array(b))), floor, LONGRANGE_WALL_M)
            for a, b in LONGRANGE_OUT_OF_RANGE_S
        )
    return Bathymetry(
        cfg.seabed_depth_m,
        cfg.seabed,
        cfg.terrain_seed,
        cfg.terrain_relief_m,
        cfg.terrain_wavelength_m,
        trenches=trenches,
    )


def _chunk_from_profile(
    name: str,
    profile: Profile,
    earth: Earth,
    rate_hz: float,
    k0: int,
    k1: int,
    pos0_n: np.ndarray,
    carried: np.ndarray | None,
) -> tuple[Truth, np.ndarray]:
    """Samples ``k0 <= k < k1`` of the mission (``t_k = k / rate_hz``) and what the next chunk
    needs to continue (``carried``: that of the chunk before; None for ``k0 = 0``).

    Motion at the samples; IMU and position increments over each ``(t_k-1, t_k]`` by 4-point
    Gauss-Legendre (row k = 0 of the mission zero). Flat model: ``pos_n = pos0_n + travelled``,
    the sum of the increments extended left to right (carried: the sum up to ``k0 - 1``).
    WGS-84: the geodetic position integrated sample after sample from the origin (latitude and
    longitude of ``earth``, depth ``pos0_n[2]``; :func:`tauvcore.geo.path.integrate_geodetic`;
    carried: the position of sample ``k0 - 1``), ``pos_n`` its offset from the sea-surface point
    above the origin in that point's tangent frame (so it starts at ``pos0_n``, as the flat one).
    Either way chunks of any size give the whole mission's numbers bit for bit.
    """
    dt = 1.0 / rate_hz
    t = np.arange(k0, k1) * dt
    first = max(k0, 1)  # the chunk's first sample ending an interval
    mid = 0.5 * (np.arange(first - 1, k1 - 1) * dt + np.arange(first, k1) * dt)
    nodes = (mid[:, None] + 0.5 * dt * _GL_NODES[None, :]).ravel()

    def interval_integral(x: np.ndarray) -> np.ndarray:
        steps = 0.5 * dt * np.einsum("g,kgi->ki", _GL_WEIGHTS, x.reshape(k1 - first, 4, 3))
        return np.concatenate([np.zeros((1, 3)), steps]) if k0 == 0 else steps

    if not earth.geodetic:
        m = _motion(profile, earth, t)
        at_nodes = _motion(profile, earth, nodes)
        dpos_n = interval_integral(at_nodes["vel_n"])
        travelled_n = np.zeros(3) if carried is None else carried
        if k0 == 0:
            travelled = np.cumsum(dpos_n, axis=0)
        else:
            travelled = np.cumsum(np.concatenate([travelled_n[None], dpos_n]), axis=0)[1:]
        pos_n = pos0_n + travelled
        pos_nav, carry = pos_n, travelled[-1]
    else:
        from tauvcore.geo.path import (
            integrate_geodetic,  # numba: with the engine, not for --help
        )

        origin = np.array([earth.latitude_rad, earth.longitude_rad, pos0_n[2]])
        start = origin if carried is None else carried
        kin_nodes = _kinematics(profile, nodes)
        ends, node_lat, node_depth = integrate_geodetic(
            start[0],
            start[1],
            start[2],
            kin_nodes["vel_n"].reshape(k1 - first, 4, 3),
            _GL_NODES,
            _GL_WEIGHTS,
            dt,
        )
        pos_nav = np.concatenate([origin[None], ends]) if k0 == 0 else ends
        m = _motion_geodetic(_kinematics(profile, t), pos_nav[:, 0], pos_nav[:, 2])
        at_nodes = _motion_geodetic(kin_nodes, node_lat.ravel(), node_depth.ravel())
        pos_n = ned_from_geodetic(pos_nav[:, 0], pos_nav[:, 1], -pos_nav[:, 2], (origin[0], origin[1], 0.0))
        carry = pos_nav[-1].copy()
    truth = Truth(
        name=name,
        earth=earth,
        t_s=t,
        pos_n=pos_n,
        vel_n=m["vel_n"],
        vel_b=m["vel_b"],
        C_nb=m["C_nb"],
        euler=m["euler"],
        omega_nb_b=m["omega_nb_b"],
        omega_ib_b=m["omega_ib_b"],
        f_b=m["f_b"],
        dtheta_ib_b=interval_integral(at_nodes["omega_ib_b"]),
        dv_b=interval_integral(at_nodes["f_b"]),
        step_s=dt,
        pos_nav=pos_nav,
    )
    return truth, carry


def generate_from_profile(
    name: str, profile: Profile, earth: Earth, duration_s: float, rate_hz: float, pos0_n: np.ndarray
) -> Truth:
    """Sample a profile at ``rate_hz`` for ``duration_s`` and derive the exact IMU outputs.

    Motion at the samples ``t_k = k / rate_hz``; the IMU and position increments over each
    ``(t_k-1, t_k]`` by 4-point Gauss-Legendre quadrature (module docstring), row 0 zero.

    Parameters
    ----------
    name : str
        Name recorded in the truth (``Truth.name``), e.g. the scenario's.
    profile : Profile
        Closed-form attitude [rad] and body velocity [m/s] against time [s], with their rates.
    earth : Earth
        Earth model (flat or WGS-84) and the origin's latitude and longitude [deg].
    duration_s : float
        Mission duration [s].
    rate_hz : float
        Sample rate, the IMU's [Hz].
    pos0_n : numpy.ndarray
        Start position, shape (3,) [m], NED from the sea-surface point above the origin; on WGS-84
        only its depth ``pos0_n[2]`` is read (the horizontal start is the origin of ``earth``).

    Returns
    -------
    Truth
        K = ``num_samples(duration_s, rate_hz)`` samples: ``t_s`` (K,) [s], ``pos_n`` (K, 3) [m]
        and ``vel_n`` (K, 3) [m/s] NED, ``vel_b`` (K, 3) [m/s], ``C_nb`` (K, 3, 3), ``euler``
        (K, 3) [rad], ``omega_nb_b`` and ``omega_ib_b`` (K, 3) [rad/s], ``f_b`` (K, 3) [m/s^2],
        increments ``dtheta_ib_b`` (K, 3) [rad] and ``dv_b`` (K, 3) [m/s], body frame b (FRD).
    """
    truth, _ = _chunk_from_profile(
        name, profile, earth, rate_hz, 0, num_samples(duration_s, rate_hz), pos0_n, None
    )
    return truth


def _start_n(cfg: TrajectoryConfig) -> np.ndarray:
    return np.array([0.0, 0.0, cfg.depth_m])


def generate(cfg: TrajectoryConfig, earth: Earth, rate_hz: float) -> Truth:
    """Truth for a named scenario, sampled at the IMU rate ``rate_hz``.

    The scenario's profile (:data:`PROFILES`) from the start ``[0, 0, depth_m]`` for
    ``duration_s`` (:func:`generate_from_profile`).

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: its ``name`` and geometry (metres, seconds, m/s, degrees as the field names say).
    earth : Earth
        Earth model (flat or WGS-84) and the origin's latitude and longitude [deg].
    rate_hz : float
        Sample rate, the IMU's [Hz].

    Returns
    -------
    Truth
        The whole mission, K = ``num_samples(cfg.duration_s, rate_hz)`` samples: positions and
        velocities NED [m, m/s], attitude, body rates [rad/s], specific force [m/s^2] and the
        exact IMU increments [rad, m/s] in the body frame b (FRD), each (K, 3) (``C_nb``
        (K, 3, 3)).

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0 ("imu.rate_hz must be > 0").
    """
    require_positive("imu.rate_hz", rate_hz)
    profile = mission_profile(cfg)
    truth = generate_from_profile(cfg.name, profile, earth, cfg.duration_s, rate_hz, _start_n(cfg))
    check_in_water(cfg, bathymetry(cfg), truth)
    return with_current(truth, current_field(cfg))


def generate_chunk(
    cfg: TrajectoryConfig,
    earth: Earth,
    rate_hz: float,
    k0: int,
    k1: int,
    travelled_n: np.ndarray | None = None,
) -> tuple[Truth, np.ndarray]:
    """Samples ``k0 <= k < k1`` of :func:`generate`'s truth (the same numbers).

    With the mission's times, and the sum of the position increments to pass on to the chunk
    starting at ``k1``. ``travelled_n`` (3,): that sum as the chunk ending at ``k0 - 1`` returned
    it (position is the only quantity not closed-form in time: ``pos_n[k] = pos_n[0] +
    travelled_n[k]`` in the flat model); omitted for ``k0 = 0``. Each call builds the scenario's
    profile; :class:`TruthStream` builds it once.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: its ``name``, ``duration_s`` [s] and geometry.
    earth : Earth
        Earth model (flat or WGS-84) and the origin's latitude and longitude [deg].
    rate_hz : float
        Sample rate, the IMU's [Hz].
    k0 : int
        The mission's index of the chunk's first sample, ``0 <= k0 < k1``.
    k1 : int
        One past the mission's index of the chunk's last sample, ``k1 <= num_samples(duration_s,
        rate_hz)``.
    travelled_n : numpy.ndarray or None, optional
        Shape (3,), what the chunk ending at ``k0 - 1`` returned: in the flat model the sum of the
        position increments [m], NED; on WGS-84 the geodetic position of sample ``k0 - 1``
        (latitude [rad], longitude [rad], depth [m]). None (only) for ``k0 = 0``.

    Returns
    -------
    truth : Truth
        The samples ``k0 <= k < k1`` (K = ``k1 - k0``), with the mission's times ``t_s`` (K,) [s]:
        the fields of :func:`generate`'s truth, NED and body frame b (FRD).
    travelled_n : numpy.ndarray
        Shape (3,), to pass to the chunk starting at ``k1``: the sum of the position increments up
        to sample ``k1 - 1`` [m], NED (flat model), or the geodetic position of sample ``k1 - 1``
        (latitude [rad], longitude [rad], depth [m]; WGS-84).

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0 ("imu.rate_hz must be > 0").
    ValueError
        If ``[k0, k1)`` does not lie within the mission's samples ("chunk samples ... must lie
        within the mission's ..."), or ``travelled_n`` is None for ``k0 > 0`` ("a chunk starting
        at sample ... > 0 needs the travelled_n of the chunk before").
    """
    require_positive("imu.rate_hz", rate_hz)
    chunk, travelled_n = _chunk(cfg, mission_profile(cfg), earth, rate_hz, k0, k1, travelled_n)
    check_in_water(cfg, bathymetry(cfg), chunk)
    return chunk, travelled_n


def _chunk(
    cfg: TrajectoryConfig,
    profile: Profile,
    earth: Earth,
    rate_hz: float,
    k0: int,
    k1: int,
    travelled_n: np.ndarray | None,
) -> tuple[Truth, np.ndarray]:
    total = num_samples(cfg.duration_s, rate_hz)
    if not 0 <= k0 < k1 <= total:
        raise ValueError(f"chunk samples [{k0}, {k1}) must lie within the mission's [0, {total})")
    if travelled_n is None and k0 > 0:
        raise ValueError(f"a chunk starting at sample {k0} > 0 needs the travelled_n of the chunk before")
    chunk, carried = _chunk_from_profile(
        cfg.name,
        profile,
        earth,
        rate_hz,
        k0,
        k1,
        _start_n(cfg),
        None if travelled_n is None else np.asarray(travelled_n, dtype=float),
    )
    return with_current(chunk, current_field(cfg)), carried


class TruthStream:
    """:func:`generate`'s truth chunk by chunk.

    ``for k0, chunk in TruthStream(...)`` yields the samples ``k0 .. k0 + chunk_samples - 1``
    (fewer in the last chunk) in order, each chunk a :class:`Truth` with the mission's times and
    exact ``dt_s``; concatenated, the chunks are :func:`generate`'s numbers bit for bit
    (tests/unit/tauvcore/sensors/test_stream.py). Memory: one chunk. Iterating again starts again from sample 0.

    Parameters
    ----------
    cfg : TrajectoryConfig
        Scenario: its ``name``, ``duration_s`` [s] and geometry.
    earth : Earth
        Earth model (flat or WGS-84) and the origin's latitude and longitude [deg].
    rate_hz : float
        Sample rate, the IMU's [Hz].
    chunk_samples : int
        Samples per chunk, >= 1.

    Raises
    ------
    ConfigError
        If ``rate_hz`` is not a finite number > 0 ("imu.rate_hz must be > 0").
    ValueError
        If ``chunk_samples`` is not a whole number >= 1.
    """

    def __init__(self, cfg: TrajectoryConfig, earth: Earth, rate_hz: float, chunk_samples: int) -> None:
        require_positive("imu.rate_hz", rate_hz)
        if (
            isinstance(chunk_samples, bool)
            or not isinstance(chunk_samples, (int, np.integer))
            or chunk_samples < 1
        ):
            raise ValueError(f"chunk_samples must be a whole number >= 1, got {chunk_samples!r}")
        self.cfg = cfg
        self.earth = earth
        self.rate_hz = float(rate_hz)
        self.chunk_samples = int(chunk_samples)
        self.num_samples = num_samples(cfg.duration_s, rate_hz)  # of the whole mission
        self.dt_s = 1.0 / rate_hz  # equal to generate(...).dt_s
        self._profile = mission_profile(cfg)
        self._seabed = bathymetry(cfg)

    def __len__(self) -> int:
        """Number of chunks."""
        return (self.num_samples + self.chunk_samples - 1) // self.chunk_samples

    def __iter__(self) -> Iterator[tuple[int, Truth]]:
        """The chunks in order, from sample 0.

        Yields
        ------
        k0 : int
            The mission's index of the chunk's first sample.
        chunk : Truth
            The samples ``k0 .. k0 + chunk_samples - 1`` (fewer in the last chunk), with the
            mission's times [s], NED and body frame b (FRD) as :func:`generate`'s truth.
        """
        travelled_n = None
        for k0 in range(0, self.num_samples, self.chunk_samples):
            k1 = min(k0 + self.chunk_samples, self.num_samples)
            chunk, travelled_n = _chunk(
                self.cfg, self._profile, self.earth, self.rate_hz, k0, k1, travelled_n
            )
            check_in_water(self.cfg, self._seabed, chunk)
            yield k0, chunk
