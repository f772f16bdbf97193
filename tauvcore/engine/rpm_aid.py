"""The propeller-RPM velocity aid of Yoo 2014, shared by both banks: one velocity Kalman filter per
run (tauvcore.filter.vkf) that learns the propeller's scale factor and bias from the DVL's
forward speed while the seabed is in range, and the DVL's least-squares body velocity it learns
from."""

from __future__ import annotations

import numpy as np

from tauvcore.aiding import echo_altitude, propeller_rpm
from tauvcore.aiding.echo_altitude import ALTITUDE
from tauvcore.aiding.propeller_rpm import RPM, TRUE_BIAS, TRUE_SCALE_FACTOR
from tauvcore.filter.families.yoo.model_kernels import dvl_body_velocity_into, vkf_step

RPM_LATERAL_SIGMA_MPS = 0.1
"""1-sigma of the sway and heave the RPM velocity takes as zero [m/s] (a cruising AUV's few cm/s,
more in turns)."""
RPM_SOURCE, ECHO_SOURCE = propeller_rpm.SOURCE.name, echo_altitude.SOURCE.name  # in SimChunk.sources


def dvl_body_velocity(
    y: np.ndarray,
    available: np.ndarray,
    dtheta_b: np.ndarray,
    dt_s: float,
    C_nb: np.ndarray,
    lat_rad: np.ndarray,
    A_b: np.ndarray,
    l_dvl_b: np.ndarray,
    beam_var: float,
    with_gain: bool = False,
) -> tuple[np.ndarray, ...]:
    """The DVL's body velocity at a ping by least squares over the beams that returned (R, 3), its
    covariance from the beams' white noise (R, 3, 3), and whether at least three returned (R,);
    with ``with_gain`` also the least squares' gain from the beams to the velocity (R, 3, 4)
    (zero columns for beams that did not return; what a beam bias does to the velocity). The
    head's own motion ``omega_nb x l`` is taken out with the gyro rate less the earth's (first
    order). Each run's is tauvcore.filter.families.yoo.model_kernels.dvl_body_velocity_into, the compiled loop's own."""
    R = y.shape[0]
    v_b, cov_b, gain = np.empty((R, 3)), np.empty((R, 3, 3)), np.empty((R, 3, 4))
    ok = np.empty(R, bool)
    y, available = np.ascontiguousarray(y, dtype=float), np.ascontiguousarray(available, dtype=bool)
    dtheta_b, C_nb = np.ascontiguousarray(dtheta_b, dtype=float), np.ascontiguousarray(C_nb, dtype=float)
    A_b, l_dvl_b = np.ascontiguousarray(A_b, dtype=float), np.ascontiguousarray(l_dvl_b, dtype=float)
    lat = np.broadcast_to(np.asarray(lat_rad, dtype=float), (R,))
    for r in range(R):
        ok[r] = dvl_body_velocity_into(
            y[r],
            available[r],
            dtheta_b[r],
            dt_s,
            C_nb[r],
            lat[r],
            A_b,
            l_dvl_b,
            beam_var,
            v_b[r],
            cov_b[r],
            gain[r],
        )
    return (v_b, cov_b, ok, gain) if with_gain else (v_b, cov_b, ok)


class RpmAid:
    """One velocity Kalman filter per run (tauvcore.filter.vkf), stepped at every DVL ping with the
    latest RPM, updated with the DVL's forward speed while the echo sounder's altitude is within
    ``switch_altitude_m`` and enough beams return; what it offers then is the body velocity
    ``[V_rpm, 0, 0]`` with the VKF's variance on surge and RPM_LATERAL_SIGMA_MPS on sway and heave.
    Used by the ``vkf`` method (eq. 29) and by the first paper's methods with ``run.rpm_fallback``.

    With current states the VKF learns the surge through the water, the DVL's less the current's
    part along the body x axis by a filter's estimate; :attr:`learn_axis_n` and
    :attr:`learn_current_n_mps` keep, per run, the axis and the estimate of its last update. The speed it
    gives is then ``x . (v - c) + (c - c_learn) . a``: the estimate's error at learning stays in
    it, along the axis ``a`` it learned on (tauvcore.engine.yoo_velocity)."""

    def __init__(self, cfg, num_runs: int) -> None:
        self.cfg = cfg
        self.x = np.broadcast_to(cfg.x0, (num_runs, 3)).copy()
        self.P = np.broadcast_to(cfg.P0, (num_runs, 3, 3)).copy()
        self.use_rpm = np.zeros(num_runs, bool)
        self.altitude = np.full(num_runs, np.nan)
        self.learn_axis_n = np.zeros((num_runs, 3))  # body x axis in NED at the last update (zero: none)
        self.learn_current_n_mps = np.zeros((num_runs, 3))  # the current estimate it took then [m/s] NED
        self.Q = np.ascontiguousarray(cfg.Q, dtype=float)
        self.noise_var, self.switch_altitude_m = float(cfg.R), float(cfg.switch_altitude_m)

    def step(
        self,
        chunk,
        i: int,
        v_b: np.ndarray,
        ok: np.ndarray,
        learned: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Predict with the RPM, learn from the DVL where eq. 29 picks it; -> (RPM chosen (R,),
        an RPM was read (R,)). ``learned``: with current states, the body x axis in NED (R, 3) and
        the current estimate (R, 3) [m/s] that ``v_b`` was taken through the water with."""
        cfg, k, R = self.cfg, chunk.k0 + i, self.x.shape[0]
        rpm, echo = chunk.sources.get(RPM_SOURCE), chunk.sources.get(ECHO_SOURCE)
        rpm_now = rpm.latest(RPM, k) if rpm is not None else np.full(R, np.nan)
        altitude = np.asarray(
            echo.latest(ALTITUDE, k) if echo is not None else np.full(R, np.nan), dtype=float
        )
        z_fwd = v_b[:, 0] if cfg.forward_speed == "body_x" else np.linalg.norm(v_b, axis=-1)
        use_rpm, have_rpm = np.empty(R, bool), np.empty(R, bool)
        for r in range(
            R
        ):  # the compiled loop's own step (tauvcore.filter.families.yoo.model_kernels.vkf_step)
            use_rpm[r], have_rpm[r] = vkf_step(
                self.x[r], self.P[r], float(rpm_now[r]), float(altitude[r]), float(z_fwd[r]), bool(ok[r]),
                self.Q, self.noise_var, self.switch_altitude_m,
            )  # fmt: skip
        learn = ~use_rpm & ok & have_rpm
        if learned is not None:
            self.learn_axis_n = np.where(learn[:, None], learned[0], self.learn_axis_n)
            self.learn_current_n_mps = np.where(learn[:, None], learned[1], self.learn_current_n_mps)
        self.use_rpm, self.altitude = use_rpm, altitude
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
        rpm = chunk.sources.get(RPM_SOURCE)
        nan = np.full(R, np.nan)
        return {
            "t_s": t,
            "x": self.x.copy(),
            "sigma": np.sqrt(np.einsum("rii->ri", self.P)),
            "sf_true": rpm.latest(TRUE_SCALE_FACTOR, k) if rpm is not None else nan,
            "b_true": rpm.latest(TRUE_BIAS, k) if rpm is not None else nan,
            "rpm_in_use": self.use_rpm.copy(),
            "altitude_m": self.altitude.copy(),
        }
