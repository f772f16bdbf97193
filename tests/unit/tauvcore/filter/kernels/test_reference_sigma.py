"""The reference's own 1-sigma (``[reference]``): the NEES is taken against P plus the reference's
covariance on the navigation blocks, in the frames of each bank's error state.

- exact (the default): every NEES of both banks, their smoothers and a replay is what it was
  (tests/fixtures/nees_reference.npz, written before the section existed), to 1e-9: the fixture
  was written on one processor, and another's vector instructions may round a sine in the last
  bit, which the filters carry to about 1e-12;
- the kernel: ``dx^T (P + P_ref)^-1 dx`` for a hand-built P and dx, the full state and each block;
- the reference's covariance: its errors carried into each bank's error state, against finite
  differences of the nonlinear difference;
- a known answer: a constant reference error of known sigma, drawn per run, brings NEES/dim back
  to about 1 when its sigma is stated and leaves it far too high when it is not (both banks).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import pathlib

import numpy as np
import pytest

from tauvcore import units
from tauvcore.config import Config, ConfigError, ReferenceConfig, from_dict
from tauvcore.engine import loop
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.filter.kernels.nees import nees_blocks_into, nees_plan
from tauvcore.filter.layout import BASE_LAYOUT, NEES_BLOCKS, STATE
from tauvcore.geo.rotations import C_nb_from_euler

ROOT = pathlib.Path(__file__).resolve().parents[5]
_spec = importlib.util.spec_from_file_location(
    "make_nees_reference", ROOT / "scripts" / "make_nees_reference.py"
)
make = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(make)


def test_an_exact_reference_leaves_every_nees_as_it_was() -> None:
    """[reference] at its default (0: exact) gives the NEES the engine gave before the section
    existed: both banks, their smoothers, a replay; every number within 1e-9 of its scale, the
    same epochs unknown (NaN)."""
    assert Config().reference.exact
    expected = np.load(ROOT / "tests" / "fixtures" / "nees_reference.npz")
    got = make.arrays()
    assert sorted(got) == sorted(expected.files)
    for key in expected.files:
        scale = max(1.0, float(np.nanmax(np.abs(expected[key])))) if np.isfinite(expected[key]).any() else 1.0
        np.testing.assert_allclose(got[key], expected[key], rtol=0.0, atol=1e-9 * scale, equal_nan=True,
                                   err_msg=key)


# --- the section -----------------------------------------------------------------------------


def test_the_section_s_variances_and_its_line() -> None:
    ref = ReferenceConfig(
        pos_horizontal_m=0.5, pos_vertical_m=0.1, vel_mps=0.02, roll_pitch_deg=0.01, yaw_deg=0.05
    )
    deg2 = np.square(np.array([0.01, 0.01, 0.05]) * units.DEG)
    np.testing.assert_allclose(ref.variances(), [0.25, 0.25, 0.01, 4e-4, 4e-4, 4e-4, *deg2], rtol=1e-15)
    assert not ref.exact
    assert ref.describe() == (
        "NEES against the reference with its stated 1-sigma: position 0.5 m horizontal, "
        "0.1 m vertical; velocity 0.02 m/s; attitude 0.01/0.05 deg (roll/pitch, yaw)"
    )
    assert ReferenceConfig(yaw_deg=0.05).describe() == (
        "NEES against the reference with its stated 1-sigma: position exact; velocity exact; attitude 0/0.05 deg "
        "(roll/pitch, yaw)"
    )
    assert ReferenceConfig().describe() == "NEES against the reference as exact (no [reference] sigma)"
    assert ref.describe(has_reference=False) == "no reference: the errors and the NEES are unknown"
    assert from_dict({"reference": {"vel_mps": 0.02}}).reference == ReferenceConfig(vel_mps=0.02)


@pytest.mark.parametrize(
    "key, bad, good",
    [
        ("pos_horizontal_m", -0.1, 1000.0),
        ("pos_vertical_m", 1001.0, 0.0),
        ("vel_mps", 10.5, 10.0),
        ("roll_pitch_deg", 11.0, 10.0),
        ("yaw_deg", -1.0, 30.0),
        ("yaw_deg", float("nan"), 0.0),
    ],
)
def test_each_sigma_has_a_range_naming_field_and_value(key: str, bad: float, good: float) -> None:
    assert getattr(from_dict({"reference": {key: good}}).reference, key) == good
    with pytest.raises(ConfigError, match=rf"reference\.{key}.*{bad}"):
        from_dict({"reference": {key: bad}})


# --- the kernel: the reference's covariance in each bank's frames, and the NEES over it ------

REF = ReferenceConfig(pos_horizontal_m=0.7, pos_vertical_m=0.2, vel_mps=0.03, roll_pitch_deg=0.4, yaw_deg=2.0)
EULER = np.array([0.3, -0.25, 2.1])  # a rolled, pitched, turned reference: every term of P_ref non-zero
VEL_N = np.array([1.2, -0.8, 0.3])


def _spd(rng: np.random.Generator, d: int) -> np.ndarray:
    """A well-conditioned random covariance (d, d)."""
    A = rng.normal(size=(d, d)) * np.exp(rng.uniform(-4, 1, size=d))
    return A @ A.T + np.diag(np.exp(rng.uniform(-8, 0, size=d)))


def _reference_jacobian(body: bool) -> np.ndarray:
    """d(dx_nav)/d(reference error) by central differences of the nonlinear difference ``x_ref (-)
    x_hat`` (tauvcore.filter.kernels.correction.nav_difference_into: position, misalignment,
    body velocity; or Yoo's NED velocity ``v_ref - v``), the reference's error being its NED
    position, NED velocity and roll, pitch, yaw: rows pos, att, vel; columns the 9 errors."""
    from tauvcore.filter.kernels.correction import difference_batch
    from tauvcore.geo.rotations import C_nb_from_euler

    pos0 = np.array([10.0, -5.0, 30.0])
    est = (pos0[None], VEL_N[None], C_nb_from_euler(EULER)[None])  # at the reference: the first order

    def dx(err: np.ndarray) -> np.ndarray:
        C = C_nb_from_euler(EULER + err[6:9])
        out = difference_batch((pos0 + err[0:3])[None], (VEL_N + err[3:6])[None], C[None], *est, False)[0]
        if not body:
            out[6:9] = (VEL_N + err[3:6]) - est[1][0]
        return out

    h = 1e-6
    return np.column_stack([(dx(h * e) - dx(-h * e)) / (2 * h) for e in np.eye(9)])


@pytest.mark.parametrize("body", [True, False], ids=["20-state body velocity", "Yoo's NED velocity"])
def test_the_reference_s_covariance_is_its_errors_carried_into_the_error_state(body: bool) -> None:
    """add_reference_into's P_ref equals ``T diag(ref_var) T^T``, T the finite-difference Jacobian of
    the error state against the reference's errors (its roll, pitch, yaw turned into the n-frame
    misalignment; its NED velocity and, in the body frame, its attitude error into the velocity)."""
    from tauvcore.filter.kernels.nees import add_reference_into
    from tauvcore.geo.rotations import C_nb_from_euler

    T = _reference_jacobian(body)
    expected = T @ np.diag(REF.variances()) @ T.T  # rows and columns: pos, att, vel (the 20-state order)
    d = 9
    A = np.empty((d, d))
    assert add_reference_into(
        np.zeros((d, d)),
        REF.variances(),
        C_nb_from_euler(EULER),
        VEL_N,
        STATE.pos.start,
        STATE.att.start,
        STATE.vel.start,
        body,
        A,
    )
    scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
    np.testing.assert_allclose(A / scale, expected / scale, rtol=0, atol=1e-7)
    if not body:  # Yoo's NED velocity carries no attitude term
        assert not A[STATE.vel, STATE.att].any()
    # the position's sigma is left out where there is no position state (Yoo's)
    assert not add_reference_into(np.eye(d), np.zeros(9), C_nb_from_euler(EULER), VEL_N, -1, 3, 0, False, A)


def _series(dx: np.ndarray, P: np.ndarray, ref_var: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 20-state records of one epoch as record_bank makes them, and the covariance the NEES took."""
    from tauvcore.filter.kernels.nees import add_reference_into
    from tauvcore.geo.rotations import C_nb_from_euler

    d = P.shape[0]
    block_of_state = np.full(d, -1)
    for b, ix in enumerate(NEES_BLOCKS.values()):
        block_of_state[list(ix)] = b
    members, sizes, lead, order = nees_plan(block_of_state, len(NEES_BLOCKS))
    A = np.empty((d, d))
    Q = A if add_reference_into(P, ref_var, C_nb_from_euler(EULER), VEL_N, 0, 3, 6, True, A) else P
    series, blocks = np.empty(len(loop.SERIES_NAMES)), np.empty(len(NEES_BLOCKS))
    loop.error_series_into(
        dx, P, Q, units.DEG, members, sizes, lead, order, np.empty((d, d)), np.empty(d), series, blocks
    )
    return series, blocks, Q


def test_the_nees_is_against_p_plus_the_reference_s_covariance() -> None:
    """For a hand-built P and dx: the full NEES is ``dx^T (P + P_ref)^-1 dx`` and each block's the
    same over its marginal (solved here by numpy, not by the kernel's Cholesky); the filter's own
    1-sigma in the series stay P's; the sensor block, which the reference says nothing of, is P's."""
    rng = np.random.default_rng(4)
    d = BASE_LAYOUT.dim
    P, dx = _spd(rng, d), rng.normal(size=d)
    series, blocks, A = _series(dx, P, REF.variances())
    T = _reference_jacobian(True)
    expected = P.copy()
    expected[:9, :9] += T @ np.diag(REF.variances()) @ T.T
    np.testing.assert_allclose(A, expected, rtol=1e-6, atol=1e-12)
    assert series[loop.SERIES_NAMES.index("nees")] == pytest.approx(dx @ np.linalg.solve(A, dx), rel=1e-10)
    for b, ix in enumerate(NEES_BLOCKS.values()):
        ix = list(ix)
        assert blocks[b] == pytest.approx(dx[ix] @ np.linalg.solve(A[np.ix_(ix, ix)], dx[ix]), rel=1e-10)
    assert series[loop.SERIES_NAMES.index("vel_sigma")] == pytest.approx(
        np.sqrt(np.trace(P[STATE.vel, STATE.vel]))
    )
    sensor = list(NEES_BLOCKS["sensor"])
    assert blocks[list(NEES_BLOCKS).index("sensor")] == pytest.approx(
        dx[sensor] @ np.linalg.solve(P[np.ix_(sensor, sensor)], dx[sensor]), rel=1e-10
    )


def test_an_exact_reference_takes_p_itself() -> None:
    """All-zero variances: the numbers of the plain NEES kernel on P, equal to the last bit."""
    rng = np.random.default_rng(5)
    d = BASE_LAYOUT.dim
    P, dx = _spd(rng, d), rng.normal(size=d)
    series, blocks, Q = _series(dx, P, np.zeros(9))
    assert Q is P
    block_of_state = np.full(d, -1)
    for b, ix in enumerate(NEES_BLOCKS.values()):
        block_of_state[list(ix)] = b
    members, sizes, lead, order = nees_plan(block_of_state, len(NEES_BLOCKS))
    plain = np.empty(len(NEES_BLOCKS))
    full = nees_blocks_into(P, dx, members, sizes, lead, order, np.empty((d, d)), np.empty(d), plain)
    assert series[loop.SERIES_NAMES.index("nees")] == full
    np.testing.assert_array_equal(blocks, plain)


# --- a known answer over seeded Monte Carlo -------------------------------------------------

SIGMA = ReferenceConfig(
    pos_horizontal_m=6.0, pos_vertical_m=3.0, vel_mps=0.08, roll_pitch_deg=0.5, yaw_deg=4.0
)
"""Each well above the filters' own 1-sigma on this mission, so that leaving it out shows."""
STEP_S = 5.0
"""The reference's error appears here (zero before): the filters start on the truth, as a replay
starts on the reference's first row, so only a reference error that arises after the start is
one the filters cannot share; from then on it is constant."""
NUM_RUNS = 16


def _with_reference_error(truth, rng: np.random.Generator):
    """The truth with one draw of :data:`SIGMA`'s errors from :data:`STEP_S` on: its position and
    velocity (NED) offset, its roll, pitch and yaw turned (the body velocity with them)."""
    after = (truth.t_s >= STEP_S)[:, None]
    err = np.sqrt(SIGMA.variances()) * rng.standard_normal(9)
    euler = truth.euler + after * err[6:9]
    C = C_nb_from_euler(euler)
    vel_n = truth.vel_n + after * err[3:6]
    return dataclasses.replace(
        truth,
        pos_n=truth.pos_n + after * err[0:3],
        pos_nav=truth.pos_nav + after * err[0:3],
        vel_n=vel_n,
        vel_b=np.einsum("kji,kj->ki", C, vel_n),
        C_nb=C,
        euler=euler,
    )


@pytest.fixture(scope="module")
def monte_carlo() -> dict[str, dict[str, np.ndarray]]:
    """Per method and block, the NEES/dim after the step averaged over its epochs, one value per
    run, with the reference's sigma stated and without."""
    base = (
        Config()
        .replace("trajectory", name="figure8", duration_s=60.0)
        .replace("earth", model="flat")
        .replace("initial_error", mode="random")
        .replace("run", methods=("lc", "ins-dvl"))
    )
    out: dict[str, dict[str, list[float]]] = {}
    for seed in range(NUM_RUNS):
        rng = np.random.default_rng(1000 + seed)
        sim = simulate(base, rng)
        sim = dataclasses.replace(sim, truth=_with_reference_error(sim.truth, rng))
        for stated, config in (
            ("stated", base.replace("reference", **dataclasses.asdict(SIGMA))),
            ("exact", base),
        ):
            results = run(config, sim, np.random.default_rng(seed), smooth=SmoothOptions())
            for method, filtered in results.items():
                for kind, r in (("filtered", filtered), ("smoothed", filtered.smoothed)):
                    keep = r.t_s >= STEP_S + 1.0
                    for b, (name, ix) in enumerate(NEES_BLOCKS.items()):
                        if name == "sensor" or (method == "ins-dvl" and name == "pos"):
                            continue
                        value = np.nanmean(r.nees_block[keep, 0, b]) / len(ix)
                        out.setdefault(f"{method}/{kind}/{stated}", {}).setdefault(name, []).append(value)
    return {k: {b: np.array(v) for b, v in d.items()} for k, d in out.items()}


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["filtered", "smoothed"])
@pytest.mark.parametrize("method", ["lc", "ins-dvl"])
def test_a_stated_reference_sigma_brings_nees_back_to_its_band(monte_carlo, method: str, kind: str) -> None:
    """Stated: each block's NEES/dim averaged over the runs within [0.6, 1.5] (16 runs of a
    chi-square over 3, 2 or 1 degrees of freedom dominated by the reference's draw: 1 +- 0.2 to
    0.35), for both banks (the 20-state filter's body velocity takes the reference's attitude
    error too) and their smoothers; not stated: above 3 on every block."""
    for block, values in monte_carlo[f"{method}/{kind}/stated"].items():
        assert 0.6 <= values.mean() <= 1.5, (method, kind, block, values.mean())
    for block, values in monte_carlo[f"{method}/{kind}/exact"].items():
        assert values.mean() > 3.0, (method, kind, block, values.mean())


def test_yoo_s_compiled_loop_equals_its_numpy_reference_against_an_uncertain_reference(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The compiled Yoo loop's NEES against P + P_ref equals the numpy reference's
    (tests/unit/tauvcore/engine/yoo_reference.py, the path its smoother takes), to 1e-9, and differs
    from the NEES against an exact reference."""
    from tauvcore.engine.mission import run_streaming
    from tests.unit.tauvcore.engine.test_yoo_bank import _assert_results_equal, _numpy_bank

    base = (
        Config()
        .replace("trajectory", name="figure8", duration_s=40.0)
        .replace("run", methods=("ins-dvl", "vkf"))
    )
    config = base.replace("reference", **dataclasses.asdict(SIGMA))
    fast = run_streaming(config, np.random.default_rng(3), num_runs=2)
    exact = run_streaming(base, np.random.default_rng(3), num_runs=2)
    assert np.nanmax(np.abs(fast["vkf"].nees - exact["vkf"].nees)) > 0.1 * np.nanmax(exact["vkf"].nees)
    _numpy_bank(monkeypatch)
    slow = run_streaming(config, np.random.default_rng(3), num_runs=2)
    _assert_results_equal(fast, slow)
