"""Error-state EKF: nominal state, covariance propagation, Joseph-form correction with the
innovation gate, closed-loop injection and reset (Tal et al. 2017 section 2.1.1).

Everything takes a leading batch shape ``B`` (methods x Monte Carlo runs). "How" a source is
modelled lives in ``tauvcore.aiding``; this module only knows a :class:`Measurement`.

Numerical safeguards, none of which acts on a healthy filter:

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

from tauvcore.filter.layout import STATE, NavState

P_CORRELATION_EIGEN_FLOOR = 1e-9
"""Smallest eigenvalue of P's correlation matrix after a repair (:func:`condition_covariance`).

Beyond removing the negative part, raising a correlation eigenvalue to 1e-9 adds at most 1e-9 of
the states' own variances along the repaired direction (a sigma grows by at most 5e-10 relative),
far below anything the filter resolves, while the repaired P has a correlation condition number
<= 20 / 1e-9 and factorises with a wide margin (double precision fails near 1e-15)."""

P_VARIANCE_FLOOR = 1e-16
"""Smallest diagonal entry of P after a repair, in the state's SI unit squared: the same floor
as the initial covariance's (tauvcore.engine.start.initial_covariance), e.g. 1e-8 m or 2e-3 deg/h
of gyro bias as a 1-sigma, below anything the filter estimates."""


@dataclass(frozen=True)
class Nominal:
    """Full nominal state: navigation solution plus the estimated sensor errors (batch ``B``)."""

    nav: NavState
    accel_bias: np.ndarray  # (B, 3) [m/s^2]
    gyro_bias: np.ndarray  # (B, 3) [rad/s]
    dvl_bias: np.ndarray  # (B, 4) [m/s]
    dvl_sf: np.ndarray  # (B,) [-]
    extra: np.ndarray | None = (
        None  # (B, E) the states the aiding sources add (tauvcore.filter.layout.Layout,
    )
    # in its units: the current [m/s] north and east); None: none

    @property
    def vel_b(self) -> np.ndarray:
        """Body-frame velocity (surge, sway, heave), shape (B, 3) [m/s], b-frame (FRD)."""
        return self.nav.vel_b

    def with_nav(self, nav: NavState) -> Nominal:
        """The same sensor-error estimates with another navigation solution.

        Parameters
        ----------
        nav : NavState
            Navigation solution to carry, batch shape ``B``: position (B, 3) [m] and velocity
            (B, 3) [m/s] in the NED n-frame, attitude ``C_nb`` (B, 3, 3) body to NED.

        Returns
        -------
        Nominal
            A new nominal state with ``nav`` and this one's accelerometer bias (B, 3) [m/s^2], gyro
            bias (B, 3) [rad/s], DVL beam biases (B, 4) [m/s], scale factor (B,) [-] and the
            sources' states (B, E).
        """
        return Nominal(nav, self.accel_bias, self.gyro_bias, self.dvl_bias, self.dvl_sf, self.extra)

    def reshaped(self, batch: tuple[int, ...]) -> Nominal:
        """The same states with another batch shape of as many states.

        Parameters
        ----------
        batch : tuple[int, ...]
            The new batch shape, its product this one's (e.g. (S * M, R) of (S, M, R)).

        Returns
        -------
        Nominal
            Every array reshaped to ``batch`` and its own trailing shape (views where numpy can),
            in the units of this one.
        """

        def to(a: np.ndarray, tail: int) -> np.ndarray:
            a = np.asarray(a)
            return a.reshape(batch + (a.shape[a.ndim - tail :] if tail else ()))

        nav = NavState(to(self.nav.pos_n, 1), to(self.nav.vel_n, 1), to(self.nav.C_nb, 2))
        extra = None if self.extra is None else to(self.extra, 1)
        return Nominal(
            nav,
            to(self.accel_bias, 1),
            to(self.gyro_bias, 1),
            to(self.dvl_bias, 1),
            to(self.dvl_sf, 0),
            extra,
        )

    @property
    def num_extra(self) -> int:
        """E: the number of the sources' own states (0 without them)."""
        return 0 if self.extra is None else int(np.shape(self.extra)[-1])


StateArrays = tuple[
    np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray
]
"""pos, vel, C, accel bias, gyro bias, DVL bias, scale factor, the sources' states (n, E): the
kernels' state (:func:`_state_arrays`)."""


def _state_arrays(nom: Nominal, batch: tuple[int, ...]) -> StateArrays:
    """Fresh C-contiguous copies of the nominal state broadcast to ``batch``, flattened to one
    leading axis (the compiled kernels' layout): pos, vel (n, 3), C (n, 3, 3), accel and gyro bias
    (n, 3), DVL bias (n, 4), scale factor (n,), the sources' states (n, E) (E = 0 without them)."""

    n = int(np.prod(batch, dtype=np.int64))

    def flat(a: np.ndarray, tail: tuple[int, ...]) -> np.ndarray:
        return np.array(np.broadcast_to(np.asarray(a, dtype=float), batch + tail), order="C").reshape(
            (n,) + tail
        )

    return (
        flat(nom.nav.pos_n, (3,)),
        flat(nom.nav.vel_n, (3,)),
        flat(nom.nav.C_nb, (3, 3)),
        flat(nom.accel_bias, (3,)),
        flat(nom.gyro_bias, (3,)),
        flat(nom.dvl_bias, (4,)),
        flat(nom.dvl_sf, ()),
        flat(np.zeros(0) if nom.extra is None else nom.extra, (nom.num_extra,)),
    )


def _nominal_of(arrays: StateArrays, batch: tuple[int, ...]) -> Nominal:
    pos, vel, C, ba, bg, bdvl, sf, extra = arrays
    return Nominal(
        NavState(pos.reshape(batch + (3,)), vel.reshape(batch + (3,)), C.reshape(batch + (3, 3))),
        ba.reshape(batch + (3,)),
        bg.reshape(batch + (3,)),
        bdvl.reshape(batch + (4,)),
        sf.reshape(batch),
        extra.reshape(batch + extra.shape[1:]) if extra.shape[1] else None,
    )


def inject(nom: Nominal, dx: np.ndarray, geodetic: bool = False) -> Nominal:
    """Closed-loop correction ``x_hat <- x_hat (+) dx`` (reset of dx to zero is implicit).

    Position and biases add; ``C_nb <- exp([rho x]) C_nb``; the body-frame velocity adds
    (the error is defined in b), and ``vel_n`` is rebuilt with the corrected attitude. The
    reset Jacobian ``I - [rho x]/2`` of the misalignment block is taken as I (rho < 1e-2 rad).
    The formula is the kernel :func:`tauvcore.filter.kernels.correction.inject_batch` the filter
    bank runs.

    Parameters
    ----------
    nom : Nominal
        Nominal state ``x_hat`` to correct, batch shape ``B``; not modified.
    dx : numpy.ndarray
        Error state ``x_true - x_hat``, shape (B, 20) (broadcast against ``nom``), in the layout
        :data:`~tauvcore.filter.layout.STATE`: position error [m] and misalignment rho [rad] in the
        NED n-frame, velocity error [m/s] in the body b-frame (FRD), accelerometer [m/s^2] and gyro
        [rad/s] bias errors in b, DVL beam bias errors [m/s] and scale factor error [-].
    geodetic : bool
        Positions are latitude [rad], longitude [rad], depth [m] (WGS-84) and the position error
        (north, east, down) [m] moves them through the metric at the estimate. False: positions are
        NED [m] from the origin and the error adds.

    Returns
    -------
    Nominal
        The corrected nominal state, batch shape the broadcast of ``nom``'s and ``dx``'s (B,).
    """
    from tauvcore.filter.kernels.correction import inject_batch

    batch = np.broadcast_shapes(nom.dvl_sf.shape, np.shape(dx)[:-1])
    arrays = _state_arrays(nom, batch)
    d = STATE.dim + nom.num_extra
    dx_flat = np.ascontiguousarray(np.broadcast_to(np.asarray(dx, dtype=float), batch + (d,)))
    inject_batch(*arrays, dx_flat.reshape(-1, d), geodetic)
    return _nominal_of(arrays, batch)


def difference(true: Nominal, est: Nominal, geodetic: bool = False) -> np.ndarray:
    """``true (-) est``: the error state that :func:`inject` would need.

    The navigation part is the kernel :func:`tauvcore.filter.kernels.correction.nav_difference_into`
    (the filter bank's records use it); the sensor errors subtract.

    Parameters
    ----------
    true : Nominal
        True state, batch shape ``B`` (broadcast against ``est``).
    est : Nominal
        Estimated state ``x_hat``, batch shape ``B``.
    geodetic : bool
        Positions are latitude [rad], longitude [rad], depth [m] (WGS-84); the position error is then
        in metres (north, east, down) through the metric at the estimate. False: positions are NED
        [m] from the origin and subtract.

    Returns
    -------
    numpy.ndarray
        Error state ``dx``, shape (B, 20), in the layout :data:`~tauvcore.filter.layout.STATE`:
        position error [m] and misalignment ``rho = log(C_true C_est^T)`` [rad] in the NED n-frame,
        body-frame (FRD) velocity error [m/s], accelerometer [m/s^2] and gyro [rad/s] bias errors in
        b, DVL beam bias errors [m/s] and scale factor error [-].
    """
    from tauvcore.filter.kernels.common import NAV
    from tauvcore.filter.kernels.correction import difference_batch

    batch = np.broadcast_shapes(
        true.dvl_sf.shape, est.dvl_sf.shape, np.shape(true.nav.pos_n)[:-1], np.shape(est.nav.pos_n)[:-1]
    )
    t, e = _state_arrays(true, batch), _state_arrays(est, batch)
    dx = np.zeros(batch + (STATE.dim + est.num_extra,))
    dx[..., :NAV] = difference_batch(t[0], t[1], t[2], e[0], e[1], e[2], geodetic).reshape(batch + (NAV,))
    dx[..., STATE.ba] = true.accel_bias - est.accel_bias
    dx[..., STATE.bg] = true.gyro_bias - est.gyro_bias
    dx[..., STATE.b_dvl] = true.dvl_bias - est.dvl_bias
    dx[..., STATE.sf_dvl] = (true.dvl_sf - est.dvl_sf)[..., None]
    if est.extra is not None:
        dx[..., STATE.dim :] = (0.0 if true.extra is None else true.extra) - est.extra
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

    z: np.ndarray  # (B, m) observation
    innovation: np.ndarray  # (B, m)
    H: np.ndarray  # (B, m, 20)
    R: np.ndarray  # (B, m, m)
    valid: np.ndarray  # (B,) bool: the source produced a measurement for this batch entry
    active: np.ndarray | None = None  # (B, m) bool rows in use; None = all
    gate_rows: bool = False


@dataclass(frozen=True)
class UpdateOutcome:
    """What one correction did, per batch entry (the record PX4 keeps for every source)."""

    z: np.ndarray  # (B, m)
    innovation: np.ndarray  # (B, m)
    innovation_var: np.ndarray  # (B, m) diagonal of S = H P H^T + R (NaN for unused rows)
    test_ratio: np.ndarray  # (B,) max over active rows of nu_i^2 / (gate^2 S_ii); > 1: rejected
    fused: np.ndarray  # (B,) bool: at least one row fused
    rejected: np.ndarray  # (B,) bool: at least one valid row failed the gate
    fused_rows: np.ndarray  # (B, m) bool
    rejected_rows: np.ndarray  # (B, m) bool
    nis: np.ndarray  # (B,) normalised innovation squared nu^T S^-1 nu over the active rows, before
    #                                the gate (NaN: no active row, or S unusable)
    nis_dof: np.ndarray  # (B,) int: number of active rows (the NIS's chi-square degrees of freedom;
    #                                rows of an unusable update count too: the source did measure)
    unusable: np.ndarray  # (B,) bool: S not finite or not positive definite: nothing fused
    log_det_s: np.ndarray | None = None  # (B,) log det S over the active rows, before the gate (NaN
    #                                where ``nis`` is NaN): with the NIS, the innovations' Gaussian
    #                                log-likelihood, -2 log p(nu) = nis + log_det_s + nis_dof log 2 pi
    #                                (tauvcore.eval.tuning); None: not computed (Yoo 2014's bank)


def propagate(P: np.ndarray, Phi: np.ndarray, Qd: np.ndarray) -> np.ndarray:
    """Covariance propagation ``P <- Phi P Phi^T + Qd``, symmetric.

    ``Phi`` has the structure of :func:`tauvcore.ins.error_model.discretise`'s (identity outside
    rows 0-8, zero beyond column 14 in them); the product is the kernel
    :func:`tauvcore.filter.kernels.error_model_kernels.sandwich_into` the filter bank runs.

    Parameters
    ----------
    P : numpy.ndarray
        Error-state covariance, shape (B, 20, 20), in the SI units of the states
        (:data:`~tauvcore.filter.layout.STATE`) squared (m^2, rad^2, (m/s)^2, ...); not modified.
    Phi : numpy.ndarray
        State transition matrix over the step, shape (B, 20, 20) (each entry in its row's state unit
        over its column's).
    Qd : numpy.ndarray
        Discrete process noise covariance over the step, shape (B, 20, 20), in the states' SI units
        squared.

    Returns
    -------
    numpy.ndarray
        Propagated covariance, shape (B, 20, 20) (the broadcast of the inputs' batch shapes), in the
        states' SI units squared.

    Raises
    ------
    ValueError
        Phi must be the identity outside rows 0-8 and zero beyond column 14 in them.
    """
    from tauvcore.filter.kernels.common import CORE, NAV
    from tauvcore.filter.kernels.error_model_kernels import propagate_batch

    Phi = np.asarray(Phi, dtype=float)
    eye = np.eye(STATE.dim)
    if not (
        np.array_equal(
            np.broadcast_to(Phi[..., NAV:, :], Phi.shape[:-2] + eye[NAV:].shape),
            np.broadcast_to(eye[NAV:], Phi.shape[:-2] + eye[NAV:].shape),
        )
        and not np.any(Phi[..., :NAV, CORE:])
    ):
        raise ValueError("Phi must be the identity outside rows 0-8 and zero beyond column 14 in them")
    batch = np.broadcast_shapes(np.shape(P)[:-2], Phi.shape[:-2], np.shape(Qd)[:-2])
    shape = (STATE.dim, STATE.dim)

    def flat(a: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float), batch + shape)).reshape(
            (-1,) + shape
        )

    return propagate_batch(flat(P), flat(Phi), flat(Qd)).reshape(batch + shape)


def _is_positive_definite(A: np.ndarray) -> np.ndarray:
    """(B,) bool: ``A`` (B, n, n) is finite and its Cholesky factorisation succeeds.

    One batched factorisation on the normal path; entry by entry only when it fails. LAPACK lets
    a NaN through to the factor instead of failing, hence the finiteness test on the factor's
    diagonal (a NaN or inf anywhere in the lower triangle reaches the diagonal of its row)."""
    try:
        return np.all(np.isfinite(np.diagonal(np.linalg.cholesky(A), axis1=-2, axis2=-1)), axis=-1)
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
    """Keep P symmetric positive definite.

    A batch entry whose P is finite but fails its Cholesky factorisation (an eigenvalue at or
    below round-off, or negative) is rebuilt from its correlation matrix with the eigenvalues
    raised to :data:`P_CORRELATION_EIGEN_FLOOR`, and its diagonal raised to
    :data:`P_VARIANCE_FLOOR`: ``P <- D V max(L, floor) V^T D``, ``D = sqrt(max(diag P, floor))``.
    A healthy P is returned unchanged (the same array); a non-finite P cannot be repaired and is
    left for the divergence monitor (tauvcore.eval.metrics).

    Parameters
    ----------
    P : numpy.ndarray
        Covariances, shape (B, n, n) (the error state's (B, 20, 20) in the filter bank), in the
        states' SI units squared; not modified.

    Returns
    -------
    P : numpy.ndarray
        The covariances, shape (B, n, n), in the same units: ``P`` itself when every entry is
        healthy, else a copy with the repaired entries rebuilt.
    repaired : numpy.ndarray
        Shape (B,) bool: the entries that were rebuilt.
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


def fuse_in_place(
    P: np.ndarray,
    state: StateArrays,
    H: np.ndarray,
    R: np.ndarray,
    nu: np.ndarray,
    active: np.ndarray,
    gate_rows: np.ndarray,
    gate_sigma: float,
    geodetic: bool = False,
    invariant: np.ndarray | None = None,
) -> tuple[np.ndarray, ...]:
    """The compiled gated Joseph correction and injection of n filters, in place.

    The filter bank's layout, one leading axis of n filters; the gate and the handling of inactive
    rows and of an unusable ``S`` are :func:`correct`'s.

    Parameters
    ----------
    P : numpy.ndarray
        Error-state covariances, shape (n, 20, 20), in the states' SI units squared; updated in place.
    state : StateArrays
        The nominal states as the arrays of :func:`_state_arrays`: position (n, 3) [m, or latitude
        and longitude in rad with depth in m] and velocity (n, 3) [m/s] in the NED n-frame, ``C_nb``
        (n, 3, 3), accelerometer (n, 3) [m/s^2] and gyro (n, 3) [rad/s] biases in the body b-frame,
        DVL beam biases (n, 4) [m/s], scale factor (n,) [-]; corrected in place.
    H : numpy.ndarray
        Measurement Jacobians, shape (n, m, 20) (any shape that reshapes to it, e.g. (M, R, m, 20)),
        in the measurement's SI unit over each state's.
    R : numpy.ndarray
        Measurement noise covariances, shape (n, m, m), in the measurement's SI unit squared.
    nu : numpy.ndarray
        Innovations ``z (-) h(x_hat)``, shape (n, m), in the measurement's SI unit.
    active : numpy.ndarray
        Shape (n, m) bool: the rows in use (active and valid).
    gate_rows : numpy.ndarray
        Shape (n,) bool: gate each row on its own (True) or the whole vector at once (False).
    gate_sigma : float
        Gate width in standard deviations of the innovation [-].
    geodetic : bool
        Positions are latitude [rad], longitude [rad], depth [m] (WGS-84) rather than NED [m].
    invariant : numpy.ndarray or None
        Shape (n,) bool: the filters that are the right-invariant EKF (tauvcore.filter.invariant):
        their correction moves the estimate on SE_2(3) and carries P in the invariant error's
        coordinates. None: none.

    Returns
    -------
    s_diag : numpy.ndarray
        Diagonal of ``S = H P H^T + R``, shape (n, m), in the measurement's SI unit squared (NaN for
        rows not used).
    keep : numpy.ndarray
        Shape (n, m) bool: the rows fused.
    nis : numpy.ndarray
        Shape (n,): normalised innovation squared over the active rows, before the gate [-].
    test_ratio : numpy.ndarray
        Shape (n,): max over the active rows of ``nu_i^2 / (gate^2 S_ii)`` [-]; > 1: rejected.
    unusable : numpy.ndarray
        Shape (n,) bool: ``S`` not finite or not positive definite, nothing fused.
    log_det_s : numpy.ndarray
        Shape (n,): ``log det S`` over the active rows, before the gate [log of the measurement's SI
        unit squared to the power of the rows] (NaN where ``nis`` is NaN).
    """
    from tauvcore.filter.kernels.correction import correct_batch, inject_batch
    from tauvcore.filter.kernels.invariant_kernels import retract_batch

    n, m = P.shape[0], nu.shape[-1]
    dx, s_diag, keep, nis, ratio, unusable, log_det_s = correct_batch(
        P,
        np.ascontiguousarray(H, dtype=float).reshape(n, m, P.shape[-1]),
        np.ascontiguousarray(R, dtype=float).reshape(n, m, m),
        np.ascontiguousarray(nu, dtype=float).reshape(n, m),
        np.ascontiguousarray(active, dtype=bool).reshape(n, m),
        np.ascontiguousarray(gate_rows, dtype=bool).reshape(n),
        float(gate_sigma),
        0,
        0,  # no consider states
    )
    if invariant is None or not invariant.any():
        inject_batch(*state, dx, geodetic)
    else:
        inject_batch(*state, np.where(invariant[:, None], 0.0, dx), geodetic)
        retract_batch(*state, P, dx, np.ascontiguousarray(invariant, dtype=bool), geodetic)
    return s_diag, keep, nis, ratio, unusable, log_det_s


def widen(H: np.ndarray, d: int) -> np.ndarray:
    """``H`` over the 20 states of the layout, or over them and the sources' own, as ``d`` columns:
    zero columns for states a measurement does not see.

    Parameters
    ----------
    H : numpy.ndarray
        Measurement Jacobians, shape (..., m, d0), d0 <= d, in the measurement's SI unit over each
        state's.
    d : int
        The states of the filter, 20 plus the sources' own.

    Returns
    -------
    numpy.ndarray
        ``H`` itself when ``d0 = d``, else shape (..., m, d) with zero columns ``d0 .. d - 1``.
    """
    H = np.asarray(H, dtype=float)
    if H.shape[-1] == d:
        return H
    out = np.zeros(H.shape[:-1] + (d,))
    out[..., : H.shape[-1]] = H
    return out


def make_outcome(
    z: np.ndarray,
    innovation: np.ndarray,
    active: np.ndarray,
    s_diag: np.ndarray,
    keep: np.ndarray,
    nis: np.ndarray,
    test_ratio: np.ndarray,
    unusable: np.ndarray,
    log_det_s: np.ndarray | None = None,
) -> UpdateOutcome:
    """The record of one correction from the kernel's outcome.

    Parameters
    ----------
    z : numpy.ndarray
        Observations, shape (B, m), in the source's SI unit (e.g. m/s for DVL beams, m for depth).
    innovation : numpy.ndarray
        Innovations ``z (-) h(x_hat)``, shape (B, m), in the source's SI unit.
    active : numpy.ndarray
        Shape (B, m) bool: the rows measured.
    s_diag : numpy.ndarray
        Diagonal of ``S = H P H^T + R``, shape (B, m), in the source's SI unit squared (NaN for
        unused rows).
    keep : numpy.ndarray
        Shape (B, m) bool: the rows fused.
    nis : numpy.ndarray
        Shape (B,): normalised innovation squared ``nu^T S^-1 nu`` over the active rows, before the
        gate [-] (NaN: no active row, or S unusable).
    test_ratio : numpy.ndarray
        Shape (B,): max over the active rows of ``nu_i^2 / (gate^2 S_ii)`` [-]; > 1: rejected.
    unusable : numpy.ndarray
        Shape (B,) bool: ``S`` not finite or not positive definite, nothing fused.
    log_det_s : numpy.ndarray or None
        Shape (B,): ``log det S`` over the active rows, before the gate (NaN where ``nis`` is NaN);
        None: not computed (a correction that does not factorise S: Yoo 2014's).

    Returns
    -------
    UpdateOutcome
        The per-entry record: the inputs, and the rows fused (``keep``) and rejected (``active`` but
        not kept), with their any-row summaries ``fused`` and ``rejected`` (B,) and the NIS's degrees
        of freedom ``nis_dof`` (B,), the number of active rows.
    """
    return UpdateOutcome(
        z=z,
        innovation=innovation,
        innovation_var=s_diag,
        test_ratio=test_ratio,
        fused=np.any(keep, axis=-1),
        rejected=np.any(active & ~keep, axis=-1),
        fused_rows=keep,
        rejected_rows=active & ~keep,
        nis=nis,
        nis_dof=active.sum(axis=-1),
        unusable=unusable,
        log_det_s=log_det_s,
    )


def correct(
    P: np.ndarray, nom: Nominal, meas: Measurement, gate_sigma: float, apply: np.ndarray | None = None
) -> tuple[np.ndarray, Nominal, UpdateOutcome]:
    """Gated Joseph-form update and injection.

    The update is the kernel :func:`tauvcore.filter.kernels.correction.correct_into`. The gate is
    the paper's (section 2.1.1): a row must lie within ``gate_sigma`` standard deviations of its
    prediction, ``nu_i^2 <= gate^2 S_ii``. A vector measurement is rejected whole if any row fails
    (``gate_rows`` False), a row-gated one loses only the failing rows; every rejection is
    recorded. Entries masked out by ``apply`` are left untouched. Joseph form
    ``P = (I - K H) P (I - K H)^T + K R K^T`` keeps P symmetric positive definite for any gain,
    including the zero gain of a rejected measurement. Inactive rows are dropped exactly.

    An entry whose ``S`` over its active rows is not finite or not positive definite (its
    Cholesky factorisation fails) fuses nothing and keeps its P and state (``unusable``; its rows
    count as rejected). The record also carries the entry's normalised innovation squared
    ``nu^T S^-1 nu`` over the active rows before the gate, for the divergence monitor.
    Inputs are not modified. The injection treats positions as NED [m] (it runs the kernel with
    ``geodetic`` False).

    Parameters
    ----------
    P : numpy.ndarray
        Error-state covariance, shape (B, 20, 20), in the states' SI units squared
        (:data:`~tauvcore.filter.layout.STATE`).
    nom : Nominal
        Nominal state, batch shape ``B``: position (B, 3) [m] and velocity (B, 3) [m/s] in the NED
        n-frame, attitude ``C_nb`` (B, 3, 3), sensor-error estimates in the body b-frame.
    meas : Measurement
        The aiding measurement: ``z`` and ``innovation`` (B, m) in the source's SI unit, ``H``
        (B, m, 20), ``R`` (B, m, m), ``valid`` (B,), ``active`` (B, m) or None, ``gate_rows``.
    gate_sigma : float
        Gate width in standard deviations of the innovation [-].
    apply : numpy.ndarray or None
        Shape (B,) bool: the batch entries that use this source; an entry False (e.g. the standalone
        INS) is left untouched. None: every entry.

    Returns
    -------
    P : numpy.ndarray
        Updated covariance, shape (B, 20, 20), in the states' SI units squared.
    nom : Nominal
        Corrected nominal state, batch shape ``B``.
    outcome : UpdateOutcome
        What the correction did per entry (:func:`make_outcome`).
    """
    valid = meas.valid if apply is None else meas.valid & apply
    batch = np.shape(P)[:-2]
    m = meas.R.shape[-1]
    active = np.ones(batch + (m,), dtype=bool) if meas.active is None else meas.active.astype(bool)
    active = np.broadcast_to(active & valid[..., None], batch + (m,))
    d = np.shape(P)[-1]
    P_new = np.array(np.broadcast_to(P, batch + (d, d)), dtype=float, order="C")
    state = _state_arrays(nom, batch)
    flat = P_new.reshape(-1, d, d)

    def rows(a: np.ndarray, tail: tuple[int, ...]) -> np.ndarray:
        return np.broadcast_to(a, batch + tail).reshape((-1,) + tail)

    fused = fuse_in_place(
        flat,
        state,
        rows(widen(meas.H, d), (m, d)),
        rows(meas.R, (m, m)),
        rows(meas.innovation, (m,)),
        rows(active, (m,)),
        np.full(flat.shape[0], meas.gate_rows),
        gate_sigma,
    )
    s_diag, keep, nis, ratio, unusable, log_det_s = (a.reshape(batch + a.shape[1:]) for a in fused)
    return (
        P_new,
        _nominal_of(state, batch),
        make_outcome(meas.z, meas.innovation, active, s_diag, keep, nis, ratio, unusable, log_det_s),
    )
