"""Extended loosely coupled methods for two returned beams (Tal et al. 2017 section 3, eq. 23-49).

Each method is an affine construction ``v = C y_c + D v_hat`` with reported covariance ``R``
(tauvcore.aiding.dvl_partial). The tests prove, per beam pair:
(a) which pairs each method can use, and which axes it measures;
(b) known answers: noise-free beams and a true prediction give the true velocity;
(c) the paper's closed forms (eq. 28-30, 33-36, 40-41, 45-46 with the sign corrected);
(d) the reported R is the covariance of the output (Monte Carlo, 10,000 samples);
(e) the selector takes the minimum-variance method per axis (eq. 48).

Beams are numbered 0..3 here (the paper's 1..4).
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tauvcore.aiding import elc_nsv, elc_plcf, elc_select, elc_vb, elc_vhv
from tauvcore.aiding.dvl_partial import (
    AXES,
    PartialSolution,
    apply_solution,
    beam_noise_cov,
    cannot,
    compensated_beams,
)
from tauvcore.sensors.dvl import beam_directions_b

PITCH = np.radians(20.0)
A = beam_directions_b(PITCH)
H_XY = np.sin(PITCH) / np.sqrt(2.0)      # |b_k,1| = |b_k,2|
C_Z = np.cos(PITCH)                      # b_k,3
NOISE = 0.042                            # beam noise, Table 2 [m/s]
LEVER = np.array([0.6, 0.0, 0.15])       # DVL head lever arm [m]
EPSILON = 1e-4                           # NSV's sway-assumption variance [m^2/s^2]
MC_EPSILON = 1e-2                        # the Monte Carlo's: 0.1 m/s, a turning hull's sway, so the leak shows
SURGE, SWAY, HEAVE = 0, 1, 2

PAIRS = list(itertools.combinations(range(4), 2))
PAIR_IDS = [f"beams{i + 1}{j + 1}" for i, j in PAIRS]
NSV_UNUSABLE = {(0, 3), (1, 2)}          # paper pairs 1-4, 2-3: A_0 singular
VHV_UNUSABLE = {(0, 2), (1, 3)}          # paper pairs 1-3, 2-4: diagonal, heave measured directly
PLCF_AXIS = {(0, 1): SURGE, (2, 3): SURGE, (0, 3): SWAY, (1, 2): SWAY, (0, 2): HEAVE, (1, 3): HEAVE}


def pattern_of(beams: tuple[int, ...]) -> tuple[bool, ...]:
    return tuple(k in beams for k in range(4))


SOLVERS = {
    "vb": lambda pattern, n_f=2.0: elc_vb.solve(PITCH, pattern, n_f),
    "nsv": lambda pattern, n_f=2.0: elc_nsv.solve(PITCH, pattern, EPSILON),
    "plcf": lambda pattern, n_f=2.0: elc_plcf.solve(PITCH, pattern),
    "vhv": lambda pattern, n_f=2.0: elc_vhv.solve(PITCH, pattern, n_f),
}
USABLE = {
    "vb": set(PAIRS),
    "nsv": set(PAIRS) - NSV_UNUSABLE,
    "plcf": set(PAIRS),
    "vhv": set(PAIRS) - VHV_UNUSABLE,
}


def beams_to_yc(v_true: np.ndarray, pattern: tuple[bool, ...]) -> np.ndarray:
    """Noise-free beams of ``v_true`` (n, 3), NaN where not returned, through the compensation
    (zero bias, scale factor and rotation): what an ELC method receives. -> (n, 4)."""
    n = v_true.shape[0]
    available = np.broadcast_to(np.array(pattern), (n, 4))
    y = np.where(available, v_true @ A.T, np.nan)
    return compensated_beams(A, y, available, np.zeros((n, 4)), np.zeros(n), np.zeros((n, 3)), LEVER)


def random_spd(rng: np.random.Generator, scale: float) -> np.ndarray:
    """A non-diagonal SPD 3x3 matrix with diagonal of order ``scale``."""
    M = rng.standard_normal((3, 3))
    P = M @ M.T / 3.0 + 0.3 * np.eye(3)
    d = np.sqrt(np.diag(P))
    P = P / np.outer(d, d)                       # correlation matrix, correlations up to ~0.8
    sig = scale * rng.uniform(0.6, 1.4, 3)
    return P * np.outer(sig, sig)


def apply(sol: PartialSolution, y_c, S_y, v_hat, P_vel):
    return apply_solution(sol.C, sol.D, sol.pred_gain, sol.assumption_sd, y_c, S_y, v_hat, P_vel)


# ------------------------------------------------------------------------------------------ (a) which pairs

@pytest.mark.parametrize("method", SOLVERS)
@pytest.mark.parametrize("pair", PAIRS, ids=PAIR_IDS)
def test_which_pairs_each_method_can_use(method, pair):
    sol = SOLVERS[method](pattern_of(pair))
    assert sol.method == method
    assert sol.ok == (pair in USABLE[method])
    if sol.ok:
        assert sol.measured.any()
        # a used pattern reads only the returned beams
        assert np.all(sol.C[:, [k for k in range(4) if k not in pair]] == 0.0)
    else:
        assert sol.reason.strip(), f"{method} refuses {pair} without a reason"
        assert not sol.measured.any()


@pytest.mark.parametrize("pair", PAIRS, ids=PAIR_IDS)
def test_plcf_measures_the_one_axis_the_pair_sees(pair):
    sol = SOLVERS["plcf"](pattern_of(pair))
    expected = np.zeros(3, dtype=bool)
    expected[PLCF_AXIS[pair]] = True
    np.testing.assert_array_equal(sol.measured, expected)


@pytest.mark.parametrize("pair", sorted(USABLE["vhv"]))
def test_vhv_measures_plcf_axis_and_the_other_horizontal_axis(pair):
    sol = SOLVERS["vhv"](pattern_of(pair))
    np.testing.assert_array_equal(sol.measured, [True, True, False])
    plcf = SOLVERS["plcf"](pattern_of(pair))
    axis = PLCF_AXIS[pair]
    np.testing.assert_array_equal(sol.C[axis], plcf.C[axis])          # eq. 47: PLCF's row unchanged
    assert np.all(sol.D[axis] == 0.0)
    other = 1 - axis
    np.testing.assert_array_equal(np.flatnonzero(sol.D[other]), [HEAVE])  # only the predicted heave enters


@pytest.mark.parametrize("method", ["vb", "nsv"])
@pytest.mark.parametrize("pair", PAIRS, ids=PAIR_IDS)
def test_vb_and_nsv_fill_all_three_axes(method, pair):
    sol = SOLVERS[method](pattern_of(pair))
    if sol.ok:
        np.testing.assert_array_equal(sol.measured, [True, True, True])


NON_PAIR_PATTERNS = [p for p in itertools.product((False, True), repeat=4) if sum(p) != 2]


@pytest.mark.parametrize("method", SOLVERS)
@pytest.mark.parametrize("pattern", NON_PAIR_PATTERNS, ids=["".join("x" if b else "." for b in p) for p in NON_PAIR_PATTERNS])
def test_patterns_without_exactly_two_beams_are_refused(method, pattern):
    sol = SOLVERS[method](pattern)
    assert not sol.ok and sol.reason.strip()


@pytest.mark.parametrize("pattern", [p for p in NON_PAIR_PATTERNS if sum(p) in (1, 3)])
def test_selector_measures_nothing_without_two_beams(pattern):
    sols = elc_select.candidate_solutions(PITCH, pattern, 2.0, EPSILON)
    n = 3
    y_c = np.zeros((n, 4))
    v, R, measured, choice = elc_select.select(sols, y_c, np.broadcast_to(np.eye(4) * NOISE**2, (n, 4, 4)),
                                               np.ones((n, 3)), np.broadcast_to(np.eye(3) * 0.01, (n, 3, 3)))
    assert not measured.any()
    np.testing.assert_array_equal(choice, -1)


# ------------------------------------------------------------------------------------------ (b) known answers

def _known_answer_inputs(seed: int, pattern: tuple[bool, ...], sway_zero: bool = False):
    rng = np.random.default_rng(seed)
    n = 8
    v_true = rng.normal(0.0, 2.0, (n, 3))
    if sway_zero:
        v_true[:, SWAY] = 0.0
    y_c = beams_to_yc(v_true, pattern)
    S_y = beam_noise_cov(A, NOISE, 1e-3, LEVER, np.zeros(n))
    P_vel = np.broadcast_to(random_spd(rng, 0.05), (n, 3, 3))
    return v_true, y_c, S_y, P_vel


@pytest.mark.parametrize(("method", "pair"), [pytest.param(m, p, id=f"{m}-{pid}") for m in ("vb", "plcf", "vhv")
                                               for p, pid in zip(PAIRS, PAIR_IDS) if p in USABLE[m]])
def test_noise_free_beams_and_true_prediction_give_true_velocity(method, pair):
    pattern = pattern_of(pair)
    sol = SOLVERS[method](pattern)
    v_true, y_c, S_y, P_vel = _known_answer_inputs(300 + PAIRS.index(pair), pattern)
    v, _ = apply(sol, y_c, S_y, v_true, P_vel)
    m = sol.measured
    np.testing.assert_allclose(v[:, m], v_true[:, m], rtol=0, atol=1e-12)


@pytest.mark.parametrize("pair", sorted(USABLE["nsv"]))
def test_nsv_is_exact_when_the_true_sway_is_zero(pair):
    pattern = pattern_of(pair)
    sol = SOLVERS["nsv"](pattern)
    v_true, y_c, S_y, P_vel = _known_answer_inputs(310 + PAIRS.index(pair), pattern, sway_zero=True)
    v, _ = apply(sol, y_c, S_y, v_true + 1.0, P_vel)     # NSV ignores the prediction
    np.testing.assert_allclose(v, v_true, rtol=0, atol=1e-12)


@pytest.mark.parametrize("pair", sorted(USABLE["nsv"]))
def test_nsv_is_wrong_in_surge_or_heave_when_the_true_sway_is_not_zero(pair):
    """The sway the assumption drops leaks into (u, w): error = v A_0^-1 a_y, a_y the pair's y components."""
    pattern = pattern_of(pair)
    sol = SOLVERS["nsv"](pattern)
    v_true, y_c, S_y, P_vel = _known_answer_inputs(320 + PAIRS.index(pair), pattern)
    assert np.all(np.abs(v_true[:, SWAY]) > 1e-3)
    v, _ = apply(sol, y_c, S_y, v_true, P_vel)
    err = v - v_true
    A_0 = A[list(pair)][:, [SURGE, HEAVE]]
    expected_uw = v_true[:, SWAY, None] * np.linalg.solve(A_0, A[list(pair), SWAY])
    np.testing.assert_allclose(err[:, [SURGE, HEAVE]], expected_uw, rtol=0, atol=1e-12)
    np.testing.assert_allclose(v[:, SWAY], 0.0, rtol=0, atol=0)
    # clearly nonzero: at least a quarter of the sway, on every sample
    assert np.all(np.linalg.norm(err[:, [SURGE, HEAVE]], axis=-1) > 0.25 * np.abs(v_true[:, SWAY]))


@pytest.mark.parametrize("pair", PAIRS, ids=PAIR_IDS)
def test_selector_gives_true_velocity_from_noise_free_beams(pair):
    """With zero true sway every candidate is exact, so the selection is exact on every measured axis;
    with nonzero sway, the rows it took from a method other than NSV are still exact."""
    pattern = pattern_of(pair)
    sols = elc_select.candidate_solutions(PITCH, pattern, 2.0, EPSILON)
    for sway_zero in (True, False):
        v_true, y_c, S_y, P_vel = _known_answer_inputs(330 + PAIRS.index(pair), pattern, sway_zero=sway_zero)
        v, R, measured, choice = elc_select.select(sols, y_c, S_y, v_true, P_vel)
        assert measured.all()                     # VB is always there
        exact = measured if sway_zero else measured & (choice != elc_select.CANDIDATES.index("nsv"))
        assert exact.any()
        np.testing.assert_allclose(v[exact], v_true[exact], rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------ (c) paper equations

def test_plcf_surge_is_eq40_with_variance_eq41():
    rng = np.random.default_rng(401)
    pattern = pattern_of((0, 1))
    sol = SOLVERS["plcf"](pattern)
    b11 = A[0, 0]
    s1, s2 = 0.03, 0.055                              # unequal beam sigmas make eq. 41 a real check
    S_y = np.diag([s1**2, s2**2, 0.07**2, 0.09**2])
    y = rng.normal(0.0, 1.0, (20, 4))                 # any beams, consistent or not (affine map)
    y[:, 2:] = 0.0
    v, R = apply(sol, y, S_y, rng.normal(0.0, 1.0, (20, 3)), random_spd(rng, 0.05))
    np.testing.assert_allclose(v[:, SURGE], (y[:, 0] - y[:, 1]) / (2.0 * b11), rtol=1e-13, atol=1e-13)
    assert R[SURGE, SURGE] == pytest.approx((s1**2 + s2**2) / (4.0 * b11**2), rel=1e-12)
    np.testing.assert_array_equal(sol.measured, [True, False, False])


def test_vhv_sway_is_eq45_and_its_variance_adds_the_heave_prediction():
    """Eq. 46 prints ``- (b13/b12)^2 sigma_w^2``; the error of eq. 45 is a sum of independent errors,
    so its variance is the SUM (the Monte Carlo test below confirms it)."""
    rng = np.random.default_rng(402)
    pattern = pattern_of((0, 1))
    sol = SOLVERS["vhv"](pattern, 1.0)
    b11, b12, b13 = A[0]
    s1, s2 = 0.03, 0.055
    S_y = np.diag([s1**2, s2**2, 0.07**2, 0.09**2])
    P_vel = random_spd(rng, 0.05)                     # correlated: only sigma_w^2 = P[2, 2] may enter
    y = rng.normal(0.0, 1.0, (20, 4))
    y[:, 2:] = 0.0
    v_hat = rng.normal(0.0, 1.0, (20, 3))
    v, R = apply(sol, y, S_y, v_hat, P_vel)
    np.testing.assert_allclose(v[:, SWAY], (y[:, 0] + y[:, 1]) / (2.0 * b12) - (b13 / b12) * v_hat[:, HEAVE],
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(v[:, SURGE], (y[:, 0] - y[:, 1]) / (2.0 * b11), rtol=1e-13, atol=1e-13)
    beams_part = (s1**2 + s2**2) / (4.0 * b12**2)
    pred_part = (b13 / b12) ** 2 * P_vel[HEAVE, HEAVE]
    assert R[SWAY, SWAY] == pytest.approx(beams_part + pred_part, rel=1e-12)
    assert R[SWAY, SWAY] != pytest.approx(beams_part - pred_part, rel=1e-3)   # not the printed minus
    assert R[SURGE, SURGE] == pytest.approx((s1**2 + s2**2) / (4.0 * b11**2), rel=1e-12)   # eq. 47 R_u,PLCF
    np.testing.assert_array_equal(sol.measured, [True, True, False])
    # n_f inflates the predicted heave's part only (our departure, as VB's eq. 28)
    _, R20 = apply(SOLVERS["vhv"](pattern, 20.0), y, S_y, v_hat, P_vel)
    assert R20[SWAY, SWAY] == pytest.approx(beams_part + 400.0 * pred_part, rel=1e-12)
    assert R20[SURGE, SURGE] == pytest.approx(R[SURGE, SURGE], rel=1e-12)


def _kalman(x, P, z, H, R):
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T
    return x + K @ (z - H @ x), (np.eye(len(x)) - K @ H) @ P


@pytest.mark.parametrize("method", ["vb", "vhv"])
def test_with_the_prediction_correlation_kept_vb_and_vhv_are_tight_coupling(method):
    """The README's claim: the prediction term ``D v_hat`` errs by ``-D dv``, part of the state
    error. Kept exactly (innovation ``(I - D) dv + C n``: H = I - D, R = C S C^T), VB and VHV
    fuse exactly the two beams' own information, the tightly coupled update (z = y, H = A_s)."""
    rng = np.random.default_rng(404)
    pattern = pattern_of((0, 1))
    sol = SOLVERS[method](pattern, 1.0)
    rows = sol.measured
    P = random_spd(rng, 0.05)
    v_hat = rng.normal(0.0, 1.0, 3)
    S_y = np.diag([0.03, 0.05, 1.0, 1.0]) ** 2
    y = rng.normal(0.0, 1.0, 4) * np.array(pattern)
    v_meas = sol.C @ y + sol.D @ v_hat
    x_exact, P_exact = _kalman(v_hat, P, (v_meas - sol.D @ v_hat)[rows], (np.eye(3) - sol.D)[rows],
                               (sol.C @ S_y @ sol.C.T)[np.ix_(rows, rows)])
    x_tc, P_tc = _kalman(v_hat, P, y[:2], A[:2], S_y[:2, :2])
    np.testing.assert_allclose(x_exact, x_tc, rtol=0, atol=1e-9)
    np.testing.assert_allclose(P_exact, P_tc, rtol=0, atol=1e-9)
    # the paper's form (H = I, the prediction's variance added to R) is not that update
    _, R_paper = apply(sol, y, S_y, v_hat, P)
    _, P_paper = _kalman(v_hat, P, v_meas[rows], np.eye(3)[rows], R_paper[np.ix_(rows, rows)])
    assert np.max(np.abs(P_paper - P_tc)) > 1e-4


@pytest.mark.parametrize("n_f", [1.0, 2.0, 3.5])
def test_vb_covariance_is_eq30_with_the_virtual_beam_of_eq28(n_f):
    """Beams 1, 2 returned: beam 3 is virtual, sigma_v3 = n_f sqrt(sum (b_3j sigma_j)^2) for a
    diagonal P (eq. 28), and R_VB = (A_s^T W_s A_s)^-1 (eq. 29-30)."""
    pattern = pattern_of((0, 1))
    sol = SOLVERS["vb"](pattern, n_f)
    sig = np.array([0.04, 0.07, 0.02])
    P_vel = np.diag(sig**2)
    S_y = np.eye(4) * NOISE**2
    sigma_v3 = n_f * np.sqrt(np.sum((A[2] * sig) ** 2))
    A_s = A[[0, 1, 2]]
    W_s = np.diag(1.0 / np.array([NOISE**2, NOISE**2, sigma_v3**2]))
    _, R = apply(sol, np.zeros(4), S_y, np.zeros(3), P_vel)
    np.testing.assert_allclose(R, np.linalg.inv(A_s.T @ W_s @ A_s), rtol=1e-10, atol=0)
    # eq. 24-25: the solution uses the beams and the virtual beam b_3 . v_hat, nothing else
    rng = np.random.default_rng(403)
    v_hat, y = rng.normal(0.0, 1.0, 3), rng.normal(0.0, 1.0, 4)
    y[2:] = 0.0
    v, _ = apply(sol, y, S_y, v_hat, P_vel)
    np.testing.assert_allclose(v, np.linalg.solve(A_s, [y[0], y[1], A[2] @ v_hat]), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("pair", sorted(USABLE["nsv"]))
def test_nsv_covariance_is_eq35_36_plus_the_sway_it_leaks(pair):
    """Eq. 35-36 with the beams' noise alone, plus epsilon times the leak of the true sway into
    each row, ``a = sqrt(epsilon) (C A - I) e_v``: -1 in the sway row, and for beams 1-2 / 3-4
    ``-+b_y / b_z`` (0.257) in heave, for 1-3 / 2-4 the full sway in surge."""
    sol = SOLVERS["nsv"](pattern_of(pair))
    leak = np.linalg.solve(A[list(pair)][:, [SURGE, HEAVE]], A[list(pair), SWAY])   # (u, w) error per unit sway
    np.testing.assert_allclose(sol.assumption_sd / np.sqrt(EPSILON), [leak[0], -1.0, leak[1]], atol=1e-12)
    s = np.array([0.03, 0.05, 0.04, 0.06])
    S_y = np.diag(s**2)
    _, R = apply(sol, np.zeros(4), S_y, np.zeros(3), np.eye(3))   # NSV ignores P
    A_0 = A[list(pair)][:, [SURGE, HEAVE]]
    W_0 = np.diag(1.0 / s[list(pair)] ** 2)
    R_0 = np.linalg.inv(A_0.T @ W_0 @ A_0)
    a = sol.assumption_sd
    assert R[SURGE, SURGE] == pytest.approx(R_0[0, 0] + a[SURGE] ** 2, rel=1e-12)
    assert R[HEAVE, HEAVE] == pytest.approx(R_0[1, 1] + a[HEAVE] ** 2, rel=1e-12)
    assert R[SWAY, SWAY] == pytest.approx(EPSILON, rel=1e-12)
    assert R[SWAY, SURGE] == pytest.approx(-a[SURGE] * np.sqrt(EPSILON), abs=1e-15)
    assert R[SWAY, HEAVE] == pytest.approx(-a[HEAVE] * np.sqrt(EPSILON), abs=1e-15)
    assert abs(a[HEAVE]) > 0.25 * np.sqrt(EPSILON) or abs(a[SURGE]) > 0.99 * np.sqrt(EPSILON)


# ------------------------------------------------------------------------------------------ (d) R vs Monte Carlo

N_MC = 10_000
MC_CASES = [pytest.param(m, p, id=f"{m}-{pid}") for m in ("vb", "nsv", "plcf", "vhv", "elc")
            for p, pid in zip(PAIRS, PAIR_IDS) if m == "elc" or p in USABLE[m]]


def _monte_carlo(seed: int, pattern: tuple[bool, ...], sway_var: float = MC_EPSILON):
    """Beam noise ~ N(0, S_y), prediction error ~ N(0, P_vel), true sway ~ N(0, sway_var) per
    sample: NSV's assumption ``v = 0`` with variance epsilon (the other methods are exact for
    any sway)."""
    rng = np.random.default_rng(seed)
    v_true = np.tile([rng.uniform(1.0, 2.5), 0.0, rng.uniform(-0.5, 0.5)], (N_MC, 1))
    v_true[:, SWAY] = rng.normal(0.0, np.sqrt(sway_var), N_MC)
    S_y = beam_noise_cov(A, NOISE, 0.01, LEVER, np.zeros(()))
    P_vel = random_spd(rng, 0.05)
    noise = rng.standard_normal((N_MC, 4)) @ np.linalg.cholesky(S_y).T
    available = np.broadcast_to(np.array(pattern), (N_MC, 4))
    y = np.where(available, v_true @ A.T + noise, np.nan)
    y_c = compensated_beams(A, y, available, np.zeros((N_MC, 4)), np.zeros(N_MC), np.zeros((N_MC, 3)), LEVER)
    v_hat = v_true + rng.standard_normal((N_MC, 3)) @ np.linalg.cholesky(P_vel).T
    return v_true, y_c, S_y, v_hat, P_vel


def _assert_covariance_matches(R: np.ndarray, err: np.ndarray, rows: np.ndarray, label: str) -> None:
    R_m = R[np.ix_(rows, rows)]
    e = err[:, rows]
    S = e.T @ e / e.shape[0]                    # about the truth: unbiasedness and covariance at once
    np.testing.assert_allclose(np.diag(S) / np.diag(R_m), 1.0, rtol=0, atol=0.1, err_msg=f"{label}: variances")
    w, V = np.linalg.eigh(R_m)
    R_inv_half = V @ np.diag(w**-0.5) @ V.T
    whitened = R_inv_half @ S @ R_inv_half
    assert np.max(np.abs(whitened - np.eye(rows.sum()))) < 0.1, f"{label}: whitened\n{whitened}"


@pytest.mark.parametrize(("method", "pair"), MC_CASES)
def test_reported_R_is_the_covariance_of_the_output(method, pair):
    pattern = pattern_of(pair)
    v_true, y_c, S_y, v_hat, P_vel = _monte_carlo(500 + PAIRS.index(pair), pattern)
    if method == "elc":
        sols = elc_select.candidate_solutions(PITCH, pattern, 1.0, MC_EPSILON)
        v, R, measured, choice = elc_select.select(sols, y_c, S_y[None], v_hat, P_vel[None])
        np.testing.assert_array_equal(R, np.broadcast_to(R[0], R.shape))   # R does not depend on the data
        assert np.all(choice == choice[0]) and np.all(measured == measured[0])
        R, measured = R[0], measured[0]
        rows = measured.copy()
    else:
        sol = elc_nsv.solve(PITCH, pattern, MC_EPSILON) if method == "nsv" else SOLVERS[method](pattern, 1.0)
        v, R = apply(sol, y_c, S_y, v_hat, P_vel)
        rows = sol.measured.copy()
        if method == "nsv":
            assert R[SWAY, SWAY] == pytest.approx(MC_EPSILON, rel=1e-12) and np.all(v[:, SWAY] == 0.0)
    assert rows.sum() >= 1
    _assert_covariance_matches(R, v - v_true, rows, f"{method} {pair}")


def test_vb_n_f_inflates_only_the_prediction_part():
    """R(n_f) = C S_y C^T + n_f^2 D P D^T: with n_f = 2 the Monte Carlo covariance is below R."""
    pattern = pattern_of((0, 1))
    v_true, y_c, S_y, v_hat, P_vel = _monte_carlo(599, pattern)
    one, two = SOLVERS["vb"](pattern, 1.0), SOLVERS["vb"](pattern, 2.0)
    _, R1 = apply(one, y_c[:1], S_y, v_hat[:1], P_vel)
    _, R2 = apply(two, y_c[:1], S_y, v_hat[:1], P_vel)
    beams_only = one.C @ S_y @ one.C.T
    np.testing.assert_allclose(R2 - beams_only, 4.0 * (R1 - beams_only), rtol=1e-10, atol=1e-15)
    v, _ = apply(two, y_c, S_y, v_hat, P_vel)
    err = v - v_true
    S = err.T @ err / err.shape[0]
    # for beams 1, 2 surge comes from the beams alone; sway and heave carry the virtual beam
    assert np.all(np.diag(S)[[SWAY, HEAVE]] < 0.9 * np.diag(R2)[[SWAY, HEAVE]])


# ------------------------------------------------------------------------------------------ (e) selector

def _per_method_variances(pattern, y_c, S_y, v_hat, P_vel, n_f=2.0):
    var = np.full((len(elc_select.CANDIDATES), 3), np.inf)
    rows = {}
    for i, name in enumerate(elc_select.CANDIDATES):
        sol = SOLVERS[name](pattern, n_f)
        if sol.ok:
            v, R = apply(sol, y_c, S_y, v_hat, P_vel)
            var[i] = np.where(sol.measured, np.diag(R), np.inf)
            rows[name] = v
    return var, rows


@pytest.mark.parametrize(("p_scale", "heave_from"), [(1e-3, "vb"), (0.1, "nsv")])
def test_selector_takes_the_smallest_variance_per_axis(p_scale, heave_from):
    """Beams 1, 2. Sway: only VB (through the prediction), NSV (epsilon) and VHV see it; epsilon is
    smallest. Heave: VB's virtual beam beats NSV when the prediction is good, and loses when it is
    poor. Surge: VB, NSV, PLCF and VHV all reduce to (y1 - y2) / (2 b11), a tie."""
    rng = np.random.default_rng(601)
    pattern = pattern_of((0, 1))
    P_vel = random_spd(rng, p_scale)
    v_true = np.array([2.0, 0.0, 0.1])
    y_c = beams_to_yc(v_true[None], pattern)[0] + rng.normal(0.0, NOISE, 4) * np.array(pattern)
    v_hat = v_true + rng.normal(0.0, p_scale, 3)
    S_y = beam_noise_cov(A, NOISE, 1e-3, LEVER, np.zeros(()))
    var, rows = _per_method_variances(pattern, y_c, S_y, v_hat, P_vel)
    sols = elc_select.candidate_solutions(PITCH, pattern, 2.0, EPSILON)
    v, R, measured, choice = elc_select.select(sols, y_c[None], S_y[None], v_hat[None], P_vel[None])
    v, R, measured, choice = v[0], R[0], measured[0], choice[0]
    assert measured.all()
    for axis in range(3):
        chosen = elc_select.CANDIDATES[choice[axis]]
        assert var[choice[axis], axis] == pytest.approx(var[:, axis].min(), rel=1e-9), AXES[axis]
        assert R[axis, axis] == pytest.approx(var[:, axis].min(), rel=1e-9)          # eq. 48
        assert v[axis] == pytest.approx(rows[chosen][axis], rel=1e-12, abs=1e-12)
    assert elc_select.CANDIDATES[choice[SWAY]] == "nsv"
    assert elc_select.CANDIDATES[choice[HEAVE]] == heave_from
    # the minimum is strict for sway and heave (no tie the argmin could break either way)
    for axis in (SWAY, HEAVE):
        others = np.delete(var[:, axis], choice[axis])
        assert np.all(others > 1.2 * var[choice[axis], axis])


def test_selector_records_minus_one_for_an_axis_no_method_measures():
    """Keep only PLCF and VHV for beams 1, 2 (VB and NSV unavailable): heave is measured by nobody."""
    rng = np.random.default_rng(602)
    pattern = pattern_of((0, 1))
    sols = elc_select.candidate_solutions(PITCH, pattern, 2.0, EPSILON)
    sols = [cannot("vb", "test: off"), cannot("nsv", "test: off")] + sols[2:]
    n = 4
    v_true = rng.normal(0.0, 1.0, (n, 3))
    y_c = beams_to_yc(v_true, pattern)
    v, R, measured, choice = elc_select.select(sols, y_c, np.broadcast_to(np.eye(4) * NOISE**2, (n, 4, 4)), v_true,
                                               np.broadcast_to(random_spd(rng, 0.05), (n, 3, 3)))
    np.testing.assert_array_equal(measured, np.broadcast_to([True, True, False], (n, 3)))
    np.testing.assert_array_equal(choice[:, HEAVE], -1)
    assert set(choice[:, SURGE]) <= {2, 3} and np.all(choice[:, SWAY] == 3)   # sway only from VHV
    np.testing.assert_allclose(v[:, :2], v_true[:, :2], rtol=0, atol=1e-12)
