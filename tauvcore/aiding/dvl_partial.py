"""Shared machinery of the extended loosely coupled (ELC) methods (Tal et al. 2017 section 3).

With exactly two returned beams the DVL has no velocity solution. Each ELC method builds one
anyway from the two beams and, for some, the filter's predicted velocity. Every method is
*affine* in its inputs, which is what makes its noise covariance exact:

    v_meas = C y_c + D v_hat        R = C S_y C^T + (g D) P_vel (g D)^T + a a^T

- ``y_c`` (4,) are the beams with the estimated beam biases, scale factor and lever-arm
  velocity removed, ``y_c,k = (y_k - b_hat_k - b_k . (omega_hat_nb x l)) / (1 + SF_hat) ~ b_k . v_b``,
  with covariance ``S_y``; ``v_hat`` is the predicted body velocity with covariance ``P_vel``
  (the filter's velocity block);
- ``C`` (3, 4) and ``D`` (3, 3) depend only on the beam geometry and on which beams returned,
  so each method derives them once per availability pattern (:class:`PartialSolution`);
- ``g`` is the method's inflation of the prediction noise (the virtual beam's n_f, eq. 28);
- ``a`` (3,) is the error an assumption puts into the rows, as a 1-sigma vector: nullified
  sway assumes ``v = 0`` with variance epsilon (eq. 36), and the true sway enters its sway row
  *and* its heave row (through the pair's beam sum), so ``a = sqrt(epsilon) (C A - I) e_v``,
  fully correlated between the two rows (eq. 36 puts epsilon on the sway row only).

Only the ``measured`` rows are fused; the others are dropped from the update exactly (the
paper's "infinite variance", eq. 43 and 47, without a huge number in the Joseph form). The
fused model is the paper's: ``z = v_meas``, ``H = [0 0 I 0 0 0 0]`` on the measured rows
(eq. 18). Like the paper (eq. 26), the correlation between ``v_hat`` and the state error is
neglected; n_f is the knob that compensates for it.

Beam pairs of the "x" Janus (beams 1, 4 forward, 2, 3 aft; 1, 2 starboard, 3, 4 port;
``b_k = [+-s, +-s, c]``, s = sin(20 deg)/sqrt(2), c = cos(20 deg)):

=========  ================  ======================  ====================================
pair       difference gives  sum gives               nullified sway (v = 0)
=========  ================  ======================  ====================================
1-2, 3-4   surge u           +-s v + c w             solvable (u, w)
1-4, 2-3   sway v            +-s u + c w             singular: the pair differs only in y
1-3, 2-4   +-(u +- v)        heave w (2c w)          solvable (u, w)
=========  ================  ======================  ====================================
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore.aiding.noise_floors import dvl_beam_sigma_mps

AXES = ("surge", "sway", "heave")
LSQ_EXACT_TOL = 1e-9


@dataclass(frozen=True)
class PartialSolution:
    """One method's affine velocity construction for one availability pattern."""

    method: str
    ok: bool  # False: the method cannot use this pattern (see reason)
    reason: str = ""  # why not, for the record and the user
    C: np.ndarray = field(default_factory=lambda: np.zeros((3, 4)))  # from compensated beams
    D: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # from the predicted velocity
    measured: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=bool))  # rows fused
    assumption_sd: np.ndarray = field(
        default_factory=lambda: np.zeros(3)
    )  # a: an assumption's 1-sigma error per row
    pred_gain: np.ndarray = field(default_factory=lambda: np.ones(3))  # g per row (n_f for VB)


def cannot(method: str, reason: str) -> PartialSolution:
    return PartialSolution(method=method, ok=False, reason=reason)


def exact_combination(A_s: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    """Coefficients c with ``A_s^T c = target`` exactly, or None if target is outside the
    beams' row space (the velocity direction the pair cannot see)."""
    c, *_ = np.linalg.lstsq(A_s.T, target, rcond=None)
    return c if np.linalg.norm(A_s.T @ c - target) < LSQ_EXACT_TOL else None


def embed(rows: np.ndarray, beams: np.ndarray) -> np.ndarray:
    """Place coefficients for the returned beams into a (3, 4) matrix over all beams."""
    C = np.zeros((rows.shape[0], 4))
    C[:, beams] = rows
    return C


def compensated_beams(
    A_b: np.ndarray,
    y_beam: np.ndarray,
    available: np.ndarray,
    dvl_bias: np.ndarray,
    dvl_sf: np.ndarray,
    omega_comp_b: np.ndarray,
    l_dvl_b: np.ndarray,
) -> np.ndarray:
    """``y_c = (y - b_hat - A (omega_hat x l)) / (1 + SF_hat)``, zero where not returned. (B, 4).
    The kernel :func:`tauvcore.filter.kernels.two_beam.compensated_beams_into`."""
    from tauvcore.filter.kernels.common import flat as f
    from tauvcore.filter.kernels.two_beam import compensated_beams_batch

    batch = np.broadcast_shapes(
        np.shape(y_beam)[:-1],
        np.shape(available)[:-1],
        np.shape(dvl_bias)[:-1],
        np.shape(dvl_sf),
        np.shape(omega_comp_b)[:-1],
    )
    y_c = compensated_beams_batch(
        f(A_b, (), (4, 3))[0],
        f(y_beam, batch, (4,)),
        f(available, batch, (4,), bool),
        f(dvl_bias, batch, (4,)),
        f(dvl_sf, batch, ()),
        f(omega_comp_b, batch, (3,)),
        f(l_dvl_b, (), (3,))[0],
    )
    return y_c.reshape(batch + (4,))


def beam_noise_cov(
    A_b: np.ndarray, noise_mps: float, gyro_rate_noise_rps: float, l_dvl_b: np.ndarray, dvl_sf: np.ndarray
) -> np.ndarray:
    """Covariance of ``y_c``: white beam noise plus the gyro noise carried by the lever-arm term. (B, 4, 4).

    ``noise_mps`` is floored at :data:`~tauvcore.aiding.noise_floors.DVL_BEAM_NOISE_FLOOR_MPS`.
    The kernel :func:`tauvcore.filter.kernels.dvl_kernels.beam_noise_into`."""
    from tauvcore.filter.kernels.common import flat
    from tauvcore.filter.kernels.dvl_kernels import beam_noise_batch

    batch = np.shape(dvl_sf)
    S = beam_noise_batch(
        flat(A_b, (), (4, 3))[0],
        dvl_beam_sigma_mps(noise_mps) ** 2,
        float(gyro_rate_noise_rps) ** 2,
        flat(l_dvl_b, (), (3,))[0],
        flat(dvl_sf, batch, ()),
    )
    return S.reshape(batch + (4, 4))


def apply_solution(
    C: np.ndarray,
    D: np.ndarray,
    gain: np.ndarray,
    assumption_sd: np.ndarray,
    y_c: np.ndarray,
    S_y: np.ndarray,
    v_hat: np.ndarray,
    P_vel: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """``v = C y_c + D v_hat`` and ``R = C S_y C^T + (g D) P (g D)^T + a a^T``; C, D (..., 3, 4|3), a (..., 3).
    The kernel :func:`tauvcore.filter.kernels.two_beam.apply_solution_into` (the one the filter bank runs)."""
    from tauvcore.filter.kernels.common import flat as f
    from tauvcore.filter.kernels.two_beam import apply_solution_batch

    r_batch = np.broadcast_shapes(
        np.shape(C)[:-2],
        np.shape(D)[:-2],
        np.shape(gain)[:-1],
        np.shape(assumption_sd)[:-1],
        np.shape(S_y)[:-2],
        np.shape(P_vel)[:-2],
    )
    batch = np.broadcast_shapes(r_batch, np.shape(y_c)[:-1], np.shape(v_hat)[:-1])

    def call(shape: tuple[int, ...], y: np.ndarray, v0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return apply_solution_batch(
            f(C, shape, (3, 4)),
            f(D, shape, (3, 3)),
            f(gain, shape, (3,)),
            f(assumption_sd, shape, (3,)),
            f(y, shape, (4,)),
            f(S_y, shape, (4, 4)),
            f(v0, shape, (3,)),
            f(P_vel, shape, (3, 3)),
        )

    v, R = call(batch, y_c, v_hat)
    if r_batch != batch:  # R does not depend on the measurements: keep its own (smaller) shape
        _, R = call(r_batch, np.zeros(4), np.zeros(3))
    return v.reshape(batch + (3,)), R.reshape(r_batch + (3, 3))
