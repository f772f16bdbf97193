"""Yoo 2014's navigation filter as methods of the engine: ``ins-dvl`` and ``vkf`` (issue 12).

Each is the paper's 12-state indirect feedback Kalman filter (section 2.1; error model
tauvcore.filter.yoo: NED velocity, attitude, accelerometer and gyro bias errors, no position)
on the same strapdown as the 20-state methods (tauvcore.filter.kernels.advance, geodetic on
WGS-84), aided at every DVL ping by a NED velocity (eq. 16-18; with the attitude column the paper's H
leaves out, :meth:`YooBank._fuse`):

- ``ins-dvl``, the paper's "conventional INS-DVL": the DVL's velocity, least squares over the
  beams that returned (at least three), rotated into n with the INS attitude; nothing when fewer
  return (beyond range) or, with Yoo's own DVL model (``dvl.beyond_range = "noisy"``), beams
  that carry 5 m/s of noise, which only the gate can refuse.
- ``vkf``, "INS-DVL + VKF": the velocity Kalman filter (tauvcore.filter.vkf, eq. 20-26) learns
  the propeller's scale factor and bias from the DVL's forward speed while the echo sounder's
  altitude is within ``vkf.switch_altitude_m``; the aiding velocity is the switch of eq. 29: the
  DVL's when within, else the RPM's, ``C_nb [V_rpm, 0, 0]`` (eq. 27-28), with the VKF's own
  variance for surge and ``RPM_LATERAL_SIGMA_MPS`` for the sway and heave it assumes zero.

The measurement noise ("R has been properly adjusted", the paper gives none): the beams' white
noise through the least squares, plus the DVL's scale factor and bias (the 12-state filter has
no states for them) as white noise of their 1-sigma size. Updates are gated like the 20-state
methods' (every row within ``filter.gate_sigma``), then injected and the error reset (feedback).

The covariance is propagated at ``filter.covariance_rate_hz`` with ``Phi = I + F dt + (F dt)^2 / 2``
and ``Qd = G Q G^T dt`` (accelerometer and gyro white noise on velocity and attitude, the bias
walks on the biases). Records at the output epochs carry the same series as the 20-state
methods; there is no position state, so the position's 1-sigma and NEES are NaN, and the NEES
dimensions are the filter's own (:data:`BLOCK_DIMS`: 12 in all, 6 sensor states).
"""

from __future__ import annotations

import numpy as np

from tauvcore import units
from tauvcore.config import Config
from tauvcore.eval.consistency import YOO_BLOCK_DIMS
from tauvcore.filter import kernels, vkf, yoo
from tauvcore.geo.earth import OMEGA_IE_RPS, ned_from_geodetic, radii_of_curvature_m
from tauvcore.geo.rotations import exp_so3, log_so3
from tauvcore.ins.strapdown import Strapdown, body_increments

BLOCK_DIMS = YOO_BLOCK_DIMS
"""Degrees of freedom of this filter's NEES (tauvcore.eval.consistency.YOO_BLOCK_DIMS)."""
RPM_LATERAL_SIGMA_MPS = 0.1
"""1-sigma of the sway and heave the RPM velocity takes as zero [m/s] (a cruising AUV's few cm/s,
more in turns)."""
MIN_BEAMS = 3


def _skew_batch(v: np.ndarray) -> np.ndarray:
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def F_batch(lat: np.ndarray, h: np.ndarray, vel_n: np.ndarray, f_n: np.ndarray, C: np.ndarray,
            geodetic: bool, w_ie_flat: np.ndarray) -> np.ndarray:
    """:func:`tauvcore.filter.yoo.F_matrix` for a batch (B,) of states -> (B, 12, 12). On the flat
    earth the transport rate is zero and the earth rate constant (``w_ie_flat``)."""
    B = vel_n.shape[0]
    F = np.zeros((B, yoo.DIM, yoo.DIM))
    if geodetic:
        R_N, R_E = radii_of_curvature_m(lat)
        rn, re = R_N + h, R_E + h
        t = np.tan(lat)
        w_ie = OMEGA_IE_RPS * np.stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)], axis=-1)
        w_en = np.stack([vel_n[:, 1] / re, -vel_n[:, 0] / rn, -vel_n[:, 1] * t / re], axis=-1)
        J = np.zeros((B, 3, 3))
        J[:, 0, 1], J[:, 1, 0], J[:, 2, 1] = 1.0 / re, -1.0 / rn, -t / re
    else:
        w_ie = np.broadcast_to(w_ie_flat, (B, 3))
        w_en = np.zeros((B, 3))
        J = np.zeros((B, 3, 3))
    F[:, yoo.VEL, yoo.VEL] = -_skew_batch(2.0 * w_ie + w_en) + _skew_batch(vel_n) @ J
    F[:, yoo.VEL, yoo.ATT] = -_skew_batch(f_n)
    F[:, yoo.VEL, yoo.BA] = -C
    F[:, yoo.ATT, yoo.VEL] = -J
    F[:, yoo.ATT, yoo.ATT] = -_skew_batch(w_ie + w_en)
    F[:, yoo.ATT, yoo.BG] = -C
    return F


def latest(index: np.ndarray, values: np.ndarray, k: int) -> np.ndarray:
    """``values`` of the last epoch at or before IMU sample ``k`` (NaN before the first)."""
    j = np.searchsorted(index, k, side="right") - 1
    if j < 0:
        return np.full(values.shape[1:], np.nan)
    return np.asarray(values[j], dtype=float)


def dvl_body_velocity(y: np.ndarray, available: np.ndarray, dtheta_b: np.ndarray, dt_s: float, C_nb: np.ndarray,
                      lat_rad: np.ndarray, A_b: np.ndarray, l_dvl_b: np.ndarray,
                      beam_var: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The DVL's body velocity at a ping by least squares over the beams that returned (R, 3), its
    covariance from the beams' white noise (R, 3, 3), and whether at least MIN_BEAMS returned (R,).
    The head's own motion ``omega_nb x l`` is taken out with the gyro rate less the earth's
    (first order)."""
    R = y.shape[0]
    avail = available & np.isfinite(y)
    W = avail.astype(float)
    N = np.einsum("rk,ki,kj->rij", W, A_b, A_b)
    ok = avail.sum(axis=1) >= MIN_BEAMS
    Ninv = np.linalg.inv(np.where(ok[:, None, None], N, np.eye(3)))
    v_head = np.einsum("rij,rk,ki,rk->rj", Ninv, W, A_b, np.where(avail, y, 0.0))
    w_ie_n = np.stack([np.cos(lat_rad), np.zeros(R), -np.sin(lat_rad)], axis=-1) * OMEGA_IE_RPS
    omega = np.asarray(dtheta_b) / dt_s - np.einsum("rji,rj->ri", C_nb, w_ie_n)
    return v_head - np.cross(omega, l_dvl_b), beam_var * Ninv, ok


class RpmAid:
    """One velocity Kalman filter per run (tauvcore.filter.vkf), stepped at every DVL ping with the
    latest RPM, updated with the DVL's forward speed while the echo sounder's altitude is within
    ``switch_altitude_m`` and enough beams return; what it offers then is the body velocity
    ``[V_rpm, 0, 0]`` with the VKF's variance on surge and RPM_LATERAL_SIGMA_MPS on sway and heave.
    Used by the ``vkf`` method (eq. 29) and by the first paper's methods with ``run.rpm_fallback``."""

    def __init__(self, cfg, num_runs: int) -> None:
        self.cfg = cfg
        self.x = np.broadcast_to(cfg.x0, (num_runs, 3)).copy()
        self.P = np.broadcast_to(cfg.P0, (num_runs, 3, 3)).copy()
        self.use_rpm = np.zeros(num_runs, bool)
        self.altitude = np.full(num_runs, np.nan)

    def step(self, chunk, i: int, v_b: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Predict with the RPM, learn from the DVL where eq. 29 picks it; -> (RPM chosen (R,),
        an RPM was read (R,))."""
        cfg, k, R = self.cfg, chunk.k0 + i, self.x.shape[0]
        rpm_now = latest(chunk.rpm.index, chunk.rpm.rpm, k) if chunk.rpm is not None else np.full(R, np.nan)
        altitude = latest(chunk.echo.index, chunk.echo.altitude_m, k) if chunk.echo is not None else np.full(R, np.nan)
        use_rpm = vkf.rpm_selected(altitude, cfg) | ~ok
        have_rpm = np.isfinite(rpm_now)
        x, P = vkf.predict(self.x, self.P, np.where(have_rpm, rpm_now, 0.0), cfg.Q)
        self.x = np.where(have_rpm[:, None], x, self.x)
        self.P = np.where(have_rpm[:, None, None], P, self.P)
        learn = ~use_rpm & ok & have_rpm
        z_fwd = v_b[:, 0] if cfg.forward_speed == "body_x" else np.linalg.norm(v_b, axis=-1)
        self.x, self.P, _, _ = vkf.update(self.x, self.P, z_fwd, learn, cfg.R)
        self.use_rpm, self.altitude = use_rpm, np.asarray(altitude, dtype=float)
        return use_rpm, have_rpm

    def velocity_b(self) -> np.ndarray:
        """(R, 3) the RPM's body velocity ``[V_rpm, 0, 0]`` (eq. 27 before the rotation)."""
        v = np.zeros_like(self.x)
        v[:, 0] = self.x[:, 0]
        return v

    def covariance_b(self) -> np.ndarray:
        """(R, 3, 3) its covariance in b: the VKF's on surge, RPM_LATERAL_SIGMA_MPS on sway and heave."""
        cov = np.zeros(self.x.shape[:1] + (3, 3))
        cov[:, 0, 0] = self.P[:, 0, 0]
        cov[:, 1, 1] = cov[:, 2, 2] = RPM_LATERAL_SIGMA_MPS**2
        return cov

    def trace(self, chunk, i: int, t: float) -> dict:
        """The VKF's state now beside the RPM model's truth (YooBank._vkf_series)."""
        k, R = chunk.k0 + i, self.x.shape[0]
        rpm = chunk.rpm
        nan = np.full(R, np.nan)
        return {"t_s": t, "x": self.x.copy(), "sigma": np.sqrt(np.einsum("rii->ri", self.P)),
                "sf_true": latest(rpm.index, rpm.scale_factor, k) if rpm is not None else nan,
                "b_true": latest(rpm.index, rpm.bias_mps, k) if rpm is not None else nan,
                "rpm_in_use": self.use_rpm.copy(), "altitude_m": self.altitude.copy()}


class YooBank:
    """The Yoo methods of ``config.run.methods`` over R runs, fed chunk by chunk (as FilterBank)."""

    def __init__(self, config: Config, methods: tuple[str, ...], num_runs: int, num_samples: int,
                 dt_s: float) -> None:
        self.config, self.methods = config, methods
        M, R = len(methods), num_runs
        self.batch = (M, R)
        self.dt = dt_s
        earth = config.earth
        sd = Strapdown(earth, dt_s)
        self.geodetic = earth.geodetic
        self.sd_consts = (dt_s, sd.C_earth, sd.C_earth_half, sd.g_n, sd.coriolis_T, self.geodetic)
        self.origin = (earth.latitude_rad, earth.longitude_rad, 0.0)
        self.w_ie = np.asarray(earth.omega_ie_n, dtype=float)
        imu = config.imu
        self.q = np.r_[np.full(3, imu.accel_noise_mps_per_sqrt_s**2), np.full(3, imu.gyro_noise_rad_per_sqrt_s**2),
                       np.full(3, imu.accel_bias_rw_mps2_per_sqrt_s**2), np.full(3, imu.gyro_bias_rw_rps_per_sqrt_s**2)]
        self.q = np.maximum(self.q, 1e-24)
        self.cov_step = max(1, int(round(imu.rate_hz / config.filter.covariance_rate_hz)))
        out_step = max(1, int(round(imu.rate_hz / config.filter.output_rate_hz)))
        self.out_idx = np.arange(0, num_samples, out_step)
        self.gate = config.filter.gate_sigma
        dvl = config.dvl
        self.A_b = dvl.A_b
        self.l_dvl_b = dvl.l_dvl_b
        self.beam_var = max(dvl.noise_mps, 1e-3) ** 2
        self.started = False
        self.records: list[dict[str, np.ndarray]] = []
        self.updates: list[dict[str, np.ndarray]] = []
        self._taken = (0, 0)
        self.vkf_trace: list[dict] = []

    # ------------------------------------------------------------------ set-up
    def start(self, pos: np.ndarray, vel_n: np.ndarray, C: np.ndarray, P0_att: np.ndarray, P0_ba: np.ndarray,
              P0_bg: np.ndarray) -> None:
        """Initial nominal states (R, ...) shared with the 20-state methods, and the attitude and
        bias blocks of their P0 (the same initial uncertainty)."""
        M, R = self.batch
        config = self.config
        ie = config.initial_error.ideal() if config.run.ideal else config.initial_error
        self.pos = np.array(np.broadcast_to(pos, (M, R, 3)), dtype=float, order="C")      # copies: the kernels
        self.vel = np.array(np.broadcast_to(vel_n, (M, R, 3)), dtype=float, order="C")    # write in place
        self.C = np.array(np.broadcast_to(C, (M, R, 3, 3)), dtype=float, order="C")
        self.ba = np.zeros((M, R, 3))
        self.bg = np.zeros((M, R, 3))
        P0 = np.zeros((yoo.DIM, yoo.DIM))
        C0 = self.C[0, 0]
        P0[yoo.VEL, yoo.VEL] = C0 @ np.diag(np.square(ie.vel_mps)) @ C0.T
        P0[yoo.ATT, yoo.ATT] = P0_att
        P0[yoo.BA, yoo.BA] = P0_ba
        P0[yoo.BG, yoo.BG] = P0_bg
        self.P = np.broadcast_to(P0 + np.eye(yoo.DIM) * 1e-16, (M, R, yoo.DIM, yoo.DIM)).copy()
        self.rpm_aid = RpmAid(config.vkf, R)
        self.dtheta_sum = np.zeros((R, 3))
        self.prev_raw: tuple[np.ndarray, np.ndarray] | None = None
        self.k_state = 0
        self.k_cov = 0
        self.started = True

    # ------------------------------------------------------------------ one chunk
    def feed(self, chunk) -> None:
        """Run over one chunk of the simulation (tauvcore.eval.runner.SimChunk), in order."""
        k0, n = chunk.k0, chunk.truth.num_samples
        imu = chunk.imu
        dtheta = np.ascontiguousarray(imu.dtheta_b)
        phi_raw, dv_raw = (np.ascontiguousarray(a) for a in body_increments(dtheta, imu.dv_b, self.prev_raw))
        self.prev_raw = (dtheta[-1].copy(), np.array(imu.dv_b[-1]))
        self._dv = dv_raw
        dvl_at = {int(k): p for p, k in enumerate(chunk.dvl.index)} if "dvl" in self.config.run.aiding else {}
        outs = self.out_idx[(self.out_idx >= k0) & (self.out_idx < k0 + n)]
        marks = set(dvl_at) | {int(k) for k in outs}
        last_cov = self.k_cov
        stops = sorted(marks | set(range(last_cov + self.cov_step, k0 + n, self.cov_step)))
        for k in stops:
            if k < k0:
                continue
            i = k - k0
            if k > self.k_state:
                kernels.advance(self.pos, self.vel, self.C, self.ba, self.bg, phi_raw, dv_raw, dtheta,
                                self.dtheta_sum, self.k_state - k0, i, *self.sd_consts)
                self.k_state = k
            if k > self.k_cov:
                self._propagate(i, k)
            if k in dvl_at:
                self._update(chunk, dvl_at[k], i)
            if k in outs:
                self._record(chunk, i)
        if k0 + n - 1 > self.k_state:
            kernels.advance(self.pos, self.vel, self.C, self.ba, self.bg, phi_raw, dv_raw, dtheta,
                            self.dtheta_sum, self.k_state - k0, n - 1, *self.sd_consts)
            self.k_state = k0 + n - 1

    def _lat_h(self) -> tuple[np.ndarray, np.ndarray]:
        pos = self.pos.reshape(-1, 3)
        if self.geodetic:
            return pos[:, 0], -pos[:, 2]
        lat = np.full(pos.shape[0], self.origin[0])
        return lat, np.zeros(pos.shape[0])

    def _propagate(self, i: int, k: int) -> None:
        M, R = self.batch
        dt_c = (k - self.k_cov) * self.dt
        C = self.C.reshape(-1, 3, 3)
        f_b = self._dv[i].reshape(1, R, 3) / self.dt - self.ba          # the latest specific force
        f_n = np.einsum("bij,bj->bi", C, f_b.reshape(-1, 3))
        lat, h = self._lat_h()
        F = F_batch(lat, h, self.vel.reshape(-1, 3), f_n, C, self.geodetic, self.w_ie) * dt_c
        Phi = np.eye(yoo.DIM) + F + 0.5 * F @ F
        P = self.P.reshape(-1, yoo.DIM, yoo.DIM)
        P = Phi @ P @ Phi.swapaxes(-1, -2) + np.diag(self.q) * dt_c   # isotropic noises: G Q G^T = Q
        self.P = (0.5 * (P + P.swapaxes(-1, -2))).reshape(M, R, yoo.DIM, yoo.DIM)
        self.dtheta_sum[:] = 0.0
        self.k_cov = k

    def _dvl_velocity(self, chunk, p: int, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        lat, _ = self._lat_h()
        R = self.batch[1]
        return dvl_body_velocity(chunk.dvl.y_beam_mps[p], chunk.dvl.available[p], chunk.imu.dtheta_b[i], self.dt,
                                 self.C[0], lat[:R], self.A_b, self.l_dvl_b, self.beam_var)

    def _update(self, chunk, p: int, i: int) -> None:
        M, R = self.batch
        config = self.config
        v_b, cov_b, ok = self._dvl_velocity(chunk, p, i)
        dvl = config.dvl
        speed = np.linalg.norm(self.vel, axis=-1)                       # (M, R)
        extra = dvl.bias_mps**2 + (dvl.scale_factor * speed) ** 2       # unmodelled DVL errors as noise
        t = float(chunk.truth.t_s[i])
        for m, method in enumerate(self.methods):
            C = self.C[m]
            v_dvl_n = np.einsum("rij,rj->ri", C, v_b)
            R_dvl = np.einsum("rij,rjk,rlk->ril", C, cov_b, C) + extra[m][:, None, None] * np.eye(3)
            z, Rm, valid = v_dvl_n, R_dvl, ok.copy()
            if method == "vkf":
                z, Rm, valid = self._vkf_switch(chunk, i, m, v_b, v_dvl_n, R_dvl, ok)
                self._trace_vkf(chunk, i, t)
            self._fuse(m, z, Rm, valid, t)

    def _vkf_switch(self, chunk, i: int, m: int, v_b: np.ndarray, v_dvl_n: np.ndarray, R_dvl: np.ndarray,
                    ok: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. 29: the DVL's NED velocity within the switch altitude (and with enough beams), else
        the VKF's RPM velocity (eq. 27-28), the VKF stepped and, while the DVL is chosen, updated."""
        use_rpm, have_rpm = self.rpm_aid.step(chunk, i, v_b, ok)
        C = self.C[m]
        v_rpm_n = np.einsum("rij,rj->ri", C, self.rpm_aid.velocity_b())
        R_rpm = np.einsum("rij,rjk,rlk->ril", C, self.rpm_aid.covariance_b(), C)
        z = np.where(use_rpm[:, None], v_rpm_n, v_dvl_n)
        Rm = np.where(use_rpm[:, None, None], R_rpm, R_dvl)
        valid = np.where(use_rpm, have_rpm, ok)
        return z, Rm, valid

    def _trace_vkf(self, chunk, i: int, t: float) -> None:
        self.vkf_trace.append(self.rpm_aid.trace(chunk, i, t))

    def _fuse(self, m: int, z: np.ndarray, Rm: np.ndarray, valid: np.ndarray, t: float) -> None:
        """Fuse a NED velocity ``z`` (R, 3) rotated into n with the estimated attitude: its error is
        ``dv + [v x] rho`` (``C_est = exp(-[rho x]) C_true``), so ``H = [I, [v x], 0, 0]`` (the
        paper's H of eq. 18 leaves the attitude column out)."""
        P = self.P[m]
        R = P.shape[0]
        nu = z - self.vel[m]                                             # dv = true - estimate
        H = np.zeros((R, 3, yoo.DIM))
        H[:, :, yoo.VEL] = np.eye(3)
        H[:, :, yoo.ATT] = _skew_batch(np.where(np.isfinite(z), z, 0.0))
        PHt = P @ H.swapaxes(-1, -2)                                     # (R, 12, 3)
        S = H @ PHt + Rm
        S_diag = np.einsum("rii->ri", S)
        with np.errstate(invalid="ignore"):
            passed = np.all(nu**2 <= self.gate**2 * S_diag, axis=-1)
        use = valid & passed & np.isfinite(nu).all(axis=-1)
        S_safe = np.where(use[:, None, None], S, np.eye(3))
        K = PHt @ np.linalg.inv(S_safe)                                  # (R, 12, 3)
        dx = np.einsum("rij,rj->ri", K, np.where(use[:, None], nu, 0.0))
        I_KH = np.eye(yoo.DIM) - K @ H
        P_new = I_KH @ P @ I_KH.swapaxes(-1, -2) + K @ Rm @ K.swapaxes(-1, -2)
        P_new = 0.5 * (P_new + P_new.swapaxes(-1, -2))
        self.P[m] = np.where(use[:, None, None], P_new, P)
        with np.errstate(invalid="ignore"):
            nis = np.einsum("ri,rij,rj->r", nu, np.linalg.inv(S_safe), nu)
        # inject and reset (feedback)
        self.vel[m] += dx[:, yoo.VEL]
        self.C[m] = exp_so3(dx[:, yoo.ATT]) @ self.C[m]
        self.ba[m] += dx[:, yoo.BA]
        self.bg[m] += dx[:, yoo.BG]
        self.updates.append({"m": m, "t": t, "z": z, "nu": np.where(valid[:, None], nu, np.nan),
                             "S": np.where(valid[:, None], S_diag, np.nan), "valid": valid, "fused": use,
                             "rejected": valid & ~passed, "nis": np.where(valid, nis, np.nan)})

    def _record(self, chunk, i: int) -> None:
        M, R = self.batch
        truth = chunk.truth
        v_t, C_t = truth.vel_n[i], truth.C_nb[i]
        ba_t, bg_t = np.asarray(chunk.imu.accel_bias[i]), np.asarray(chunk.imu.gyro_bias[i])   # (R, 3)
        if self.geodetic:
            est_ned = ned_from_geodetic(self.pos[..., 0], self.pos[..., 1], -self.pos[..., 2], self.origin)
        else:
            est_ned = self.pos
        pos_err = np.linalg.norm(est_ned - truth.pos_n[i], axis=-1)
        dx = np.zeros((M, R, yoo.DIM))
        dx[..., yoo.VEL] = v_t - self.vel
        dx[..., yoo.ATT] = log_so3(C_t @ self.C.swapaxes(-1, -2))
        dx[..., yoo.BA] = ba_t - self.ba
        dx[..., yoo.BG] = bg_t - self.bg
        vel_b_err = np.einsum("ji,j->i", C_t, v_t) - np.einsum("mrji,mrj->mri", self.C, self.vel)
        P = self.P
        Pinv = np.linalg.inv(P)
        nees = np.einsum("mri,mrij,mrj->mr", dx, Pinv, dx)

        def block(ix: list[int]) -> np.ndarray:
            sub = P[..., ix, :][..., :, ix]
            d = dx[..., ix]
            return np.einsum("mri,mrij,mrj->mr", d, np.linalg.inv(sub), d)

        att = dx[..., yoo.ATT]
        deg = 1.0 / units.DEG
        rec = {
            "t_s": float(truth.t_s[i]),
            "vel_err": np.linalg.norm(vel_b_err, axis=-1), "att_err": np.linalg.norm(att, axis=-1) * deg,
            "pos_err": pos_err, "vel_sigma": np.sqrt(np.einsum("mrii->mr", P[..., :3, :3])),
            "att_sigma": np.sqrt(np.einsum("mrii->mr", P[..., 3:6, 3:6])) * deg, "pos_sigma": np.full((M, R), np.nan),
            "nees": nees, "tilt_err": np.linalg.norm(att[..., :2], axis=-1) * deg, "heading_err": np.abs(att[..., 2]) * deg,
            "tilt_sigma": np.sqrt(P[..., 3, 3] + P[..., 4, 4]) * deg, "heading_sigma": np.sqrt(P[..., 5, 5]) * deg,
            "nees_block": np.stack([np.full((M, R), np.nan), block([0, 1, 2]), block([3, 4]), block([5]),
                                    block(list(range(6, 12)))], axis=-1),
            "est_pos_n": est_ned.copy(), "est_vel_n": self.vel.copy(),
            "est_euler": _euler_batch(self.C),
        }
        self.records.append(rec)

    # ------------------------------------------------------------------ results
    def take(self, keep: bool = True):
        """The output epochs and updates since the last :meth:`take`; without ``keep`` they are
        dropped (as FilterBank.take)."""
        recs, ups = self.records[self._taken[0]:], self.updates[self._taken[1]:]
        if keep:
            self._taken = (len(self.records), len(self.updates))
        else:
            self.records, self.updates = [], []
        return self._results(recs, ups)

    def _vkf_series(self) -> dict[str, np.ndarray] | None:
        """The VKF at every ping so far (all of the mission when results are kept): ``t_s`` (U,),
        ``x`` (U, R, 3) = V [m/s], sf [m/s per rpm], b [m/s], ``sigma`` (U, R, 3), the RPM model's
        ``sf_true``, ``b_true`` (U, R; NaN on the dynamic truth), ``rpm_in_use`` (U, R) (eq. 29
        chose the RPM) and the echo sounder's ``altitude_m`` (U, R)."""
        return _stack_trace(self.vkf_trace) if self.vkf_trace else None

    def results(self):
        """MethodResult per method, every output epoch and update so far."""
        return self._results(self.records, self.updates)

    def _results(self, recs: list, all_updates: list):
        from tauvcore.eval.runner import MethodResult, UpdateRecord

        M, R = self.batch
        t_s = np.array([r["t_s"] for r in recs])

        def series(name: str) -> np.ndarray:
            return np.stack([r[name] for r in recs]) if recs else np.zeros((0, M, R))

        out = {}
        for m, method in enumerate(self.methods):
            ups = [u for u in all_updates if u["m"] == m]
            updates = {}
            if ups:
                nu = np.stack([u["nu"] for u in ups])
                fused = np.stack([u["fused"] for u in ups])
                rejected = np.stack([u["rejected"] for u in ups])
                valid = np.stack([u["valid"] for u in ups])
                S = np.stack([u["S"] for u in ups])
                updates["dvl"] = UpdateRecord(           # the velocity aid, from the DVL or (vkf) the RPM
                    t_s=np.array([u["t"] for u in ups]), z=np.stack([u["z"] for u in ups]), innovation=nu,
                    innovation_var=S, test_ratio=np.max(nu**2 / (self.gate**2 * S), axis=-1),
                    fused=fused, rejected=rejected, valid=valid, fused_rows=np.repeat(fused[..., None], 3, -1),
                    rejected_rows=np.repeat(rejected[..., None], 3, -1), nis=np.stack([u["nis"] for u in ups]),
                    nis_dof=np.where(valid, 3, 0), unusable=np.zeros_like(valid))
            nonfinite = ~np.isfinite(series("nees")[:, m]) if recs else np.zeros((0, R), bool)
            first_bad = np.array([t_s[np.argmax(col)] if col.any() else np.nan for col in nonfinite.T]) if recs \
                else np.full(R, np.nan)
            out[method] = MethodResult(
                method=method, t_s=t_s, vel_err_mps=series("vel_err")[:, m], att_err_deg=series("att_err")[:, m],
                pos_err_m=series("pos_err")[:, m], vel_sigma_mps=series("vel_sigma")[:, m],
                att_sigma_deg=series("att_sigma")[:, m], pos_sigma_m=series("pos_sigma")[:, m],
                nees=series("nees")[:, m], tilt_err_deg=series("tilt_err")[:, m],
                heading_err_deg=series("heading_err")[:, m], tilt_sigma_deg=series("tilt_sigma")[:, m],
                heading_sigma_deg=series("heading_sigma")[:, m],
                nees_block=(np.stack([r["nees_block"] for r in recs]) if recs else np.zeros((0, M, R, 5)))[:, m],
                est_pos_n=(np.stack([r["est_pos_n"] for r in recs]) if recs else np.zeros((0, M, R, 3)))[:, m],
                est_vel_n=(np.stack([r["est_vel_n"] for r in recs]) if recs else np.zeros((0, M, R, 3)))[:, m],
                est_euler_rad=(np.stack([r["est_euler"] for r in recs]) if recs else np.zeros((0, M, R, 3)))[:, m],
                diverged=~np.isnan(first_bad), diverged_at_s=first_bad, p_floor_count=np.zeros(R, int),
                updates=updates, block_dims=BLOCK_DIMS,
                vkf_trace=self._vkf_series() if method == "vkf" else None)
        return out


def _stack_trace(trace: list[dict]) -> dict[str, np.ndarray]:
    keys = ("t_s", "x", "sigma", "sf_true", "b_true", "rpm_in_use", "altitude_m")
    return {k: np.array([e[k] for e in trace]) for k in keys}


def _euler_batch(C: np.ndarray) -> np.ndarray:
    roll = np.arctan2(C[..., 2, 1], C[..., 2, 2])
    pitch = -np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(C[..., 1, 0], C[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)
