"""Dynamic truth: the TAUV flown through the scenario by its autopilot (Tal et al. 2017 section
2: hydrodynamic and motion block, control system, guidance).

The mission of a scenario (tauvcore.truth.kinematic) becomes a horizontal path, the track of the
kinematic scenario sampled every 0.25 s, and a depth schedule, its depth against time; the
vehicle starts where and as the kinematic one does and tracks them at the scenario's speed
(tauvcore.truth.control). The 17 states of tauvcore.truth.vehicle (velocity relative to the water,
NED position, Euler angles, fins, propeller) are integrated by classical Runge-Kutta 4 with the
IMU's step, the autopilot's commands held over each step (it runs at the IMU rate).

The ocean current (tauvcore.truth.current): the vehicle flies the whole field ``c_n(t, z)``
(constant, sheared with depth, slowly varying), evaluated by the compiled :func:`current_into`
from :meth:`~tauvcore.truth.current.CurrentField.params` at each Runge-Kutta stage's time (the
mission's, ``k dt`` at knot k, whatever the chunk) and its state's depth ``x[8]``. The
hydrodynamics see the velocity relative to the water ``nu_r`` (the state), and its kinetics
``M nu_r' = tau(nu_r, ...)`` are Fossen's relative-velocity form (tauvcore.truth.vehicle), exact
for an irrotational current constant in n. With a slowly varying current the terms in the
water's acceleration as the vehicle meets it, ``dc/dt + dc/dz zdot``, are neglected: the force
it takes to carry the rigid body along with that acceleration (``m C_nb^T dc/dt``) and, where the
water itself accelerates, the pressure gradient that drives it (``rho V C_nb^T dc/dt``, which in
an ideal fluid nearly cancels the first for this nearly neutral hull; a steady shear has no such
gradient). Each is of order mass x dc/dt: per unit mass about 1e-3 m/s^2 for the documented
variations (0.1 m/s RMS at the default 600 s period; a 0.3 m/s dive through a 0.005 1/s shear),
against 0.16 m/s^2 of drag and thrust balancing at 2 m/s. The flow's variation along the hull is
neglected too (in a 0.01 1/s shear, 3 mm/s across its 0.3 m diameter).

What the truth records is the motion over ground: at each knot ``nu = nu_r + C_nb^T c_n(t, z)``
with its exact derivative ``nu_r' - omega_nb_b x (C_nb^T c_n) + C_nb^T (dc/dt + dc/dz zdot)``
(``zdot`` the position derivative's down part), so the interpolant below is the integrated
motion in any current. (An ideal INS would not notice a wrong knot derivative, since it follows
whatever interpolant the knots make; the truth's specific force at the knots would be off by the
water's acceleration: tests/unit/tauvcore/truth/test_vehicle.py compares the knots' derivatives with their
differences.) ``Truth.current_n_mps`` is the field at the truth's times and depths
(tauvcore.truth.kinematic.with_current), the current the integrator used to round-off. Still
water is the all-zero field (:data:`STILL_WATER`): the integrator adds exact zeros, and its
numbers are those it gave before it knew of currents, bit for bit, as are a constant current's.

From the integration to the truth record: at every IMU sample (a knot) the integrator gives the
Euler angles and body velocity over ground and, from the equations of motion, their exact time
derivatives (fins and propeller are states, so the forces and hence these derivatives are
continuous in time). Between knots the truth *is* the cubic Hermite interpolant of those values
and derivatives (C1 in attitude and velocity), which agrees with the integrated motion to the
integrator's O(dt^4). That interpolant is a :class:`~tauvcore.truth.kinematic.Profile`, so the
kinematic generator's machinery turns it into the truth record: angular rate from the Euler
rates, specific force from the velocity's derivative with gravity and the earth's rotation of
the chosen earth model, position and the IMU increments by Gauss-Legendre quadrature. Specific
force, angular rate and positions are therefore consistent with one another to round-off, as on
the kinematic truth (an ideal INS follows it: tests/scenario/test_dynamic_truth.py).

Streaming: the simulation runs chunk by chunk, carrying its state, so :class:`DynamicTruthStream`
holds one chunk whatever the mission's length, and chunks of any size give the same numbers bit
for bit (the integration does not know where a chunk ends; the interpolant at a time depends only
on the two knots around it). A mission of up to CACHE_MAX_KNOTS samples (11 min at 150 Hz) is
simulated once per process and its knots kept (a few MB): every Monte Carlo run and every chunk of
runs a process computes then shares one simulation, as they share the kinematic profile.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numba
import numpy as np

from tauvcore.geo.earth import Earth
from tauvcore.truth import control as ctl
from tauvcore.truth import vehicle as veh
from tauvcore.truth.current import current_field
from tauvcore.truth.kinematic import (
    PROFILES,
    TrajectoryConfig,
    _chunk_from_profile,
    _start_n,
    bathymetry,
    check_in_water,
    with_current,
)
from tauvcore.truth.profile import Profile, _kinematics, num_samples
from tauvcore.truth.truth_record import Truth, VehicleRecord
from tauvcore.validation import require_positive

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")

DEFAULT_VEHICLE = veh.VehicleConfig()
"""The vehicle when none is given (the configuration's default)."""
DEFAULT_CONTROL = ctl.ControlConfig()
"""The autopilot when none is given (the configuration's default)."""

MISSION_STEP_S = 0.25
"""Spacing in time of the kinematic scenario's points that make the path and depth schedule [s]."""
MISSION_MARGIN_S = 120.0
"""Path beyond the mission's duration [s]: the vehicle may get ahead of the schedule."""

CACHE_MAX_KNOTS = 100_000
"""Longest mission whose knots a process keeps [samples] (19 MB); longer ones are streamed."""
CACHE_MISSIONS = 1
"""Missions kept (the most recent: a dashboard worker draws the 3-D view and runs the same one)."""
_knots_cache: dict[tuple, np.ndarray] = {}

# columns of a knot row
K_EULER, K_EULER_DOT, K_VEL, K_VEL_DOT = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
K_FINS, K_RPM, K_HEADING_CMD, K_PITCH_CMD, K_TRACK, K_DEPTH_REF, K_POS = (
    slice(12, 16),
    16,
    17,
    18,
    19,
    20,
    slice(21, 24),
)
KNOT_COLUMNS = 24


CURRENT_HEAD = 7
"""Length of :meth:`~tauvcore.truth.current.CurrentField.params`'s head: ``c0_n`` (3), ``z0``,
``S_ne`` (2), ``M``; then 5 numbers per cosine (``omega``, ``a_n``, ``a_e``, ``phi_n``, ``phi_e``)."""
STILL_WATER = np.zeros(CURRENT_HEAD)
"""The packed field of still water (no current, no shear, no cosines)."""


def current_params(cfg: TrajectoryConfig) -> np.ndarray:
    """The mission's current packed for the compiled integrator.

    Parameters
    ----------
    cfg : TrajectoryConfig
        The mission: its current fields (tauvcore.truth.current.current_field).

    Returns
    -------
    numpy.ndarray
        :meth:`~tauvcore.truth.current.CurrentField.params` of its field, shape (7 + 5 M,);
        :data:`STILL_WATER` (all zero, M = 0) in still water.
    """
    field = current_field(cfg)
    return STILL_WATER.copy() if field is None else np.ascontiguousarray(field.params())


@_jit
def current_into(params: np.ndarray, t: float, z: float, c_n: np.ndarray) -> None:
    """The current at time ``t`` and depth ``z``, written into ``c_n``.

    ``c_n = c0_n + [S_ne (z - z0); 0] + [sum_m a_m cos(omega_m t + phi_m); 0]``, the same sums in
    the same order as :meth:`~tauvcore.truth.current.CurrentField.velocity_n_mps`.

    Parameters
    ----------
    params : numpy.ndarray
        The packed field, shape (7 + 5 M,) (:meth:`~tauvcore.truth.current.CurrentField.params`,
        :func:`current_params`).
    t : float
        The mission's time [s].
    z : float
        Depth, positive down [m].
    c_n : numpy.ndarray
        Shape (3,), overwritten.

    Returns
    -------
    None
        The current is in ``c_n``, NED [m/s].
    """
    dz = z - params[3]
    vn = 0.0
    ve = 0.0
    for m in range(int(params[6])):
        k = CURRENT_HEAD + 5 * m
        vn += params[k + 1] * math.cos(t * params[k] + params[k + 3])
        ve += params[k + 2] * math.cos(t * params[k] + params[k + 4])
    c_n[0] = params[0] + dz * params[4] + vn
    c_n[1] = params[1] + dz * params[5] + ve
    c_n[2] = params[2]


@_jit
def current_rate_into(params: np.ndarray, t: float, z_rate: float, c_rate_n: np.ndarray) -> None:
    """The rate of the current met by a vehicle going down at ``z_rate``, written into ``c_rate_n``.

    ``dc/dt + dc/dz z_rate``, as :meth:`~tauvcore.truth.current.CurrentField.rate_n_mps2`.

    Parameters
    ----------
    params : numpy.ndarray
        The packed field, shape (7 + 5 M,) (:func:`current_params`).
    t : float
        The mission's time [s].
    z_rate : float
        The vehicle's down velocity [m/s].
    c_rate_n : numpy.ndarray
        Shape (3,), overwritten.

    Returns
    -------
    None
        The rate is in ``c_rate_n``, NED [m/s^2] (its down part zero: the field has no vertical
        shear of the vertical current, nor a varying one).
    """
    vn = 0.0
    ve = 0.0
    for m in range(int(params[6])):
        k = CURRENT_HEAD + 5 * m
        w = params[k]
        vn -= params[k + 1] * w * math.sin(t * w + params[k + 3])
        ve -= params[k + 2] * w * math.sin(t * w + params[k + 4])
    c_rate_n[0] = z_rate * params[4] + vn
    c_rate_n[1] = z_rate * params[5] + ve
    c_rate_n[2] = 0.0


@_jit
def _rk4_step(
    p: veh.VehicleParams,
    x: np.ndarray,
    d1: np.ndarray,
    fins: np.ndarray,
    rps: float,
    current: np.ndarray,
    t: float,
    dt: float,
    work: np.ndarray,
) -> None:
    """x += one classical Runge-Kutta step from time ``t``, d1 = f(x, t) given; each stage's
    current at its time and its state's depth (``current``: the packed field); ``work`` (6, 17)
    scratch."""
    n = x.shape[0]
    xs, d2, d3, d4, tau, c_n = work[0], work[1], work[2], work[3], work[4, :6], work[5, :3]
    for i in range(n):
        xs[i] = x[i] + 0.5 * dt * d1[i]
    current_into(current, t + 0.5 * dt, xs[8], c_n)
    veh.derivative_into(p, xs, fins, rps, c_n, tau, d2)
    for i in range(n):
        xs[i] = x[i] + 0.5 * dt * d2[i]
    current_into(current, t + 0.5 * dt, xs[8], c_n)
    veh.derivative_into(p, xs, fins, rps, c_n, tau, d3)
    for i in range(n):
        xs[i] = x[i] + dt * d3[i]
    current_into(current, t + dt, xs[8], c_n)
    veh.derivative_into(p, xs, fins, rps, c_n, tau, d4)
    for i in range(n):
        x[i] += dt / 6.0 * (d1[i] + 2.0 * d2[i] + 2.0 * d3[i] + d4[i])


@_jit
def simulate_knots(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    p: veh.VehicleParams,
    c: ctl.ControlParams,
    x: np.ndarray,
    cs: np.ndarray,
    current: np.ndarray,
    first_knot: int,
    path_ne: np.ndarray,
    s_m: np.ndarray,
    depth_ref_m: np.ndarray,
    depth_rate_ref_mps: np.ndarray,
    speed_ref_mps: np.ndarray,
    dt: float,
    out: np.ndarray,
) -> None:
    """Record ``out.shape[0]`` knots from the vehicle and controller states, stepping both forward
    one IMU interval per knot (in place).

    Parameters
    ----------
    p : tauvcore.truth.vehicle.VehicleParams
        The vehicle.
    c : tauvcore.truth.control.ControlParams
        The autopilot.
    x : numpy.ndarray
        The vehicle's state at knot ``first_knot``, shape (17,) (tauvcore.truth.vehicle layout);
        advanced to knot ``first_knot + out.shape[0]``.
    cs : numpy.ndarray
        The controller's state, advanced with it.
    current : numpy.ndarray
        The packed current field (:func:`current_params`).
    first_knot : int
        The mission's index of the first knot: its time is ``first_knot dt`` [s].
    path_ne : numpy.ndarray
        The mission's path, shape (P, 2), north and east [m].
    s_m : numpy.ndarray
        Arc length along it, shape (P,) [m].
    depth_ref_m : numpy.ndarray
        The depth schedule at each knot, shape (N,) [m].
    depth_rate_ref_mps : numpy.ndarray
        Its rate, shape (N,) [m/s].
    speed_ref_mps : numpy.ndarray
        The speed schedule, shape (N,) [m/s].
    dt : float
        The IMU interval [s].
    out : numpy.ndarray
        Shape (N, KNOT_COLUMNS), overwritten.

    Returns
    -------
    None
        The knots are in ``out``, one row per knot (the K_* columns): Euler angles [rad] and
        rates [rad/s], body velocity over ground [m/s] and its derivative [m/s^2], fins [rad],
        propeller [rev/min], guidance, the depth schedule and the NED position [m].
    """
    guidance = np.zeros(3)
    work = np.zeros((6, x.shape[0]))
    d1 = np.empty(x.shape[0])
    current_n = np.empty(3)
    rate_n = np.empty(3)
    current_b = np.empty(3)
    rate_b = np.empty(3)
    for i in range(out.shape[0]):
        t = (first_knot + i) * dt  # the mission's time of the knot, whatever the chunk
        fins, rps = ctl.autopilot(
            c, x, cs, path_ne, s_m, depth_ref_m[i], depth_rate_ref_mps[i], speed_ref_mps[i], dt, guidance
        )
        current_into(current, t, x[8], current_n)
        veh.derivative_into(p, x, fins, rps, current_n, work[4, :6], d1)
        current_rate_into(current, t, d1[8], rate_n)
        C_nb = veh.C_nb_of(x[9], x[10], x[11])
        for j in range(3):
            current_b[j] = C_nb[0, j] * current_n[0] + C_nb[1, j] * current_n[1] + C_nb[2, j] * current_n[2]
            rate_b[j] = C_nb[0, j] * rate_n[0] + C_nb[1, j] * rate_n[1] + C_nb[2, j] * rate_n[2]
        w_x_current = veh._cross(x[3:6], current_b)
        for j in range(3):
            out[i, j] = x[9 + j]
            out[i, 3 + j] = d1[9 + j]
            out[i, 6 + j] = x[j] + current_b[j]
            # d/dt (C_nb.T c_n) = -omega_nb_b x (C_nb.T c_n) + C_nb.T (dc/dt + dc/dz zdot)
            out[i, 9 + j] = d1[j] - w_x_current[j] + rate_b[j]
            out[i, 21 + j] = x[6 + j]
        for j in range(4):
            out[i, 12 + j] = x[12 + j]
        out[i, 16] = 60.0 * x[16]
        out[i, 17], out[i, 18], out[i, 19] = guidance[0], guidance[1], guidance[2]
        out[i, 20] = depth_ref_m[i]
        _rk4_step(p, x, d1, fins, rps, current, t, dt, work)


class HermiteProfile:
    """The :class:`~tauvcore.truth.kinematic.Profile` through knots ``first .. first + n - 1`` at
    ``t_k = k dt``: cubic Hermite in each interval of the Euler angles and body velocity, from
    their values and derivatives at the knots; the derivatives are the interpolant's own."""

    def __init__(self, knots: np.ndarray, first: int, dt: float) -> None:
        self.knots, self.first, self.dt = knots, first, dt
        self._last: tuple[np.ndarray, dict[str, np.ndarray]] | None = None

    def _at(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Values and rates at ``t``, computed once per time array (the kinematic generator asks
        for the four quantities at the same times in turn)."""
        if self._last is not None and self._last[0] is t:
            return self._last[1]
        u = np.asarray(t, dtype=float) / self.dt
        i = np.clip(np.floor(u).astype(np.int64), self.first, self.first + self.knots.shape[0] - 2)
        s = (u - i)[:, None]
        j = i - self.first
        h = self.dt
        k0, k1 = self.knots[j, :12], self.knots[j + 1, :12]
        s2 = s * s
        s3 = s2 * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, (s3 - 2 * s2 + s) * h, 3 * s2 - 2 * s3, (s3 - s2) * h
        g0, g10, g11 = (6 * s2 - 6 * s) / h, 3 * s2 - 4 * s + 1, 3 * s2 - 2 * s
        out = {}
        for name, cols, dcols in (("euler", K_EULER, K_EULER_DOT), ("vel", K_VEL, K_VEL_DOT)):
            y0, y1, m0, m1 = k0[:, cols], k1[:, cols], k0[:, dcols], k1[:, dcols]
            out[name] = h00 * y0 + h10 * m0 + h01 * y1 + h11 * m1
            out[name + "_dot"] = g0 * (y0 - y1) + g10 * m0 + g11 * m1
        self._last = (t, out)
        return out

    def profile(self) -> Profile:
        return Profile(
            euler=lambda t: self._at(t)["euler"],
            euler_dot=lambda t: self._at(t)["euler_dot"],
            vel_b=lambda t: self._at(t)["vel"],
            vel_b_dot=lambda t: self._at(t)["vel_dot"],
        )


@dataclass(frozen=True)
class Mission:
    """What the guidance follows: the horizontal path and the depth schedule of a scenario."""

    path_ne: np.ndarray  # (P, 2) north, east [m]
    s_m: np.ndarray  # (P,) arc length along the path [m]
    t_s: np.ndarray  # (P,) schedule times [s]
    depth_m: np.ndarray  # (P,) depth schedule [m]
    depth_rate_mps: np.ndarray  # (P,) its rate [m/s]
    speed_mps: np.ndarray  # (P,) speed schedule (the scenario's surge) [m/s]
    euler0: np.ndarray  # (3,) attitude at the start [rad]
    yaw_rate0_rps: float  # the scenario's turn rate at the start [rad/s]


def mission(cfg: TrajectoryConfig) -> Mission:
    """The kinematic scenario ``cfg`` as a path and depth schedule (trapezoidal integration of its
    velocity every MISSION_STEP_S: the path's points, not the truth)."""
    profile = PROFILES[cfg.name](cfg)
    t = np.arange(0.0, cfg.duration_s + MISSION_MARGIN_S + MISSION_STEP_S, MISSION_STEP_S)
    kin = _kinematics(profile, t)
    vel_n = kin["vel_n"]
    pos = np.concatenate(
        [np.zeros((1, 3)), np.cumsum(0.5 * MISSION_STEP_S * (vel_n[1:] + vel_n[:-1]), axis=0)]
    )
    pos += _start_n(cfg)
    path = np.ascontiguousarray(pos[:, :2])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    return Mission(
        path_ne=path,
        s_m=s,
        t_s=t,
        depth_m=pos[:, 2],
        depth_rate_mps=vel_n[:, 2],
        speed_mps=kin["vel_b"][:, 0],
        euler0=kin["euler"][0],
        yaw_rate0_rps=float(profile.euler_dot(t[:1])[0, 2]),
    )


class DynamicSimulation:
    """The vehicle flying a mission, advanced knot by knot (:meth:`knots`)."""

    def __init__(
        self,
        cfg: TrajectoryConfig,
        rate_hz: float,
        vehicle: veh.VehicleConfig = DEFAULT_VEHICLE,
        control: ctl.ControlConfig = DEFAULT_CONTROL,
    ) -> None:
        self.cfg = cfg
        self.dt = 1.0 / rate_hz
        self.params = veh.vehicle_params(vehicle)
        rps_per_mps = 1.0 / veh.steady_speed_per_rps(self.params)
        self.control = ctl.control_params(control, self.params.fin_max_rad, self.params.rps_max, rps_per_mps)
        self.mission = mission(cfg)
        self.current = current_params(cfg)
        x = np.zeros(veh.NUM_STATES)
        x[veh.EULER] = self.mission.euler0
        # level (the autopilot holds the roll at zero), heading at the guidance's first target and
        # turning as the scenario does (figure8): the autopilot's steady state, no start-up kick
        x[9] = 0.0
        target = ctl.point_at(self.mission.path_ne, self.mission.s_m, 0, control.lookahead_m)
        x[11] = math.atan2(target[1] - self.mission.path_ne[0, 1], target[0] - self.mission.path_ne[0, 0])
        x[5] = self.mission.yaw_rate0_rps / math.cos(x[10])
        C_nb = veh.C_nb_of.py_func(x[9], x[10], x[11])
        x[veh.POS] = _start_n(cfg)
        current0_n = np.empty(3)
        current_into(self.current, 0.0, x[8], current0_n)
        x[0:3] = np.array([self.mission.speed_mps[0], 0.0, 0.0]) - C_nb.T @ current0_n
        x[veh.RPS] = rps_per_mps * self.mission.speed_mps[0]
        self.x = x
        self.cs = np.zeros(ctl.NUM_CONTROL_STATES)
        self.next_knot = 0

    def knots(self, count: int) -> np.ndarray:
        """The next ``count`` knots (count, KNOT_COLUMNS), from knot ``next_knot`` on."""
        m = self.mission
        t = (self.next_knot + np.arange(count)) * self.dt
        depth_ref = np.interp(t, m.t_s, m.depth_m)
        depth_rate = np.interp(t, m.t_s, m.depth_rate_mps)
        out = np.empty((count, KNOT_COLUMNS))
        speed = np.interp(t, m.t_s, m.speed_mps)
        simulate_knots(
            self.params,
            self.control,
            self.x,
            self.cs,
            self.current,
            self.next_knot,
            m.path_ne,
            m.s_m,
            depth_ref,
            depth_rate,
            speed,
            self.dt,
            out,
        )
        self.next_knot += count
        return out


def _vehicle_record(knots: np.ndarray) -> VehicleRecord:
    return VehicleRecord(
        propeller_rpm=knots[:, K_RPM].copy(),
        fin_angles_rad=knots[:, K_FINS].copy(),
        heading_cmd_rad=knots[:, K_HEADING_CMD].copy(),
        pitch_cmd_rad=knots[:, K_PITCH_CMD].copy(),
        cross_track_m=knots[:, K_TRACK].copy(),
        depth_error_m=knots[:, K_POS][:, 2] - knots[:, K_DEPTH_REF],
    )


class DynamicTruthStream:
    """The dynamic truth chunk by chunk, as tauvcore.truth.kinematic.TruthStream gives the kinematic
    one (same interface); each chunk's :attr:`Truth.vehicle` carries fins, propeller and guidance."""

    def __init__(
        self,
        cfg: TrajectoryConfig,
        earth: Earth,
        rate_hz: float,
        chunk_samples: int,
        vehicle: veh.VehicleConfig = DEFAULT_VEHICLE,
        control: ctl.ControlConfig = DEFAULT_CONTROL,
        cache: bool = True,
    ) -> None:
        require_positive("imu.rate_hz", rate_hz)
        if (
            isinstance(chunk_samples, bool)
            or not isinstance(chunk_samples, (int, np.integer))
            or chunk_samples < 1
        ):
            raise ValueError(f"chunk_samples must be a whole number >= 1, got {chunk_samples!r}")
        self.cfg, self.earth, self.rate_hz = cfg, earth, float(rate_hz)
        self.chunk_samples = int(chunk_samples)
        self.num_samples = num_samples(cfg.duration_s, rate_hz)
        self.dt_s = 1.0 / rate_hz
        self.vehicle, self.control = vehicle, control
        self.cache = cache and self.num_samples + 1 <= CACHE_MAX_KNOTS

    def __len__(self) -> int:
        return (self.num_samples + self.chunk_samples - 1) // self.chunk_samples

    def _whole(self) -> np.ndarray:
        """Every knot of the mission (0 .. num_samples), simulated once per process."""
        key = (self.cfg, self.rate_hz, self.vehicle, self.control)
        whole = _knots_cache.pop(key, None)
        if whole is None:
            whole = DynamicSimulation(self.cfg, self.rate_hz, self.vehicle, self.control).knots(
                self.num_samples + 1
            )
            whole.flags.writeable = False
        _knots_cache[key] = whole  # the most recent last
        while len(_knots_cache) > CACHE_MISSIONS:
            del _knots_cache[next(iter(_knots_cache))]
        return whole

    def __iter__(self) -> Iterator[tuple[int, Truth]]:
        whole = self._whole() if self.cache else None
        sim = None if self.cache else DynamicSimulation(self.cfg, self.rate_hz, self.vehicle, self.control)
        pos0_n = _start_n(self.cfg)
        seabed = bathymetry(self.cfg)
        field = current_field(self.cfg)
        carried = None
        kept = None if sim is None else sim.knots(1)  # streamed: knots first .. first + len - 1
        first = 0
        for k0 in range(0, self.num_samples, self.chunk_samples):
            k1 = min(k0 + self.chunk_samples, self.num_samples)
            # the chunk's samples and intervals need knots max(k0 - 1, 0) .. k1 (one past its last sample)
            start = max(k0 - 1, 0)
            if sim is None:
                assert whole is not None  # cached: the whole mission's knots (above)
                knots, first = whole[start : k1 + 1], start
            else:
                assert kept is not None  # streamed: sim's knots so far (above, and each chunk)
                knots = np.concatenate([kept, sim.knots(k1 + 1 - sim.next_knot)])
                knots, first = knots[start - first :], start
            profile = HermiteProfile(knots, first, self.dt_s).profile()
            truth, carried = _chunk_from_profile(
                self.cfg.name, profile, self.earth, self.rate_hz, k0, k1, pos0_n, carried
            )
            check_in_water(self.cfg, seabed, truth)
            rows = knots[k0 - first : k1 - first]
            yield k0, dataclasses.replace(with_current(truth, field), vehicle=_vehicle_record(rows))
            kept, first = knots[k1 - 1 - first :], k1 - 1


def generate(
    cfg: TrajectoryConfig,
    earth: Earth,
    rate_hz: float,
    vehicle: veh.VehicleConfig = DEFAULT_VEHICLE,
    control: ctl.ControlConfig = DEFAULT_CONTROL,
) -> Truth:
    """The whole mission's dynamic truth at ``rate_hz`` (one chunk of :class:`DynamicTruthStream`)."""
    stream = DynamicTruthStream(cfg, earth, rate_hz, num_samples(cfg.duration_s, rate_hz), vehicle, control)
    return next(iter(stream))[1]
