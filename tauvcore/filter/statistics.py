"""Chi-square quantiles and the normalised estimation error squared (NEES), for any batch of
errors and covariances: what the filter's gate, the engine's divergence monitor and the
consistency summaries (tauvcore.eval.consistency) are built on."""

from __future__ import annotations

import numpy as np


def chi2_ppf(q: float | np.ndarray, dof: float | np.ndarray) -> np.ndarray:
    """Quantile of the chi-square distribution, ``2 P^-1(dof / 2, q)`` (the regularised incomplete
    gamma function's inverse: what ``scipy.stats.chi2.ppf`` computes, without importing
    scipy.stats, which costs 0.3 s of every command's start). scipy.special itself is imported
    here, at the first call, not with this module: it costs 0.25 s, which ``tauv --help`` and
    ``tauv config`` need not pay."""
    from scipy import special

    return 2.0 * special.gammaincinv(np.asarray(dof, dtype=float) / 2.0, q)


def chi2_isf(p: float | np.ndarray, dof: float | np.ndarray) -> np.ndarray:
    """Upper quantile: ``chi2_ppf(1 - p, dof)`` without the round-off of ``1 - p`` for tiny p."""
    from scipy import special

    return 2.0 * special.gammainccinv(np.asarray(dof, dtype=float) / 2.0, p)


def _flat(dx: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """dx and P broadcast together, in the kernels' one-leading-axis layout, and their batch shape."""
    from tauvcore.filter.kernels.common import flat

    n = dx.shape[-1]
    batch = np.broadcast_shapes(dx.shape[:-1], P.shape[:-2])
    return flat(dx, batch, (n,)), flat(P, batch, (n, n)), batch


def nees(dx: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``dx^T P^-1 dx``. dx (..., n), P (..., n, n) -> (...).

    By Cholesky (the kernel :func:`tauvcore.filter.kernels.nees.quadratic_into` the filter bank's records
    use). NaN for an entry whose dx or P is not finite or whose P is not positive definite (a
    diverged filter's record, never an exception)."""
    from tauvcore.filter.kernels.nees import nees_batch

    dx_f, P_f, batch = _flat(np.asarray(dx), np.asarray(P))
    return nees_batch(dx_f, P_f).reshape(batch)


def block_nees(dx: np.ndarray, P: np.ndarray, block_of_state: np.ndarray, num_blocks: int) -> np.ndarray:
    """NEES of every block of a partition of the state at once. -> (..., num_blocks).

    ``block_of_state`` (n,) gives each state's block (0 .. num_blocks - 1; every state in one).
    Block b's NEES is ``dx_b^T (P_bb)^-1 dx_b`` with P_bb the marginal covariance of the block,
    one Cholesky factorisation per block. NaN for a block whose error or marginal covariance is not
    finite or not positive definite (the other blocks keep their values)."""
    from tauvcore.filter.kernels.nees import block_nees_batch

    dx_f, P_f, batch = _flat(np.asarray(dx), np.asarray(P))
    out = block_nees_batch(dx_f, P_f, np.ascontiguousarray(block_of_state, dtype=np.int64), int(num_blocks))
    return out.reshape(batch + (num_blocks,))
