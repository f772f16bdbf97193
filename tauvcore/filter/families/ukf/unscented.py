"""The unscented transform of a measurement about the error-state estimate, as the statistical
linearisation the bank's gated Joseph correction fuses.

Sigma points (Julier and Uhlmann 2004; the scaled points of van der Merwe 2004, as filterpy's
``MerweScaledSigmaPoints``) of the error ``dx ~ N(0, P)``, d states::

    chi_0 = 0,   chi_i = +sqrt(d + lambda) L e_i,   chi_{d+i} = -sqrt(d + lambda) L e_i,   P = L L^T
    lambda = alpha^2 (d + kappa) - d
    Wm_0 = lambda / (d + lambda),   Wc_0 = Wm_0 + 1 - alpha^2 + beta,   W_i = 1 / (2 (d + lambda))

Each is put on the estimate as a correction would put it (``x_hat (+) chi``,
tauvcore.filter.eskf.inject), and the measurement is evaluated there: its innovation
``nu_i = z (-) h(x_hat (+) chi_i)`` (the bank's own kernels and models, handed over as
``remeasure``). With ``dz_i = -(nu_i - nu_bar)`` the spread of the prediction about its mean::

    nu_bar = sum Wm_i nu_i,   P_zz = sum Wc_i dz_i dz_i^T,   P_xz = sum Wc_i chi_i dz_i^T

The unscented update is ``K = P_xz (P_zz + R)^-1``, ``dx = K nu_bar``, ``P <- P - K (P_zz + R) K^T``.
Its statistical linearisation ``H_s = P_xz^T P^-1``, ``R_s = R + P_zz - H_s P H_s^T`` gives the
same update through the Kalman equations: ``H_s P H_s^T + R_s = P_zz + R``, ``P H_s^T = P_xz``, and
the Joseph form ``(I - K H_s) P (I - K H_s)^T + K R_s K^T = P - K (P_zz + R) K^T``. So the family
hands ``(H_s, R_s, nu_bar)`` to the bank's one gated correction (its gate, records, NIS and
``log det S`` included) instead of carrying a correction of its own. For a measurement linear in
the error, ``H_s = H`` and ``R_s = R``: the filter is the Kalman filter
(tests/unit/tauvcore/filter/families/ukf/test_ukf.py).

alpha = 1, beta = 2, kappa = 0: every weight is non-negative (so ``P_zz`` and the Schur complement
``R_s - R`` stay positive semidefinite, which a negative ``Wc_0``, e.g. kappa = 3 - d, does not
promise), and the points sit sqrt(d) sigma out (4.5 sigma for d = 20), where the measurement's
curvature over the filter's uncertainty shows. A filter whose P has no Cholesky factor (the bank
repairs such a P at the epoch's end) keeps the Jacobian at the estimate for that correction.
"""

from __future__ import annotations

import numpy as np

from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.families.spec import Remeasure

ALPHA = 1.0
"""The sigma points' spread, scaling sqrt(d + kappa) [-]."""
BETA = 2.0
"""Prior knowledge of the distribution in the central covariance weight (2: Gaussian) [-]."""
KAPPA = 0.0
"""Secondary spread parameter [-]."""


def weights(d: int) -> tuple[float, np.ndarray, np.ndarray]:
    """The scaled unscented transform's parameter and weights for a d-state error.

    Parameters
    ----------
    d : int
        The error state's size.

    Returns
    -------
    lam : float
        ``lambda = alpha^2 (d + kappa) - d`` [-].
    wm : numpy.ndarray
        The mean's weights, shape (2 d + 1,) [-], summing to 1.
    wc : numpy.ndarray
        The covariance's weights, shape (2 d + 1,) [-].
    """
    lam = ALPHA**2 * (d + KAPPA) - d
    wm = np.full(2 * d + 1, 0.5 / (d + lam))
    wc = wm.copy()
    wm[0] = lam / (d + lam)
    wc[0] = wm[0] + 1.0 - ALPHA**2 + BETA
    return lam, wm, wc


def sigma_offsets(L: np.ndarray, lam: float) -> np.ndarray:
    """The sigma points of ``N(0, L L^T)`` as offsets from the estimate.

    Parameters
    ----------
    L : numpy.ndarray
        Lower Cholesky factors of the error covariances, shape (..., d, d), in the states' SI units.
    lam : float
        The transform's ``lambda`` (:func:`weights`).

    Returns
    -------
    numpy.ndarray
        ``chi``, shape (2 d + 1, ..., d): zero, then the columns of ``sqrt(d + lambda) L``, then
        their negatives, in the states' SI units.
    """
    d = L.shape[-1]
    columns = np.moveaxis(np.sqrt(d + lam) * L, -1, 0)  # (d, ..., d): column i first
    return np.concatenate([np.zeros((1,) + columns.shape[1:]), columns, -columns])


def linearize(
    P: np.ndarray,
    nominal: Nominal,
    remeasure: Remeasure,
    measurement: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    geodetic: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The statistical linearisation of a measurement over the sigma points of the filters' errors.

    The rows not in use, and the filters whose P has no Cholesky factor, keep the given values.

    Parameters
    ----------
    P : numpy.ndarray
        The filters' error covariances, shape (M, R, d, d), in the states' SI units squared.
    nominal : Nominal
        Their estimates, batch (M, R).
    remeasure : Remeasure
        The innovation ``z (-) h(x)`` at nominal states of batch (B', R) -> (B', R, m).
    measurement : tuple of numpy.ndarray
        ``(H, R, nu, active)`` at the estimate: Jacobians (M, R, m, d), noise (M, R, m, m),
        innovations (M, R, m) in the measurement's SI unit, the rows in use (M, R, m) bool.
    geodetic : bool
        Positions are latitude, longitude, depth (tauvcore.filter.eskf.inject).

    Returns
    -------
    H : numpy.ndarray
        ``H_s = P_xz^T P^-1``, shape (M, R, m, d), in the measurement's SI unit over each state's.
    R : numpy.ndarray
        ``R_s = R + P_zz - H_s P H_s^T``, shape (M, R, m, m), in the measurement's unit squared.
    nu : numpy.ndarray
        ``nu_bar``, the weighted mean of the sigma points' innovations, shape (M, R, m).
    """
    H, Rm, nu, active = measurement
    M, R, m, d = H.shape
    factor, ok = _cholesky(P)
    lam, wm, wc = weights(d)
    chi = sigma_offsets(factor, lam)  # (S, M, R, d)
    S = chi.shape[0]
    points = inject(nominal, chi, geodetic).reshaped((S * M, R))
    nu_s = np.where(active, remeasure(points).reshape(S, M, R, m), 0.0)  # a row not in use carries nothing
    nu_bar = np.einsum("s,s...->...", wm, nu_s)
    dz = nu_bar - nu_s  # the prediction's spread about its mean
    P_xz = np.einsum("s,s...i,s...j->...ij", wc, chi, dz)
    P_zz = np.einsum("s,s...i,s...j->...ij", wc, dz, dz)
    G = np.linalg.solve(factor, P_xz)  # L^-1 P_xz: H_s = G^T L^-1, H_s P H_s^T = G^T G
    H_s = np.swapaxes(np.linalg.solve(np.swapaxes(factor, -1, -2), G), -1, -2)
    spread = P_zz - np.swapaxes(G, -1, -2) @ G
    R_s = Rm + 0.5 * (spread + np.swapaxes(spread, -1, -2))
    use = active & ok[..., None]
    both = use[..., :, None] & use[..., None, :]
    return (
        np.where(use[..., None], H_s, H),
        np.where(both, R_s, Rm),
        np.where(use, nu_bar, nu),
    )


def _cholesky(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower Cholesky factors of P (..., d, d) and where they exist (...,) bool (the identity
    stands in where they do not)."""
    try:
        return np.linalg.cholesky(P), np.ones(P.shape[:-2], bool)
    except np.linalg.LinAlgError:
        pass
    flat = P.reshape((-1,) + P.shape[-2:])
    factor = np.broadcast_to(np.eye(P.shape[-1]), flat.shape).copy()
    ok = np.zeros(flat.shape[0], bool)
    for i, Pi in enumerate(flat):
        try:
            factor[i] = np.linalg.cholesky(Pi)
            ok[i] = True
        except np.linalg.LinAlgError:
            continue
    return factor.reshape(P.shape), ok.reshape(P.shape[:-2])
