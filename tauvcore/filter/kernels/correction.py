"""The error state's arithmetic with the nominal state, compiled: the gated Joseph-form
correction (tauvcore.filter.eskf.correct), the closed-loop injection ``x_hat (+) dx``
(tauvcore.filter.eskf.inject), and the difference ``true (-) estimate``
(tauvcore.filter.eskf.difference); positions on WGS-84 through the metric at the estimate."""

from __future__ import annotations

import math

import numpy as np

from tauvcore.filter.kernels.common import ATT, BA, BDVL, BG, NAV, POS, SF, VEL, N, jit, radii_nav
from tauvcore.filter.kernels.nees import cholesky_into
from tauvcore.filter.kernels.rotation_kernels import exp_so3_into, log_so3_into


@jit
def _solve_chol(L: np.ndarray, n: int, b: np.ndarray, x: np.ndarray) -> None:
    """Solve ``L L^T x = b`` (n,) with the factor in ``L[:n, :n]``."""
    for i in range(n):
        t = b[i]
        for k in range(i):
            t -= L[i, k] * x[k]
        x[i] = t / L[i, i]
    for i in range(n - 1, -1, -1):
        t = x[i]
        for k in range(i + 1, n):
            t -= L[k, i] * x[k]
        x[i] = t / L[i, i]


@jit
def _active_rows(active: np.ndarray, keep: np.ndarray, s_diag: np.ndarray, rows: np.ndarray) -> int:
    """The rows in use (``active`` (m,) True), in order, into ``rows[:n_a]``; ``keep`` (m,) cleared
    and ``s_diag`` (m,) NaN everywhere. -> ``n_a``."""
    n_a = 0
    for i in range(active.shape[0]):
        keep[i] = False
        s_diag[i] = np.nan
        if active[i]:
            rows[n_a] = i
            n_a += 1
    return n_a


@jit
def _hp_into(H: np.ndarray, P: np.ndarray, rows: np.ndarray, n: int, U: np.ndarray) -> None:
    """``U[a] = H[rows[a]] P`` for the first ``n`` rows in use: H (m, d), P (d, d), U (m, d)."""
    d = P.shape[0]
    for a in range(n):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += H[rows[a], k] * P[k, j]
            U[a, j] = s


@jit
def _innovation_cov_into(
    U: np.ndarray, H: np.ndarray, Rm: np.ndarray, rows: np.ndarray, n: int, S: np.ndarray
) -> None:
    """``S = R + U H^T = R + H P H^T`` over the first ``n`` rows in use (``rows[:n]``) into
    ``S[:n, :n]``: U (m, d) from :func:`_hp_into`, H (m, d), Rm (m, m)."""
    d = U.shape[1]
    for a in range(n):
        for b in range(n):
            s = Rm[rows[a], rows[b]]
            for k in range(d):
                s += U[a, k] * H[rows[b], k]
            S[a, b] = s


@jit
def _gate_into(
    nu_a: np.ndarray,
    sol: np.ndarray,
    S: np.ndarray,
    rows: np.ndarray,
    n_a: int,
    gate_rows: bool,
    gate_sigma: float,
    keep: np.ndarray,
    s_diag: np.ndarray,
) -> tuple[float, float]:
    """The NIS ``nu^T S^-1 nu`` (``sol = S^-1 nu`` over the ``n_a`` active rows) and the gate:
    row ``a`` passes if ``nu_a^2 <= gate^2 S_aa``; ``keep`` (m,) the rows that pass (all or none
    unless ``gate_rows``), ``s_diag`` (m,) S's diagonal at the active rows. -> ``(nis,
    largest test ratio nu_a^2 / (gate^2 S_aa))``."""
    nis = 0.0
    ratio_max = 0.0
    all_pass = True
    for a in range(n_a):
        nis += nu_a[a] * sol[a]
        s_diag[rows[a]] = S[a, a]
        ratio = nu_a[a] * nu_a[a] / (gate_sigma * gate_sigma * S[a, a])
        ratio_max = max(ratio_max, ratio)
        keep[rows[a]] = ratio <= 1.0
        all_pass = all_pass and ratio <= 1.0
    if not gate_rows and not all_pass:
        for a in range(n_a):
            keep[rows[a]] = False
    return nis, ratio_max


@jit
def _compact_kept(keep: np.ndarray, rows: np.ndarray, n_a: int, U: np.ndarray, nu_a: np.ndarray) -> int:
    """Move the kept rows among the first ``n_a`` in use to the front of ``rows``, ``U`` and
    ``nu_a``, in order. -> their number ``n_k``."""
    n_k = 0
    for a in range(n_a):
        if keep[rows[a]]:
            if n_k != a:
                rows[n_k] = rows[a]
                for j in range(U.shape[1]):
                    U[n_k, j] = U[a, j]
                nu_a[n_k] = nu_a[a]
            n_k += 1
    return n_k


@jit
def _gain_into(
    U: np.ndarray, L: np.ndarray, n_k: int, consider_start: int, consider_stop: int, K: np.ndarray
) -> None:
    """The gain ``K = P H^T S^-1 = (S^-1 U)^T`` over the ``n_k`` kept rows into ``K[:, :n_k]``
    (d, m): column j of U (m, d) through the factor ``S = L L^T`` (``L[:n_k, :n_k]``); zero on
    the rows of the consider states ``consider_start <= j < consider_stop``, never corrected."""
    m = L.shape[0]
    col = np.empty(m)
    out = np.empty(m)
    for j in range(U.shape[1]):
        if consider_start <= j < consider_stop:
            for a in range(n_k):
                K[j, a] = 0.0
            continue
        for a in range(n_k):
            col[a] = U[a, j]
        _solve_chol(L, n_k, col, out)
        for a in range(n_k):
            K[j, a] = out[a]


@jit
def _joseph_into(
    P: np.ndarray, H: np.ndarray, Rm: np.ndarray, K: np.ndarray, rows: np.ndarray, n_k: int
) -> None:
    """The Joseph form in place, ``P <- (I - K H) P (I - K H)^T + K R K^T``, over the ``n_k`` kept
    rows ``rows[:n_k]`` of H (m, d) and Rm (m, m) with K (d, m); P (d, d) stays symmetric (its
    upper triangle computed, mirrored below): stable for any K, also a non-optimal one."""
    d = P.shape[0]
    IKH = np.empty((d, d))
    for i in range(d):
        for j in range(d):
            s = 1.0 if i == j else 0.0
            for a in range(n_k):
                s -= K[i, a] * H[rows[a], j]
            IKH[i, j] = s
    W = np.empty((d, d))
    for i in range(d):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += IKH[i, k] * P[k, j]
            W[i, j] = s
    KR = np.empty((d, K.shape[1]))
    for i in range(d):
        for b in range(n_k):
            s = 0.0
            for a in range(n_k):
                s += K[i, a] * Rm[rows[a], rows[b]]
            KR[i, b] = s
    for i in range(d):
        for j in range(i, d):
            s = 0.0
            for k in range(d):
                s += W[i, k] * IKH[j, k]
            t = 0.0
            for b in range(n_k):
                t += KR[i, b] * K[j, b]
            P[i, j] = s + t
    for i in range(d):
        for j in range(i):
            P[i, j] = P[j, i]


@jit
def correct_into(  # noqa: PLR0913 - compiled kernel (pyproject.toml)
    P: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: bool,
    gate_sigma: float,
    dx: np.ndarray,
    s_diag: np.ndarray,
    keep: np.ndarray,
    consider_start: int,
    consider_stop: int,
) -> tuple[float, float, bool, float]:
    """Gated Joseph-form correction of one filter (tauvcore.filter.eskf.correct), P in place: the
    one correction of every filter family.

    Rows with ``active`` False are dropped exactly. ``S`` over the active rows must factorise
    (else: unusable, nothing fused). The paper's gate keeps a row if ``nu_i^2 <= gate^2 S_ii``
    (all rows or none unless ``gate_rows``). Fills ``dx`` (n,) for P (n, n), ``s_diag`` (m,; NaN where not
    used), ``keep`` (m,); returns ``(nis, test_ratio, unusable, log_det_s)`` (NaN when no row was used;
    ``log_det_s`` NaN also when S is unusable): ``log det S = 2 sum_a log L_aa`` of the factor
    ``S = L L^T`` over the active rows, before the gate, the term the innovations' likelihood needs
    beside the NIS (``-2 log p(nu) = NIS + log det S + dof log 2 pi``). The states
    ``consider_start <= j < consider_stop`` are consider states (Schmidt-Kalman: their rows of K
    are zero, so they are never corrected, while the Joseph form carries their covariance with
    the others'; Yoo 2014's DVL errors); ``0, 0``: none.
    """
    m = nu.shape[0]
    d = P.shape[0]  # the error states: the 20 of the layout and a source's own after them
    rows = np.empty(m, dtype=np.int64)
    n_a = _active_rows(active, keep, s_diag, rows)
    dx[:] = 0.0
    if n_a == 0:
        return np.nan, np.nan, False, np.nan
    U = np.empty((m, d))  # H P over the rows in use
    S = np.empty((m, m))
    L = np.empty((m, m))
    _hp_into(H, P, rows, n_a, U)
    _innovation_cov_into(U, H, Rm, rows, n_a, S)
    ident = np.arange(m)
    if not cholesky_into(S, ident, n_a, L):
        return np.nan, np.nan, True, np.nan
    log_det = 0.0
    for a in range(n_a):
        log_det += 2.0 * math.log(L[a, a])
    nu_a = np.empty(m)
    sol = np.empty(m)
    for a in range(n_a):
        nu_a[a] = nu[rows[a]]
    _solve_chol(L, n_a, nu_a, sol)
    nis, ratio_max = _gate_into(nu_a, sol, S, rows, n_a, gate_rows, gate_sigma, keep, s_diag)
    n_k = _compact_kept(keep, rows, n_a, U, nu_a)
    if n_k == 0:
        return nis, ratio_max, False, log_det
    if n_k != n_a:  # S over the kept rows
        _innovation_cov_into(U, H, Rm, rows, n_k, S)
        if not cholesky_into(S, ident, n_k, L):
            return nis, ratio_max, True, log_det
    K = np.empty((d, m))
    _gain_into(U, L, n_k, consider_start, consider_stop, K)
    _joseph_into(P, H, Rm, K, rows, n_k)
    for i in range(d):
        s = 0.0
        for a in range(n_k):
            s += K[i, a] * nu_a[a]
        dx[i] = s
    return nis, ratio_max, False, log_det


@jit
def correct_batch(
    P: np.ndarray,
    H: np.ndarray,
    Rm: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: np.ndarray,
    gate_sigma: float,
    consider_start: int,
    consider_stop: int,
) -> tuple:
    """:func:`correct_into` for n filters: P (n, d, d) in place, H (n, m, d), Rm (n, m, m), nu,
    active (n, m), gate_rows (n,), the consider states ``consider_start:consider_stop``. -> dx (n, d),
    s_diag (n, m), keep (n, m), nis, test_ratio, unusable, log_det_s (n,)."""
    n, m = nu.shape
    dx = np.empty((n, P.shape[-1]))
    s_diag = np.empty((n, m))
    keep = np.empty((n, m), dtype=np.bool_)
    nis = np.empty(n)
    ratio = np.empty(n)
    unusable = np.empty(n, dtype=np.bool_)
    log_det = np.empty(n)
    for i in range(n):
        nis[i], ratio[i], unusable[i], log_det[i] = correct_into(
            P[i],
            H[i],
            Rm[i],
            nu[i],
            active[i],
            gate_rows[i],
            gate_sigma,
            dx[i],
            s_diag[i],
            keep[i],
            consider_start,
            consider_stop,
        )
    return dx, s_diag, keep, nis, ratio, unusable, log_det


@jit
def add_position_into(pos: np.ndarray, d_north: float, d_east: float, d_down: float, geodetic: bool) -> None:
    """Move a position by (north, east, down) metres in place: added as they are in the flat model;
    on WGS-84 (latitude, longitude, depth) through the metric at the position itself, the inverse
    of :func:`nav_difference_into`'s position error."""
    if geodetic:
        R_N, R_E = radii_nav(pos[0])
        lat = pos[0]
        pos[0] = lat + d_north / (R_N - pos[2])
        pos[1] = pos[1] + d_east / ((R_E - pos[2]) * math.cos(lat))
        pos[2] = pos[2] + d_down
    else:
        pos[0] += d_north
        pos[1] += d_east
        pos[2] += d_down


@jit
def add_position_batch(pos: np.ndarray, d: np.ndarray, geodetic: bool) -> np.ndarray:
    """:func:`add_position_into` for n positions (n, 3) and offsets (n, 3) -> new positions (n, 3)."""
    out = pos.copy()
    for i in range(pos.shape[0]):
        add_position_into(out[i], d[i, 0], d[i, 1], d[i, 2], geodetic)
    return out


@jit
def inject_batch(
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    accel_bias: np.ndarray,
    gyro_bias: np.ndarray,
    dvl_bias: np.ndarray,
    dvl_sf: np.ndarray,
    extra: np.ndarray,
    dx: np.ndarray,
    geodetic: bool,
) -> None:
    """Closed-loop injection ``x_hat <- x_hat (+) dx`` (tauvcore.filter.eskf.inject) for n filters in
    place: position and biases add, ``C <- exp([rho x]) C``, the body velocity adds and ``vel_n`` is
    rebuilt with the corrected attitude. pos, vel (n, 3), C (n, 3, 3), biases (n, 3), (n, 3), (n, 4),
    dvl_sf (n,), the sources' own states ``extra`` (n, E) (they add), dx (n, 20 + E). On WGS-84 (``geodetic``) the position error in metres moves latitude,
    longitude and depth by the metric at the estimate (:func:`add_position_into`)."""
    E = np.empty((3, 3))
    C1 = np.empty((3, 3))
    vb = np.empty(3)
    for i in range(pos.shape[0]):
        exp_so3_into(dx[i, ATT], dx[i, ATT + 1], dx[i, ATT + 2], E)
        for r in range(3):
            for c in range(3):
                C1[r, c] = E[r, 0] * C[i, 0, c] + E[r, 1] * C[i, 1, c] + E[r, 2] * C[i, 2, c]
        for c in range(3):
            vb[c] = C[i, 0, c] * vel[i, 0] + C[i, 1, c] * vel[i, 1] + C[i, 2, c] * vel[i, 2] + dx[i, VEL + c]
        add_position_into(pos[i], dx[i, POS], dx[i, POS + 1], dx[i, POS + 2], geodetic)
        for r in range(3):
            vel[i, r] = C1[r, 0] * vb[0] + C1[r, 1] * vb[1] + C1[r, 2] * vb[2]
            accel_bias[i, r] += dx[i, BA + r]
            gyro_bias[i, r] += dx[i, BG + r]
            for c in range(3):
                C[i, r, c] = C1[r, c]
        for b in range(4):
            dvl_bias[i, b] += dx[i, BDVL + b]
        dvl_sf[i] += dx[i, SF]
        for e in range(extra.shape[1]):
            extra[i, e] += dx[i, N + e]


@jit
def nav_difference_into(
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    Ce: np.ndarray,
    rho: np.ndarray,
    dx: np.ndarray,
    geodetic: bool,
) -> None:
    """Navigation part of ``true (-) estimate`` (tauvcore.filter.eskf.difference) into ``dx[0:9]``:
    position, misalignment ``log(C_t C^T)``, body velocity ``C_t^T v_t - C^T v``. Ce (3, 3), rho (3,)
    scratch. On WGS-84 (``geodetic``; positions latitude, longitude, depth) the position error is
    in metres at the estimate, the filter's own definition (tauvcore.ins.error_model):
    ``((R_N + h) dlat, (R_E + h) cos(lat) dlon, d depth)``."""
    for i in range(3):
        for j in range(3):
            Ce[i, j] = C_t[i, 0] * C[j, 0] + C_t[i, 1] * C[j, 1] + C_t[i, 2] * C[j, 2]
    log_so3_into(Ce, rho)
    if geodetic:
        R_N, R_E = radii_nav(pos[0])
        dx[POS] = (R_N - pos[2]) * (pos_t[0] - pos[0])
        dx[POS + 1] = (R_E - pos[2]) * math.cos(pos[0]) * (pos_t[1] - pos[1])
        dx[POS + 2] = pos_t[2] - pos[2]
    for i in range(3):
        if not geodetic:
            dx[POS + i] = pos_t[i] - pos[i]
        dx[ATT + i] = rho[i]
        dx[VEL + i] = (C_t[0, i] * vel_t[0] + C_t[1, i] * vel_t[1] + C_t[2, i] * vel_t[2]) - (
            C[0, i] * vel[0] + C[1, i] * vel[1] + C[2, i] * vel[2]
        )


@jit
def difference_batch(
    pos_t: np.ndarray,
    vel_t: np.ndarray,
    C_t: np.ndarray,
    pos: np.ndarray,
    vel: np.ndarray,
    C: np.ndarray,
    geodetic: bool,
) -> np.ndarray:
    """:func:`nav_difference_into` for n pairs -> (n, 9)."""
    out = np.empty((pos.shape[0], NAV))
    Ce = np.empty((3, 3))
    rho = np.empty(3)
    for n in range(pos.shape[0]):
        nav_difference_into(pos_t[n], vel_t[n], C_t[n], pos[n], vel[n], C[n], Ce, rho, out[n], geodetic)
    return out
