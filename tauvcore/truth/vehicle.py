"""The TAUV as a rigid body in water: geometry, mass, hydrodynamic coefficients and the 6-DOF
equations of motion (Tal et al. 2017 section 2, "Hydrodynamic and Motion block").

The paper does not publish TAUV's hydrodynamic model (it thanks G. Iosilevskii for it). This
module derives one from TAUV's published geometry (length 3 m, diameter 0.3 m, four rudders in
an "x") with the semi-empirical slender-body method Prestero used for the REMUS AUV:

    T. Prestero, "Verification of a six-degree of freedom simulation model for the REMUS
    autonomous underwater vehicle", MSc thesis, MIT/WHOI 2001, chapter 4 (hull profile, added
    mass, cross-flow drag, body lift, fin lift, hydrostatics); the equations of motion in the
    vector form of T. I. Fossen, "Handbook of Marine Craft Hydrodynamics and Motion Control",
    Wiley 2011, eq. 7.190 (rigid body about a point other than the centre of gravity, added
    mass Coriolis of eq. 6.43, ocean current by relative velocity, section 10.3).

What is taken from where (every number in :class:`VehicleConfig`, each with its source):

- Hull: a Myring profile (Prestero eq. 2.1-2.2) with TAUV's length and diameter; nose and tail
  lengths are REMUS's fractions of its length (0.191 / 1.33 and 0.368 / 1.33, rounded).
- Mass: neutral buoyancy less a 0.5 % reserve (REMUS: W = 299 N, B = 306 N, 2 %); the centre of
  gravity 2 cm below the centre of buoyancy (REMUS: 1.96 cm); inertia of the displaced volume at
  uniform density about the centre of buoyancy (the body origin).
- Added mass: strip theory, ``m_a(x) = rho pi r(x)^2`` on the hull and Blevins' cruciform section
  ``rho pi (a^2 - r^2 + r^4 / a^2)`` (a = fin tip radius) over the fins' chord (Prestero eq.
  4.8-4.14); the axial term from Lamb's k1 for the prolate spheroid of the same length and
  diameter; roll added mass of the fins ``(2 / pi) rho a^4`` per unit chord (Prestero eq. 4.16).
- Added-mass Coriolis and Munk moments: Fossen's C_A(nu) of the added-mass matrix (these are
  Prestero's X_wq, Y_ur, N_uv_a, M_uw_a, ... terms, eq. 4.20-4.28, all at once).
- Drag: axial ``X_u|u| = -rho c_d A_f / 2`` with Prestero's c_d = 0.2; cross-flow drag of the hull
  by strip theory with c_dc = 1.1 (Hoerner's cylinder, Prestero eq. 4.5); the fins' roll drag as
  flat plates (c_d 1.1).
- Body lift ``Y = -rho d^2 c_ydb u v / 2`` at x_cp (Prestero eq. 4.30-4.33, c_ydb = 1.2, x_cp at
  REMUS's fraction of the length aft of the centre of buoyancy, 0.321 / 1.33).
- Fins: each of the four a lifting surface of slope c_La = 3.12 /rad (Prestero, Hoerner) whose
  angle of attack is its deflection less the local flow across it, ``v_loc = v_r + omega x p``:
  fin lift, its damping of sway, heave, pitch, yaw and roll, and the fin forces of the rudder
  commands all come from that one model (Prestero's Y_uv_f, Y_ur_f, Y_uudr ... in vector form).
  Fin size: span 0.15 m and chord 0.12 m (REMUS's fin scaled by the diameter ratio, rounded).
- Thruster: a 0.18 m propeller with thrust ``T = rho D^4 (K_T0 n|n| - K_T1 |n| u_a / D)`` and
  torque of the same form (linear K_T(J) and K_Q(J), a B-series-like screw), wake fraction 0.2
  and thrust deduction 0.1; the motor follows its RPM command as a first-order lag. Because
  thrust and drag are both homogeneous of degree 2 in (n, u), steady speed is proportional to
  RPM.

Frames: body b (origin at the centre of buoyancy = the IMU, x forward, y starboard, z down), n
the NED frame the attitude is given in. The hydrodynamics use the velocity relative to the water
``nu_r = nu - [C_nb.T v_c_n; 0]`` for a constant current ``v_c_n``; for a current constant in n the
rigid-body equations keep their form in ``nu_r`` (Fossen Property 8.1), so ``nu_r`` is the state.
The earth's rotation acts on the vehicle through the INS only: its effect on the hydrodynamics
(Coriolis force ~1e-4 of the vehicle's weight per m/s) is below everything else modelled here.

The equations of motion are compiled (numba); ``.py_func`` of each is the plain Python.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from tauvcore import units
from tauvcore.geo.rotations import skew
from tauvcore.validation import require_positive, require_range

RHO_KGPM3 = 1025.0  # sea water density [kg/m^3]
NUM_FINS = 4
FIN_POSITION_ANGLES_RAD = np.array([45.0, 135.0, 225.0, 315.0]) * units.DEG
"""Where each fin stands around the hull, measured from starboard (+y) towards down (+z): fin 1
lower starboard, 2 lower port, 3 upper port, 4 upper starboard (the "x" of the paper)."""

# indices of the state vector x of the equations of motion
NU = slice(0, 6)  # nu_r: surge, sway, heave [m/s], roll, pitch, yaw rates [rad/s], relative to the water
POS = slice(6, 9)  # NED position [m]
EULER = slice(9, 12)  # roll, pitch, yaw [rad] (yaw unwrapped)
FINS = slice(12, 16)  # fin deflections [rad]
RPS = 16  # propeller speed [rev/s]
NUM_STATES = 17

_jit = numba.njit(cache=True, nogil=True, error_model="numpy")


@dataclass(frozen=True)
class VehicleConfig:
    """The TAUV's geometry and the empirical constants its hydrodynamic coefficients come from
    (module docstring: the method and each source)."""

    length_m: float = 3.0  # Tal et al. 2017 section 1: 3000 mm; [1, 20]
    diameter_m: float = 0.3  # section 1: 300 mm; [0.05, 2]
    nose_fraction: float = 0.144  # Myring nose length / length (REMUS 0.191 / 1.33)
    tail_fraction: float = 0.277  # Myring tail length / length (REMUS 0.368 / 1.33)
    tail_angle_deg: float = 25.0  # Myring tail half-angle at its start (REMUS 0.436 rad)
    buoyancy_reserve: float = 0.005  # (B - W) / B: a little positive, as AUVs are trimmed
    cg_below_cb_m: float = 0.02  # z_g: metacentric height of roll and pitch (REMUS 0.0196 m)
    drag_coefficient: float = 0.2  # c_d of the axial drag on the frontal area (Prestero)
    crossflow_drag_coefficient: float = 1.1  # c_dc of a cylinder in cross flow (Hoerner, Prestero)
    body_lift_coefficient: float = 1.2  # c_ydb (Prestero, after Hoerner)
    body_lift_centre_fraction: float = 0.241  # body lift's centre aft of the CB / length (REMUS 0.321 / 1.33)
    fin_span_m: float = 0.15  # each fin's span (REMUS's scaled by the diameter ratio)
    fin_chord_m: float = 0.12  # each fin's chord
    fin_lift_slope_per_rad: float = 3.12  # c_La (Prestero, Hoerner for the fin's aspect ratio)
    fin_from_tail_m: float = 0.2  # fins' quarter chord ahead of the tail's end
    fin_max_deg: float = 25.0  # deflection limit [deg]; [1, 45]
    fin_time_constant_s: float = 0.1  # servo lag [s]
    fin_rate_max_dps: float = 60.0  # servo rate limit [deg/s]
    propeller_diameter_m: float = 0.18
    kt0: float = 0.40  # K_T = kt0 - kt1 J (J = u_a / (n D))
    kt1: float = 0.40
    kq0: float = 0.060  # K_Q = kq0 - kq1 J
    kq1: float = 0.050
    wake_fraction: float = 0.2  # u_a = (1 - w) u
    thrust_deduction: float = 0.1  # hull sees (1 - t) T
    rpm_max: float = 2500.0  # motor limit [rev/min]: 5.9 m/s, within reach of Yoo 2014's 10 kn mission
    motor_time_constant_s: float = 0.3  # RPM follows its command with this lag [s]
    max_depth_m: float = 200.0  # section 1: maximum operating depth [m]

    def __post_init__(self) -> None:
        require_range("vehicle.length_m", self.length_m, 1.0, 20.0)
        require_range("vehicle.diameter_m", self.diameter_m, 0.05, 2.0)
        require_range("vehicle.fin_max_deg", self.fin_max_deg, 1.0, 45.0)
        require_range("vehicle.nose_fraction", self.nose_fraction, 0.01, 0.45)
        require_range("vehicle.tail_fraction", self.tail_fraction, 0.01, 0.45)
        require_range("vehicle.tail_angle_deg", self.tail_angle_deg, 0.0, 60.0)
        require_range("vehicle.buoyancy_reserve", self.buoyancy_reserve, -0.1, 0.1)
        require_range("vehicle.cg_below_cb_m", self.cg_below_cb_m, 0.0, 0.5 * self.diameter_m)
        for name in (
            "drag_coefficient",
            "crossflow_drag_coefficient",
            "body_lift_coefficient",
            "body_lift_centre_fraction",
            "fin_span_m",
            "fin_chord_m",
            "fin_lift_slope_per_rad",
            "fin_from_tail_m",
            "fin_time_constant_s",
            "fin_rate_max_dps",
            "propeller_diameter_m",
            "kt0",
            "kq0",
            "rpm_max",
            "motor_time_constant_s",
            "max_depth_m",
        ):
            require_positive(f"vehicle.{name}", getattr(self, name))
        for name in ("kt1", "kq1", "wake_fraction", "thrust_deduction"):
            require_range(f"vehicle.{name}", getattr(self, name), 0.0, 1.0)


class VehicleParams(NamedTuple):
    """Everything the compiled equations of motion need, derived once by :func:`vehicle_params`."""

    M_inv: np.ndarray  # (6, 6) inverse of rigid-body plus added mass
    M_A: np.ndarray  # (6, 6) added mass (positive definite) [kg, kg m, kg m^2]
    mass_kg: float
    inertia: np.ndarray  # (3,) Ixx, Iyy, Izz about the centre of buoyancy [kg m^2]
    r_g_b: np.ndarray  # (3,) centre of gravity from the centre of buoyancy [m]
    weight_n: float
    buoyancy_n: float
    x_uu: float  # axial drag X_u|u| [kg/m]
    y_vv: float  # hull cross-flow drag, Y_v|v| = Z_w|w| [kg/m]
    y_rr: float  # Y_r|r| = -Z_q|q| [kg m / rad^2]
    n_vv: float  # N_v|v| = -M_w|w| [kg]
    n_rr: float  # N_r|r| = M_q|q| [kg m^2 / rad^2]
    k_pp: float  # K_p|p| (fins' roll drag) [kg m^2 / rad^2]
    y_uv_lift: float  # body lift Y = y_uv_lift u v (= Z for w) [kg/m]
    x_lift_m: float  # its centre [m]
    fin_pos_b: np.ndarray  # (4, 3) fins' centres of pressure [m]
    fin_normal_b: np.ndarray  # (4, 3) direction of each fin's force for a positive deflection
    fin_lift: float  # rho c_La S / 2 per fin [kg/m]
    fin_max_rad: float
    fin_tau_s: float
    fin_rate_max_rps: float
    prop_d_m: float
    kt0: float
    kt1: float
    kq0: float
    kq1: float
    wake: float
    deduction: float
    rps_max: float
    motor_tau_s: float


def hull_radius_m(cfg: VehicleConfig, x_from_nose_m: np.ndarray) -> np.ndarray:
    """Myring profile r(x), x from the nose tip (Prestero eq. 2.1-2.2, n = 2)."""
    L, R = cfg.length_m, 0.5 * cfg.diameter_m
    a, c = cfg.nose_fraction * L, cfg.tail_fraction * L
    b = L - a - c
    x = np.asarray(x_from_nose_m, dtype=float)
    tan_t = math.tan(cfg.tail_angle_deg * units.DEG)
    nose = R * np.sqrt(np.clip(1.0 - ((x - a) / a) ** 2, 0.0, None))
    s = x - a - b
    tail = R - (3.0 * R / c**2 - tan_t / c) * s**2 + (2.0 * R / c**3 - tan_t / c**2) * s**3
    return np.where(x < a, nose, np.where(x <= a + b, R, np.clip(tail, 0.0, None)))


def _spheroid_k1(length_m: float, diameter_m: float) -> float:
    """Lamb's axial added-mass coefficient of a prolate spheroid (fraction of its displaced mass)."""
    e = math.sqrt(1.0 - (diameter_m / length_m) ** 2)
    alpha0 = 2.0 * (1.0 - e * e) / e**3 * (0.5 * math.log((1.0 + e) / (1.0 - e)) - e)
    return alpha0 / (2.0 - alpha0)


@dataclass(frozen=True)
class Coefficients:
    """Every coefficient of the model in one place, in Prestero's names [SI]: what
    :func:`vehicle_params` compiles, printed by ``python -m tauvcore.truth.vehicle``."""

    volume_m3: float
    mass_kg: float
    cb_from_nose_m: float
    Ixx: float
    Iyy: float
    Izz: float
    X_udot: float
    Y_vdot: float
    Y_rdot: float
    K_pdot: float
    M_qdot: float
    N_rdot: float
    X_uu: float
    Y_vv: float
    Y_rr: float
    N_vv: float
    N_rr: float
    K_pp: float
    Y_uv_lift: float
    x_lift_m: float
    fin_lift: float
    fin_x_m: float
    fin_r_m: float


def coefficients(cfg: VehicleConfig = VehicleConfig()) -> Coefficients:
    """The hydrodynamic coefficients of the hull ``cfg`` (module docstring: the method)."""
    L, R = cfg.length_m, 0.5 * cfg.diameter_m
    x_nose = np.linspace(0.0, L, 4001)
    r = hull_radius_m(cfg, x_nose)
    area = np.pi * r**2
    volume = float(np.trapezoid(area, x_nose))
    cb = float(np.trapezoid(x_nose * area, x_nose)) / volume
    x = cb - x_nose  # body x of each station (forward positive)
    mass = RHO_KGPM3 * volume * (1.0 - cfg.buoyancy_reserve)
    density = mass / volume
    Ixx = float(np.trapezoid(density * np.pi * r**4 / 2.0, x_nose))
    Iyy = float(np.trapezoid(density * area * (x**2 + r**2 / 4.0), x_nose))
    # fins: quarter chord fin_from_tail_m ahead of the tail's end; centre of pressure at 40 % span
    fin_x_nose = L - cfg.fin_from_tail_m
    r_root = float(hull_radius_m(cfg, np.array([fin_x_nose]))[0])
    tip = r_root + cfg.fin_span_m
    on_fins = np.abs(x_nose - fin_x_nose) <= 0.5 * cfg.fin_chord_m
    m_a = RHO_KGPM3 * np.where(on_fins, np.pi * (tip**2 - r**2 + r**4 / tip**2), area)
    Y_vdot = -float(np.trapezoid(m_a, x_nose))
    Y_rdot = -float(np.trapezoid(x * m_a, x_nose))
    N_rdot = -float(np.trapezoid(x**2 * m_a, x_nose))
    K_pdot = -float(np.trapezoid(np.where(on_fins, 2.0 / np.pi * RHO_KGPM3 * tip**4, 0.0), x_nose))
    X_udot = -_spheroid_k1(L, cfg.diameter_m) * RHO_KGPM3 * volume
    half_rho_cdc = 0.5 * RHO_KGPM3 * cfg.crossflow_drag_coefficient
    Y_vv = -half_rho_cdc * float(np.trapezoid(2.0 * r, x_nose))
    Y_rr = -half_rho_cdc * float(np.trapezoid(2.0 * r * x * np.abs(x), x_nose))
    N_vv = -half_rho_cdc * float(np.trapezoid(2.0 * r * x, x_nose))
    N_rr = -half_rho_cdc * float(np.trapezoid(2.0 * r * np.abs(x) ** 3, x_nose))
    r_span = np.linspace(r_root, tip, 201)
    K_pp = -4.0 * 0.5 * RHO_KGPM3 * 1.1 * cfg.fin_chord_m * float(np.trapezoid(r_span**3, r_span))
    return Coefficients(
        volume_m3=volume,
        mass_kg=mass,
        cb_from_nose_m=cb,
        Ixx=Ixx,
        Iyy=Iyy,
        Izz=Iyy,
        X_udot=X_udot,
        Y_vdot=Y_vdot,
        Y_rdot=Y_rdot,
        K_pdot=K_pdot,
        M_qdot=N_rdot,
        N_rdot=N_rdot,
        X_uu=-0.5 * RHO_KGPM3 * cfg.drag_coefficient * np.pi * R**2,
        Y_vv=Y_vv,
        Y_rr=Y_rr,
        N_vv=N_vv,
        N_rr=N_rr,
        K_pp=K_pp,
        Y_uv_lift=-0.5 * RHO_KGPM3 * cfg.diameter_m**2 * cfg.body_lift_coefficient,
        x_lift_m=-cfg.body_lift_centre_fraction * L,
        fin_lift=0.5 * RHO_KGPM3 * cfg.fin_lift_slope_per_rad * cfg.fin_span_m * cfg.fin_chord_m,
        fin_x_m=cb - fin_x_nose,
        fin_r_m=r_root + 0.4 * cfg.fin_span_m,
    )


def vehicle_params(cfg: VehicleConfig = VehicleConfig()) -> VehicleParams:
    """The compiled model's parameters: :func:`coefficients` assembled into matrices."""
    co = coefficients(cfg)
    r_g = np.array([0.0, 0.0, cfg.cg_below_cb_m])
    m = co.mass_kg
    inertia = np.array([co.Ixx, co.Iyy, co.Izz])
    M_RB = np.zeros((6, 6))
    M_RB[:3, :3] = m * np.eye(3)
    M_RB[:3, 3:] = -m * skew(r_g)
    M_RB[3:, :3] = m * skew(r_g)
    M_RB[3:, 3:] = np.diag(inertia)
    M_A = np.diag([-co.X_udot, -co.Y_vdot, -co.Y_vdot, -co.K_pdot, -co.M_qdot, -co.N_rdot])
    # Y_rdot = N_vdot couples sway and yaw; heave and pitch by symmetry with the opposite sign
    M_A[1, 5] = M_A[5, 1] = -co.Y_rdot
    M_A[2, 4] = M_A[4, 2] = co.Y_rdot
    gamma = FIN_POSITION_ANGLES_RAD
    fin_pos = np.stack(
        [np.full(NUM_FINS, co.fin_x_m), co.fin_r_m * np.cos(gamma), co.fin_r_m * np.sin(gamma)], 1
    )
    fin_normal = np.stack([np.zeros(NUM_FINS), -np.sin(gamma), np.cos(gamma)], 1)
    return VehicleParams(
        M_inv=np.linalg.inv(M_RB + M_A),
        M_A=M_A,
        mass_kg=m,
        inertia=inertia,
        r_g_b=r_g,
        weight_n=m * units.G0,
        buoyancy_n=RHO_KGPM3 * co.volume_m3 * units.G0,
        x_uu=co.X_uu,
        y_vv=co.Y_vv,
        y_rr=co.Y_rr,
        n_vv=co.N_vv,
        n_rr=co.N_rr,
        k_pp=co.K_pp,
        y_uv_lift=co.Y_uv_lift,
        x_lift_m=co.x_lift_m,
        fin_pos_b=fin_pos,
        fin_normal_b=fin_normal,
        fin_lift=co.fin_lift,
        fin_max_rad=cfg.fin_max_deg * units.DEG,
        fin_tau_s=cfg.fin_time_constant_s,
        fin_rate_max_rps=cfg.fin_rate_max_dps * units.DEG,
        prop_d_m=cfg.propeller_diameter_m,
        kt0=cfg.kt0,
        kt1=cfg.kt1,
        kq0=cfg.kq0,
        kq1=cfg.kq1,
        wake=cfg.wake_fraction,
        deduction=cfg.thrust_deduction,
        rps_max=cfg.rpm_max / 60.0,
        motor_tau_s=cfg.motor_time_constant_s,
    )


@_jit
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@_jit
def C_nb_of(phi: float, theta: float, psi: float) -> np.ndarray:
    """ZYX Euler angles to C_nb (tauvcore.conventions), scalar form for the compiled loop."""
    cf, sf, ct, st, cp, sp = (
        math.cos(phi),
        math.sin(phi),
        math.cos(theta),
        math.sin(theta),
        math.cos(psi),
        math.sin(psi),
    )
    return np.array(
        [
            [cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
            [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
            [-st, ct * sf, ct * cf],
        ]
    )


@_jit
def euler_dot_of(phi: float, theta: float, omega_nb_b: np.ndarray) -> np.ndarray:
    """Euler angle rates from the body rate (Fossen eq. 2.29; singular at pitch +-90 deg)."""
    p, q, r = omega_nb_b[0], omega_nb_b[1], omega_nb_b[2]
    cf, sf, ct, tt = math.cos(phi), math.sin(phi), math.cos(theta), math.tan(theta)
    return np.array([p + sf * tt * q + cf * tt * r, cf * q - sf * r, (sf * q + cf * r) / ct])


@_jit
def thrust_torque(p: VehicleParams, rps: float, u_r: float) -> tuple[float, float]:
    """Propeller thrust on the hull [N] (after thrust deduction) and its torque [N m] at ``rps``."""
    u_a = (1.0 - p.wake) * u_r
    D = p.prop_d_m
    t = RHO_KGPM3 * D**4 * (p.kt0 * rps * abs(rps) - p.kt1 * abs(rps) * u_a / D)
    q = RHO_KGPM3 * D**5 * (p.kq0 * rps * abs(rps) - p.kq1 * abs(rps) * u_a / D)
    return (1.0 - p.deduction) * t, q


@_jit
def _cx(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> tuple[float, float, float]:
    """a x b on scalars (no array allocated in the compiled loop)."""
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@_jit
def force_into(
    p: VehicleParams,
    nu_r: np.ndarray,
    down_b: tuple[float, float, float],
    fins: np.ndarray,
    rps: float,
    tau: np.ndarray,
) -> None:
    """Everything but the mass-matrix term, tau in ``M nu_r' = tau`` (6,) [N, N m], written into
    ``tau``: rigid-body and added-mass Coriolis, hydrostatics, drag, body and fin lift, thrust.
    ``down_b``: n's down axis in b (the third row of C_nb)."""
    u, v, w, p_, q, r = nu_r[0], nu_r[1], nu_r[2], nu_r[3], nu_r[4], nu_r[5]
    m = p.mass_kg
    gx, gy, gz = p.r_g_b[0], p.r_g_b[1], p.r_g_b[2]
    # rigid-body Coriolis about the CB: -m (w x v + w x (w x r_g)), -(w x I w) - m r_g x (w x v)
    c0, c1, c2 = _cx(p_, q, r, u, v, w)
    e0, e1, e2 = _cx(p_, q, r, gx, gy, gz)
    f0, f1, f2 = _cx(p_, q, r, e0, e1, e2)
    h0, h1, h2 = _cx(p_, q, r, p.inertia[0] * p_, p.inertia[1] * q, p.inertia[2] * r)
    k0, k1, k2 = _cx(gx, gy, gz, c0, c1, c2)
    t0, t1, t2 = -m * (c0 + f0), -m * (c1 + f1), -m * (c2 + f2)
    t3, t4, t5 = -h0 - m * k0, -h1 - m * k1, -h2 - m * k2
    # added-mass Coriolis (Fossen eq. 6.43): -C_A(nu) nu = -[w x a1; v x a1 + w x a2], a = M_A nu
    A = p.M_A
    a = np.empty(6)
    for i in range(6):
        a[i] = A[i, 0] * u + A[i, 1] * v + A[i, 2] * w + A[i, 3] * p_ + A[i, 4] * q + A[i, 5] * r
    c0, c1, c2 = _cx(p_, q, r, a[0], a[1], a[2])
    e0, e1, e2 = _cx(u, v, w, a[0], a[1], a[2])
    f0, f1, f2 = _cx(p_, q, r, a[3], a[4], a[5])
    t0, t1, t2 = t0 - c0, t1 - c1, t2 - c2
    t3, t4, t5 = t3 - e0 - f0, t4 - e1 - f1, t5 - e2 - f2
    # hydrostatics: weight at r_g, buoyancy at the origin, both along n's down axis
    d0, d1, d2 = down_b
    net = p.weight_n - p.buoyancy_n
    t0, t1, t2 = t0 + net * d0, t1 + net * d1, t2 + net * d2
    c0, c1, c2 = _cx(gx, gy, gz, p.weight_n * d0, p.weight_n * d1, p.weight_n * d2)
    t3, t4, t5 = t3 + c0, t4 + c1, t5 + c2
    # axial drag, hull cross-flow drag, body lift
    t0 += p.x_uu * u * abs(u)
    t1 += p.y_vv * v * abs(v) + p.y_rr * r * abs(r) + p.y_uv_lift * u * v
    t2 += p.y_vv * w * abs(w) - p.y_rr * q * abs(q) + p.y_uv_lift * u * w
    t3 += p.k_pp * p_ * abs(p_)
    t4 += -p.n_vv * w * abs(w) + p.n_rr * q * abs(q) - p.x_lift_m * p.y_uv_lift * u * w
    t5 += p.n_vv * v * abs(v) + p.n_rr * r * abs(r) + p.x_lift_m * p.y_uv_lift * u * v
    # fins: lift along the fin's normal from its deflection less the local cross flow
    for i in range(fins.shape[0]):
        x0, x1, x2 = p.fin_pos_b[i, 0], p.fin_pos_b[i, 1], p.fin_pos_b[i, 2]
        n0, n1, n2 = p.fin_normal_b[i, 0], p.fin_normal_b[i, 1], p.fin_normal_b[i, 2]
        l0, l1, l2 = _cx(p_, q, r, x0, x1, x2)
        across = n0 * (u + l0) + n1 * (v + l1) + n2 * (w + l2)
        lift = p.fin_lift * (u * abs(u) * fins[i] - abs(u) * across)
        t0, t1, t2 = t0 + lift * n0, t1 + lift * n1, t2 + lift * n2
        c0, c1, c2 = _cx(x0, x1, x2, lift * n0, lift * n1, lift * n2)
        t3, t4, t5 = t3 + c0, t4 + c1, t5 + c2
    thrust, torque = thrust_torque(p, rps, u)
    tau[0], tau[1], tau[2], tau[3], tau[4], tau[5] = t0 + thrust, t1, t2, t3 - torque, t4, t5


@_jit
def generalized_force(
    p: VehicleParams, nu_r: np.ndarray, C_nb: np.ndarray, fins: np.ndarray, rps: float
) -> np.ndarray:
    """:func:`force_into` as a new (6,) array, the attitude given as C_nb."""
    tau = np.empty(6)
    force_into(p, nu_r, (C_nb[2, 0], C_nb[2, 1], C_nb[2, 2]), fins, rps, tau)
    return tau


@_jit
def derivative_into(
    p: VehicleParams,
    x: np.ndarray,
    fin_cmd: np.ndarray,
    rps_cmd: float,
    current_n: np.ndarray,
    tau: np.ndarray,
    dx: np.ndarray,
) -> None:
    """dx/dt of the 17 states (index slices NU, POS, EULER, FINS, RPS) into ``dx``, under commanded
    fin angles [rad] and propeller speed [rev/s] held constant; ``current_n`` (3,) [m/s] NED;
    ``tau`` (6,) scratch."""
    phi, theta, psi = x[9], x[10], x[11]
    cf, sf, ct, st, cp, sp = (
        math.cos(phi),
        math.sin(phi),
        math.cos(theta),
        math.sin(theta),
        math.cos(psi),
        math.sin(psi),
    )
    # C_nb (tauvcore.conventions, ZYX)
    c00, c01, c02 = cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf
    c10, c11, c12 = sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf
    c20, c21, c22 = -st, ct * sf, ct * cf
    force_into(p, x, (c20, c21, c22), x[12:16], x[16], tau)
    Mi = p.M_inv
    for i in range(6):
        dx[i] = (
            Mi[i, 0] * tau[0]
            + Mi[i, 1] * tau[1]
            + Mi[i, 2] * tau[2]
            + Mi[i, 3] * tau[3]
            + Mi[i, 4] * tau[4]
            + Mi[i, 5] * tau[5]
        )
    cn, ce, cd = current_n[0], current_n[1], current_n[2]
    vb0 = x[0] + c00 * cn + c10 * ce + c20 * cd
    vb1 = x[1] + c01 * cn + c11 * ce + c21 * cd
    vb2 = x[2] + c02 * cn + c12 * ce + c22 * cd
    dx[6] = c00 * vb0 + c01 * vb1 + c02 * vb2
    dx[7] = c10 * vb0 + c11 * vb1 + c12 * vb2
    dx[8] = c20 * vb0 + c21 * vb1 + c22 * vb2
    p_, q, r = x[3], x[4], x[5]
    tt = st / ct
    dx[9] = p_ + sf * tt * q + cf * tt * r
    dx[10] = cf * q - sf * r
    dx[11] = (sf * q + cf * r) / ct
    for i in range(NUM_FINS):
        rate = (fin_cmd[i] - x[12 + i]) / p.fin_tau_s
        dx[12 + i] = min(max(rate, -p.fin_rate_max_rps), p.fin_rate_max_rps)
    dx[16] = (rps_cmd - x[16]) / p.motor_tau_s


@_jit
def state_derivative(
    p: VehicleParams, x: np.ndarray, fin_cmd: np.ndarray, rps_cmd: float, current_n: np.ndarray
) -> np.ndarray:
    """:func:`derivative_into` as a new (17,) array."""
    dx = np.empty(NUM_STATES)
    derivative_into(p, x, fin_cmd, rps_cmd, current_n, np.empty(6), dx)
    return dx


def steady_speed_per_rps(p: VehicleParams) -> float:
    """Steady straight-line surge speed per propeller rev/s [m/rev]: thrust and drag are both
    homogeneous of degree 2 in (n, u), so ``(1 - t) rho D^4 (kt0 - kt1 (1 - w) s / D) = -X_u|u| s^2``
    for s = u / n, the positive root."""
    c = RHO_KGPM3 * p.prop_d_m**4 * (1.0 - p.deduction)
    a2, a1, a0 = -p.x_uu, c * p.kt1 * (1.0 - p.wake) / p.prop_d_m, -c * p.kt0
    return (-a1 + math.sqrt(a1 * a1 - 4.0 * a2 * a0)) / (2.0 * a2)


def main() -> None:
    """Print the derived coefficients of the default TAUV."""
    for name, value in vars(coefficients()).items():
        print(f"{name:16s} {value: .5g}")
    print(f"steady speed     {steady_speed_per_rps(vehicle_params()) * 1000.0 / 60.0:.5g} m/s per 1000 rpm")


if __name__ == "__main__":
    main()
