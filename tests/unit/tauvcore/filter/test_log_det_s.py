"""The correction's log det S (the innovations' likelihood's second term) against numpy's slogdet of
H P H^T + R over the active rows, on random cases; every other field of the outcome against a numpy
Joseph update written out; and the engine's records carry it."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.filter.eskf import Measurement, Nominal, correct
from tauvcore.filter.layout import STATE, NavState
from tauvcore.geo.rotations import exp_so3, mv


def _nominal(rng: np.random.Generator, n: int) -> Nominal:
    C = exp_so3(rng.standard_normal((n, 3)))
    nav = NavState(pos_n=rng.normal(0.0, 10.0, (n, 3)), vel_n=mv(C, rng.normal(0.0, 2.0, (n, 3))), C_nb=C)
    return Nominal(
        nav,
        rng.normal(0.0, 1e-3, (n, 3)),
        rng.normal(0.0, 1e-4, (n, 3)),
        rng.normal(0.0, 5e-3, (n, 4)),
        rng.normal(0.0, 7e-3, n),
    )


def _case(seed: int, n: int = 40, m: int = 4):
    """n filters with random SPD P, H, R (m rows), innovations of a few sigma, random active rows."""
    rng = np.random.default_rng(seed)
    d = STATE.dim
    A = rng.normal(0.0, 0.05, (n, d, d))
    P = A @ np.swapaxes(A, -1, -2) / d + 1e-4 * np.eye(d)
    H = rng.normal(0.0, 1.0, (n, m, d))
    B = rng.normal(0.0, 0.03, (n, m, m))
    R = B @ np.swapaxes(B, -1, -2) + 1e-4 * np.eye(m)
    S = H @ P @ np.swapaxes(H, -1, -2) + R
    nu = np.einsum("nij,nj->ni", np.linalg.cholesky(S), rng.normal(0.0, 2.0, (n, m)))
    active = rng.random((n, m)) < 0.75
    active[0] = False  # no row: nothing measured
    active[1] = True
    return rng, _nominal(rng, n), P, H, R, nu, active


def _reference(P, H, R, nu, active, gate, gate_rows):
    """The gated Joseph update of one filter in numpy (tauvcore.filter.eskf.correct's contract)."""
    rows = np.flatnonzero(active)
    m, d = nu.size, P.shape[0]
    out = {"s_diag": np.full(m, np.nan), "keep": np.zeros(m, bool), "P": P.copy(), "dx": np.zeros(d)}
    if rows.size == 0:
        return out | {"nis": np.nan, "ratio": np.nan, "log_det": np.nan}
    Ha, Ra, nua = H[rows], R[np.ix_(rows, rows)], nu[rows]
    S = Ha @ P @ Ha.T + Ra
    sign, log_det = np.linalg.slogdet(S)
    assert sign > 0
    nis = float(nua @ np.linalg.solve(S, nua))
    ratio_rows = nua**2 / (gate**2 * np.diag(S))
    out["s_diag"][rows] = np.diag(S)
    passed = ratio_rows <= 1.0
    keep = rows[passed] if gate_rows else (rows if passed.all() else rows[:0])
    out["keep"][keep] = True
    if keep.size:
        Hk, Rk = H[keep], R[np.ix_(keep, keep)]
        K = P @ Hk.T @ np.linalg.inv(Hk @ P @ Hk.T + Rk)
        I_KH = np.eye(d) - K @ Hk
        out["P"] = I_KH @ P @ I_KH.T + K @ Rk @ K.T
        out["dx"] = K @ nu[keep]
    return out | {"nis": nis, "ratio": float(ratio_rows.max()), "log_det": float(log_det)}


@pytest.mark.parametrize("gate_rows", [False, True])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_log_det_s_is_slogdet_and_the_other_fields_are_the_numpy_update(seed: int, gate_rows: bool) -> None:
    _rng, nom, P, H, R, nu, active = _case(seed)
    gate = 3.0
    meas = Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.ones(nu.shape[0], bool), active=active,
                       gate_rows=gate_rows)
    P1, nom1, out = correct(P, nom, meas, gate)
    assert out.log_det_s is not None and out.log_det_s.shape == (nu.shape[0],)
    fused_some = False
    for i in range(nu.shape[0]):
        ref = _reference(P[i], H[i], R[i], nu[i], active[i], gate, gate_rows)
        if np.isnan(ref["log_det"]):
            assert np.isnan(out.log_det_s[i]) and np.isnan(out.nis[i])
        else:
            assert out.log_det_s[i] == pytest.approx(ref["log_det"], abs=1e-9)
            assert out.nis[i] == pytest.approx(ref["nis"], rel=1e-9)
            assert out.test_ratio[i] == pytest.approx(ref["ratio"], rel=1e-9)
        np.testing.assert_allclose(out.innovation_var[i], ref["s_diag"], rtol=1e-12)
        np.testing.assert_array_equal(out.fused_rows[i], ref["keep"])
        np.testing.assert_array_equal(out.rejected_rows[i], active[i] & ~ref["keep"])
        assert out.nis_dof[i] == active[i].sum()
        assert not out.unusable[i]
        np.testing.assert_allclose(P1[i], ref["P"], rtol=0, atol=1e-12 * np.abs(P[i]).max())
        np.testing.assert_allclose(nom1.nav.pos_n[i] - nom.nav.pos_n[i], ref["dx"][STATE.pos], rtol=0, atol=1e-12)
        fused_some |= bool(ref["keep"].any())
    assert fused_some  # the cases exercise the update, not only the gate


def test_log_det_s_is_nan_where_s_is_unusable() -> None:
    _rng, nom, P, H, R, nu, active = _case(4, n=3, m=3)
    R = R.copy()
    R[2, 0, 0] = -10.0  # S not positive definite
    active[:] = True
    meas = Measurement(z=nu.copy(), innovation=nu, H=H, R=R, valid=np.ones(3, bool), active=active)
    _, _, out = correct(P, nom, meas, 3.0)
    assert out.unusable[2] and np.isnan(out.log_det_s[2]) and np.isnan(out.nis[2])
    assert np.all(np.isfinite(out.log_det_s[:2]))


def test_the_engine_records_log_det_s_for_every_source() -> None:
    """A short LC and TC run with the depth aided: log det S recorded wherever the NIS is, finite
    exactly there; a one-row source's is the log of its innovation variance, and a several-row
    one's at most the sum of the logs of S's diagonal (Hadamard's inequality)."""
    from tauvcore.config import Config
    from tauvcore.engine.mission import Sinks, run_streaming

    config = (
        Config()
        .replace("trajectory", name="figure8", duration_s=40.0)
        .replace("run", methods=("lc", "tc"), aiding=("dvl", "depth"), seed=3)
    )
    got = {}
    run_streaming(config, np.random.default_rng(3), keep=False, sinks=Sinks(on_chunk=lambda r: got.setdefault("r", []).append(r)))
    for method in ("lc", "tc"):
        for source in ("dvl", "depth"):
            records = [chunk[method].updates[source] for chunk in got["r"] if source in chunk[method].updates]
            nis = np.concatenate([r.nis for r in records])
            log_det = np.concatenate([r.log_det_s for r in records])
            var = np.concatenate([r.innovation_var for r in records])
            assert nis.size > 0 and log_det.shape == nis.shape
            np.testing.assert_array_equal(np.isfinite(log_det), np.isfinite(nis))
            ok = np.isfinite(log_det)
            if source == "depth":
                np.testing.assert_allclose(log_det[ok], np.log(var[ok][..., 0]), rtol=0, atol=1e-9)
            else:
                hadamard = np.nansum(np.log(var[ok]), axis=-1)
                assert np.all(log_det[ok] <= hadamard + 1e-9)
                assert np.any(log_det[ok] < hadamard - 1e-6)  # S is not diagonal
