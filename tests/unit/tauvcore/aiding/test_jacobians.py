"""Analytic Jacobians against central finite differences of the nonlinear models.

(a) F and G of the INS error model against the exact error dynamics
    (tests/unit/tauvcore/ins/error_rate_reference.py).
(b) H of every aiding model against its nonlinear ``predict`` at ``inject(nom, +-eps e_j)``,
    parametrised over a registry of the models (one line per model): every aiding source, and
    for the DVL every fusion kind the runner uses that has a nonlinear model (lc, tc).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

from tauvcore.aiding import AIDING_SOURCES, Depth, DvlLoose, MagAttitude
from tauvcore.aiding.attitude_mag import EULER
from tauvcore.aiding.dvl_tight import DvlTight
from tauvcore.aiding.source import SourceData
from tauvcore.aiding.sources import FUSED
from tauvcore.engine.dvl_fusion import DVL_FUSION
from tauvcore.filter.eskf import Nominal, inject
from tauvcore.filter.layout import NOISE, STATE, NavState
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import C_nb_from_euler, exp_so3, mv
from tauvcore.ins.error_model import F_matrix, G_matrix
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.sensors.magnetometer import MagnetometerConfig
from tauvcore.sensors.pressure import PressureConfig
from tests.unit.tauvcore.ins.error_rate_reference import error_rate, error_rate_geodetic

EARTH = Earth(latitude_deg=32.8)
EPS = 1e-6


# ------------------------------------------------------------------------------------------ (a) F and G

def _random_ins_point(rng: np.random.Generator) -> dict:
    return dict(
        C_hat=exp_so3(rng.standard_normal(3)),
        vel_b_hat=rng.normal(0.0, 2.0, 3),
        omega_ib_meas=rng.normal(0.0, 0.1, 3),
        f_meas=np.array([0.0, 0.0, -9.8]) + rng.normal(0.0, 1.0, 3),
        bias_hat={"ba": rng.normal(0.0, 1e-3, 3), "bg": rng.normal(0.0, 1e-4, 3)},
    )


def _rate(pt: dict, dx: np.ndarray, w: np.ndarray) -> np.ndarray:
    return error_rate(pt["C_hat"], pt["vel_b_hat"], pt["omega_ib_meas"], pt["f_meas"], pt["bias_hat"], dx, w, EARTH)


@pytest.mark.parametrize("seed", range(5))
def test_F_and_G_match_finite_differences_of_error_rate(seed):
    rng = np.random.default_rng(100 + seed)
    pt = _random_ins_point(rng)
    omega_hat = pt["omega_ib_meas"] - pt["bias_hat"]["bg"]
    F = F_matrix(pt["C_hat"], pt["vel_b_hat"], omega_hat, EARTH)
    G = G_matrix(pt["C_hat"], pt["vel_b_hat"])
    assert F.shape == (STATE.dim, STATE.dim) and G.shape == (STATE.dim, NOISE.dim)

    zero_x, zero_w = np.zeros(STATE.dim), np.zeros(NOISE.dim)
    np.testing.assert_allclose(_rate(pt, zero_x, zero_w), 0.0, rtol=0, atol=1e-12)

    F_fd = np.zeros_like(F)
    for j in range(STATE.dim):
        e = np.zeros(STATE.dim)
        e[j] = EPS
        F_fd[:, j] = (_rate(pt, e, zero_w) - _rate(pt, -e, zero_w)) / (2 * EPS)
    G_fd = np.zeros_like(G)
    for j in range(NOISE.dim):
        e = np.zeros(NOISE.dim)
        e[j] = EPS
        G_fd[:, j] = (_rate(pt, zero_x, e) - _rate(pt, zero_x, -e)) / (2 * EPS)

    atol_F = 1e-7 * max(1.0, np.abs(F).max())
    atol_G = 1e-7 * max(1.0, np.abs(G).max())
    for name in STATE.names:   # block by block, so a failure names the block
        np.testing.assert_allclose(F[getattr(STATE, name)], F_fd[getattr(STATE, name)], rtol=0, atol=atol_F,
                                   err_msg=f"F rows {name}")
    np.testing.assert_allclose(G, G_fd, rtol=0, atol=atol_G)


def test_F_is_batched():
    rng = np.random.default_rng(11)
    pts = [_random_ins_point(rng) for _ in range(3)]
    C = np.stack([p["C_hat"] for p in pts])
    v = np.stack([p["vel_b_hat"] for p in pts])
    om = np.stack([p["omega_ib_meas"] for p in pts])
    F = F_matrix(C, v, om, EARTH)
    G = G_matrix(C, v)
    for i in range(3):
        np.testing.assert_array_equal(F[i], F_matrix(C[i], v[i], om[i], EARTH))
        np.testing.assert_array_equal(G[i], G_matrix(C[i], v[i]))


# ------------------------------------------------------------------------------------------ (b) aiding H

DVL_CFG = DvlConfig(lever_arm_m=(0.6, -0.25, 0.15))
AVAILABILITY = {
    "4 beams": np.array([[True, True, True, True], [True, True, True, True]]),
    "3 beams (1 lost) + 4": np.array([[False, True, True, True], [True, True, True, True]]),
    "3 beams (2, 3 lost)": np.array([[True, False, True, True], [True, True, False, True]]),
    "3 beams (4 lost) x2": np.array([[True, True, True, False], [True, True, True, False]]),
}
# the tightly coupled model takes any number of beams: its H must be right for every pattern
AVAILABILITY_TC = {
    "4 beams": AVAILABILITY["4 beams"],
    "2 beams (12, 34)": np.array([[True, True, False, False], [False, False, True, True]]),
    "2 beams (14, 23)": np.array([[True, False, False, True], [False, True, True, False]]),
    "1 beam (1, 4)": np.array([[True, False, False, False], [False, False, False, True]]),
    "1 beam (2, 3)": np.array([[False, True, False, False], [False, False, True, False]]),
}


def _random_nominal(rng: np.random.Generator, batch: tuple[int, ...]) -> Nominal:
    euler = np.stack([rng.uniform(-0.5, 0.5, batch), rng.uniform(-0.6, 0.6, batch), rng.uniform(-3.0, 3.0, batch)], -1)
    euler.reshape(-1, 3)[0, 2] = np.pi - 1e-7       # first entry's yaw at the wrap (exercises the mag innovation)
    C = C_nb_from_euler(euler)
    vel_b = rng.normal(0.0, 2.0, batch + (3,))
    nav = NavState(pos_n=rng.normal(0.0, 50.0, batch + (3,)), vel_n=mv(C, vel_b), C_nb=C)
    return Nominal(nav=nav,
                   accel_bias=rng.normal(0.0, 5e-3, batch + (3,)),
                   gyro_bias=rng.normal(0.0, 1e-3, batch + (3,)),
                   dvl_bias=rng.normal(0.0, 5e-3, batch + (4,)),
                   dvl_sf=rng.normal(0.0, 7e-3, batch))


@dataclass(frozen=True)
class AidingCase:
    """How to build one aiding model's setup at a nominal, and how to difference its outputs."""

    name: str
    build: Callable[[Nominal, np.random.Generator, np.ndarray], tuple[object, object, np.ndarray]]
    # (model, setup, H from the model's measure())
    source: str                                   # the aiding source (AIDING_SOURCES) the model serves
    dvl_fusion: str | None = None                 # DVL only: the runner's fusion kind (DVL_FUSION values)
    availability: dict[str, np.ndarray] | None = None   # beam patterns to check (DVL only)


def _build_dvl(nom: Nominal, rng: np.random.Generator, available: np.ndarray):
    batch = nom.vel_b.shape[:-1]
    model = DvlLoose(DVL_CFG, EARTH, gyro_rate_noise_rps=1e-3)
    y = rng.normal(0.0, 1.0, batch + (4,))
    y = np.where(available, y, np.nan)
    omega = rng.normal(0.0, 0.2, batch + (3,))
    setup = model.prepare(nom, y, available, omega)
    H = model.measure(nom, y, available, omega).H
    return model, setup, H


def _build_dvl_tight(nom: Nominal, rng: np.random.Generator, available: np.ndarray):
    batch = nom.vel_b.shape[:-1]
    model = DvlTight(DVL_CFG, EARTH, gyro_rate_noise_rps=1e-3)
    y = np.where(available, rng.normal(0.0, 1.0, batch + (4,)), np.nan)
    omega = rng.normal(0.0, 0.2, batch + (3,))
    setup = model.prepare(nom, y, available, omega)
    meas = model.measure(nom, y, available, omega)
    assert meas.H.shape == batch + (4, STATE.dim)          # all four rows, whichever beams returned
    np.testing.assert_array_equal(meas.active, available)   # the missing beams are the inactive rows
    return model, setup, meas.H


def _build_depth(nom: Nominal, rng: np.random.Generator, available: np.ndarray):
    batch = nom.vel_b.shape[:-1]
    model = Depth(PressureConfig())
    depth = rng.uniform(0.0, 50.0, batch)
    data = SourceData(t_s=np.zeros(1), index=np.zeros(1, np.int64), values={"depth_m": depth[None]})
    return model, model.prepare(depth, batch), model.measure(nom, data, 0).H


def _build_mag(nom: Nominal, rng: np.random.Generator, available: np.ndarray):
    batch = nom.vel_b.shape[:-1]
    model = MagAttitude(MagnetometerConfig())
    euler = rng.uniform(-1.0, 1.0, batch + (3,))
    data = SourceData(t_s=np.zeros(1), index=np.zeros(1, np.int64),
                      values={n: euler[None, ..., i] for i, n in enumerate(EULER)})
    return model, model.prepare(euler, batch), model.measure(nom, data, 0).H


AIDING_REGISTRY = [
    AidingCase("dvl", _build_dvl, source="dvl", dvl_fusion="lc", availability=AVAILABILITY),
    AidingCase("dvl-tc", _build_dvl_tight, source="dvl", dvl_fusion="tc", availability=AVAILABILITY_TC),
    AidingCase("depth", _build_depth, source="depth"),
    AidingCase("mag", _build_mag, source="mag"),
]
# The ELC kind (DvlExtended) fuses a constructed velocity with H = [0 0 I 0 0 0 0] on the measured
# rows (eq. 18); it has no nonlinear predict to difference. Its construction and R are proved in
# test_partial.py (beside this file).
NO_NONLINEAR_MODEL = {"elc"}


def test_registry_covers_every_aiding_source_and_dvl_fusion():
    # the registry's sources' H is checked through their own interface (test_sources.py, beside this file);
    # the depth's and the magnetometer's also here, at random states of a batch
    # (the DVL's, fused by the methods themselves, only here)
    covered = {c.source for c in AIDING_REGISTRY}
    assert covered - set(FUSED) == set(AIDING_SOURCES) - set(FUSED) == {"dvl"}
    assert covered & set(FUSED) == {"depth", "mag"}
    assert len({c.name for c in AIDING_REGISTRY}) == len(AIDING_REGISTRY)
    runner_kinds = {k for k in DVL_FUSION.values() if k is not None} - NO_NONLINEAR_MODEL
    assert {c.dvl_fusion for c in AIDING_REGISTRY if c.source == "dvl"} == runner_kinds
    assert NO_NONLINEAR_MODEL <= set(DVL_FUSION.values())     # the exemption names a real kind


def _diff(model: object, h_plus: np.ndarray, h_minus: np.ndarray) -> np.ndarray:
    # a model with an innovation() (angles) defines how two of its outputs are differenced
    if hasattr(model, "innovation"):
        return model.innovation(h_plus, h_minus)
    return h_plus - h_minus


# only the DVL depends on which beams returned; the other models get one availability each
_H_CASES = [pytest.param(c, a, id=f"{c.name}-{a}") for c in AIDING_REGISTRY
            for a in (c.availability or {"4 beams": AVAILABILITY["4 beams"]})]


@pytest.mark.parametrize(("case", "availability"), _H_CASES)
def test_H_matches_finite_difference_of_predict(case, availability):
    rng = np.random.default_rng(sum(map(ord, case.name + availability)))
    available = (case.availability or AVAILABILITY)[availability]
    nom = _random_nominal(rng, (2,))
    model, setup, H = case.build(nom, rng, available)
    m = H.shape[-2]
    assert H.shape == (2, m, STATE.dim)
    H_fd = np.zeros_like(H)
    for j in range(STATE.dim):
        dx = np.zeros((2, STATE.dim))
        dx[:, j] = EPS
        h_plus = model.predict(inject(nom, dx), setup)
        h_minus = model.predict(inject(nom, -dx), setup)
        H_fd[..., j] = _diff(model, h_plus, h_minus) / (2 * EPS)
    for name in STATE.names:
        sl = getattr(STATE, name)
        np.testing.assert_allclose(H[..., sl], H_fd[..., sl], rtol=0, atol=1e-8, err_msg=f"{case.name}: H[{name}]")


@pytest.mark.parametrize("case", AIDING_REGISTRY, ids=[c.name for c in AIDING_REGISTRY])
def test_H_with_single_entry_batch(case):
    """Batch shape (1,): same check, with the DVL on three beams."""
    rng = np.random.default_rng(77)
    nom = _random_nominal(rng, (1,))
    model, setup, H = case.build(nom, rng, np.array([[True, False, True, True]]))
    H_fd = np.zeros_like(H)
    for j in range(STATE.dim):
        dx = np.zeros((1, STATE.dim))
        dx[:, j] = EPS
        H_fd[..., j] = _diff(model, model.predict(inject(nom, dx), setup),
                             model.predict(inject(nom, -dx), setup)) / (2 * EPS)
    np.testing.assert_allclose(H, H_fd, rtol=0, atol=1e-8)


# ------------------------------------------------------------------------------------------ (a') geodetic F

def _geodetic_point(rng: np.random.Generator, lat: float, h: float, speed: float) -> dict:
    pt = _random_ins_point(rng)
    # mostly east and a little north and down: every transport-rate term is exercised
    direction = np.array([0.3, 0.9, 0.1]) / np.linalg.norm([0.3, 0.9, 0.1])
    pt["vel_b_hat"] = pt["C_hat"].T @ direction * speed
    pt["position"] = (lat, 0.4, h)
    return pt


@pytest.mark.parametrize("lat_deg, h_m, speed_mps, seed", [
    (32.8, -150.0, 2.0, 0), (-60.0, -3000.0, 5.0, 1), (75.0, 200.0, 100.0, 2), (0.5, -20.0, 250.0, 3)])
def test_geodetic_F_and_G_match_finite_differences(lat_deg, h_m, speed_mps, seed):
    """Every block of F on the ellipsoid, new ones included (position columns of the velocity and
    attitude rows, the position rows' own terms, transport rate), against central differences of
    the exact error dynamics, entry by entry at 1e-6 of the entry's own size: the new terms are
    of the order 1e-7 to 1e-5 and a blanket tolerance at F's scale would not see them. Position
    columns are differenced over 1 m (the fields change over kilometres), the rest over 1e-6."""
    rng = np.random.default_rng(200 + seed)
    pt = _geodetic_point(rng, np.deg2rad(lat_deg), h_m, speed_mps)
    omega_hat = pt["omega_ib_meas"] - pt["bias_hat"]["bg"]
    lat, lon, h = pt["position"]
    F = F_matrix(pt["C_hat"], pt["vel_b_hat"], omega_hat, EARTH, position=(np.float64(lat), np.float64(lon),
                                                                         np.float64(h)))
    G = G_matrix(pt["C_hat"], pt["vel_b_hat"])

    def rate(dx: np.ndarray, w: np.ndarray) -> np.ndarray:
        return error_rate_geodetic(pt["position"], pt["C_hat"], pt["vel_b_hat"], pt["omega_ib_meas"], pt["f_meas"],
                                   pt["bias_hat"], dx, w)

    zero_x, zero_w = np.zeros(STATE.dim), np.zeros(NOISE.dim)
    np.testing.assert_allclose(rate(zero_x, zero_w), 0.0, rtol=0, atol=1e-12)
    F_fd = np.zeros_like(F)
    for j in range(STATE.dim):
        step = 1.0 if j in range(STATE.pos.start, STATE.pos.stop) else EPS
        e = np.zeros(STATE.dim)
        e[j] = step
        F_fd[:, j] = (rate(e, zero_w) - rate(-e, zero_w)) / (2 * step)
    G_fd = np.zeros_like(G)
    for j in range(NOISE.dim):
        e = np.zeros(NOISE.dim)
        e[j] = EPS
        G_fd[:, j] = (rate(zero_x, e) - rate(zero_x, -e)) / (2 * EPS)
    # entry by entry: 1e-6 relative, and an absolute floor at the finite difference's round-off,
    # 20 ulp of the row's rates over the column's step (rates: the speed for position, 0.3 rad/s
    # for attitude, 20 m/s^2 for velocity)
    steps = np.where(np.arange(STATE.dim) < STATE.pos.stop, 1.0, EPS)
    scale = np.ones(STATE.dim)
    scale[STATE.pos], scale[STATE.att], scale[STATE.vel] = speed_mps, 0.3, 20.0
    floor = 20 * np.finfo(float).eps * scale[:, None] / steps[None, :]
    for name in STATE.names:
        rows = getattr(STATE, name)
        bad = np.abs(F[rows] - F_fd[rows]) > 1e-6 * np.abs(F_fd[rows]) + floor[rows]
        assert not bad.any(), (name, np.argwhere(bad), F[rows][bad], F_fd[rows][bad])
    np.testing.assert_allclose(G, G_fd, rtol=0, atol=1e-7 * max(1.0, np.abs(G).max()))
    # the geodetic terms are there and not negligible for the test: position columns of the
    # velocity rows carry the free-air gradient 2 g / a, about 3.1e-6 s^-2
    assert abs(F[STATE.vel, STATE.pos][:, 2]).max() > 2e-6
    # and the flat model's F is the geodetic one without them
    F_flat = F_matrix(pt["C_hat"], pt["vel_b_hat"], omega_hat, EARTH)
    assert not F_flat[:, STATE.pos].any()


def test_rpm_fallback_H_matches_finite_difference_of_its_prediction():
    """--rpm-fallback's RPM velocity (tauvcore.engine.dvl_fusion.rpm_measurement): surge the speed the
    VKF learned from the DVL, (1 + SF) v_b1 + A+_1 . b; sway and heave the body velocity. Its H
    against central differences over every error state (the DVL scale factor and bias columns
    included: with H on the velocity alone the filter did not know the RPM speed shares the DVL's
    errors)."""
    from tauvcore.engine.dvl_fusion import rpm_measurement

    rng = np.random.default_rng(91)
    nom = _random_nominal(rng, (2,))
    A_pinv = np.linalg.pinv(DVL_CFG.A_b)

    def predict(n: Nominal) -> np.ndarray:
        return rpm_measurement(n.vel_b, np.reshape(n.dvl_sf, (2,)), n.dvl_bias, A_pinv)[0]

    _, H = rpm_measurement(nom.vel_b, np.reshape(nom.dvl_sf, (2,)), nom.dvl_bias, A_pinv)
    H_fd = np.zeros_like(H)
    for j in range(STATE.dim):
        dx = np.zeros((2, STATE.dim))
        dx[:, j] = EPS
        H_fd[..., j] = (predict(inject(nom, dx)) - predict(inject(nom, -dx))) / (2 * EPS)
    np.testing.assert_allclose(H, H_fd, rtol=0, atol=1e-8)
    assert np.all(H[..., 0, STATE.sf_dvl] != 0.0) and np.all(H[..., 0, STATE.b_dvl] != 0.0)
