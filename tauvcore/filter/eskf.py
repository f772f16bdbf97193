"""Error-state EKF: nominal state, covariance propagation, Joseph-form correction with the
innovation gate, closed-loop injection and reset (Tal et al. 2017 section 2.1.1).

Everything takes a leading batch shape ``B`` (methods x Monte Carlo runs). "How" a source is
modelled lives in ``tauvcore.aiding``; this module only knows a :class:`Measurement`.

Numerical safeguards (issue 7), none of which acts on a healthy filter:

- :func:`correct` fuses nothing for a batch entry whose innovation covariance ``S`` is not
  finite or not positive definite (its Cholesky factorisation fails) and says so in
  :attr:`UpdateOutcome.unusable`, instead of raising ``LinAlgError`` or injecting NaN.
- :func:`condition_covariance` (called by the runner after the corrections of every aiding
  epoch and once per second of propagation) keeps P symmetric positive definite: when P's
  Cholesky factorisation fails, the eigenvalues of its correlation matrix ``D^-1 P D^-1``
  (``D = sqrt(diag P)``) are raised to :data:`P_CORRELATION_EIGEN_FLOOR` and P rebuilt; every
  such repair is counted. Working on the correlation matrix makes the floor independent of the
  states' units (m^2 next to (rad/s)^2), and Cholesky's success is itself invariant to that
  diagonal scaling.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import exp_so3, log_so3
from tauvcore.ins.strapdown import NavState, mv

P_CORRELATION_EIGEN_FLOOR = 1e-9
"""Smallest eigenvalue of P's correlation matrix after a repair (:func:`condition_covariance`).

Beyond removing the negative part, raising a correlation eigenvalue to 1e-9 adds at most 1e-9 of
the states' own variances along the repaired direction (a sigma grows by at most 5e-10 relative),
far below anything the filter resolves, while the repaired P has a correlation condition number
<= 20 / 1e-9 and factorises with a wide margin (double precision fails near 1e-15)."""

P_VARIANCE_FLOOR = 1e-16
"""Smallest diagonal entry of P after a repair, in the state's SI unit squared: the same floor
as the initial covariance's (tauvcore.eval.runner.initial_covariance), e.g. 1e-8 m or 2e-3 deg/h
of gyro bias as a 1-sigma, below anything the filter estimates."""


@dataclass(frozen=True)
class Nominal:
    """Full nominal state: navigation solution plus the estimated sensor errors (batch ``B``)."""

    nav: NavState
    accel_bias: np.ndarray  # (B, 3) [m/s^2]
    gyro_bias: np.ndarray   # (B, 3) [rad/s]
    dvl_bias: np.ndarray    # (B, 4) [m/s]
    dvl_sf: np.ndarray      # (B,) [-]

    @property
    def vel_b(self) -> np.ndarray:
        return self.nav.vel_b

    def with_nav(self, nav: NavState) -> Nominal:
        return Nominal(nav, self.accel_bias, self.gyro_bias, self.dvl_bias, self.dvl_sf)


def inject(nom: Nominal, dx: np.ndarray) -> Nominal:
    """Closed-loop correction ``x_hat <- x_hat (+) dx`` (reset of dx to zero is implicit).

    Position and biases add; ``C_nb <- exp([rho x]) C_nb``; the body-frame velocity adds
    (the error is defined in b), and ``vel_n`` is rebuilt with the corrected attitude. The
    reset Jacobian ``I - [rho x]/2`` of the misalignment block is taken as I (rho < 1e-2 rad).
    """
    C1 = exp_so3(dx[..., STATE.att]) @ nom.nav.C_nb
    vel_b = nom.vel_b + dx[..., STATE.vel]
    nav = NavState(pos_n=nom.nav.pos_n + dx[..., STATE.pos], vel_n=mv(C1, vel_b), C_nb=C1)
    return Nominal(nav=nav,
                   accel_bias=nom.accel_bias + dx[..., STATE.ba],
                   gyro_bias=nom.gyro_bias + dx[..., STATE.bg],
                   dvl_bias=nom.dvl_bias + dx[..., STATE.b_dvl],
                   dvl_sf=nom.dvl_sf + dx[..., STATE.sf_dvl][..., 0])


def difference(true: Nominal, est: Nominal) -> np.ndarray:
    """``true (-) est``: the error state that :func:`inject` would need. -> (B, 20)."""
    batch = est.vel_b.shape[:-1]
    dx = np.zeros(batch + (STATE.dim,))
    dx[..., STATE.pos] = true.nav.pos_n - est.nav.pos_n
    dx[..., STATE.att] = log_so3(true.nav.C_nb @ np.swapaxes(est.nav.C_nb, -1, -2))
    dx[..., STATE.vel] = true.vel_b - est.vel_b
    dx[..., STATE.ba] = true.accel_bias - est.accel_bias
    dx[..., STATE.bg] = true.gyro_bias - est.gyro_bias
    dx[..., STATE.b_dvl] = true.dvl_bias - est.dvl_bias
    dx[..., STATE.sf_dvl] = (true.dvl_sf - est.dvl_sf)[..., None]
    return dx


@dataclass(frozen=True)
class Measurement:
    """One aiding measurement, ``innovation = z (-) h(x_hat) ~ H dx + n``, n ~ N(0, R).

    ``active`` (B, m) marks the rows that carry information; an inactive row (an unmeasured
    axis, a beam that did not return) is dropped exactly: its H row, innovation and R row and
    column are removed from the update, not given a huge variance (which would leave round-off
    in the Joseph form). ``gate_rows``: gate each row on its own (tightly coupled beams), or
    the whole vector at once (a velocity solution).
    """

    z: np.ndarray           # (B, m) observation
    innovation: np.ndarray  # (B, m)
    H: np.ndarray           # (B, m, 20)
    R: np.ndarray           # (B, m, m)
    valid: np.ndarray       # (B,) bool: the source produced a measurement for this batch entry
    active: np.ndarray | None = None  # (B, m) bool rows in use; None = all
    gate_rows: bool = False


@dataclass(frozen=True)
class UpdateOutcome:
    """What one correction did, per batch entry (the record PX4 keeps for every source)."""

    z: np.ndarray                  # (B, m)
    innovation: np.ndarray         # (B, m)
    innovation_var: np.ndarray     # (B, m) diagonal of S = H P H^T + R (NaN for unused rows)
    test_ratio: np.ndarray         # (B,) max over active rows of nu_i^2 / (gate^2 S_ii); > 1: rejected
    fused: np.ndarray              # (B,) bool: at least one row fused
    rejected: np.ndarray           # (B,) bool: at least one valid row failed the gate
    fused_rows: np.ndarray         # (B, m) bool
    rejected_rows: np.ndarray      # (B, m) bool
    nis: np.ndarray                # (B,) normalised innovation squared nu^T S^-1 nu over the active rows, before
    #                                the gate (NaN: no active row, or S unusable)
    nis_dof: np.ndarray            # (B,) int: number of active rows (the NIS's chi-square degrees of freedom;
    #                                rows of an unusable update count too: the source did measure)
    unusable: np.ndarray           # (B,) bool: S not finite or not positive definite: nothing fused


def propagate(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """``P <- Phi P Phi^T + Qd``, symmetrised."""
    P = Phi @ P @ np.swapaxes(Phi, -1, -2) + Qd
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def _is_positive_definite(A: np.ndarray) -> np.ndarray:
    """(B,) bool: ``A`` (B, n, n) is finite and its Cholesky factorisation succeeds.

    One batched factorisation on the normal path; entry by entry only when it fails. LAPACK lets
    a NaN through to the factor instead of failing, hence the finiteness test on the factor's
    diagonal (a NaN or inf anywhere in the lower triangle reaches the diagonal of its row)."""
    try:
        return np.isfinite(np.diagonal(np.linalg.cholesky(A), axis1=-2, axis2=-1)).all(axis=-1)
    except np.linalg.LinAlgError:
        pass
    flat = A.reshape((-1,) + A.shape[-2:])
    ok = np.zeros(flat.shape[0], dtype=bool)
    for i in range(flat.shape[0]):
        try:
            ok[i] = np.isfinite(np.diagonal(np.linalg.cholesky(flat[i]))).all()
        except np.linalg.LinAlgError:
            pass
    return ok.reshape(A.shape[:-2])


def condition_covariance(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Keep P symmetric positive definite; returns ``(P, repaired)`` with ``repaired`` (B,) bool.

    A batch entry whose P is finite but fails its Cholesky factorisation (an eigenvalue at or
    below round-off, or negative) is rebuilt from its correlation matrix with the eigenvalues
    raised to :data:`P_CORRELATION_EIGEN_FLOOR`, and its diagonal raised to
    :data:`P_VARIANCE_FLOOR`: ``P <- D V max(L, floor) V^T D``, ``D = sqrt(max(diag P, floor))``.
    A healthy P is returned unchanged (the same array); a non-finite P cannot be repaired and is
    left for the divergence monitor (tauvcore.eval.metrics).
    """
    ok = _is_positive_definite(P)
    if ok.all():
        return P, ~ok
    repair = ~ok & np.isfinite(P).all(axis=(-2, -1))
    if not repair.any():
        return P, repair
    P = P.copy()
    Pb = P[repair]
    d = np.sqrt(np.maximum(np.diagonal(Pb, axis1=-2, axis2=-1), P_VARIANCE_FLOOR))
    corr = Pb / (d[..., :, None] * d[..., None, :])
    corr = 0.5 * (corr + np.swapaxes(corr, -1, -2))
    lam, V = np.linalg.eigh(corr)
    corr = (V * np.maximum(lam, P_CORRELATION_EIGEN_FLOOR)[..., None, :]) @ np.swapaxes(V, -1, -2)
    Pb = corr * (d[..., :, None] * d[..., None, :])
    Pb = 0.5 * (Pb + np.swapaxes(Pb, -1, -2))
    diag = np.diagonal(Pb, axis1=-2, axis2=-1)
    Pb = Pb + np.maximum(P_VARIANCE_FLOOR - diag, 0.0)[..., None] * np.eye(P.shape[-1])
    P[repair] = Pb
    return P, repair


def _keep_rows(H: np.ndarray, R: np.ndarray, nu: np.ndarray, keep: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Remove the rows not in ``keep`` exactly (zero H row and innovation, unit R diagonal, no
    cross-covariance): the update is then identical to one without those rows."""
    both = keep[..., :, None] & keep[..., None, :]
    R = np.where(both, R, 0.0) + np.eye(R.shape[-1]) * (~keep)[..., None, :]
    return H * keep[..., None], R, np.where(keep, nu, 0.0)


def correct(P: np.ndarray, nom: Nominal, meas: Measurement, gate_sigma: float,
            apply: np.ndarray | None = None) -> tuple[np.ndarray, Nominal, UpdateOutcome]:
    """Gated Joseph-form update and injection.

    The gate is the paper's (section 2.1.1): a row must lie within ``gate_sigma`` standard
    deviations of its prediction, ``nu_i^2 <= gate^2 S_ii``. A vector measurement is rejected
    whole if any row fails (``gate_rows`` False), a row-gated one loses only the failing rows;
    every rejection is recorded. ``apply`` (B,) masks batch entries that do not use this source
    (e.g. the standalone INS); they are left untouched. Joseph form
    ``P = (I - K H) P (I - K H)^T + K R K^T`` keeps P symmetric positive definite for any gain,
    including the zero gain of a rejected measurement.

    An entry whose ``S`` over its active rows is not finite or not positive definite fuses
    nothing and keeps its P and state (``unusable``; its rows count as rejected). The record
    also carries the entry's normalised innovation squared ``nu^T S^-1 nu`` over the active rows
    before the gate, for the divergence monitor.
    """
    valid = meas.valid if apply is None else meas.valid & apply
    m = meas.R.shape[-1]
    active = np.ones(valid.shape + (m,), dtype=bool) if meas.active is None else meas.active.astype(bool)
    active = active & valid[..., None]
    H, R, nu = _keep_rows(meas.H, meas.R, meas.innovation, active)
    HT = np.swapaxes(H, -1, -2)
    S_active = H @ P @ HT + R
    usable = _is_positive_definite(S_active)
    unusable = ~usable & active.any(axis=-1)
    if not usable.all():
        # no fusion for these entries: zero rows, and a stand-in P that keeps the algebra finite
        active_use = active & usable[..., None]
        P_in, P = P, np.where(usable[..., None, None], P, np.eye(P.shape[-1]))
        H, R, nu = _keep_rows(H, R, nu, active_use)
        HT = np.swapaxes(H, -1, -2)
        S_active = H @ P @ HT + R
    else:
        active_use, P_in = active, P
    s_diag = np.diagonal(S_active, axis1=-2, axis2=-1)
    # one solve gives S^-1 nu for the NIS and, when the gate keeps every active row, the gain
    sol = np.linalg.solve(S_active, np.concatenate((H @ P, nu[..., None]), axis=-1))
    nis = np.einsum("...i,...i->...", nu, sol[..., -1])
    ratio_rows = np.where(active_use, nu**2 / (gate_sigma**2 * s_diag), 0.0)
    if meas.gate_rows:
        keep = active_use & (ratio_rows <= 1.0)
    else:
        keep = active_use & np.all(ratio_rows <= 1.0, axis=-1)[..., None]
    if np.array_equal(keep, active_use):
        K = np.swapaxes(sol[..., :-1], -1, -2)                   # P H^T S^-1 (S, P symmetric)
    else:
        H, R, nu = _keep_rows(H, R, nu, keep)
        HT = np.swapaxes(H, -1, -2)
        S = H @ P @ HT + R
        K = np.swapaxes(np.linalg.solve(S, H @ P), -1, -2)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    dx = mv(K, nu)
    if not usable.all():
        P = np.where(usable[..., None, None], P, P_in)
    any_active = active_use.any(axis=-1)
    outcome = UpdateOutcome(z=meas.z, innovation=meas.innovation,
                            innovation_var=np.where(active_use, s_diag, np.nan),
                            test_ratio=np.where(any_active, ratio_rows.max(axis=-1), np.nan),
                            fused=keep.any(axis=-1), rejected=(active & ~keep).any(axis=-1),
                            fused_rows=keep, rejected_rows=active & ~keep,
                            nis=np.where(any_active, nis, np.nan), nis_dof=active.sum(axis=-1),
                            unusable=unusable)
    return P, inject(nom, dx), outcome
