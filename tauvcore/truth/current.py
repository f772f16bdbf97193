"""The ocean current a mission flies through: a field of time and depth, and the crab angle the
kinematic vehicle flies to keep its track over ground in it.

The field, NED [m/s], at time ``t`` and depth ``z``::

    c_n(t, z) = c0_n + [S_ne (z - z0); 0] + [v_ne(t); 0]

- ``c0_n`` (``trajectory.current_n_mps``): the constant current at the start depth ``z0``
  (``trajectory.depth_m``); its down part only with the dynamic truth.
- ``S_ne`` (``trajectory.current_shear_ne_per_s``): the linear shear, the change of the north and
  east current per metre of depth [(m/s)/m = 1/s]. Oceanic shears are 1e-3 to 1e-2 1/s; a water
  layer 30 m below a vehicle in 0.01 1/s moves 0.3 m/s faster than the water at the vehicle.
- ``v_ne(t)`` (``trajectory.current_variation_mps``, ``..._period_s``, ``current_seed``): the slowly
  varying part, a seeded sum of :data:`VARIATION_COMPONENTS` cosines per axis with periods of 1,
  2, 4 and 8 times ``current_variation_period_s``, random phases, and amplitudes scaled so that
  its RMS over time is ``current_variation_mps`` on each axis exactly (its peak is at most
  ``2 sqrt(2)`` times that). It is the world, like the terrain: every run of a study flies the
  same current. It is smooth, so the truth's accelerations and the crab's rate stay closed-form.

Every field zero is still water: :func:`current_field` gives None, and the truth is today's.

The crab angle (:func:`crab_profile`): the kinematic truth flies its path over ground, so in a
current its velocity through the water is ``w = v_n - c_n``. The vehicle turns by the angle from
its ground velocity's horizontal direction to ``w``'s, ``chi = atan2(w_e, w_n) - atan2(v_e, v_n)``,
about the vertical, so that it meets the water as the profile met the ground (the same sideslip
and angle of attack, at the water-relative speed). The crab is taken against the current at the
start depth (``z = z0``): in a shear the vehicle's dives add a small sway through the water, which
the truth records (``Truth.current_n_mps`` is the current at the vehicle's true depth). A crab
beyond :data:`MAX_CRAB_DEG` cannot be honoured (:func:`check_crab`): the kinematic truth would fly
sideways to hold its track; the dynamic truth's autopilot crabs by itself.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from tauvcore.geo.rotations import C_nb_from_euler, euler_rates_to_omega_nb_b
from tauvcore.truth.profile import Profile
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.water import MIN_ALTITUDE_M, Mission, lawnmower_level_depth_m, seabed_floor_m
from tauvcore.validation import ConfigError, require_range, require_vector3, show

VARIATION_COMPONENTS = 4
"""Cosines per horizontal axis in the slowly varying current."""
VARIATION_PERIOD_RATIOS = (1.0, 2.0, 4.0, 8.0)
"""Their periods, in multiples of ``trajectory.current_variation_period_s``."""
MAX_CRAB_DEG = 45.0
"""Largest crab angle the kinematic truth flies [deg]; beyond, it would fly sideways."""
MAX_DURATION_S = 86400.0
"""Longest period of the variation [s]: a day (tauvcore.truth.kinematic.MAX_DURATION_S)."""
CRAB_CHECK_STEP_S = 1.0
"""Spacing of the times :func:`check_crab` checks the crab at [s]."""


class CurrentSettings(Mission, Protocol):
    """The fields of a mission the current reads (tauvcore.truth.kinematic.TrajectoryConfig's)."""

    @property
    def name(self) -> str: ...
    @property
    def duration_s(self) -> float: ...
    @property
    def dive_rate_mps(self) -> float: ...
    @property
    def current_n_mps(self) -> tuple[float, float, float]: ...
    @property
    def current_shear_ne_per_s(self) -> tuple[float, float]: ...
    @property
    def current_variation_mps(self) -> float: ...
    @property
    def current_variation_period_s(self) -> float: ...
    @property
    def current_seed(self) -> int: ...


@dataclass(frozen=True)
class CurrentField:
    """The current as a function of time and depth (module docstring); :meth:`params` packs it for
    compiled code (tauvcore.truth.dynamic)."""

    constant_n_mps: np.ndarray  # (3,) c0_n, at the reference depth, NED [m/s]
    reference_depth_m: float  # z0, the mission's start depth [m]
    shear_ne_per_s: np.ndarray  # (2,) S_ne, d(north, east current)/d(depth) [1/s]
    amplitude_ne_mps: np.ndarray  # (2, M) the cosines' amplitudes, north row then east [m/s]
    omega_rps: np.ndarray  # (M,) their angular frequencies [rad/s]
    phase_ne_rad: np.ndarray  # (2, M) their phases [rad]

    def velocity_n_mps(self, t_s: np.ndarray, depth_m: np.ndarray) -> np.ndarray:
        """The current at times ``t_s`` and depths ``depth_m``.

        Parameters
        ----------
        t_s : numpy.ndarray
            Times, shape (K,) [s].
        depth_m : numpy.ndarray
            Depths, positive down, shape (K,) (or a scalar) [m].

        Returns
        -------
        numpy.ndarray
            The current, shape (K, 3), NED [m/s].
        """
        t = np.asarray(t_s, dtype=float)
        dz = np.broadcast_to(np.asarray(depth_m, dtype=float) - self.reference_depth_m, t.shape)
        out = np.empty(t.shape + (3,))
        out[:] = self.constant_n_mps
        out[..., :2] += dz[..., None] * self.shear_ne_per_s
        out[..., :2] += self._variation(t, 0)
        return out

    def rate_n_mps2(self, t_s: np.ndarray, depth_rate_mps: np.ndarray | float) -> np.ndarray:
        """The rate of the current met by a vehicle moving down at ``depth_rate_mps``.

        Parameters
        ----------
        t_s : numpy.ndarray
            Times, shape (K,) [s].
        depth_rate_mps : numpy.ndarray or float
            The vehicle's down velocity, shape (K,) (or a scalar) [m/s].

        Returns
        -------
        numpy.ndarray
            ``dc/dt + dc/dz dz/dt``, shape (K, 3), NED [m/s^2] (its down part zero).
        """
        t = np.asarray(t_s, dtype=float)
        zdot = np.broadcast_to(np.asarray(depth_rate_mps, dtype=float), t.shape)
        out = np.zeros(t.shape + (3,))
        out[..., :2] = zdot[..., None] * self.shear_ne_per_s + self._variation(t, 1)
        return out

    def _variation(self, t: np.ndarray, order: int) -> np.ndarray:
        """The varying part (order 0) or its time derivative (order 1), shape t.shape + (2,)."""
        if self.omega_rps.size == 0:
            return np.zeros(t.shape + (2,))
        arg = t[..., None, None] * self.omega_rps + self.phase_ne_rad  # (..., 2, M)
        if order == 0:
            return np.sum(self.amplitude_ne_mps * np.cos(arg), axis=-1)
        return -np.sum(self.amplitude_ne_mps * self.omega_rps * np.sin(arg), axis=-1)

    def peak_horizontal_mps(self, depth_span_m: float) -> float:
        """A bound on the horizontal current's magnitude within ``depth_span_m`` of the start
        depth [m/s]: the constant, the shear over the span and the variation's largest sum."""
        peak_var = float(np.linalg.norm(np.sum(np.abs(self.amplitude_ne_mps), axis=-1)))
        shear = float(np.linalg.norm(self.shear_ne_per_s)) * depth_span_m
        return float(np.linalg.norm(self.constant_n_mps[:2])) + shear + peak_var

    def params(self) -> np.ndarray:
        """The field packed in one array for compiled code: ``[c0_n (3), z0, S_ne (2), M, then per
        component omega, a_n, a_e, phi_n, phi_e]`` (tauvcore.truth.dynamic)."""
        m = self.omega_rps.size
        comp = np.stack(
            [
                self.omega_rps,
                self.amplitude_ne_mps[0],
                self.amplitude_ne_mps[1],
                self.phase_ne_rad[0],
                self.phase_ne_rad[1],
            ],
            axis=-1,
        ).ravel()
        head = np.concatenate([self.constant_n_mps, [self.reference_depth_m], self.shear_ne_per_s, [m]])
        return np.concatenate([head, comp])


def current_field(cfg: CurrentSettings) -> CurrentField | None:
    """The current of the mission ``cfg``; None in still water (every current field zero).

    Parameters
    ----------
    cfg : CurrentSettings
        The mission: ``depth_m`` [m] (the reference depth), ``current_n_mps`` [m/s] NED,
        ``current_shear_ne_per_s`` [1/s], ``current_variation_mps`` [m/s],
        ``current_variation_period_s`` [s], ``current_seed``.

    Returns
    -------
    CurrentField or None
        The field (module docstring); the varying part's amplitudes and phases drawn from
        ``numpy.random.default_rng(current_seed)``.
    """
    still = (
        not any(cfg.current_n_mps)
        and not any(cfg.current_shear_ne_per_s)
        and cfg.current_variation_mps == 0.0
    )
    if still:
        return None
    m = VARIATION_COMPONENTS if cfg.current_variation_mps > 0.0 else 0
    omega = np.array(
        [2.0 * np.pi / (r * cfg.current_variation_period_s) for r in VARIATION_PERIOD_RATIOS[:m]]
    )
    amp = np.zeros((2, m))
    phase = np.zeros((2, m))
    if m:
        rng = np.random.default_rng(cfg.current_seed)
        g = rng.standard_normal((2, m))
        amp = cfg.current_variation_mps * np.sqrt(2.0) * g / np.linalg.norm(g, axis=-1, keepdims=True)
        phase = rng.uniform(0.0, 2.0 * np.pi, (2, m))
    return CurrentField(
        constant_n_mps=np.array(cfg.current_n_mps, dtype=float),
        reference_depth_m=float(cfg.depth_m),
        shear_ne_per_s=np.array(cfg.current_shear_ne_per_s, dtype=float),
        amplitude_ne_mps=amp,
        omega_rps=omega,
        phase_ne_rad=phase,
    )


def crab_angle_rad(
    field: CurrentField, t_s: np.ndarray, vel_n: np.ndarray, acc_n: np.ndarray, reference_depth_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """The crab angle and its rate for a ground velocity ``vel_n`` and acceleration ``acc_n``.

    Parameters
    ----------
    field : CurrentField
        The current; taken at ``reference_depth_m`` (module docstring).
    t_s : numpy.ndarray
        Times, shape (K,) [s].
    vel_n : numpy.ndarray
        Velocity over ground, shape (K, 3), NED [m/s].
    acc_n : numpy.ndarray
        Its rate, shape (K, 3), NED [m/s^2].
    reference_depth_m : float
        The depth the crab takes the current at [m].

    Returns
    -------
    chi : numpy.ndarray
        Crab angle, shape (K,), the water-relative course less the ground course, wrapped to
        (-pi, pi] [rad].
    chi_dot : numpy.ndarray
        Its rate, shape (K,) [rad/s].
    """
    c = field.velocity_n_mps(t_s, np.full(np.shape(t_s), reference_depth_m))
    c_dot = field.rate_n_mps2(t_s, 0.0)
    w, w_dot = vel_n - c, acc_n - c_dot
    course_w = np.arctan2(w[:, 1], w[:, 0])
    course_v = np.arctan2(vel_n[:, 1], vel_n[:, 0])
    chi = np.angle(np.exp(1j * (course_w - course_v)))
    rate_w = (w[:, 0] * w_dot[:, 1] - w[:, 1] * w_dot[:, 0]) / (w[:, 0] ** 2 + w[:, 1] ** 2)
    rate_v = (vel_n[:, 0] * acc_n[:, 1] - vel_n[:, 1] * acc_n[:, 0]) / (vel_n[:, 0] ** 2 + vel_n[:, 1] ** 2)
    return chi, rate_w - rate_v


def _over_ground(profile: Profile, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """The profile's Euler angles and rates, and its velocity and acceleration over ground (NED)."""
    euler, euler_dot, vel_b = profile.euler(t), profile.euler_dot(t), profile.vel_b(t)
    C = C_nb_from_euler(euler)
    omega = euler_rates_to_omega_nb_b(euler, euler_dot)
    vel_n = np.einsum("kij,kj->ki", C, vel_b)
    acc_n = np.einsum("kij,kj->ki", C, profile.vel_b_dot(t) + np.cross(omega, vel_b))
    return euler, euler_dot, vel_n, acc_n


def crab_profile(profile: Profile, field: CurrentField, reference_depth_m: float) -> Profile:
    """``profile`` flown over the same ground track in the current ``field``: heading turned by the
    crab angle, body velocity the same ground velocity seen from the turned hull.

    With ``C' = Rz(chi) C`` (a yaw offset on ZYX Euler angles), ``vel_b' = C'^T vel_n`` and
    ``vel_b_dot' = C'^T acc_n - omega' x vel_b'``, so the ground velocity, acceleration and track
    are the profile's exactly.

    Parameters
    ----------
    profile : Profile
        The mission's profile in still water.
    field : CurrentField
        The current.
    reference_depth_m : float
        The depth the crab takes the current at [m] (the start depth).

    Returns
    -------
    Profile
        The crabbing profile: Euler angles [rad] and rates [rad/s], body velocity [m/s] and its
        rate [m/s^2], each a function of times (K,) [s] returning (K, 3).
    """
    cache: dict[str, object] = {}

    def at(t: np.ndarray) -> dict[str, np.ndarray]:
        if cache.get("t") is t:
            return cache["m"]  # type: ignore[return-value]
        euler, euler_dot, vel_n, acc_n = _over_ground(profile, t)
        chi, chi_dot = crab_angle_rad(field, t, vel_n, acc_n, reference_depth_m)
        euler2 = euler.copy()
        euler2[:, 2] += chi
        euler_dot2 = euler_dot.copy()
        euler_dot2[:, 2] += chi_dot
        C2 = C_nb_from_euler(euler2)
        omega2 = euler_rates_to_omega_nb_b(euler2, euler_dot2)
        vel_b2 = np.einsum("kji,kj->ki", C2, vel_n)
        vel_b_dot2 = np.einsum("kji,kj->ki", C2, acc_n) - np.cross(omega2, vel_b2)
        m = {"euler": euler2, "euler_dot": euler_dot2, "vel_b": vel_b2, "vel_b_dot": vel_b_dot2}
        cache["t"], cache["m"] = t, m
        return m

    return Profile(
        euler=lambda t: at(t)["euler"],
        euler_dot=lambda t: at(t)["euler_dot"],
        vel_b=lambda t: at(t)["vel_b"],
        vel_b_dot=lambda t: at(t)["vel_b_dot"],
    )


def check_crab(profile: Profile, field: CurrentField, duration_s: float, reference_depth_m: float) -> None:
    """Refuse a current the kinematic truth cannot honour: a crab beyond :data:`MAX_CRAB_DEG`.

    Checked every :data:`CRAB_CHECK_STEP_S` over the mission.

    Parameters
    ----------
    profile : Profile
        The mission's profile in still water.
    field : CurrentField
        The current.
    duration_s : float
        The mission's duration [s].
    reference_depth_m : float
        The depth the crab takes the current at [m].

    Raises
    ------
    ConfigError
        At the first time the crab exceeds the limit, naming ``trajectory.current_n_mps`` and the
        angle.
    """
    t = np.arange(0.0, duration_s + CRAB_CHECK_STEP_S, CRAB_CHECK_STEP_S)
    _, _, vel_n, acc_n = _over_ground(profile, t)
    c = field.velocity_n_mps(t, np.full(t.shape, reference_depth_m))
    w = vel_n[:, :2] - c[:, :2]
    chi, _ = crab_angle_rad(field, t, vel_n, acc_n, reference_depth_m)
    bad = np.flatnonzero((np.abs(chi) > np.deg2rad(MAX_CRAB_DEG)) | (np.hypot(*w.T) < 1e-3))
    if bad.size:
        k = int(bad[0])
        raise ConfigError(
            f"trajectory.current_n_mps {show([float(c) for c in field.constant_n_mps])}: the kinematic vehicle would "
            f"crab {np.rad2deg(abs(chi[k])):.0f} deg at t = {t[k]:g} s (beyond {MAX_CRAB_DEG:g} deg it "
            f'flies sideways to hold its track); use trajectory.truth = "dynamic" or a weaker current'
        )


def check_current(cfg: CurrentSettings, profile_of: Callable[[], Profile]) -> None:
    """The current's fields in range, below the vehicle's speed, and one the truth can honour.

    Parameters
    ----------
    cfg : CurrentSettings
        The mission (tauvcore.truth.kinematic.TrajectoryConfig): its current, speed [m/s], depths
        [m], duration [s] and truth.
    profile_of : Callable
        Makes the mission's profile in still water (tauvcore.truth.kinematic.PROFILES), called only
        when the crab must be checked.

    Raises
    ------
    ConfigError
        A field out of range, a current reaching ``speed_mps``, a vertical current with the
        kinematic truth, or a crab beyond :data:`MAX_CRAB_DEG` (:func:`check_crab`), naming the
        field and the value.
    """
    require_vector3("trajectory.current_n_mps", cfg.current_n_mps, bound=3.0)
    shear = cfg.current_shear_ne_per_s
    if not isinstance(shear, (tuple, list)) or len(shear) != 2:
        raise ConfigError(f"trajectory.current_shear_ne_per_s must be a list of 2 numbers, got {show(shear)}")
    for i, v in enumerate(shear):
        require_range(f"trajectory.current_shear_ne_per_s[{i}]", v, -0.1, 0.1)
    require_range("trajectory.current_variation_mps", cfg.current_variation_mps, 0.0, 3.0)
    require_range(
        "trajectory.current_variation_period_s", cfg.current_variation_period_s, 60.0, MAX_DURATION_S
    )
    seed = cfg.current_seed
    if not isinstance(seed, int) or isinstance(seed, bool) or not 0 <= seed <= 2**63 - 1:
        raise ConfigError(
            f"trajectory.current_seed must be an integer within [0, 2**63 - 1], got {show(seed)}"
        )
    field = current_field(cfg)
    if field is None:
        return
    if cfg.truth == "kinematic" and cfg.current_n_mps[2] != 0.0:
        raise ConfigError(
            f"trajectory.current_n_mps {show(list(cfg.current_n_mps))}: a vertical current needs "
            f'trajectory.truth = "dynamic" (the kinematic truth holds its depth schedule)'
        )
    peak = field.peak_horizontal_mps(deepest_m(cfg) - cfg.depth_m)
    if peak >= cfg.speed_mps:
        parts = [f"trajectory.current_n_mps {show(list(cfg.current_n_mps))}"]
        if any(shear):
            parts.append(f"current_shear_ne_per_s {show(list(shear))}")
        if cfg.current_variation_mps:
            parts.append(f"current_variation_mps {show(cfg.current_variation_mps)}")
        raise ConfigError(
            f"{', '.join(parts)}: the current reaches {peak:.3g} m/s, not below the vehicle's speed "
            f"trajectory.speed_mps {show(cfg.speed_mps)} m/s (it could not make way against it)"
        )
    if cfg.truth == "kinematic":
        check_crab(profile_of(), field, cfg.duration_s, cfg.depth_m)


def deepest_m(cfg: CurrentSettings) -> float:
    """The deepest the mission's depth schedule goes.

    Parameters
    ----------
    cfg : CurrentSettings
        The mission: its name, start depth [m], dive rates [m/s] and seabed.

    Returns
    -------
    float
        Depth [m], positive down: the figure eight's level-off, the lawnmower's level depth, else
        the start depth.
    """
    if cfg.name == "figure8" and cfg.dive_rate_mps > 0.0:
        return min(cfg.depth_m + cfg.dive_rate_mps * cfg.duration_s, seabed_floor_m(cfg) - MIN_ALTITUDE_M)
    if cfg.name == "lawnmower":
        return max(cfg.depth_m, lawnmower_level_depth_m(cfg))
    return cfg.depth_m


def with_current(truth: Truth, field: CurrentField | None) -> Truth:
    """``truth`` with the current at the vehicle (``Truth.current_n_mps``); itself in still water.

    Parameters
    ----------
    truth : Truth
        Samples of the mission: times [s], depths [m].
    field : CurrentField or None
        The mission's current (:func:`current_field`); None: still water.

    Returns
    -------
    Truth
        The same samples, with ``current_n_mps`` (K, 3) NED [m/s] at each sample's time and depth.
    """
    if field is None:
        return truth
    return dataclasses.replace(truth, current_n_mps=field.velocity_n_mps(truth.t_s, truth.depth_m))
