"""Yoo 2014's bank in numpy: the reference tauvcore.engine.yoo_loop (the compiled loop, with the
smoother's tape) is held equal to, to 1e-9 (test_yoo_bank.py and test_sensor_errors.py beside it,
tests/unit/tauvcore/filter/kernels/test_reference_sigma.py).

:class:`NumpyYooBank` is tauvcore.engine.yoo_bank.YooBank with every chunk's stops run by numpy
methods (one batch of runs at a time: covariance steps with tauvcore.filter.families.yoo.model.F_batch, the DVL's
least squares of tauvcore.engine.rpm_aid, the VKF's switch, the velocity aid :func:`fuse_velocity`
with :func:`velocity_H`, the water-track's :func:`fuse_water`, the records), and the smoother's
marks written by numpy. :func:`use_numpy_bank` makes the engine build it for Yoo's methods.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tauvcore import units
from tauvcore.engine.chunk_driver import ChunkInputs, Store
from tauvcore.engine.rpm_aid import dvl_body_velocity
from tauvcore.engine.simulation import SimChunk
from tauvcore.engine.yoo_bank import NA, NC, SENSOR_INDEX, SERIES, YooBank
from tauvcore.engine.yoo_smoothing import with_reference
from tauvcore.engine.yoo_velocity import Added
from tauvcore.filter import statistics
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.geo.earth import ned_from_geodetic
from tauvcore.geo.rotations import exp_so3, log_so3, skew


def use_numpy_bank(monkeypatch: Any) -> type:
    """Make the engine run the Yoo methods with :class:`NumpyYooBank` (its ``made`` lists the
    spans it ran); returns the class."""
    from tauvcore.engine import mission

    class Counted(NumpyYooBank):
        made: list = []

        def _run_span(self, *args: Any) -> None:
            Counted.made.append(1)
            super()._run_span(*args)

    Counted.made = []
    monkeypatch.setitem(mission.BANKS, "yoo", Counted)
    return Counted


class NumpyYooBank(YooBank):
    """YooBank with numpy methods in place of the compiled loop."""

    def _run_span(self, *args: Any) -> None:
        self._run_numpy(*args)

    def _record_again(self, chunk, i: int, row: int, inputs, store) -> None:
        self._record(chunk, i, row, store)

    def _tape_record(self, row: int, P: np.ndarray, dx: np.ndarray, vel_b_true_mps: np.ndarray) -> None:
        """An output epoch's mark on the smoother's tape (the compiled loop's _record_row)."""
        out = self.taping.out
        out["tape_X"][row] = self.phi_acc
        self.phi_acc[...] = 0.0
        out["tape_P"][row] = P
        out["tape_dx"][row] = dx
        out["tape_vel_b_mps"][row] = vel_b_true_mps
        self.rows = max(self.rows, row + 1)

    def _run_numpy(
        self,
        chunk: SimChunk,
        s0: int,
        s1: int,
        stops: np.ndarray,
        ping_of_stop: np.ndarray,
        row_of_stop: np.ndarray,
        inputs: ChunkInputs,
        store: Store,
    ) -> None:
        dv_raw = inputs.dv_raw
        k0 = chunk.k0
        self._dv = dv_raw
        for s in range(s0, s1):
            k = int(stops[s])
            i = k - k0
            if k > self.k_state:
                self._advance_to(inputs, k0, k)
            if k > self.k_cov:
                self._propagate(i, k)
            if ping_of_stop[s] >= 0:
                t = float(chunk.truth.t_s[i])
                mark = (
                    self.taping.before(self.phi_acc, self.P, self._nominal(), t)
                    if self.taping is not None
                    else None
                )
                self._update(chunk, int(ping_of_stop[s]), i, store)
                if self.taping is not None and mark is not None:
                    self.taping.after(mark, self.P, self._nominal(), self.rows)
            if row_of_stop[s] >= 0:
                self._record(chunk, i, int(row_of_stop[s]), store)

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
        f_b = self._dv[i].reshape(1, R, 3) / self.dt - self.ba  # the latest specific force
        f_n = np.einsum("bij,bj->bi", C, f_b.reshape(-1, 3))
        lat, h = self._lat_h()
        F = yoo.F_batch(lat, h, self.vel.reshape(-1, 3), f_n, C, self.geodetic, self.w_ie) * dt_c
        Phi = np.eye(yoo.DIM) + F + 0.5 * F @ F
        if self.taping is not None:
            X = (Phi - np.eye(yoo.DIM)).reshape(self.phi_acc.shape)
            self.phi_acc[...] = X + self.phi_acc + X @ self.phi_acc
        na = self.added.dim
        P = self.P.reshape(-1, na, na).copy()
        X = slice(0, yoo.DIM)
        P[:, X, X] = (
            Phi @ P[:, X, X] @ Phi.swapaxes(-1, -2) + np.diag(self.q) * dt_c
        )  # isotropic: G Q G^T = Q
        P[:, X, yoo.DIM :] = Phi @ P[:, X, yoo.DIM :]  # consider states: constant plus walks
        P[:, yoo.DIM :, X] = P[:, X, yoo.DIM :].swapaxes(-1, -2)
        P[:, yoo.DIM : NA, yoo.DIM : NA] += np.diag(self.qc) * dt_c
        propagate_added(P, self.added, dt_c)
        self.P = (0.5 * (P + P.swapaxes(-1, -2))).reshape(M, R, na, na)
        self.dtheta_sum[:] = 0.0
        self.k_cov = k

    def _dvl_velocity(
        self, chunk, i: int, y: np.ndarray, available: np.ndarray, beam_var: float
    ) -> tuple[np.ndarray, ...]:
        """The least squares' body velocity of beams ``y`` (R, 4) [m/s] returned where ``available``
        at sample ``i`` of ``chunk``, its covariance from ``beam_var`` [m^2/s^2], whether enough beams
        returned and the gain (tauvcore.engine.rpm_aid.dvl_body_velocity)."""
        lat, _ = self._lat_h()
        R = self.batch[1]
        return dvl_body_velocity(
            y, available, chunk.imu.dtheta_b[i], self.dt, self.C[0], lat[:R], self.A_b, self.l_dvl_b, beam_var,
            with_gain=True,
        )  # fmt: skip

    def _update(self, chunk, p: int, i: int, store: dict[str, np.ndarray]) -> None:
        v_b, cov_b, ok, gain = self._dvl_velocity(
            chunk, i, chunk.dvl.y_beam_mps[p], chunk.dvl.available[p], self.beam_var
        )
        R = self.batch[1]
        for m, method in enumerate(self.methods):
            C = self.C[m]
            v_dvl_n = np.einsum("rij,rj->ri", C, v_b)
            R_dvl = np.einsum("rij,rjk,rlk->ril", C, cov_b, C)
            # the consider states' columns: the scale factor scales the (estimated) body velocity, a
            # beam bias goes through the least squares of the beams that returned
            v_est_b = np.einsum("rji,rj->ri", C, self.vel[m])
            Hc = C @ np.concatenate([v_est_b[:, :, None], gain], axis=-1)  # (R, 3, NC)
            z, Rm, valid, water, learned = v_dvl_n, R_dvl, ok.copy(), None, None
            if method == "vkf":
                z, Rm, valid = self._vkf_switch(chunk, i, m, v_b, v_dvl_n, R_dvl, ok)
                if self.added.current is not None:
                    water = self.rpm_aid.use_rpm
                    learned = (C[:, :, 0], self.rpm_aid.learn_axis_n, self.rpm_aid.learn_current_n_mps)
                Hr = np.zeros((R, 3, NC))  # the RPM's surge was learnt from the DVL's (4 beams)
                Hr[:, 0, 0] = self.rpm_aid.x[:, 0]
                Hr[:, 0, 1:] = self.L4[0]
                Hc = np.where(self.rpm_aid.use_rpm[:, None, None], C @ Hr, Hc)
                tr = self.rpm_aid.trace(chunk, i, 0.0)
                store["tr_x"][p], store["tr_sigma"][p] = tr["x"], tr["sigma"]
                store["tr_truth"][p] = np.stack([tr["sf_true"], tr["b_true"]], axis=-1)
                store["tr_use"][p], store["tr_alt"][p] = tr["rpm_in_use"], tr["altitude_m"]
            fuse_velocity(self, m, z, Rm, valid, Hc, p, store, water, learned)
        if self.added.water_var is not None and chunk.dvl.y_water_mps is not None:
            fuse_water(self, chunk, p, i, store)

    def _vkf_switch(
        self, chunk, i: int, m: int, v_b: np.ndarray, v_dvl_n: np.ndarray, R_dvl: np.ndarray, ok: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. 29: the DVL's NED velocity within the switch altitude (and with enough beams), else
        the VKF's RPM velocity (eq. 27-28), the VKF stepped and, while the DVL is chosen, updated;
        with current states it learns the surge through the water, the DVL's less the current's by
        this method's estimate (tauvcore.engine.yoo_velocity)."""
        learned = None
        if self.added.current is not None:
            c_n = self.added.current_in(self.extra[m])
            v_b = v_b - surge_current(self.C[m], c_n)[:, None] * np.array([1.0, 0.0, 0.0])
            learned = (self.C[m, :, :, 0], c_n)
        use_rpm, have_rpm = self.rpm_aid.step(chunk, i, v_b, ok, learned)
        C = self.C[m]
        v_rpm_n = np.einsum("rij,rj->ri", C, self.rpm_aid.velocity_b())
        R_rpm = np.einsum("rij,rjk,rlk->ril", C, self.rpm_aid.covariance_b(), C)
        z = np.where(use_rpm[:, None], v_rpm_n, v_dvl_n)
        Rm = np.where(use_rpm[:, None, None], R_rpm, R_dvl)
        valid = np.where(use_rpm, have_rpm, ok)
        return z, Rm, valid

    def _record(self, chunk, i: int, row: int, store: dict[str, np.ndarray]) -> None:
        truth = chunk.truth
        v_t, C_t = truth.vel_n[i], truth.C_nb[i]
        ba_t, bg_t = np.asarray(chunk.imu.accel_bias[i]), np.asarray(chunk.imu.gyro_bias[i])  # (R, 3)
        if self.geodetic:
            lat0, lon0, h0 = (float(v) for v in self.origin)
            est_ned = ned_from_geodetic(
                self.pos[..., 0], self.pos[..., 1], -self.pos[..., 2], (lat0, lon0, h0)
            )
        else:
            est_ned = self.pos
        pos_err = np.linalg.norm(est_ned - truth.pos_n[i], axis=-1)
        E = self.added.num
        dx = np.zeros(self.batch + (yoo.DIM + E,))  # the 12 states, then the added
        dx[..., yoo.VEL] = v_t - self.vel
        dx[..., yoo.ATT] = log_so3(C_t @ self.C.swapaxes(-1, -2))
        dx[..., yoo.BA] = ba_t - self.ba
        dx[..., yoo.BG] = bg_t - self.bg
        extra_t = self._added_truth(chunk)[i] if E else np.zeros(0)
        dx[..., yoo.DIM :] = extra_t - self.extra
        vel_b_err = np.einsum("ji,j->i", C_t, v_t) - np.einsum("mrji,mrj->mri", self.C, self.vel)
        est = self.added.estimated
        P = np.ascontiguousarray(self.P[..., est[:, None], est])  # the estimated states
        P_nees = with_reference(P, self.ref_var, C_t, v_t)
        blocks = statistics.block_nees(dx, P_nees, self.block_of_state, self.num_blocks)
        blocks[..., 0] = np.nan  # no position state
        att = dx[..., yoo.ATT]
        deg = 1.0 / units.DEG
        series = {
            "vel_err": np.linalg.norm(vel_b_err, axis=-1),
            "att_err": np.linalg.norm(att, axis=-1) * deg,
            "pos_err": pos_err,
            "vel_sigma": np.sqrt(np.einsum("mrii->mr", P[..., :3, :3])),
            "att_sigma": np.sqrt(np.einsum("mrii->mr", P[..., 3:6, 3:6])) * deg,
            "pos_sigma": np.nan,
            "nees": statistics.nees(dx, P_nees),
            "tilt_err": np.linalg.norm(att[..., :2], axis=-1) * deg,
            "heading_err": np.abs(att[..., 2]) * deg,
            "tilt_sigma": np.sqrt(P[..., 3, 3] + P[..., 4, 4]) * deg,
            "heading_sigma": np.sqrt(P[..., 5, 5]) * deg,
        }
        for j, name in enumerate(SERIES):
            store["series"][j, row] = series[name]
        store["nees_block"][row] = blocks
        store["est_pos_n"][row] = est_ned
        store["est_vel_n"][row] = self.vel
        store["est_euler"][row] = _euler_batch(self.C)
        if E:
            store["state_est"][row] = self.extra
            store["state_sigma"][row] = np.sqrt(np.einsum("...ii->...i", self.P[..., NA:, NA:]))
            store["state_true"][row] = extra_t
        if self.taping is not None:
            self._tape_record(row, self.P, dx, np.einsum("ji,j->i", C_t, v_t))
        if self.sensor_errors:
            x_est = np.zeros(self.batch + (yoo.DIM,))
            x_est[..., yoo.BA], x_est[..., yoo.BG] = self.ba, self.bg
            x_true = np.zeros(self.batch + (yoo.DIM,))
            x_true[..., yoo.BA], x_true[..., yoo.BG] = ba_t, bg_t
            store["sensor_est"][row] = x_est[..., SENSOR_INDEX]
            store["sensor_sigma"][row] = np.sqrt(self.P[..., SENSOR_INDEX, SENSOR_INDEX])
            store["sensor_true"][row] = x_true[..., SENSOR_INDEX]


def _euler_batch(C: np.ndarray) -> np.ndarray:
    roll = np.arctan2(C[..., 2, 1], C[..., 2, 2])
    pitch = -np.arcsin(np.clip(C[..., 2, 0], -1.0, 1.0))
    yaw = np.arctan2(C[..., 1, 0], C[..., 0, 0])
    return np.stack([roll, pitch, yaw], axis=-1)


def propagate_added(P: np.ndarray, added: Added, dt_s: float) -> None:
    """The added states over ``dt_s``, in place: their rows and columns of ``P`` (B, N, N) scale by
    ``phi = exp(rate dt)`` and each variance gains ``q (1 - phi^2) / (-2 rate)`` (``q dt`` for a
    walk), as tauvcore.filter.kernels.error_model_kernels.extra_step_into.

    Parameters
    ----------
    P : numpy.ndarray
        Covariance, shape (B, N, N), the added states last, in their units squared; written.
    added : Added
        The added states.
    dt_s : float
        The step [s].
    """
    for e in range(added.num):
        a, rate, q = NA + e, float(added.rate[e]), float(added.q[e])
        if rate != 0.0:
            phi = np.exp(rate * dt_s)
            P[:, a, :] *= phi
            P[:, :, a] *= phi
            P[:, a, a] += q * (1.0 - phi * phi) / (-2.0 * rate)
        else:
            P[:, a, a] += q * dt_s


def velocity_H(
    vel_n: np.ndarray,
    c_n: np.ndarray,
    Hc: np.ndarray,
    through_water: np.ndarray | None,
    added: Added,
    learned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """A NED velocity aid's prediction and Jacobian (module docstring).

    Parameters
    ----------
    vel_n : numpy.ndarray
        Estimated velocity over ground, shape (..., 3) [m/s], NED.
    c_n : numpy.ndarray
        Estimated current, shape (..., 3) [m/s], NED (down zero).
    Hc : numpy.ndarray
        The measurement's columns on the consider states, shape (..., 3, 5) [m/s per unit].
    through_water : numpy.ndarray or None
        Shape (...) bool: the measured velocity is through the water; None: over ground.
    added : Added
        The added states.
    learned : tuple of numpy.ndarray or None
        An RPM velocity's VKF (module docstring): the body x axis ``x`` now, the axis ``a`` and the
        current estimate ``c_l`` [m/s] of its last update, each (..., 3) NED; None: none.

    Returns
    -------
    h : numpy.ndarray
        The prediction, ``v``, ``v - c`` or with ``learned`` ``v - c + x (c - c_l) . a``, shape
        (..., 3) [m/s].
    H : numpy.ndarray
        Its Jacobian over ``[dv_n, rho, d_ba, d_bg, consider, added]``, shape (..., 3, N).
    """
    water = np.zeros(vel_n.shape[:-1], bool) if through_water is None else np.asarray(through_water, bool)
    h = vel_n - np.where(water[..., None], c_n, 0.0)
    H = np.zeros(vel_n.shape[:-1] + (3, added.dim))
    H[..., yoo.VEL] = np.eye(3)
    H[..., yoo.ATT] = skew(h)
    H[..., yoo.DIM : NA] = np.where(np.isfinite(Hc), Hc, 0.0)
    if added.current is not None:
        Hcur = np.broadcast_to(-np.eye(3)[:, :2], H.shape[:-2] + (3, 2))
        if learned is not None:
            x_n, a_n, c_l = learned
            along = np.einsum("...j,...j->...", c_n - c_l, a_n)
            h = h + np.where(water[..., None], x_n * along[..., None], 0.0)
            Hcur = Hcur + x_n[..., :, None] * a_n[..., None, :2]
        H[..., added.current] = np.where(water[..., None, None], Hcur, 0.0)
    return h, H


def surge_current(C_nb: np.ndarray, c_n: np.ndarray) -> np.ndarray:
    """The current's part along the body x axis, ``(C^T c)_x``.

    Parameters
    ----------
    C_nb : numpy.ndarray
        Attitudes, shape (..., 3, 3), body (FRD) to NED.
    c_n : numpy.ndarray
        Currents, shape (..., 3) [m/s], NED.

    Returns
    -------
    numpy.ndarray
        Shape (...) [m/s].
    """
    return np.einsum("...j,...j->...", C_nb[..., :, 0], c_n)


def fuse_water(bank: Any, chunk: Any, p: int, i: int, store: dict[str, np.ndarray]) -> None:
    """The water-track beams of ping ``p`` (sample ``i`` of ``chunk``) fused by every method of the
    Yoo bank ``bank`` (tauvcore.engine.yoo_bank.YooBank) with at least three of them, as a NED
    velocity through the water (module docstring), gated as the bank's DVL update
    (:func:`fuse_velocity`), recorded in the store's ``wt_*`` rows of the ping (the source
    ``water``).

    Parameters
    ----------
    bank : YooBank
        The bank: its estimates and covariance, written in place.
    chunk : SimChunk
        The chunk of the ping: its DVL data's ``y_water_mps`` and ``water_available`` (pings, R, 4).
    p : int
        The ping within the chunk.
    i : int
        The ping's sample within the chunk.
    store : dict[str, numpy.ndarray]
        The chunk's store.
    """
    added: Added = bank.added
    assert added.water_var is not None  # called only when the bank fuses water-track
    R = bank.batch[1]
    dvl = chunk.dvl
    w_b, cov_b, ok, gain = bank._dvl_velocity(
        chunk, i, dvl.y_water_mps[p], dvl.water_available[p], added.water_var
    )
    for m in range(bank.batch[0]):
        C = bank.C[m]
        z = np.einsum("rij,rj->ri", C, w_b)
        Rm = np.einsum("rij,rjk,rlk->ril", C, cov_b, C)
        w_est_b = np.einsum("rji,rj->ri", C, bank.vel[m] - added.current_in(bank.extra[m]))
        Hc = C @ np.concatenate([w_est_b[..., None], gain], axis=-1)
        fuse_velocity(bank, m, z, Rm, ok, Hc, p, store, np.ones(R, bool), prefix="wt")


def fuse_velocity(
    bank: Any,
    m: int,
    z: np.ndarray,
    Rm: np.ndarray,
    valid: np.ndarray,
    Hc: np.ndarray,
    p: int,
    store: dict[str, np.ndarray],
    water: np.ndarray | None = None,
    learned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    prefix: str = "up",
) -> None:
    """One method of the Yoo bank fuses a NED velocity rotated into n with the estimated attitude.

    Its error is ``dv + [v x] rho`` (``C_est = exp(-[rho x]) C_true``), so ``H = [I, [v x], 0, 0]``
    (the paper's H of eq. 18 leaves the attitude column out), ``v`` the estimated velocity (the
    measured one would put the measurement's noise into H: a random lever on the heading that
    the filter reads as information about it), and ``Hc`` on the consider states, whose rows of K
    are zero. Through the water it is ``v - c`` with the current states (:func:`velocity_H`).
    Gated as a whole at ``bank.gate``; the NIS is over S before the gate (NaN where S is not
    finite or not invertible).

    Parameters
    ----------
    bank : YooBank
        The bank (tauvcore.engine.yoo_bank.YooBank): its estimates and covariance, written in place.
    m : int
        The method's index along the bank's method axis.
    z : numpy.ndarray
        The measured velocity, shape (R, 3) [m/s], NED.
    Rm : numpy.ndarray
        Its noise covariance, shape (R, 3, 3) [m^2/s^2].
    valid : numpy.ndarray
        Shape (R,) bool: there is a measurement.
    Hc : numpy.ndarray
        Its columns on the consider states, shape (R, 3, 5) [m/s per unit].
    p : int
        The ping's row in ``store``.
    store : dict[str, numpy.ndarray]
        The chunk's store: its ``up_*`` records are written.
    water : numpy.ndarray or None
        Shape (R,) bool: the velocity is through the water; None: over ground.
    learned : tuple of numpy.ndarray or None
        An RPM velocity's learning (:func:`velocity_H`); None: none.
    prefix : str
        The store's records written: ``up`` (the DVL's, or the RPM's) or ``wt`` (water-track).
    """
    P = bank.P[m]
    c_n = bank.added.current_in(bank.extra[m])
    h, H = velocity_H(bank.vel[m], c_n, Hc, water, bank.added, learned)
    nu = z - h  # dv = true - estimate
    PHt = P @ H.swapaxes(-1, -2)  # (R, N, 3)
    S = H @ PHt + Rm
    S_diag = np.einsum("rii->ri", S)
    with np.errstate(invalid="ignore"):
        passed = np.all(nu**2 <= bank.gate**2 * S_diag, axis=-1)
    invertible = np.isfinite(S).all(axis=(-2, -1)) & (
        np.abs(np.linalg.det(np.where(np.isfinite(S), S, 0.0))) > 0.0
    )
    use = valid & passed & np.isfinite(nu).all(axis=-1) & invertible
    S_inv = np.linalg.inv(np.where(invertible[:, None, None], S, np.eye(3)))
    K = PHt @ np.where(use[:, None, None], S_inv, np.eye(3))  # (R, N, 3)
    K[:, yoo.DIM : NA, :] = 0.0  # consider states: never corrected
    dx = np.einsum("rij,rj->ri", K, np.where(use[:, None], nu, 0.0))
    I_KH = np.eye(bank.added.dim) - K @ H
    P_new = I_KH @ P @ I_KH.swapaxes(-1, -2) + K @ Rm @ K.swapaxes(-1, -2)
    P_new = 0.5 * (P_new + P_new.swapaxes(-1, -2))
    bank.P[m] = np.where(use[:, None, None], P_new, P)
    with np.errstate(invalid="ignore"):
        nis = np.where(invertible, np.einsum("ri,rij,rj->r", nu, S_inv, nu), np.nan)
    # inject and reset (feedback)
    bank.vel[m] += dx[:, yoo.VEL]
    bank.C[m] = exp_so3(dx[:, yoo.ATT]) @ bank.C[m]
    bank.ba[m] += dx[:, yoo.BA]
    bank.bg[m] += dx[:, yoo.BG]
    bank.extra[m] += dx[:, NA:]
    store[f"{prefix}_z"][p, m] = z
    store[f"{prefix}_nu"][p, m] = np.where(valid[:, None], nu, np.nan)
    store[f"{prefix}_S"][p, m] = np.where(valid[:, None], S_diag, np.nan)
    store[f"{prefix}_flags"][p, m] = np.stack([valid, use, valid & ~passed], axis=-1)
    store[f"{prefix}_nis"][p, m] = np.where(valid, nis, np.nan)
