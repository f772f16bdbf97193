"""The TAUV's 6-DOF model, autopilot and dynamic truth stream: known answers and physical sanity
."""

import math

import numpy as np
import pytest
from scipy.optimize import fsolve

from tauvcore.geo.earth import Earth
from tauvcore.truth import TrajectoryConfig, generate
from tauvcore.truth import control as ctl
from tauvcore.truth import vehicle as veh
from tauvcore.truth.current import current_field
from tauvcore.truth.dynamic import (
    K_EULER,
    K_FINS,
    K_POS,
    K_VEL,
    K_VEL_DOT,
    STILL_WATER,
    DynamicSimulation,
    DynamicTruthStream,
    current_into,
    current_params,
    current_rate_into,
    mission,
)

NEUTRAL = veh.VehicleConfig(buoyancy_reserve=0.0)
# constant, sheared and varying within a short run (period 60 s: 1, 2, 4, 8 min cosines)
CURRENT = {"current_n_mps": (0.2, -0.3, 0.0), "current_shear_ne_per_s": (0.005, 0.0),
           "current_variation_mps": 0.1, "current_variation_period_s": 60.0}


def _fly(p: veh.VehicleParams, x0: np.ndarray, fins: np.ndarray, rps: float, seconds: float, dt: float = 0.02,
         current_n: np.ndarray = np.zeros(3)) -> np.ndarray:
    """Open loop: fins and propeller commanded constant, RK4; the states every step (n, 17)."""
    x = x0.copy()
    out = [x.copy()]
    for _ in range(int(round(seconds / dt))):
        k1 = veh.state_derivative(p, x, fins, rps, current_n)
        k2 = veh.state_derivative(p, x + 0.5 * dt * k1, fins, rps, current_n)
        k3 = veh.state_derivative(p, x + 0.5 * dt * k2, fins, rps, current_n)
        k4 = veh.state_derivative(p, x + dt * k3, fins, rps, current_n)
        x = x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(x.copy())
    return np.array(out)


def _cruising(p: veh.VehicleParams, speed: float, rps: float, fins: np.ndarray = np.zeros(4)) -> np.ndarray:
    x = np.zeros(veh.NUM_STATES)
    x[0] = speed
    x[8] = 50.0
    x[veh.FINS] = fins
    x[veh.RPS] = rps
    return x


# ------------------------------------------------------------------ the model's coefficients

def test_lamb_k1_of_a_prolate_spheroid() -> None:
    """Known values (Lamb, Hydrodynamics, art. 373; Newman, Marine Hydrodynamics table 4.2): a
    sphere 0.5, a 10:1 spheroid 0.0207."""
    assert veh._spheroid_k1(1.0001, 1.0) == pytest.approx(0.5, abs=1e-3)
    assert veh._spheroid_k1(10.0, 1.0) == pytest.approx(0.0207, abs=3e-4)


def test_derived_coefficients_have_the_signs_and_sizes_of_a_torpedo_hull() -> None:
    co = veh.coefficients()
    cylinder = math.pi * 0.15**2 * 3.0
    assert 0.75 * cylinder < co.volume_m3 < cylinder            # nose and tail take off a fraction
    assert co.mass_kg == pytest.approx(1025.0 * co.volume_m3 * 0.995)
    # strip theory: lateral added mass close to the displaced mass of the hull (plus the fins)
    assert 1.0 < -co.Y_vdot / (1025.0 * co.volume_m3) < 1.3
    for name in ("X_udot", "Y_vdot", "K_pdot", "M_qdot", "N_rdot", "X_uu", "Y_vv", "N_rr", "K_pp", "Y_uv_lift"):
        assert getattr(co, name) < 0.0, name
    assert co.fin_x_m < -1.0 and co.x_lift_m < 0.0               # fins and body lift aft: weathervane stable
    p = veh.vehicle_params()
    M = np.linalg.inv(p.M_inv)
    np.testing.assert_allclose(M, M.T, atol=1e-9)
    assert np.all(np.linalg.eigvalsh(M) > 0.0)


def test_coriolis_forces_do_no_work() -> None:
    """With drag, lift, gravity, fins and thruster taken away, the rigid-body and added-mass
    Coriolis forces are workless (nu^T C(nu) nu = 0): the kinetic energy 1/2 nu^T M nu is
    conserved while the vehicle tumbles."""
    p = veh.vehicle_params()._replace(x_uu=0.0, y_vv=0.0, y_rr=0.0, n_vv=0.0, n_rr=0.0, k_pp=0.0, y_uv_lift=0.0,
                                       fin_lift=0.0, weight_n=0.0, buoyancy_n=0.0, kt0=0.0, kt1=0.0, kq0=0.0,
                                       kq1=0.0)
    M = np.linalg.inv(p.M_inv)
    rng = np.random.default_rng(1)
    for _ in range(5):
        nu = rng.normal(size=6)
        tau = veh.generalized_force(p, nu, np.eye(3), np.zeros(4), 0.0)
        assert abs(nu @ tau) < 1e-9 * np.abs(tau).sum()
    x0 = np.zeros(veh.NUM_STATES)
    x0[:6] = [2.0, 0.3, -0.2, 0.5, 0.2, 0.3]
    states = _fly(p, x0, np.zeros(4), 0.0, 20.0, dt=0.005)
    energy = 0.5 * np.einsum("ki,ij,kj->k", states[:, :6], M, states[:, :6])
    assert np.ptp(energy) < 1e-6 * energy[0]
    assert np.ptp(states[:, 9]) > 1.0                             # it did tumble


# ------------------------------------------------------------------ physical sanity

@pytest.mark.parametrize("rpm", [400.0, 850.0, 1500.0])
def test_steady_speed_is_proportional_to_rpm(rpm: float) -> None:
    """Thrust and drag both scale with the square of (n, u): the steady speed is
    ``steady_speed_per_rps * n`` (2 m/s at 850 rpm), reached from rest."""
    p = veh.vehicle_params(NEUTRAL)
    rps = rpm / 60.0
    states = _fly(p, _cruising(p, 0.0, rps), np.zeros(4), rps, 120.0)
    expected = veh.steady_speed_per_rps(p) * rps
    assert states[-1, 0] == pytest.approx(expected, rel=2e-3)
    assert abs(states[-1, 1]) < 1e-3 and abs(states[-1, 2]) < 1e-3
    if rpm == 850.0:
        assert expected == pytest.approx(2.0, abs=0.02)


def _steady_turn(p: veh.VehicleParams, fins: np.ndarray, rps: float) -> tuple[float, np.ndarray]:
    """Radius [m] of the steady turn at these fins, from the algebra alone: nu' = 0 and constant
    roll and pitch (8 equations in u, v, w, p, q, r, roll, pitch)."""

    def residual(z: np.ndarray) -> np.ndarray:
        x = np.zeros(veh.NUM_STATES)
        x[:6], x[9], x[10] = z[:6], z[6], z[7]
        x[veh.FINS], x[veh.RPS] = fins, rps
        d = veh.state_derivative(p, x, fins, rps, np.zeros(3))
        return np.concatenate([d[:6], d[9:11]])

    z = fsolve(residual, np.array([1.5, 0.1, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0]), xtol=1e-13)
    x = np.zeros(veh.NUM_STATES)
    x[:6], x[9], x[10] = z[:6], z[6], z[7]
    vel_n = veh.C_nb_of(z[6], z[7], 0.0) @ z[:3]
    yaw_rate = veh.euler_dot_of(z[6], z[7], z[3:6])[2]
    return float(np.hypot(vel_n[0], vel_n[1]) / abs(yaw_rate)), z


def test_steady_turning_radius_at_full_rudder() -> None:
    """Full rudder (every fin at its limit, yaw only): the simulated vehicle settles on the circle
    the steady-state equations predict, slipping outward and losing half its speed; the circle's
    diameter, 1.9 lengths, is at the tight end of torpedo AUVs' few lengths (all four fins of the
    "x" steer, and the model has no stall: the fins' effective angle stays near 13 deg)."""
    p = veh.vehicle_params(NEUTRAL)
    fins = ctl.allocate(0.0, 0.0, p.fin_max_rad, p.fin_max_rad)
    np.testing.assert_allclose(np.abs(fins), p.fin_max_rad)
    rps = 850.0 / 60.0
    radius, z = _steady_turn(p, fins, rps)
    states = _fly(p, _cruising(p, 2.0, rps, fins), fins, rps, 120.0)
    late = states[-1500:]                                         # the last 30 s
    centre = 0.5 * (late[:, 6:8].max(axis=0) + late[:, 6:8].min(axis=0))
    measured = np.linalg.norm(late[:, 6:8] - centre, axis=1)
    assert np.mean(measured) == pytest.approx(radius, rel=0.01)
    np.testing.assert_allclose(late[-1, :6], z[:6], atol=2e-3)
    assert 1.5 * 3.0 < 2.0 * radius < 6.0 * 3.0                   # diameter: 1.5-6 lengths
    assert z[5] > 0.0 and z[1] < 0.0                              # turning to starboard, sliding outward (port)
    assert 0.4 < z[0] / 2.0 < 0.7


def test_passively_stable_at_zero_fins() -> None:
    """Rolled 20 deg and pitched 10 deg, with the fins at zero: metacentric height and the fins'
    damping bring it back to level (roll within 1 deg after 20 s, pitch within 1 deg after 60 s);
    the only roll left is the propeller's torque against the righting moment."""
    p = veh.vehicle_params(NEUTRAL)
    rps = 850.0 / 60.0
    x0 = _cruising(p, 2.0, rps)
    x0[9], x0[10] = np.radians(20.0), np.radians(10.0)
    states = _fly(p, x0, np.zeros(4), rps, 60.0)
    t = np.arange(states.shape[0]) * 0.02
    _, torque = veh.thrust_torque(p, rps, 2.0)
    roll_trim = -math.asin(torque / (p.weight_n * p.r_g_b[2]))
    assert np.max(np.abs(states[t > 20.0, 9] - roll_trim)) < np.radians(1.0)
    assert abs(states[-1, 10]) < np.radians(1.0)
    assert abs(states[-1, 9] - roll_trim) < np.radians(0.1)
    assert abs(np.degrees(roll_trim)) < 3.0


def test_depth_follows_the_dive_commands() -> None:
    """The lawnmower's schedule dives at 0.3 m/s for 30 s, then holds depth: the vehicle dives at
    that rate and levels off at the new depth."""
    cfg = TrajectoryConfig(name="lawnmower", duration_s=90.0, truth="dynamic")
    truth = generate(cfg, Earth(model="flat"), 150.0)
    t, depth = truth.t_s, truth.depth_m
    diving = (t > 8.0) & (t < 28.0)
    rate = np.polyfit(t[diving], depth[diving], 1)[0]
    assert rate == pytest.approx(0.3, abs=0.02)
    schedule = mission(cfg)
    level = np.interp(45.0, schedule.t_s, schedule.depth_m)      # before the first turn (50 s)
    kinematic = generate(TrajectoryConfig(name="lawnmower", duration_s=45.0), Earth(model="flat"), 150.0)
    assert level == pytest.approx(kinematic.depth_m[-1], abs=0.01)
    assert level == pytest.approx(20.0 + 0.3 * (30.0 + 2.0), abs=0.1)   # 30 s and half the 4 s blend
    assert np.max(np.abs(depth[(t > 40.0) & (t < 50.0)] - level)) < 0.1
    assert np.max(np.abs(truth.vehicle.depth_error_m[t > 40.0])) < 0.1


# ------------------------------------------------------------------ allocation and control

def test_each_virtual_fin_angle_makes_only_its_own_moment() -> None:
    """The X-fin allocation decouples roll, pitch and yaw: through the fin model each virtual
    angle changes only its own moment (and the matching side or vertical force)."""
    p = veh.vehicle_params()
    nu = np.array([2.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    base = veh.generalized_force(p, nu, np.eye(3), np.zeros(4), 0.0)
    d = np.radians(5.0)
    roll = veh.generalized_force(p, nu, np.eye(3), ctl.allocate(d, 0.0, 0.0, 1.0), 0.0) - base
    pitch = veh.generalized_force(p, nu, np.eye(3), ctl.allocate(0.0, d, 0.0, 1.0), 0.0) - base
    yaw = veh.generalized_force(p, nu, np.eye(3), ctl.allocate(0.0, 0.0, d, 1.0), 0.0) - base
    per_fin_n = p.fin_lift * nu[0] ** 2 * d                      # each fin's force
    np.testing.assert_allclose(roll, [0, 0, 0, 4.0 * per_fin_n * np.hypot(*p.fin_pos_b[0, 1:]), 0, 0], atol=1e-9)
    assert pitch[4] > 0.0 and yaw[5] > 0.0 and roll[3] > 0.0     # positive virtual angles: up, starboard, roll right
    np.testing.assert_allclose(pitch[[0, 1, 3, 5]], 0.0, atol=1e-9)
    np.testing.assert_allclose(yaw[[0, 2, 3, 4]], 0.0, atol=1e-9)
    # arms: the tail force times the fins' distance aft
    assert pitch[4] == pytest.approx(-p.fin_pos_b[0, 0] * pitch[2])
    assert yaw[5] == pytest.approx(p.fin_pos_b[0, 0] * yaw[1])


def test_allocation_saturates_steering_first_then_roll() -> None:
    limit = np.radians(25.0)
    fins = ctl.allocate(0.1, 0.4, 0.2, limit)
    assert np.max(np.abs(fins)) == pytest.approx(limit)
    # pitch and yaw scaled together (ratio kept), no room left for roll
    d_pitch = np.mean(fins * ctl.FIN_SIGN_PITCH)
    d_yaw = np.mean(fins * ctl.FIN_SIGN_YAW)
    assert d_pitch / d_yaw == pytest.approx(2.0)
    assert np.mean(fins) == pytest.approx(0.0, abs=1e-12)
    small = ctl.allocate(0.3, 0.1, 0.05, limit)                   # roll clipped to the room steering leaves
    assert np.max(np.abs(small)) == pytest.approx(limit)
    assert np.mean(small) == pytest.approx(limit - 0.15)


def test_pid_integrator_does_not_wind_up_while_saturated() -> None:
    gains = np.array([1.0, 0.5, 0.0])
    cs = np.zeros(ctl.NUM_CONTROL_STATES)
    for _ in range(1000):
        out = ctl._pid(gains, 2.0, 0.0, cs, ctl.I_ROLL, 0.4, 0.01, 0.2)
    assert out == pytest.approx(2.0)                               # saturated by the error alone
    assert cs[ctl.I_ROLL] == 0.0                                   # so it never integrated
    for _ in range(1000):
        ctl._pid(gains, 0.1, 0.0, cs, ctl.I_ROLL, 0.4, 0.01, 0.2)
    assert cs[ctl.I_ROLL] == pytest.approx(0.2 / 0.5)              # clamped at integral_max / ki


def test_cross_track_error_sign_and_lookahead_point() -> None:
    path = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0], [20.0, 10.0]])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    j, s_close, e = ctl.closest_on_path(path, s, 0, 5.0, 2.0, 20)     # 2 m east of a northward path: right
    assert (j, s_close, e) == (0, pytest.approx(5.0), pytest.approx(2.0))
    assert ctl.point_at(path, s, j, 25.0) == (pytest.approx(20.0), pytest.approx(5.0))


# ------------------------------------------------------------------ streaming

@pytest.mark.parametrize("current", [False, True], ids=["still", "sheared_varying"])
@pytest.mark.parametrize("chunk_samples", [1, 149, 1000])
@pytest.mark.parametrize("earth", ["flat", "wgs84"])
def test_dynamic_truth_chunks_are_the_whole_mission_bit_for_bit(chunk_samples: int, earth: str,
                                                                 current: bool) -> None:
    """Simulated chunk by chunk (as a mission too long to keep is) or once and kept: the same (the
    current is taken at the mission's time of each knot, not the chunk's)."""
    cfg = TrajectoryConfig(name="figure8", duration_s=12.0, truth="dynamic", **(CURRENT if current else {}))
    whole = generate(cfg, Earth(model=earth), 150.0)
    chunks = [c for _, c in DynamicTruthStream(cfg, Earth(model=earth), 150.0, chunk_samples, cache=False)]
    names = ("t_s", "pos_n", "pos_nav", "vel_b", "C_nb", "f_b", "omega_ib_b", "dtheta_ib_b", "dv_b")
    for name in names + (("current_n_mps",) if current else ()):
        np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in chunks]), getattr(whole, name))
    assert (whole.current_n_mps is not None) == current
    for name in ("propeller_rpm", "fin_angles_rad", "cross_track_m"):
        np.testing.assert_array_equal(np.concatenate([getattr(c.vehicle, name) for c in chunks]),
                                      getattr(whole.vehicle, name))


def test_truth_passes_through_the_integrated_knots() -> None:
    """At every IMU sample the truth is the integrator's state (attitude, velocity over ground,
    fins, propeller); between samples the Hermite interpolant."""
    cfg = TrajectoryConfig(name="figure8", duration_s=20.0, truth="dynamic", current_n_mps=(0.2, -0.1, 0.0))
    truth = generate(cfg, Earth(model="flat"), 150.0)
    knots = DynamicSimulation(cfg, 150.0).knots(truth.num_samples)
    np.testing.assert_allclose(truth.euler, knots[:, K_EULER], rtol=0, atol=1e-12)
    np.testing.assert_allclose(truth.vel_b, knots[:, K_VEL], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(truth.vehicle.fin_angles_rad, knots[:, K_FINS])
    np.testing.assert_allclose(truth.pos_n, knots[:, K_POS], rtol=0, atol=1e-6)   # two integrations of one motion
    assert np.max(np.abs(truth.vel_b - truth.vel_b[:, :1] * [1, 0, 0])) > 0.05


def test_the_compiled_current_is_the_field() -> None:
    """The integrator's current and its rate (from the packed field) are CurrentField's; still
    water packs to zeros."""
    cfg = TrajectoryConfig(truth="dynamic", **CURRENT)
    field = current_field(cfg)
    params = current_params(cfg)
    rng = np.random.default_rng(1)
    t, z, zdot = rng.uniform(0.0, 600.0, 50), rng.uniform(0.0, 200.0, 50), rng.uniform(-1.0, 1.0, 50)
    c, rate = np.empty((50, 3)), np.empty((50, 3))
    for k in range(50):
        current_into(params, t[k], z[k], c[k])
        current_rate_into(params, t[k], zdot[k], rate[k])
    np.testing.assert_allclose(c, field.velocity_n_mps(t, z), rtol=0, atol=1e-15)
    np.testing.assert_allclose(rate, field.rate_n_mps2(t, zdot), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(current_params(TrajectoryConfig(truth="dynamic")), STILL_WATER)
    current_into(STILL_WATER, 12.3, 45.6, c[0])
    np.testing.assert_array_equal(c[0], 0.0)


@pytest.mark.parametrize("earth", ["flat", "wgs84"])
def test_truth_records_the_current_the_vehicle_flew_through(earth: str) -> None:
    """At every IMU sample: Truth.current_n_mps is the current the integrator used (the field at
    the knot's time and the integrator's depth); the velocity through the water the truth records
    is the integrator's own state nu_r; over ground less through the water is the current."""
    cfg = TrajectoryConfig(name="figure8", duration_s=20.0, truth="dynamic", **CURRENT)
    truth = generate(cfg, Earth(model=earth), 150.0)
    sim = DynamicSimulation(cfg, 150.0)
    nu_r = np.empty((truth.num_samples, 3))
    depth = np.empty(truth.num_samples)
    for k in range(truth.num_samples):  # knot by knot, the integrator's state at each
        nu_r[k], depth[k] = sim.x[0:3], sim.x[8]
        sim.knots(1)
    used = np.empty((truth.num_samples, 3))
    params = current_params(cfg)
    for k in range(truth.num_samples):
        current_into(params, k * (1.0 / 150.0), depth[k], used[k])
    np.testing.assert_array_equal(truth.current_n_mps, current_field(cfg).velocity_n_mps(truth.t_s, truth.depth_m))
    np.testing.assert_allclose(truth.current_n_mps, used, rtol=0, atol=1e-12)   # 1e-13: depths 1e-11 m apart
    np.testing.assert_allclose(truth.vel_water_b, nu_r, rtol=0, atol=1e-9)
    water_n = np.einsum("kij,kj->ki", truth.C_nb, truth.vel_water_b)
    np.testing.assert_allclose(truth.vel_n - water_n, truth.current_n_mps, rtol=0, atol=1e-9)
    assert np.all(np.ptp(truth.current_n_mps[:, :2], axis=0) > 0.02)   # it varied in 20 s


def test_knot_accelerations_are_those_of_the_integrated_motion() -> None:
    """The velocity over ground's derivative at each knot (what the truth's specific force is made
    of) against a central difference of the knots' velocities: the water's acceleration met by the
    vehicle, C_nb^T (dc/dt + dc/dz zdot), is in it (without it: 7e-3 m/s^2 off; the ideal INS
    cannot tell, as the truth is the interpolant of whatever derivatives the knots carry)."""
    cfg = TrajectoryConfig(name="figure8", duration_s=60.0, truth="dynamic", **CURRENT)
    knots = DynamicSimulation(cfg, 150.0).knots(9000)
    central = (knots[2:, K_VEL] - knots[:-2, K_VEL]) * (150.0 / 2.0)
    np.testing.assert_allclose(knots[1:-1, K_VEL_DOT], central, rtol=0, atol=3e-4)   # 8e-5: the O(dt^2)


def test_a_current_the_truth_cannot_honour_is_refused() -> None:
    from tauvcore.validation import ConfigError

    TrajectoryConfig(current_n_mps=(0.1, 0.3, 0.0))  # the kinematic truth crabs into it
    with pytest.raises(ConfigError, match=r"trajectory.current_n_mps \[0.1, 0.0, 0.05\]: a vertical current"):
        TrajectoryConfig(current_n_mps=(0.1, 0.0, 0.05))
    TrajectoryConfig(truth="dynamic", current_n_mps=(0.1, 0.0, 0.05))
    with pytest.raises(ConfigError, match=r"reaches 2.1 m/s, not below the vehicle's speed trajectory.speed_mps 2.0"):
        TrajectoryConfig(truth="dynamic", current_n_mps=(0.0, 2.1, 0.0))
    with pytest.raises(ConfigError, match=r"current_variation_mps 0.5: the current reaches"):
        TrajectoryConfig(current_n_mps=(0.0, 1.0, 0.0), current_variation_mps=0.5)
    with pytest.raises(ConfigError, match=r"would crab 50 deg at t = 0 s"):
        TrajectoryConfig(current_n_mps=(1.0, 1.2, 0.0))
    with pytest.raises(ConfigError, match=r"trajectory.current_n_mps\[1\]"):
        TrajectoryConfig(truth="dynamic", current_n_mps=(0.0, 5.0, 0.0))
    with pytest.raises(ConfigError, match=r"trajectory.truth"):
        TrajectoryConfig(truth="6dof")
