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

    def with_nav(self, nav: NavState) -> "Nominal":
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
    """One aiding measurement, ``innovation = z (-) h(x_hat) ~ H dx + n``, n ~ N(0, R)."""

    z: np.ndarray           # (B, m) observation
    innovation: np.ndarray  # (B, m)
    H: np.ndarray           # (B, m, 20)
    R: np.ndarray           # (B, m, m)
    valid: np.ndarray       # (B,) bool: the source produced a measurement for this batch entry


@dataclass(frozen=True)
class UpdateOutcome:
    """What one correction did, per batch entry (the record PX4 keeps for every source)."""

    z: np.ndarray                  # (B, m)
    innovation: np.ndarray         # (B, m)
    innovation_var: np.ndarray     # (B, m) diagonal of S = H P H^T + R
    test_ratio: np.ndarray         # (B,) max_i nu_i^2 / (gate^2 S_ii); > 1 means rejected
    fused: np.ndarray              # (B,) bool
    rejected: np.ndarray           # (B,) bool: valid but failed the gate


def propagate(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """``P <- Phi P Phi^T + Qd``, symmetrised."""
    P = Phi @ P @ np.swapaxes(Phi, -1, -2) + Qd
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def correct(P: np.ndarray, nom: Nominal, meas: Measurement, gate_sigma: float,
            apply: np.ndarray | None = None) -> tuple[np.ndarray, Nominal, UpdateOutcome]:
    """Gated Joseph-form update and injection.

    The gate is the paper's (section 2.1.1): every component of the innovation must lie within
    ``gate_sigma`` standard deviations of its prediction, ``nu_i^2 <= gate^2 S_ii``; otherwise
    the whole measurement is rejected and recorded as such. ``apply`` (B,) masks batch entries
    that do not use this source (e.g. the standalone INS); they are left untouched.
    Joseph form ``P = (I - K H) P (I - K H)^T + K R K^T`` keeps P symmetric positive definite
    for any gain, including the zero gain of a rejected measurement.
    """
    valid = meas.valid if apply is None else meas.valid & apply
    H, R = meas.H, meas.R
    m = R.shape[-1]
    HT = np.swapaxes(H, -1, -2)
    S = H @ P @ HT + R
    S = np.where(valid[..., None, None], S, np.eye(m))
    nu = np.where(valid[..., None], meas.innovation, 0.0)
    s_diag = np.diagonal(S, axis1=-2, axis2=-1)
    test_ratio = np.max(nu**2 / (gate_sigma**2 * s_diag), axis=-1)
    fused = valid & (test_ratio <= 1.0)
    K = np.swapaxes(np.linalg.solve(S, H @ P), -1, -2)          # P H^T S^-1 (S, P symmetric)
    K = np.where(fused[..., None, None], K, 0.0)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    dx = mv(K, nu)
    outcome = UpdateOutcome(z=meas.z, innovation=meas.innovation,
                            innovation_var=np.where(valid[..., None], s_diag, np.nan),
                            test_ratio=np.where(valid, test_ratio, np.nan), fused=fused,
                            rejected=valid & ~fused)
    return P, inject(nom, dx), outcome
