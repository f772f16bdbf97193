"""Where the filters start: the estimate at t = 0 (the truth with the initial errors, fixed or
drawn per run) and the initial covariance P0 from the configuration's Table 2 sigmas."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tauvcore.config import Config
from tauvcore.filter.eskf import (
    Nominal,
)
from tauvcore.filter.kernels.correction import add_position_batch
from tauvcore.filter.layout import STATE, Layout, NavState
from tauvcore.geo.rotations import (
    C_nb_from_euler,
    euler_from_misalignment_jacobian,
    exp_so3,
    mv,
)
from tauvcore.truth import Truth


def initial_draws(rng: np.random.Generator | Sequence[np.random.Generator], R: int) -> tuple[np.ndarray, ...]:
    """Standard normals of the random initial errors (position, misalignment, velocity), (R, 3)
    each: from one generator for the whole batch, or one per run (a study's runs, each its own
    seeded unit: tauvcore.eval.study)."""
    if isinstance(rng, np.random.Generator):
        return rng.standard_normal((R, 3)), rng.standard_normal((R, 3)), rng.standard_normal((R, 3))
    if len(rng) != R:
        raise ValueError(f"one generator per run expected ({R}), got {len(rng)}")
    draws = [(g.standard_normal(3), g.standard_normal(3), g.standard_normal(3)) for g in rng]
    return tuple(np.stack([d[i] for d in draws]) for i in range(3))


def initial_nominal(
    config: Config,
    truth: Truth,
    rng: np.random.Generator | Sequence[np.random.Generator],
    batch: tuple[int, int],
    P0_nav_att: np.ndarray,
) -> Nominal:
    """Estimate at t = 0: truth with the initial errors (fixed, or drawn per run), biases zero."""
    _, R = batch
    ie = config.initial_error.ideal() if config.run.ideal else config.initial_error
    assert truth.pos_nav is not None  # Truth.__post_init__ sets pos_n where it was not given
    pos_true, C_true, v_true_b = truth.pos_nav[0], truth.C_nb[0], truth.vel_b[0]

    def moved(offset_m: np.ndarray) -> np.ndarray:
        """The true position moved by (R, 3) north, east, down metres (on WGS-84: latitude,
        longitude and depth through the metric there)."""
        offset_m = np.ascontiguousarray(np.broadcast_to(offset_m, (R, 3)), dtype=float)
        if not truth.earth.geodetic:
            return pos_true + offset_m
        return add_position_batch(np.ascontiguousarray(np.broadcast_to(pos_true, (R, 3))), offset_m, True)

    if ie.mode == "fixed":
        pos = moved(np.asarray(ie.pos_m))
        C = np.broadcast_to(C_nb_from_euler(truth.euler[0] + np.asarray(ie.euler_rad)), (R, 3, 3))
        vel_b = np.broadcast_to(v_true_b + np.asarray(ie.vel_mps), (R, 3))
    else:
        n_pos, n_rho, n_vel = initial_draws(rng, R)
        pos = moved(n_pos * np.asarray(ie.pos_m))
        rho = (np.linalg.cholesky(P0_nav_att) @ n_rho[..., None])[..., 0]
        C = exp_so3(-rho) @ C_true  # C_true = exp(rho) C_hat
        vel_b = v_true_b + n_vel * np.asarray(ie.vel_mps)
    vel_n = mv(C, vel_b)
    nav = NavState(
        pos_n=np.broadcast_to(pos, batch + (3,)).copy(),
        vel_n=np.broadcast_to(vel_n, batch + (3,)).copy(),
        C_nb=np.broadcast_to(C, batch + (3, 3)).copy(),
    )
    return Nominal(
        nav=nav,
        accel_bias=np.zeros(batch + (3,)),
        gyro_bias=np.zeros(batch + (3,)),
        dvl_bias=np.zeros(batch + (4,)),
        dvl_sf=np.zeros(batch),
    )


def initial_covariance(config: Config, euler0: np.ndarray, layout: Layout | None = None) -> np.ndarray:
    """P0 (d, d) from the initial-error and sensor sections (Table 2 values as 1-sigma), and the
    sources' states of ``layout`` after the 20 (each its block's initial 1-sigma, uncorrelated;
    ``d = 20`` without them).

    The attitude block maps the Euler-angle sigmas into the n-frame misalignment:
    ``P_rho = J^-1 diag(sigma_euler^2) J^-T``, ``J = d euler / d rho`` at the initial attitude.

    The filter has no states for the IMU's scale factors and misalignments (the paper's 20
    states). On a vehicle that cruises level they act on gravity alone, as a constant bias: the
    x and y accelerometers see ``m g`` of the axis leaning towards z, the z accelerometer ``s g``;
    so that part joins the accelerometer bias's initial sigma, and the filter's bias states take
    it in. What they do with turn rates and accelerations stays unmodelled (150 ppm of a 10 deg/s
    turn is 5 deg/h while it lasts).
    """
    ie, imu, dvl = config.initial_error, config.imu, config.dvl
    P0 = np.zeros((STATE.dim, STATE.dim))
    P0[STATE.pos, STATE.pos] = np.diag(np.square(ie.pos_m))
    J_inv = np.linalg.inv(euler_from_misalignment_jacobian(euler0))
    P0[STATE.att, STATE.att] = J_inv @ np.diag(np.square(ie.euler_rad)) @ J_inv.T
    P0[STATE.vel, STATE.vel] = np.diag(np.square(ie.vel_mps))
    g = float(np.linalg.norm(config.earth.g_n))
    axes_on_gravity = g * np.array(
        [imu.accel_misalignment_rad, imu.accel_misalignment_rad, imu.accel_scale_factor]
    )
    P0[STATE.ba, STATE.ba] = np.diag(imu.accel_bias_mps2**2 + axes_on_gravity**2)
    P0[STATE.bg, STATE.bg] = np.eye(3) * imu.gyro_bias_rps**2
    P0[STATE.b_dvl, STATE.b_dvl] = np.eye(4) * dvl.bias_mps**2
    P0[STATE.sf_dvl, STATE.sf_dvl] = dvl.scale_factor**2
    # a zero tuning value would make P0 singular; keep a floor far below any real error
    P0 = P0 + np.eye(STATE.dim) * 1e-16
    if layout is None or not layout.num_extra:
        return P0
    out = np.zeros((layout.dim, layout.dim))
    out[: STATE.dim, : STATE.dim] = P0
    _, _, sigma0 = layout.extra_arrays()
    out[STATE.dim :, STATE.dim :] = np.diag(sigma0**2 + 1e-16)
    return out
