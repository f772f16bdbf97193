"""Error-state EKF: nominal state, covariance propagation, Joseph-form correction with the
innovation gate, closed-loop injection and reset (Tal et al. 2017 section 2.1.1).

Everything takes a leading batch shape ``B`` (methods x Monte Carlo runs). "How" a source is
modelled lives in ``tauvcore.aiding``; this module only knows a :class:`Measurement`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import exp_so3, log_so3
from tauvcore.ins.strapdown import NavState, mv


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


def propagate(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """``P <- Phi P Phi^T + Qd``, symmetrised."""
    P = Phi @ P @ np.swapaxes(Phi, -1, -2) + Qd
    return 0.5 * (P + np.swapaxes(P, -1, -2))


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
    """
    valid = meas.valid if apply is None else meas.valid & apply
    m = meas.R.shape[-1]
    active = np.ones(valid.shape + (m,), dtype=bool) if meas.active is None else meas.active.astype(bool)
    active = active & valid[..., None]
    H, R, nu = _keep_rows(meas.H, meas.R, meas.innovation, active)
    HT = np.swapaxes(H, -1, -2)
    s_diag = np.diagonal(H @ P @ HT + R, axis1=-2, axis2=-1)
    ratio_rows = np.where(active, nu**2 / (gate_sigma**2 * s_diag), 0.0)
    if meas.gate_rows:
        keep = active & (ratio_rows <= 1.0)
    else:
        keep = active & np.all(ratio_rows <= 1.0, axis=-1)[..., None]
    H, R, nu = _keep_rows(H, R, nu, keep)
    HT = np.swapaxes(H, -1, -2)
    S = H @ P @ HT + R
    K = np.swapaxes(np.linalg.solve(S, H @ P), -1, -2)          # P H^T S^-1 (S, P symmetric)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    dx = mv(K, nu)
    any_active = active.any(axis=-1)
    outcome = UpdateOutcome(z=meas.z, innovation=meas.innovation,
                            innovation_var=np.where(active, s_diag, np.nan),
                            test_ratio=np.where(any_active, ratio_rows.max(axis=-1), np.nan),
                            fused=keep.any(axis=-1), rejected=(active & ~keep).any(axis=-1),
                            fused_rows=keep, rejected_rows=active & ~keep)
    return P, inject(nom, dx), outcome
