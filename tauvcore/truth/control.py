"""Guidance and control of the TAUV (Tal et al. 2017 section 2: "Control system block" and
"Guidance system block").

Guidance (target tracking, the paper's reference [21]: Breivik & Fossen, "Guidance laws for
autonomous underwater vehicles", 2009): the mission is a horizontal path (a polyline through
closely spaced points) and a depth schedule. Horizontally, lookahead-based steering: the target
is the point ``lookahead_m`` further along the path than the point of the path closest to the
vehicle, and the heading command points at it, less an integral of the cross-track error
(integral LOS, which takes out the crab angle a current or a steady sideslip needs). Vertically
the same law in the vertical plane: the pitch command is the depth schedule's glide angle plus
``atan`` of the depth error over ``depth_lookahead_m``, plus an integral of it (the angle of
attack that holds the positive buoyancy). The speed command is constant.

Control: four PID loops, "three for the attitude control and one for the velocity control": roll
(held level), pitch and yaw to the guidance commands, each giving a virtual fin angle; speed
gives the propeller command around the RPM of steady motion at that speed (feed-forward). The
derivative acts on the measured rate (no kick when a command steps); the integrators stop while
their output saturates and are clamped (anti-windup). The autopilot runs at the IMU rate on the
true state (its own sensors are not modelled).

X-rudder allocation: fin i at angle gamma_i around the hull (tauvcore.truth.vehicle) gets
``delta_i = delta_roll + sgn(cos gamma_i) delta_pitch + sgn(sin gamma_i) delta_yaw``: each virtual
angle then makes only its own moment (the columns are orthogonal), of the size two fins of a
"+" tail deflected by sqrt(2) times as much would make. Saturation: pitch and yaw are scaled
together into the fin limit, roll gets what remains (it is passively stable; steering is not).

The per-step functions are compiled (numba); ``.py_func`` of each is the plain Python.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from tauvcore import units
from tauvcore.validation import require_nonnegative, require_positive

FIN_SIGN_PITCH = np.array([1.0, -1.0, -1.0, 1.0])  # sgn(cos gamma_i), gamma = 45, 135, 225, 315 deg
FIN_SIGN_YAW = np.array([1.0, 1.0, -1.0, -1.0])  # sgn(sin gamma_i)

# controller state (one float array): integrators, then the path segment index
I_SPEED, I_ROLL, I_PITCH, I_YAW, I_DEPTH, I_TRACK, SEGMENT = range(7)
NUM_CONTROL_STATES = 7

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@dataclass(frozen=True)
class ControlConfig:
    """Autopilot gains and guidance constants (tuned on the default TAUV; module docstring)."""

    roll_kp: float = 1.0  # virtual roll fin [rad] per rad of roll error
    roll_ki: float = 0.5  # per rad s
    roll_kd: float = 0.2  # per rad/s of roll rate
    pitch_kp: float = 1.5
    pitch_ki: float = 0.2
    pitch_kd: float = 0.8
    yaw_kp: float = 1.5
    yaw_ki: float = 0.05
    yaw_kd: float = 0.8
    speed_kp: float = 10.0  # rev/s per m/s of speed error
    speed_ki: float = 2.0  # rev/s per m
    integral_max: float = 0.2  # clamp of each attitude integrator's contribution [rad]
    lookahead_m: float = 8.0  # horizontal lookahead (below the tightest turn radius) [m]
    depth_lookahead_m: float = 8.0
    track_ki: float = 0.002  # integral LOS gain [1/(m s)], contribution clamped to 10 deg
    depth_ki: float = 0.002
    pitch_max_deg: float = 30.0  # pitch command limit

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            require_nonnegative(f"control.{f.name}", getattr(self, f.name))
        for name in ("lookahead_m", "depth_lookahead_m", "pitch_max_deg"):
            require_positive(f"control.{name}", getattr(self, name))


class ControlParams(NamedTuple):
    roll: np.ndarray  # (3,) kp, ki, kd
    pitch: np.ndarray
    yaw: np.ndarray
    speed_kp: float
    speed_ki: float
    integral_max: float
    lookahead_m: float
    depth_lookahead_m: float
    track_ki: float
    depth_ki: float
    pitch_max_rad: float
    fin_max_rad: float
    rps_max: float
    rps_per_mps: float  # feed-forward: steady propeller speed per m/s


def control_params(
    cfg: ControlConfig, fin_max_rad: float, rps_max: float, rps_per_mps: float
) -> ControlParams:
    return ControlParams(
        roll=np.array([cfg.roll_kp, cfg.roll_ki, cfg.roll_kd]),
        pitch=np.array([cfg.pitch_kp, cfg.pitch_ki, cfg.pitch_kd]),
        yaw=np.array([cfg.yaw_kp, cfg.yaw_ki, cfg.yaw_kd]),
        speed_kp=cfg.speed_kp,
        speed_ki=cfg.speed_ki,
        integral_max=cfg.integral_max,
        lookahead_m=cfg.lookahead_m,
        depth_lookahead_m=cfg.depth_lookahead_m,
        track_ki=cfg.track_ki,
        depth_ki=cfg.depth_ki,
        pitch_max_rad=cfg.pitch_max_deg * units.DEG,
        fin_max_rad=fin_max_rad,
        rps_max=rps_max,
        rps_per_mps=rps_per_mps,
    )


@_jit
def wrap_pi(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@_jit
def allocate(d_roll: float, d_pitch: float, d_yaw: float, fin_max: float) -> np.ndarray:
    """Four fin angles [rad] from virtual roll, pitch and yaw angles (module docstring)."""
    steer = abs(d_pitch) + abs(d_yaw)  # the largest |pitch part + yaw part| over the fins
    if steer > fin_max:
        d_pitch *= fin_max / steer
        d_yaw *= fin_max / steer
        steer = fin_max
    room = fin_max - steer
    d_roll = min(max(d_roll, -room), room)
    return d_roll + FIN_SIGN_PITCH * d_pitch + FIN_SIGN_YAW * d_yaw


@_jit
def closest_on_path(
    path_ne: np.ndarray, s_m: np.ndarray, first: int, north: float, east: float, window: int
) -> tuple[int, float, float]:
    """Closest point of segments ``first .. first + window`` of the polyline to (north, east):
    its segment, its arc length [m] and the signed cross-track error [m] (positive: the vehicle
    is to the right of the path's direction)."""
    best_j, best_d2, best_s, best_e = first, 1e300, s_m[first], 0.0
    last = min(first + window, path_ne.shape[0] - 2)
    for j in range(first, last + 1):
        dn = path_ne[j + 1, 0] - path_ne[j, 0]
        de = path_ne[j + 1, 1] - path_ne[j, 1]
        seg2 = dn * dn + de * de
        rn, re = north - path_ne[j, 0], east - path_ne[j, 1]
        tau = (rn * dn + re * de) / seg2 if seg2 > 0.0 else 0.0
        tau = min(max(tau, 0.0), 1.0)
        pn, pe = rn - tau * dn, re - tau * de
        d2 = pn * pn + pe * pe
        if d2 < best_d2:
            seg = math.sqrt(seg2)
            best_j, best_d2, best_s = j, d2, s_m[j] + tau * seg
            best_e = (-rn * de + re * dn) / seg if seg > 0.0 else 0.0
    return best_j, best_s, best_e


@_jit
def point_at(path_ne: np.ndarray, s_m: np.ndarray, first: int, s: float) -> tuple[float, float]:
    """The point at arc length ``s`` (searching forward from segment ``first``; beyond the end,
    the last segment extended)."""
    j = first
    n = path_ne.shape[0]
    while j < n - 2 and s_m[j + 1] < s:
        j += 1
    seg = s_m[j + 1] - s_m[j]
    tau = (s - s_m[j]) / seg if seg > 0.0 else 0.0
    return (
        path_ne[j, 0] + tau * (path_ne[j + 1, 0] - path_ne[j, 0]),
        path_ne[j, 1] + tau * (path_ne[j + 1, 1] - path_ne[j, 1]),
    )


@_jit
def _pid(
    gains: np.ndarray,
    error: float,
    rate: float,
    cs: np.ndarray,
    slot: int,
    limit: float,
    dt: float,
    integral_max: float,
) -> float:
    """PID with derivative on the measured rate; the integrator runs only while the output is
    within ``limit`` (or moving back into it) and its contribution is clamped."""
    out_free = gains[0] * error - gains[2] * rate
    out = out_free + gains[1] * cs[slot]
    if abs(out) < limit or out * error < 0.0:
        cs[slot] += error * dt
        if gains[1] > 0.0:
            bound = integral_max / gains[1]
            cs[slot] = min(max(cs[slot], -bound), bound)
    return out_free + gains[1] * cs[slot]


@_jit
def autopilot(
    c: ControlParams,
    x: np.ndarray,
    cs: np.ndarray,
    path_ne: np.ndarray,
    s_m: np.ndarray,
    depth_ref_m: float,
    depth_rate_ref_mps: float,
    speed_ref_mps: float,
    dt: float,
    out_guidance: np.ndarray,
) -> tuple[np.ndarray, float]:
    """Fin angle commands (4,) [rad] and propeller command [rev/s] for the vehicle state ``x``
    (tauvcore.truth.vehicle state layout), advancing the controller state ``cs`` by ``dt``.
    ``out_guidance`` receives heading command [rad], pitch command [rad], cross-track error [m]."""
    u_r = x[0]
    p, q, r = x[3], x[4], x[5]
    north, east, depth = x[6], x[7], x[8]
    phi, theta, psi = x[9], x[10], x[11]
    # horizontal guidance: lookahead-based steering with integral action
    j, s_close, e_track = closest_on_path(path_ne, s_m, int(cs[SEGMENT]), north, east, 20)
    cs[SEGMENT] = j
    tn, te = point_at(path_ne, s_m, j, s_close + c.lookahead_m)
    track_bound = 10.0 * units.DEG / c.track_ki if c.track_ki > 0.0 else 0.0
    cs[I_TRACK] = min(max(cs[I_TRACK] + e_track * dt, -track_bound), track_bound)
    psi_cmd = math.atan2(te - east, tn - north) - c.track_ki * cs[I_TRACK]
    # vertical guidance: glide angle of the schedule, depth error over the lookahead, integral
    speed = max(abs(u_r), 0.1)
    glide = -math.asin(min(max(depth_rate_ref_mps / speed, -0.9), 0.9))
    e_depth = depth_ref_m - depth
    depth_bound = 10.0 * units.DEG / c.depth_ki if c.depth_ki > 0.0 else 0.0
    cs[I_DEPTH] = min(max(cs[I_DEPTH] + e_depth * dt, -depth_bound), depth_bound)
    theta_cmd = glide - math.atan(e_depth / c.depth_lookahead_m) - c.depth_ki * cs[I_DEPTH]
    theta_cmd = min(max(theta_cmd, -c.pitch_max_rad), c.pitch_max_rad)
    out_guidance[0], out_guidance[1], out_guidance[2] = psi_cmd, theta_cmd, e_track
    # attitude loops: virtual fin angles
    fm = c.fin_max_rad
    d_roll = _pid(c.roll, -phi, p, cs, I_ROLL, fm, dt, c.integral_max)
    d_pitch = _pid(c.pitch, theta_cmd - theta, q, cs, I_PITCH, fm, dt, c.integral_max)
    d_yaw = _pid(c.yaw, wrap_pi(psi_cmd - psi), r, cs, I_YAW, fm, dt, c.integral_max)
    fins = allocate(d_roll, d_pitch, d_yaw, fm)
    # speed loop: feed-forward plus PI on the speed through the water
    e_u = speed_ref_mps - u_r
    rps_ff = c.rps_per_mps * speed_ref_mps
    rps = rps_ff + c.speed_kp * e_u + c.speed_ki * cs[I_SPEED]
    if 0.0 < rps < c.rps_max or (rps >= c.rps_max and e_u < 0.0) or (rps <= 0.0 and e_u > 0.0):
        cs[I_SPEED] += e_u * dt
    rps = rps_ff + c.speed_kp * e_u + c.speed_ki * cs[I_SPEED]
    return fins, min(max(rps, 0.0), c.rps_max)
