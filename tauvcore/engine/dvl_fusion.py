"""How the 20-state bank fuses the DVL: which construction each method uses, the compiled DVL
kernel's tables of two-beam constructions, and the RPM velocity that stands in for the DVL's
(``run.rpm_fallback``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from tauvcore.aiding import elc_select
from tauvcore.aiding.dvl_extended import (
    ELC_METHODS,
    MODE_COAST,
    MODE_LC,
    MODE_PARTIAL,
    MODE_TC,
    DvlExtended,
)
from tauvcore.aiding.dvl_water import CURRENT_BLOCK, WaterTrack
from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps
from tauvcore.config import Config
from tauvcore.engine.rpm_aid import dvl_body_velocity
from tauvcore.filter.eskf import make_outcome
from tauvcore.filter.families import FAMILIES
from tauvcore.filter.kernels.common import plain
from tauvcore.filter.kernels.dvl_kernels import (
    DVL_ELC,
    DvlRows,
    DvlState,
    Ping,
    TwoBeamTables,
    dvl_measure_bank,
)
from tauvcore.filter.kernels.two_beam import MAX_CANDIDATES
from tauvcore.filter.layout import STATE, Layout
from tauvcore.geo.rotations import skew

DVL_FUSION: dict[str, str | None] = {
    method: kind
    for family in FAMILIES.values()
    if family.error_state == "eskf"
    for method, kind in family.dvl_fusion.items()
}
"""How each method of the 20-state bank fuses the DVL (tauvcore.filter.families: each family's
``dvl_fusion``; None: not at all; a registered method, tauvcore.aiding.registry, is not in it and
takes no DVL)."""
_UNBUILT = {m for m, kind in DVL_FUSION.items() if kind == "elc"} - set(ELC_METHODS)
if _UNBUILT:  # an extended method's two-beam construction is built by its name (partial_tables)
    raise ValueError(f"methods {sorted(_UNBUILT)} fuse the DVL as 'elc' but are not one of {ELC_METHODS}")
INVARIANT_METHODS = frozenset({"iekf"})
"""The methods that are the right-invariant EKF (tauvcore.filter.invariant): the filter bank corrects
them on SE_2(3) and carries their covariance in the invariant error's coordinates."""


DVL_ROWS = 4
"""The widest DVL measurement (tightly coupled: one row per beam); narrower ones are padded with
inactive rows so that one compiled correction fuses every DVL method of a ping."""


DVL_MODE_CODES = np.array([MODE_COAST, MODE_LC, MODE_PARTIAL, MODE_TC], dtype=np.int64)
"""The record's DVL mode codes in the order the compiled DVL kernel takes them."""


def partial_tables(methods: Sequence[str], config: Config) -> TwoBeamTables:
    """The two-beam constructions of each DVL method, for every pattern of two returned beams
    (index: the sum of 2^k over the beams k), from the methods' own ``solve`` functions
    (tauvcore.aiding.elc_*): candidates (1, or the selector's 4), ok, C, D, gain, assumption
    error and measured rows, as :func:`tauvcore.filter.kernels.dvl_kernels.dvl_measure_bank` takes them."""
    n, K = len(methods), MAX_CANDIDATES
    n_cand = np.ones(n, np.int64)
    ok = np.zeros((n, 16, K), bool)
    Cc, Dc = np.zeros((n, 16, K, 3, 4)), np.zeros((n, 16, K, 3, 3))
    gc, ac, mc = np.ones((n, 16, K, 3)), np.zeros((n, 16, K, 3)), np.zeros((n, 16, K, 3), bool)
    pitch, n_f, eps = config.dvl.beam_pitch_rad, config.partial.vb_nf, config.nsv_epsilon_value_m2_per_s2()
    for i, method in enumerate(methods):
        if DVL_FUSION[method] != "elc":
            continue
        for code in range(16):
            pattern = tuple(bool(code >> k & 1) for k in range(4))
            if sum(pattern) != 2:
                continue
            if method == "elc":
                solutions = elc_select.candidate_solutions(pitch, pattern, n_f, eps)
                n_cand[i] = len(solutions)
            else:
                solutions = [DvlExtended(method, config.dvl, config.earth, 0.0, n_f, eps)._solution(pattern)]
            for c, sol in enumerate(solutions):
                ok[i, code, c] = sol.ok
                Cc[i, code, c], Dc[i, code, c] = sol.C, sol.D
                gc[i, code, c], ac[i, code, c], mc[i, code, c] = (
                    sol.pred_gain,
                    sol.assumption_sd,
                    sol.measured,
                )
    return TwoBeamTables(n_cand, ok, Cc, Dc, gc, ac, mc)


def rpm_measurement(
    v_b: np.ndarray,
    sf: np.ndarray,
    b_dvl: np.ndarray,
    A_pinv: np.ndarray,
    current: tuple[np.ndarray, np.ndarray, slice, int, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The RPM velocity's prediction and Jacobian (``--rpm-fallback``, :func:`rpm_fallback`).

    Surge is the speed the VKF learned from the DVL, ``(1 + SF) v_b1 + A+_1 . b`` (the first row
    of the LC measurement); sway and heave are the body velocity (taken as zero). With the current
    as states, the propeller's velocity is through the water: the current's body part
    ``C^T c_n`` comes off every row (the VKF learned its surge less the estimated current,
    :class:`~tauvcore.engine.rpm_aid.RpmAid`), and H gains ``-C^T [c x]`` on the misalignment
    and ``-C^T [e_N e_E]`` on the current. What the VKF learned carries the current estimate's
    error along the axis ``a`` it learned on, ``(c - c_l) . a`` (``c_l`` the estimate it took), so
    the surge gains that and its current columns ``a_NE``: on a straight track the surge says
    nothing of the current along it (tauvcore.engine.yoo_velocity).

    Parameters
    ----------
    v_b : numpy.ndarray
        Body velocity over ground, shape (..., 3) [m/s].
    sf : numpy.ndarray
        DVL scale factor, shape (...) [-].
    b_dvl : numpy.ndarray
        DVL beam biases, shape (..., 4) [m/s].
    A_pinv : numpy.ndarray
        The DVL's A+, shape (3, 4) [-].
    current : tuple or None
        With current states: the attitude ``C_nb`` (..., 3, 3), the estimated current ``c_n``
        (..., 3) NED [m/s], its slice of the error state, the error state's size, and the VKF's
        learning axis ``a`` and current ``c_l`` (..., 3) NED [m/s]; None: none.

    Returns
    -------
    h : numpy.ndarray
        The prediction, shape (..., 3) [m/s].
    H : numpy.ndarray
        Its Jacobian over the error state, shape (..., 3, 20) (or the size ``current`` gives).
    """
    h = np.array(v_b, dtype=float, copy=True)
    h[..., 0] = (1.0 + sf) * v_b[..., 0] + b_dvl @ A_pinv[0]
    H = np.zeros(np.shape(v_b)[:-1] + (3, STATE.dim if current is None else current[3]))
    H[..., STATE.vel] = np.eye(3)
    H[..., 0, STATE.vel.start] = 1.0 + sf
    H[..., 0, STATE.b_dvl] = A_pinv[0]
    H[..., 0, STATE.sf_dvl.start] = v_b[..., 0]
    if current is not None:
        C, c_n, cols, _, a_n, c_l = current
        CT = np.swapaxes(C, -1, -2)
        h -= np.einsum("...ij,...j->...i", CT, c_n)
        h[..., 0] += np.einsum("...j,...j->...", c_n - c_l, a_n)
        H[..., STATE.att] = -(CT @ skew(c_n))
        H[..., cols] = -CT[..., :, :2]
        H[..., 0, cols] += a_n[..., :2]
    return h, H


def rpm_fallback(bank: Any, chunk: Any, p: int, i: int, t: float, dvl_valid: np.ndarray) -> None:
    """``run.rpm_fallback`` of the filter bank ``bank`` (tauvcore.engine.filter_bank.FilterBank) at
    ping ``p`` of ``chunk``, sample ``i``, time ``t`` [s]: step the runs' velocity Kalman filters (learning from the DVL while
    it is in range), and where a DVL method had no velocity from this ping, fuse the RPM's body
    velocity ``[V_rpm, 0, 0]`` (R from the VKF and RPM_LATERAL_SIGMA_MPS; source "rpm" in the
    records).

    The VKF learns the speed the DVL measures, ``(1 + SF) v_b + A+ b`` (the LC measurement,
    tauvcore.filter.kernels.dvl_kernels.lc_jacobian_into), not the true one: a DVL 0.7 % off in scale makes the RPM speed
    0.7 % off. So the surge row is predicted and linearised as that measurement is, with the
    DVL scale factor and beam bias columns (H = [(1 + SF) e1, A+ row 1, v_b1] on the velocity,
    beam bias and scale factor states), and the filter knows the RPM speed shares the DVL's
    errors; the sway and heave rows are the zero lateral velocity on the velocity block. (With
    H on the velocity alone the methods were over-confident, velocity NEES/dim about 2.)"""
    dvl = bank.config.dvl
    R = bank.batch[1]
    lat = bank.pos[0, :, 0] if bank.geodetic else np.full(R, bank.config.earth.latitude_rad)
    v_b, _, ok = dvl_body_velocity(
        chunk.dvl.y_beam_mps[p],
        chunk.dvl.available[p],
        chunk.imu.dtheta_b[i],
        bank.dt,
        bank.C[0],
        lat,
        bank.A_b,
        bank.l_dvl_b,
        dvl_beam_sigma_mps(dvl.noise_mps) ** 2,
    )
    aid = bank.rpm_aid
    assert aid is not None  # called only with run.rpm_fallback's filters (see the caller)
    if CURRENT_BLOCK in {b.name for b in bank.layout.blocks}:
        cols = bank.layout.slice_of(CURRENT_BLOCK)
        c_n = np.zeros(bank.batch + (3,))
        c_n[..., :2] = bank.extra[..., cols.start - STATE.dim : cols.stop - STATE.dim]
        # the runs' one VKF learns the surge through the water by the first DVL method's current
        m0 = bank.dvl_index[0]
        surge_current = np.einsum("rj,rj->r", bank.C[m0, :, :, 0], c_n[m0])
        v_b = v_b - surge_current[:, None] * np.array([1.0, 0.0, 0.0])
        _, have_rpm = aid.step(chunk, i, v_b, ok, (bank.C[m0, :, :, 0], c_n[m0]))
    else:
        _, have_rpm = aid.step(chunk, i, v_b, ok)
    coast = np.zeros(bank.batch, bool)
    coast[bank.dvl_index] = ~dvl_valid[bank.dvl_index] & have_rpm
    if not coast.any():  # every method had its DVL velocity: the bank is left as it was
        return
    z = np.broadcast_to(aid.velocity_b(), bank.batch + (3,))

    def predict(nom: Any) -> tuple[np.ndarray, np.ndarray]:
        current = None
        if CURRENT_BLOCK in {b.name for b in bank.layout.blocks}:
            cols = bank.layout.slice_of(CURRENT_BLOCK)
            c_n = np.zeros(nom.dvl_sf.shape + (3,))
            c_n[..., :2] = nom.extra[..., cols.start - STATE.dim : cols.stop - STATE.dim]
            current = (
                nom.nav.C_nb,
                c_n,
                cols,
                bank.layout.dim,
                aid.learn_axis_n[None],
                aid.learn_current_n_mps[None],
            )
        return rpm_measurement(nom.vel_b, nom.dvl_sf, nom.dvl_bias, bank.rpm_A_pinv, current)

    h, H = predict(bank.nominal())
    nu = z - h
    Rm = np.ascontiguousarray(np.broadcast_to(aid.covariance_b(), bank.batch + (3, 3)))
    active = np.repeat(coast[..., None], 3, axis=-1)
    H, Rm, nu = bank._linearized(H, Rm, nu, active, lambda nom, _: z[:1] - predict(nom)[0])
    fused = bank._fuse(H, Rm, np.ascontiguousarray(nu), active, np.zeros(bank.batch, bool))
    bank.recorders["rpm"].add(t, make_outcome(np.array(z), nu, active, *fused), coast)


def dvl_innovation(bank: Any, nom: Any, methods: np.ndarray, ping: Ping) -> np.ndarray:
    """The innovations of a ping as the filter bank's DVL methods measure it at other nominal states:
    the same compiled kernel as the bank's (tauvcore.filter.kernels.dvl_kernels.dvl_measure_bank), for a
    family's linearisation (tauvcore.filter.families.spec.Linearize).

    Parameters
    ----------
    bank : FilterBank
        The bank (tauvcore.engine.filter_bank.FilterBank): its DVL methods, their constructions and
        covariances.
    nom : Nominal
        The nominal states, batch (B', R).
    methods : numpy.ndarray
        Shape (B',) int: the bank's method (row) each state is measured as.
    ping : Ping
        The ping: beams (R, 4) [m/s], which returned (R, 4), the gyros' rate (R, 3) [rad/s].

    Returns
    -------
    numpy.ndarray
        The innovations, shape (B', R, 4) [m/s] (rows beyond a measurement's width zero).
    """
    n, R = nom.dvl_sf.shape
    position = {int(m): i for i, m in enumerate(bank.dvl_index)}  # a method's place in the tables
    at = np.array([position[int(m)] for m in methods], dtype=np.int64)
    rows = DvlRows(
        z=np.zeros((n, R, DVL_ROWS)),
        nu=np.zeros((n, R, DVL_ROWS)),
        H=np.empty((n, R, DVL_ROWS, STATE.dim)),
        Rm=np.ones((n, R, DVL_ROWS, DVL_ROWS)),
        active=np.zeros((n, R, DVL_ROWS), bool),
        valid=np.zeros((n, R), bool),
        mode=np.zeros((n, R), np.int64),
        measured_axes=np.zeros((n, R, 3), bool),
        choice=np.full((n, R, 3), -1, np.int64),
    )
    codes = bank.dvl_codes[at]
    # only an extended method's two-beam construction reads P: the others are handed one row of it
    # (the kernel's types unchanged) rather than a copy per sigma point
    P = bank.P[methods] if np.any(codes == DVL_ELC) else bank.P[:1]
    state = DvlState(
        np.ascontiguousarray(nom.nav.C_nb),
        np.ascontiguousarray(nom.nav.vel_n),
        np.ascontiguousarray(nom.gyro_bias),
        np.ascontiguousarray(nom.dvl_bias),
        np.ascontiguousarray(nom.dvl_sf),
        np.ascontiguousarray(P),
    )
    dvl_measure_bank(
        plain(bank._dvl_methods(np.arange(n, dtype=np.int64), codes)),
        plain(TwoBeamTables(*(np.ascontiguousarray(a[at]) for a in bank.partial_tables))),
        plain(ping),
        plain(state),
        plain(rows),
    )
    return rows.nu


def water_model(config: Config, layout: Layout) -> WaterTrack | None:
    """The water-track beams' model of a run with current states (tauvcore.aiding.dvl_water), else None.

    Parameters
    ----------
    config : Config
        The configuration: its ``[dvl]`` section.
    layout : Layout
        The run's error state (tauvcore.engine.source_streams.layout_of).

    Returns
    -------
    WaterTrack or None
        The model, the current's slice of the error state in it; None without a ``current`` block
        or with a DVL that does not water-track.
    """
    if CURRENT_BLOCK not in {b.name for b in layout.blocks} or config.dvl.water_track == "off":
        return None
    return WaterTrack(config.dvl, layout.slice_of(CURRENT_BLOCK), layout.dim)


def fuse_water_track(bank: Any, chunk: Any, p: int, omega_meas: np.ndarray, t: float) -> None:
    """The water-track beams of ping ``p`` fused by every DVL method of the filter bank ``bank``
    (tauvcore.engine.filter_bank.FilterBank), row by row, and recorded as the source ``water``.

    Parameters
    ----------
    bank : FilterBank
        The bank: its estimates, covariances and recorders, written in place.
    chunk : SimChunk
        The chunk of the ping: its DVL data's ``y_water_mps`` and ``water_available`` (M, R, 4).
    p : int
        The ping within the chunk.
    omega_meas : numpy.ndarray
        The gyros' rate at the ping, shape (R, 3) [rad/s].
    t : float
        The ping's time [s].
    """
    y, available = chunk.dvl.y_water_mps[p], chunk.dvl.water_available[p]
    if not np.any(available):
        return

    def measure(nom: Any) -> Any:
        w_ie_b = np.einsum("mrji,j->mri", nom.nav.C_nb, bank.w_ie)
        return bank.water.measure(nom, y, available, omega_meas - w_ie_b)

    meas = measure(bank.nominal())
    members = np.zeros(bank.batch, bool)
    members[bank.dvl_index] = True
    valid = meas.valid & members
    active = np.asarray(meas.active) & valid[..., None]
    H, Rm, nu = bank._linearized(
        meas.H, meas.R, meas.innovation, active, lambda nom, _: measure(nom).innovation
    )
    fused = bank._fuse(H, Rm, np.ascontiguousarray(nu), active, np.ones(bank.batch, bool))
    bank.recorders["water"].add(t, make_outcome(meas.z, nu, active, *fused), valid)
