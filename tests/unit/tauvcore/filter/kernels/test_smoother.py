"""The smoother's backward pass (tauvcore.filter.kernels.smoother) on a linear-Gaussian model run
as the filter bank runs its error state: a feedback Kalman filter that keeps a nominal state,
resets its error estimate after each correction and leaves the smoother's tape at its marks.
There the RTS smoother is the batch least-squares solution, mean and covariance."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.filter.kernels.smoother import AidingMarks, CarriedMark, OutputMarks, smooth_backward

DT_S = 0.5


def constant_velocity(num_steps: int, rng: np.random.Generator):
    """A 2-D constant-velocity model (north, east position and velocity), its truth and noisy
    position fixes at every third step (and a velocity fix at step 7): the model, the
    measurements by step and the prior."""
    n = 4
    Phi = np.eye(n)
    Phi[0, 2] = Phi[1, 3] = DT_S
    q = 0.05
    Q = q * np.array(
        [
            [DT_S**3 / 3, 0, DT_S**2 / 2, 0],
            [0, DT_S**3 / 3, 0, DT_S**2 / 2],
            [DT_S**2 / 2, 0, DT_S, 0],
            [0, DT_S**2 / 2, 0, DT_S],
        ]
    )
    P0 = np.diag([4.0, 4.0, 0.25, 0.25])
    x0_hat = np.array([10.0, -5.0, 1.0, 0.5])
    x = x0_hat + rng.multivariate_normal(np.zeros(n), P0)
    truth = [x]
    for _ in range(num_steps):
        x = Phi @ x + rng.multivariate_normal(np.zeros(n), Q)
        truth.append(x)
    H_pos = np.eye(n)[:2]
    H_vel = np.eye(n)[2:]
    measurements = {}
    for k in range(1, num_steps + 1):
        fixes = []
        if k % 3 == 0:
            fixes.append((H_pos, np.diag([1.0, 2.0])))
        if k == 7:
            fixes.append((H_vel, 0.01 * np.eye(2)))
        measurements[k] = [(H, R, H @ truth[k] + rng.multivariate_normal(np.zeros(2), R)) for H, R in fixes]
    return Phi, Q, P0, x0_hat, np.array(truth), measurements


def feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, output_every):
    """The filter as the bank runs it, with its tape: output marks every ``output_every`` steps
    (and at step 0), aiding marks where it corrects (before the output mark of the same step)."""
    n = Phi.shape[0]
    x, P = x0_hat.copy(), P0.copy()
    Phi_acc = np.eye(n)
    out_X, out_P, out_x, out_k = [np.zeros((n, n))], [P.copy()], [x.copy()], [0]
    ev_X, ev_Pm, ev_Pp, ev_d, ev_pos = [], [], [], [], []
    for k in range(1, num_steps + 1):
        x = Phi @ x
        P = Phi @ P @ Phi.T + Q
        Phi_acc = Phi @ Phi_acc
        if measurements[k]:
            Pm, x_before = P.copy(), x.copy()
            for H, R, z in measurements[k]:  # one after another, as the bank fuses its sources
                S = H @ P @ H.T + R
                K = P @ H.T @ np.linalg.inv(S)
                dx = K @ (z - H @ x)
                x = x + dx  # the correction injected, the error estimate reset to zero
                IKH = np.eye(n) - K @ H
                P = IKH @ P @ IKH.T + K @ R @ K.T
            ev_X.append(Phi_acc - np.eye(n))
            ev_Pm.append(Pm)
            ev_Pp.append(P.copy())
            ev_d.append(x - x_before)
            ev_pos.append(len(out_k))
            Phi_acc = np.eye(n)
        if k % output_every == 0:
            out_X.append(Phi_acc - np.eye(n))
            out_P.append(P.copy())
            out_x.append(x.copy())
            out_k.append(k)
            Phi_acc = np.eye(n)
    tape = (
        np.array(out_X)[:, None],
        np.array(out_P)[:, None],
        np.array(ev_X).reshape(-1, 1, n, n),
        np.array(ev_Pm).reshape(-1, 1, n, n),
        np.array(ev_Pp).reshape(-1, 1, n, n),
        np.array(ev_d).reshape(-1, 1, n),
        np.array(ev_pos, dtype=np.int64),
    )
    return tape, np.array(out_x), np.array(out_k)


def batch_least_squares(Phi, Q, P0, x0_hat, measurements, num_steps):
    """The states of every step minimising the prior's, the process noise's and the
    measurements' weighted squares: the mean (K + 1, n) and the covariance of each (K + 1, n, n)."""
    n = Phi.shape[0]
    N = (num_steps + 1) * n
    info = np.zeros((N, N))
    vec = np.zeros(N)
    P0i, Qi = np.linalg.inv(P0), np.linalg.inv(Q)
    info[:n, :n] += P0i
    vec[:n] += P0i @ x0_hat
    for k in range(num_steps):
        J = np.zeros((n, N))  # x_{k+1} - Phi x_k
        J[:, k * n : (k + 1) * n] = -Phi
        J[:, (k + 1) * n : (k + 2) * n] = np.eye(n)
        info += J.T @ Qi @ J
    for k, fixes in measurements.items():
        for H, R, z in fixes:
            J = np.zeros((H.shape[0], N))
            J[:, k * n : (k + 1) * n] = H
            Ri = np.linalg.inv(R)
            info += J.T @ Ri @ J
            vec += J.T @ Ri @ z
    cov = np.linalg.inv(info)
    mean = np.linalg.solve(info, vec).reshape(num_steps + 1, n)
    blocks = np.array([cov[k * n : (k + 1) * n, k * n : (k + 1) * n] for k in range(num_steps + 1)])
    return mean, blocks


def run_backward(tape, stretches=((None, None),), num_extra: int = 0):
    """smooth_backward over the tape, in stretches of output marks (latest first): the smoothed
    errors (T, n), covariances (T, n, n) and the cuts. With ``num_extra`` E the dense
    transitions' last E states (uncoupled from the rest) go to the kernel as their diagonal."""
    out_X, out_P, ev_X, ev_Pm, ev_Pp, ev_d, ev_pos = tape
    T, n = out_P.shape[0], out_P.shape[-1]
    a = n - num_extra

    def split(X):
        return np.ascontiguousarray(X[..., :a, :a]), 1.0 + np.einsum("...ii->...i", X)[..., a:]

    (out_X, out_E), (ev_X, ev_E) = split(out_X), split(ev_X)
    s, Ps = np.zeros((T, 1, n)), np.zeros((T, 1, n, n))
    carry = CarriedMark(np.zeros(1, bool), np.zeros((1, a, a)), np.zeros((1, num_extra)), np.zeros((1, n, n)),
                        np.zeros((1, n)), np.zeros((1, n, n)))
    cuts = np.zeros(1, np.int64)
    for lo, hi in stretches:
        lo = 0 if lo is None else lo
        hi = T if hi is None else hi
        # the aiding marks of this stretch: after output mark lo - 1 (for lo > 0) and before mark hi
        sel = (ev_pos > (lo if lo else -1)) & (ev_pos <= hi) if lo else ev_pos <= hi
        smooth_backward(
            OutputMarks(out_X[lo:hi], out_E[lo:hi], out_P[lo:hi]),
            AidingMarks(ev_X[sel], ev_E[sel], ev_Pm[sel], ev_Pp[sel], ev_d[sel], ev_pos[sel] - lo),
            carry, s[lo:hi], Ps[lo:hi], cuts,
        )  # fmt: skip
    return s[:, 0], Ps[:, 0], int(cuts[0])


@pytest.mark.parametrize("output_every", [1, 2, 4])
def test_smoother_is_batch_least_squares(output_every):
    """Mean and covariance at every output mark equal the batch least-squares solution to 1e-9,
    with output marks at every step, or between aiding marks that are not output marks."""
    num_steps = 24
    Phi, Q, P0, x0_hat, _, measurements = constant_velocity(num_steps, np.random.default_rng(3))
    tape, x_filtered, out_k = feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, output_every)
    s, Ps, cuts = run_backward(tape)
    mean, cov = batch_least_squares(Phi, Q, P0, x0_hat, measurements, num_steps)
    assert cuts == 0
    np.testing.assert_allclose(x_filtered + s, mean[out_k], rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps, cov[out_k], rtol=0, atol=1e-9)
    # the smoother changed the estimates (the test would not pass with s = 0)
    assert np.abs(s[:-1]).max() > 0.05
    # the last mark: smoothed = filtered, exactly
    assert np.all(s[-1] == 0.0)
    np.testing.assert_array_equal(Ps[-1], tape[1][-1, 0])


def with_gauss_markov_bias(num_steps: int, rng: np.random.Generator, tau_s: float = 4.0):
    """:func:`constant_velocity` with a first-order Gauss-Markov bias on the north position fixes
    (a fifth state, uncoupled in Phi: ``phi = exp(-dt/tau)``), as a source's own state."""
    Phi4, Q4, P04, x04, _, _ = constant_velocity(num_steps, rng)
    n, phi = 5, np.exp(-DT_S / tau_s)
    Phi, Q, P0 = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    Phi[:4, :4], Q[:4, :4], P0[:4, :4] = Phi4, Q4, P04
    Phi[4, 4], Q[4, 4], P0[4, 4] = phi, 0.3**2 * (1.0 - phi**2), 0.3**2
    x0_hat = np.r_[x04, 0.0]
    x = x0_hat + rng.multivariate_normal(np.zeros(n), P0)
    truth = [x]
    for _ in range(num_steps):
        x = Phi @ x + rng.multivariate_normal(np.zeros(n), Q)
        truth.append(x)
    H_pos = np.eye(n)[:2] + np.outer([1.0, 0.0], np.eye(n)[4])
    H_vel = np.eye(n)[2:4]
    measurements = {}
    for k in range(1, num_steps + 1):
        fixes = []
        if k % 3 == 0:
            fixes.append((H_pos, np.diag([1.0, 2.0])))
        if k in (7, 16):
            fixes.append((H_vel, 0.01 * np.eye(2)))
        if k == 11:
            fixes.append((np.eye(n)[:1], np.array([[0.05]])))  # the position alone: the bias observed
        measurements[k] = [(H, R, H @ truth[k] + rng.multivariate_normal(np.zeros(H.shape[0]), R)) for H, R in fixes]
    return Phi, Q, P0, x0_hat, np.array(truth), measurements


@pytest.mark.parametrize("output_every", [1, 3])
def test_a_source_s_own_states_are_smoothed_with_their_own_transition(output_every: int) -> None:
    """A Gauss-Markov state after the rest, its transition handed to the kernel as its diagonal
    (the bank's tape keeps the 20 states' block and the sources' diagonal apart): mean and
    covariance at every output mark equal batch least squares to 1e-9."""
    num_steps = 24
    Phi, Q, P0, x0_hat, _, measurements = with_gauss_markov_bias(num_steps, np.random.default_rng(8))
    tape, x_filtered, out_k = feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, output_every)
    s, Ps, cuts = run_backward(tape, num_extra=1)
    mean, cov = batch_least_squares(Phi, Q, P0, x0_hat, measurements, num_steps)
    assert cuts == 0
    np.testing.assert_allclose(x_filtered + s, mean[out_k], rtol=0, atol=1e-9)
    np.testing.assert_allclose(Ps, cov[out_k], rtol=0, atol=1e-9)
    assert np.abs(s[:-1, 4]).max() > 0.02  # the bias was smoothed
    # without its phi (a random walk's identity) the pass is wrong: the test sees the transition
    out_X = tape[0].copy()
    out_X[..., 4, 4] = 0.0
    ev_X = tape[2].copy()
    ev_X[..., 4, 4] = 0.0
    wrong, _, _ = run_backward((out_X, tape[1], ev_X, *tape[3:]), num_extra=1)
    assert np.abs(x_filtered + wrong - mean[out_k]).max() > 1e-3


def test_stretches_carry_the_pass():
    """The pass over the tape cut into stretches (as a mission is stored chunk by chunk) equals
    the pass over the whole tape, bit for bit."""
    num_steps = 30
    Phi, Q, P0, x0_hat, _, measurements = constant_velocity(num_steps, np.random.default_rng(5))
    tape, _, _ = feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, 2)
    whole = run_backward(tape)
    T = tape[1].shape[0]
    parts = run_backward(tape, ((9, T), (4, 9), (0, 4)))
    np.testing.assert_array_equal(whole[0], parts[0])
    np.testing.assert_array_equal(whole[1], parts[1])


def test_smoother_is_consistent():
    """Over seeded runs the smoothed error's NEES against truth averages its dimension (chi-square
    band), and the smoothed RMS is below the filtered one."""
    num_steps, runs = 24, 200
    rng = np.random.default_rng(11)
    nees, err_f, err_s = [], [], []
    for _ in range(runs):
        Phi, Q, P0, x0_hat, truth, measurements = constant_velocity(num_steps, rng)
        tape, x_filtered, out_k = feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, 1)
        s, Ps, _ = run_backward(tape)
        e = truth[out_k] - (x_filtered + s)
        nees.append(np.einsum("ti,tij,tj->t", e, np.linalg.inv(Ps), e))
        err_s.append(e**2)
        err_f.append((truth[out_k] - x_filtered) ** 2)
    mean_nees = np.mean(nees)  # chi-square with 4 * 200 * 25 degrees of freedom (correlated in time)
    assert 3.6 < mean_nees < 4.4
    assert np.mean(err_s) < 0.8 * np.mean(err_f)


def test_not_positive_definite_prior_starts_afresh():
    """A prior that is not positive definite cuts the pass there (counted), not a NaN."""
    num_steps = 12
    Phi, Q, P0, x0_hat, _, measurements = constant_velocity(num_steps, np.random.default_rng(2))
    tape, _, _ = feedback_filter(Phi, Q, P0, x0_hat, measurements, num_steps, 1)
    out_P = tape[1].copy()
    out_P[6, 0] = -np.eye(4)
    s, Ps, cuts = run_backward((tape[0], out_P, *tape[2:]))
    assert cuts == 1
    assert np.isfinite(s).all() and np.isfinite(Ps).all()
