"""The two-beam rows' columns of the DVL errors (partial.sensor_columns): against finite differences
of the compiled measurement, against the numpy construction (tauvcore.aiding.dvl_extended), and
the paper's H when switched off."""

import itertools

import numpy as np
import pytest

from tauvcore.aiding.dvl_extended import ELC_METHODS, DvlExtended
from tauvcore.config import Config, PartialConfig
from tauvcore.engine.dvl_fusion import DVL_MODE_CODES, partial_tables
from tauvcore.filter.eskf import Nominal
from tauvcore.filter.kernels.common import plain
from tauvcore.filter.kernels.dvl_kernels import DVL_ELC, DvlMethods, DvlRows, DvlState, Ping, dvl_measure_bank
from tauvcore.filter.layout import STATE
from tauvcore.geo.rotations import C_nb_from_euler, mv
from tauvcore.ins.strapdown import NavState
from tauvcore.validation import ConfigError

CONFIG = Config()
A_B = np.asarray(CONFIG.dvl.A_b, dtype=float)
L_B = np.asarray(CONFIG.dvl.l_dvl_b, dtype=float)
W_IE = np.asarray(CONFIG.earth.omega_ie_n, dtype=float)
SIGMA2, GYRO_VAR = 0.003**2, 1e-6
PAIRS = list(itertools.combinations(range(4), 2))            # every pattern of two returned beams
M, R = len(ELC_METHODS), len(PAIRS)


def _state(rng: np.random.Generator) -> DvlState:
    C = np.stack([C_nb_from_euler(rng.uniform(-0.3, 0.3, 3) + [0, 0, rng.uniform(-3, 3)]) for _ in range(M * R)])
    v_b = rng.normal([1.5, 0.0, 0.0], 0.3, (M * R, 3))
    P = np.empty((M * R, STATE.dim, STATE.dim))
    for k in range(M * R):
        L = rng.normal(0.0, 0.05, (STATE.dim, STATE.dim))
        P[k] = L @ L.T + 1e-3 * np.eye(STATE.dim)
    return DvlState(
        C=C.reshape(M, R, 3, 3),
        vel_n=mv(C, v_b).reshape(M, R, 3),
        gyro_bias=rng.normal(0.0, 1e-4, (M, R, 3)),
        dvl_bias=rng.normal(0.0, 5e-3, (M, R, 4)),
        sf=rng.normal(0.0, 7e-3, (M, R)),
        P=P.reshape(M, R, STATE.dim, STATE.dim),
    )


def _available() -> np.ndarray:
    available = np.zeros((R, 4), bool)
    for r, pair in enumerate(PAIRS):
        available[r, list(pair)] = True
    return available


def _measure(state: DvlState, y: np.ndarray, omega: np.ndarray, sensor_columns: bool) -> DvlRows:
    """The compiled measurement of every method and run (each method sees its own ping ``y[m]``)."""
    config = CONFIG.replace("partial", sensor_columns=sensor_columns)
    dvl = DvlMethods(np.arange(M, dtype=np.int64), np.full(M, DVL_ELC, np.int64), A_B, L_B, SIGMA2, GYRO_VAR,
                     W_IE, DVL_MODE_CODES, sensor_columns)
    tables = partial_tables(list(ELC_METHODS), config)
    batch = (M, R)
    rows = DvlRows(z=np.zeros(batch + (4,)), nu=np.zeros(batch + (4,)), H=np.empty(batch + (4, STATE.dim)),
                   Rm=np.ones(batch + (4, 4)), active=np.zeros(batch + (4,), bool), valid=np.zeros(batch, bool),
                   mode=np.zeros(batch, np.int64), measured_axes=np.zeros(batch + (3,), bool),
                   choice=np.full(batch + (3,), -1, np.int64))
    out = DvlRows(*(np.array(a) for a in rows))
    for m in range(M):   # one method's ping at a time: the others' rows are overwritten by their own
        one = DvlRows(*(np.empty_like(a) for a in rows))
        dvl_measure_bank(plain(dvl), plain(tables), plain(Ping(y[m], _available(), omega)), plain(state), plain(one))
        for dst, src in zip(out, one, strict=True):
            dst[m] = src[m]
    return out


def _beams(state: DvlState, omega: np.ndarray, bias: np.ndarray, sf: np.ndarray) -> np.ndarray:
    """Noise-free beams of the estimated velocity with true biases ``bias`` and scale factor ``sf``:
    ``(1 + SF) A v_b + b + A (omega_nb x l)`` (M, R, 4)."""
    v_b = np.einsum("mrji,mrj->mri", state.C, state.vel_n)
    omega_nb = omega - state.gyro_bias - np.einsum("mrji,j->mri", state.C, W_IE)
    lever = np.einsum("kj,mrj->mrk", A_B, np.cross(omega_nb, L_B))
    return (1.0 + sf)[..., None] * np.einsum("kj,mrj->mrk", A_B, v_b) + bias + lever


@pytest.fixture(scope="module")
def setting():
    rng = np.random.default_rng(29)
    state = _state(rng)
    omega = rng.normal(0.0, 0.05, (R, 3))
    return state, omega


def test_the_dvl_error_columns_match_finite_differences(setting):
    """H's beam-bias and scale-factor columns are the derivatives of the innovation with respect to the
    true errors at the estimate (the innovation is affine in them: central differences are exact to
    round-off)."""
    state, omega = setting
    rows = _measure(state, _beams(state, omega, state.dvl_bias, state.sf), omega, True)
    # every method builds a velocity from most pairs (NSV and PLCF not from the diagonal ones: they coast)
    assert set(np.unique(rows.mode)) <= {DVL_MODE_CODES[0], DVL_MODE_CODES[2]}
    assert (rows.mode == DVL_MODE_CODES[2]).sum() >= M * R - 4
    eps = 1e-4
    columns = [(STATE.b_dvl.start + k, k) for k in range(4)] + [(STATE.sf_dvl.start, None)]
    for col, beam in columns:
        bias_p, bias_m, sf_p, sf_m = state.dvl_bias.copy(), state.dvl_bias.copy(), state.sf.copy(), state.sf.copy()
        if beam is None:
            sf_p += eps
            sf_m -= eps
        else:
            bias_p[..., beam] += eps
            bias_m[..., beam] -= eps
        nu_p = _measure(state, _beams(state, omega, bias_p, sf_p), omega, True).nu
        nu_m = _measure(state, _beams(state, omega, bias_m, sf_m), omega, True).nu
        fd = (nu_p - nu_m) / (2.0 * eps)
        active = rows.active
        np.testing.assert_allclose(np.where(active, rows.H[..., col], 0.0), np.where(active, fd, 0.0),
                                   rtol=0.0, atol=1e-9, err_msg=f"column {col}")
        assert np.abs(np.where(active, fd, 0.0)).max() > 0.05   # the errors do reach the rows


def test_switched_off_the_rows_are_the_papers(setting):
    state, omega = setting
    y = _beams(state, omega, state.dvl_bias + 0.01, state.sf)
    on, off = _measure(state, y, omega, True), _measure(state, y, omega, False)
    for name in ("z", "nu", "Rm", "active", "valid", "mode", "measured_axes", "choice"):
        np.testing.assert_array_equal(getattr(on, name), getattr(off, name))
    sensor = np.r_[STATE.b_dvl, STATE.sf_dvl]
    assert not off.H[..., sensor].any()
    expected = np.zeros((3, STATE.dim))
    expected[:, STATE.vel] = np.eye(3)
    np.testing.assert_array_equal(off.H[..., :3, :], np.broadcast_to(expected, (M, R, 3, STATE.dim)))
    np.testing.assert_array_equal(on.H[..., np.r_[0:STATE.b_dvl.start]], off.H[..., np.r_[0:STATE.b_dvl.start]])


@pytest.mark.parametrize("sensor_columns", [True, False])
def test_the_numpy_construction_equals_the_compiled_one(setting, sensor_columns):
    state, omega = setting
    y = _beams(state, omega, state.dvl_bias + np.array([0.01, -0.02, 0.005, 0.0]), state.sf + 0.004)
    rows = _measure(state, y, omega, sensor_columns)
    for m, method in enumerate(ELC_METHODS):
        model = DvlExtended(method, CONFIG.dvl, CONFIG.earth, np.sqrt(GYRO_VAR), CONFIG.partial.vb_nf,
                            CONFIG.nsv_epsilon_value_m2_per_s2(), sensor_columns)
        nom = Nominal(nav=NavState(pos_n=np.zeros((R, 3)), vel_n=state.vel_n[m], C_nb=state.C[m]),
                      accel_bias=np.zeros((R, 3)), gyro_bias=state.gyro_bias[m], dvl_bias=state.dvl_bias[m],
                      dvl_sf=state.sf[m])
        meas, _ = model.measure(nom, state.P[m][:, STATE.vel, STATE.vel], y[m], _available(), omega)
        act = rows.active[m, :, :3]
        np.testing.assert_array_equal(meas.active, act)
        np.testing.assert_allclose(np.where(act, meas.innovation, 0), np.where(act, rows.nu[m, :, :3], 0), atol=1e-9)
        np.testing.assert_allclose(np.where(act[..., None], meas.H, 0), np.where(act[..., None], rows.H[m, :, :3], 0),
                                   atol=1e-9, err_msg=method)


@pytest.mark.parametrize("bad", [1, "true", None])
def test_a_non_boolean_setting_is_refused(bad):
    with pytest.raises(ConfigError, match=r"partial\.sensor_columns"):
        PartialConfig(sensor_columns=bad)
