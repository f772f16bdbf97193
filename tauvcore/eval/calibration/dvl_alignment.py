"""The DVL's mounting misalignment and scale factor (tauvcore.eval.calibration): per ping the
reference's velocity at the head against the DVL's beams or head velocity, solved by least squares
with each log's beam biases under their prior, its covariance and parts."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from tauvcore import units
from tauvcore.config import Config
from tauvcore.eval.calibration.boresight import earth_rates, wahba
from tauvcore.eval.calibration.estimate import OUTLIER_SIGMAS, Estimate, correlation_time, rms, robust_sigma
from tauvcore.eval.replay import _epochs, _reference_at
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb, skew
from tauvcore.logs import Log

DVL_NAMES = ("DVL misalignment roll", "DVL misalignment pitch", "DVL misalignment yaw", "DVL scale factor")
DVL_UNITS = ("deg", "deg", "deg", "%")


def zyx_partials(euler: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``C = Rz(yaw) Ry(pitch) Rx(roll)`` and its derivatives by roll, pitch and yaw.

    Parameters
    ----------
    euler : numpy.ndarray
        ``[roll, pitch, yaw]`` [rad], shape (3,).

    Returns
    -------
    C : numpy.ndarray
        Shape (3, 3) [-] (tauvcore.geo.rotations.C_nb_from_euler).
    dC : numpy.ndarray
        Shape (3, 3, 3) [1/rad]: ``dC[j]`` is ``dC / d euler[j]`` (``dR_a / d t = R_a [e_a x]``).
    """
    r, p, y = (float(a) for a in euler)
    Rx = C_nb_from_euler(np.array([r, 0.0, 0.0]))
    Ry = C_nb_from_euler(np.array([0.0, p, 0.0]))
    Rz = C_nb_from_euler(np.array([0.0, 0.0, y]))
    ex, ey, ez = skew(np.eye(3))
    dC = np.stack([Rz @ Ry @ Rx @ ex, Rz @ Ry @ ey @ Rx, Rz @ ez @ Ry @ Rx])
    return Rz @ Ry @ Rx, dC


@dataclass(frozen=True)
class DvlRows:
    """One log's DVL residual rows and what its reference velocity at the head is made of."""

    z: np.ndarray  # (n,) measured: a beam velocity, or a head-velocity component [m/s]
    d: np.ndarray  # (n, 3) the direction z is along, in the head frame h [-]
    ping: np.ndarray  # (n,) the row's ping (index into the arrays below)
    group: np.ndarray  # (n,) its beam (0-3) or axis (0-2): one series each for the correlation
    D: np.ndarray  # (n, 4) d z / d (beam biases) [-]
    v_head: np.ndarray  # (m, 3) each ping's head velocity (least squares of >= 3 beams), NaN if none
    C_nr: np.ndarray  # (m, 3, 3) reference attitude at the ping
    vel_n: np.ndarray  # (m, 3) reference velocity [m/s]
    omega_ib_b: np.ndarray  # (m, 3) gyro rate around the ping [rad/s]
    omega_in_n: np.ndarray  # (m, 3) n frame's rate [rad/s]
    l_dvl_b: np.ndarray  # (3,) lever arm [m]
    bias_sigma_mps: float  # the beams' turn-on bias, 1-sigma [m/s]

    def v_ref_b(self, C_rb: np.ndarray) -> np.ndarray:
        """(m, 3) the reference's velocity at the DVL head in the IMU's body [m/s]."""
        C_nb = self.C_nr @ C_rb
        v_b = np.einsum("mji,mj->mi", C_nb, self.vel_n)
        omega_nb_b = self.omega_ib_b - np.einsum("mji,mj->mi", C_nb, self.omega_in_n)
        return v_b + np.cross(omega_nb_b, self.l_dvl_b)


def dvl_rows(log: Log, config: Config) -> DvlRows:
    """One log's DVL residual rows (module docstring): each returned bottom-track beam, or each
    component of a bottom-track head velocity, at pings within the reference's span whose IMU
    sample has a neighbour on either side.

    Parameters
    ----------
    log : Log
        A log with a reference and a DVL table (beams, or a body velocity taken as the head's).
    config : Config
        Its configuration: the beams ``dvl.A_b``, lever arm, beam bias 1-sigma, the earth.

    Returns
    -------
    DvlRows
        The rows (n) and the pings' ingredients (m).
    """
    assert log.dvl_t_s is not None and log.ref_t_s is not None
    K = log.imu_t_s.size
    k, keep = _epochs(log, log.dvl_t_s)
    keep &= (k >= 1) & (k <= K - 2)
    t = log.imu_t_s[np.clip(k, 0, K - 1)]
    keep &= (t >= log.ref_t_s[0]) & (t <= log.ref_t_s[-1])
    idx = np.flatnonzero(keep)
    kk = k[idx]
    pos, euler, vel_n = _reference_at(log, log.imu_t_s[kk])
    _, in_n = earth_rates(log, config, pos, vel_n)
    span = (log.imu_t_s[kk + 1] - log.imu_t_s[kk - 1])[:, None]
    omega_ib_b = (log.dtheta_b[kk] + log.dtheta_b[kk + 1]) / span
    A = config.dvl.A_b
    water = None if log.dvl_water_track is None else log.dvl_water_track[idx]
    if log.dvl_beams_mps is not None:
        y = log.dvl_beams_mps[idx]
        use = np.isfinite(y) & (True if water is None else ~water)
        ping, beam = np.nonzero(use)
        z, d, group = y[ping, beam], A[beam], beam
        D = np.eye(4)[beam]
        v_head = np.full((idx.size, 3), np.nan)
        for pattern in np.unique(use, axis=0):
            if pattern.sum() >= 3:
                same = (use == pattern).all(axis=1)
                v_head[same] = y[np.ix_(same, pattern)] @ np.linalg.pinv(A[pattern]).T
    else:
        v = log.dvl_body_mps[idx] if log.dvl_body_mps is not None else np.full((idx.size, 3), np.nan)
        good = np.asarray(np.isfinite(v).all(axis=1), dtype=bool)  # (m,)
        if water is not None:
            good &= ~water[:, 0]
        v_head = np.where(good[:, None], v, np.nan)
        ping = np.repeat(np.flatnonzero(good), 3)
        group = np.tile(np.arange(3), int(good.sum()))
        z, d = v[ping, group], np.eye(3)[group]
        D = np.linalg.pinv(A)[group]  # a bias pattern of the beams seen in the head velocity
    return DvlRows(
        z=z,
        d=d,
        ping=ping,
        group=group,
        D=D,
        v_head=v_head,
        C_nr=C_nb_from_euler(euler),
        vel_n=vel_n,
        omega_ib_b=omega_ib_b,
        omega_in_n=in_n,
        l_dvl_b=config.dvl.l_dvl_b,
        bias_sigma_mps=config.dvl.bias_mps,
    )


def predicted(theta: np.ndarray, rows: DvlRows, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model's ``d . (1 + s) C_bh^T v_ref_b`` per row (n,) and its Jacobian (n, 4) by
    roll, pitch, yaw [rad] and s."""
    C, dC = zyx_partials(theta[:3])
    Vp = V[rows.ping]  # (n, 3)
    head = Vp @ C  # rows of C^T v
    pred = (1.0 + theta[3]) * np.einsum("ni,ni->n", rows.d, head)
    J = np.empty((pred.size, 4))
    for j in range(3):
        J[:, j] = (1.0 + theta[3]) * np.einsum("ni,ni->n", rows.d, Vp @ dC[j])
    J[:, 3] = np.einsum("ni,ni->n", rows.d, head)
    return pred, J


@dataclass(frozen=True)
class DvlFit:
    theta: np.ndarray  # (4,) roll, pitch, yaw [rad], s [-]
    estimate: Estimate
    keep: list[np.ndarray]  # per log: rows kept
    sigma: list[float]  # per log: residual 1-sigma [m/s]
    tau: list[float]  # per log: correlation time of its residuals [pings]


def procrustes(rows: Sequence[DvlRows], V: Sequence[np.ndarray]) -> np.ndarray:
    """Scaled Procrustes start: ``C_bh^T``, ``s`` minimising ``sum |v_h - (1 + s) C_bh^T v_ref|^2``
    over the pings with a head velocity; zeros if none."""
    vh = np.concatenate([r.v_head for r in rows])
    vr = np.concatenate(list(V))
    ok = np.isfinite(vh).all(axis=1)
    if ok.sum() < 3:
        return np.zeros(4)
    R = wahba(vh[ok], vr[ok], np.ones(int(ok.sum())))  # C_bh^T
    s = np.sum(vh[ok] * (vr[ok] @ R.T)) / np.sum(vr[ok] ** 2) - 1.0
    return np.concatenate([euler_from_C_nb(R.T), [s]])


def fit_dvl(rows: Sequence[DvlRows], C_rb: np.ndarray, P_boresight_rad: np.ndarray) -> DvlFit:
    """The DVL's misalignment and scale factor from ``rows`` (one vehicle), with the boresight
    ``C_rb`` of covariance ``P_boresight_rad`` (its Euler angles [rad^2]); module docstring.

    The unknowns are ``x = [roll, pitch, yaw, s, b_1, ..., b_L]``: the four of the calibration
    and each log's four beam biases (a log of ``dvl.bias_mps`` zero has none), the biases with
    their turn-on 1-sigma as a prior (a row ``b / bias_mps`` each)."""
    problem = _DvlProblem.of(rows, C_rb)
    x = _solve(problem)
    sigma, tau = _residual_statistics(problem, x)
    scale = np.diag([1.0 / units.DEG] * 3 + [1.0 / units.PERCENT])
    parts = {
        name: scale @ P @ scale
        for name, P in _covariance_parts(problem, x, tau, C_rb, P_boresight_rad).items()
    }
    estimate = Estimate(
        names=DVL_NAMES,
        units=DVL_UNITS,
        value=scale @ x[:4],
        cov=sum(parts.values(), np.zeros((4, 4))),
        parts=parts,
    )
    return DvlFit(theta=x[:4], estimate=estimate, keep=problem.keep, sigma=sigma, tau=tau)


@dataclass
class _DvlProblem:
    """:func:`fit_dvl`'s least squares: the logs' rows and reference velocities at the head, each
    log's rows kept and weight (the fit sets both), and where its beam biases sit in ``x``."""

    rows: Sequence[DvlRows]
    V: list[np.ndarray]  # per log (m, 3): DvlRows.v_ref_b at the boresight [m/s]
    keep: list[np.ndarray]  # per log (n,) bool: rows kept
    weights: list[float]  # per log: 1 / its residuals' 1-sigma [s/m]
    offsets: list[int]  # per log: its biases' first index in x (-1: none)
    n_x: int  # unknowns: the four, and four per log with biases

    @classmethod
    def of(cls, rows: Sequence[DvlRows], C_rb: np.ndarray) -> _DvlProblem:
        """The problem of ``rows`` at the boresight ``C_rb``: every row kept, every weight 1."""
        offsets, n_x = [], 4
        for r in rows:
            offsets.append(n_x if r.bias_sigma_mps > 0.0 else -1)
            n_x += 4 if r.bias_sigma_mps > 0.0 else 0
        keep = [np.ones(r.z.size, bool) for r in rows]
        return cls(rows, [r.v_ref_b(C_rb) for r in rows], keep, [1.0] * len(rows), offsets, n_x)

    def stacked(
        self, x: np.ndarray, Vs: Sequence[np.ndarray], prior: bool = True
    ) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (data rows of every log, then the biases' prior rows) and Jacobian."""
        res, jac = [], []
        for r, v, k, w, o in zip(self.rows, Vs, self.keep, self.weights, self.offsets, strict=True):
            pred, J = predicted(x[:4], r, v)
            Jx = np.zeros((int(k.sum()), self.n_x))
            Jx[:, :4] = -w * J[k]
            e = r.z - pred
            if o >= 0:
                e = e - r.D @ x[o : o + 4]
                Jx[:, o : o + 4] = -w * r.D[k]
            res.append(w * e[k])
            jac.append(Jx)
        if prior:
            for r, o in zip(self.rows, self.offsets, strict=True):
                if o >= 0:
                    res.append(x[o : o + 4] / r.bias_sigma_mps)
                    Jp = np.zeros((4, self.n_x))
                    Jp[:, o : o + 4] = np.eye(4) / r.bias_sigma_mps
                    jac.append(Jp)
        return np.concatenate(res), np.concatenate(jac)

    def residuals(self, x: np.ndarray, i: int) -> np.ndarray:
        """Log ``i``'s data residuals at ``x``, unweighted, every row (n_i,) [m/s]."""
        r, o = self.rows[i], self.offsets[i]
        e = r.z - predicted(x[:4], r, self.V[i])[0]
        return e - r.D @ x[o : o + 4] if o >= 0 else e


def _solve(problem: _DvlProblem) -> np.ndarray:
    """The least-squares ``x`` of ``problem``, fitted twice: first every row, from zero and from the
    Procrustes start (the lower cost kept), then without the first fit's outliers from its
    solution; after each fit every log weighted by its residuals' RMS."""
    x = np.zeros(problem.n_x)
    for fit in range(2):
        starts = (
            [
                np.zeros(problem.n_x),
                np.concatenate([procrustes(problem.rows, problem.V), np.zeros(problem.n_x - 4)]),
            ]
            if fit == 0
            else [x]
        )
        best = None
        for x0 in starts:
            sol = least_squares(
                lambda x: problem.stacked(x, problem.V)[0],
                x0,
                jac=lambda x: problem.stacked(x, problem.V)[1],  # pyright: ignore[reportArgumentType] (a callable is taken)
                method="lm",
                xtol=1e-12,
                ftol=1e-12,
                gtol=1e-12,
            )
            if best is None or sol.cost < best.cost:
                best = sol
        assert best is not None
        x = best.x
        for i in range(len(problem.rows)):
            e = problem.residuals(x, i)
            if fit == 0:
                problem.keep[i] = np.abs(e) <= OUTLIER_SIGMAS * max(robust_sigma(e), 1e-9)
            problem.weights[i] = 1.0 / max(rms(e[problem.keep[i]]), 1e-9)
    return x


def _residual_statistics(problem: _DvlProblem, x: np.ndarray) -> tuple[list[float], list[float]]:
    """Each log's residual 1-sigma at ``x`` [m/s] (its degrees of freedom less its unknowns), which
    becomes its weight, and the correlation time of its residuals [pings]."""
    sigma, tau = [], []
    for i, (r, k, o) in enumerate(zip(problem.rows, problem.keep, problem.offsets, strict=True)):
        e = problem.residuals(x, i)[k]
        s = rms(e, dof=max(1.0 - (4.0 + (4 if o >= 0 else 0)) / max(int(k.sum()), 9), 0.1))
        problem.weights[i] = 1.0 / max(s, 1e-9)
        sigma.append(s)
        tau.append(series_tau(e, r.group[k]))
    return sigma, tau


def _covariance_parts(
    problem: _DvlProblem, x: np.ndarray, tau: list[float], C_rb: np.ndarray, P_boresight_rad: np.ndarray
) -> dict[str, np.ndarray]:
    """The covariance of ``x[:4]`` (rad and -) in parts: each log's information over its
    correlation time ``tau`` with the biases known ("noise"), what estimating the biases under
    their prior adds ("beam biases"), the boresight's covariance through the solution's
    sensitivity to it ("boresight")."""
    _, J_all = problem.stacked(x, problem.V, prior=False)
    row_tau = np.repeat(tau, [int(k.sum()) for k in problem.keep])
    H_data = J_all.T @ (J_all / row_tau[:, None])
    H_prior = np.zeros((problem.n_x, problem.n_x))
    for r, o in zip(problem.rows, problem.offsets, strict=True):
        if o >= 0:
            H_prior[o : o + 4, o : o + 4] = np.eye(4) / r.bias_sigma_mps**2
    P = np.linalg.inv(H_data + H_prior)[:4, :4]
    P_known = np.linalg.inv(H_data[:4, :4])  # were the biases known
    # the boresight's share: d x / d beta = -(J^T J + prior)^-1 J^T d r / d beta, central differences
    step = 1e-6
    beta = euler_from_C_nb(C_rb)
    dr = np.zeros((J_all.shape[0], 3))
    for j in range(3):
        plus, minus = beta.copy(), beta.copy()
        plus[j] += step
        minus[j] -= step
        r_plus = problem.stacked(x, [r.v_ref_b(C_nb_from_euler(plus)) for r in problem.rows], prior=False)[0]
        r_minus = problem.stacked(x, [r.v_ref_b(C_nb_from_euler(minus)) for r in problem.rows], prior=False)[
            0
        ]
        dr[:, j] = (r_plus - r_minus) / (2.0 * step)
    S_beta = (np.linalg.inv(J_all.T @ J_all + H_prior) @ J_all.T @ dr)[:4]
    return {"noise": P_known, "beam biases": P - P_known, "boresight": S_beta @ P_boresight_rad @ S_beta.T}


def series_tau(e: np.ndarray, group: np.ndarray) -> float:
    """The correlation time of residuals ``e`` (n,), each group's series (a beam's, an axis's) in
    ping order, averaged weighted by its length."""
    taus, counts = [], []
    for g in np.unique(group):
        series = e[group == g]
        taus.append(correlation_time(series))
        counts.append(series.size)
    return float(np.average(taus, weights=counts)) if counts else 1.0
