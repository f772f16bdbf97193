"""The velocity the DVL scale factor's column of H is evaluated at: an average of the filter's own
body velocity, not its current estimate.

Why. A DVL measures ``(1 + SF) v_b`` (tauvcore.aiding.dvl_loose, dvl_tight), so the scale factor's
column of H is the body velocity, and the plain EKF takes it at the current estimate ``v_hat``. The
estimate's error ``e = v - v_hat`` is also in the innovation (``nu = ... + (1 + SF) e + n``), so the
column and the innovation are correlated: each update moves the scale factor by
``K_sf nu``, whose mean is about ``-P_sf,sf E[e^2] / S`` per row, whatever the truth. Where the
scale factor is observable (the vehicle turns or changes speed: the accelerometers see the change
the DVL scales) this bias is negligible beside the information; on a straight leg at constant
speed the scale factor is unobservable (a faster vehicle with a smaller scale factor gives the same
pings), nothing pulls the estimate back, and the bias adds up ping after ping. It is the
errors-in-variables bias of a regression on a noisy regressor, and in the sway and heave rows,
where the true velocity is near zero and the regressor is nearly all noise, it is the regression
slope attenuated towards zero: the scale factor is pulled towards -1.

Measured (``python benchmarks/long_mission_causes.py``, the figures on the page it writes): on the
10-hour straight line with DVL, depth and magnetometer, the plain EKF's scale factor drifts about
-2 %/h with a sigma of 1 % (the filter over-confident: velocity NEES/dim 10, position 30); with
the column at the true velocity (an oracle the benchmark runs) it does not drift, and neither does
it with the column at the average below.

What. The column is evaluated at ``v_ref``, the filter's body velocity after each ping averaged
with the time constant ``filter.scale_factor_velocity_tau_s`` (300 s): its error is correlated with
the current innovation only through the few seconds over which the velocity error itself is
correlated, a fraction of about that time over the time constant. The velocity and every other
column are the EKF's, and the prediction ``h(x_hat)`` is unchanged (``(1 + SF_hat) v_hat``):
only where the scale factor's information is taken from changes. In a steady turn or on a leg the
body velocity is constant and the average is the velocity itself; for the minutes after a change
of speed or turn rate the column lags it, which mis-weights a scale factor that is 1 % by the
change's fraction (a few millimetres per second, below the DVL's noise). After a lock-out reset
(tauvcore.engine.lockout) the average restarts at the reset velocity. ``0`` evaluates the column
at the current estimate, as the plain EKF does.

Every DVL row carries the scale factor the way it carries the beam biases: a beam measures
``(1 + SF) a_k . v_b + b_k``, so a row whose beam-bias columns are ``h_b`` (4,) has the scale
factor's column ``h_b . A v_b``, ``A`` the beams' unit vectors. The loosely coupled velocity
(``h_b`` the rows of A+, and ``A+ A = I``: the column is ``v_b``), the tightly coupled beams
(``h_b = e_k``: ``a_k . v_b``) and the two-beam constructions of the extended methods (``h_b = c /
(1 + SF_hat)``, ``c`` the row's weights on the compensated beams; tauvcore.filter.kernels.dvl_kernels)
all take it at ``v_ref``.
"""

from __future__ import annotations

import math

import numpy as np

from tauvcore.aiding.dvl_extended import MODE_LC, MODE_PARTIAL, MODE_TC
from tauvcore.filter.layout import STATE


def body_velocity(C_nb: np.ndarray, vel_n: np.ndarray) -> np.ndarray:
    """``C_nb^T vel_n``: (..., 3, 3), (..., 3) NED [m/s] -> (..., 3) body (FRD) [m/s]."""
    return np.einsum("...ji,...j->...i", C_nb, vel_n)


def scale_factor_rows(H: np.ndarray, mode: np.ndarray, A_b: np.ndarray, v_ref_b: np.ndarray) -> None:
    """The scale factor's column of the DVL rows at ``v_ref_b``, in place: ``h_b . A v_ref`` for
    each row with beam-bias columns ``h_b``.

    Parameters
    ----------
    H : numpy.ndarray
        The DVL rows of every method and run, shape (M, R, m, 20), as the measurement kernel built
        them at the current estimate (tauvcore.filter.kernels.dvl_kernels.dvl_measure_bank); the scale
        factor's column of the loosely and tightly coupled rows and the two-beam rows is replaced.
    mode : numpy.ndarray
        Shape (M, R) int: each filter's construction at this ping (MODE_* of
        tauvcore.aiding.dvl_extended); a coasting filter's rows are left as they are.
    A_b : numpy.ndarray
        The beams' unit vectors, shape (4, 3), b-frame (FRD).
    v_ref_b : numpy.ndarray
        The body velocity to evaluate the column at, shape (M, R, 3) [m/s], b-frame (FRD).
    """
    carried = (mode == MODE_LC) | (mode == MODE_TC) | (mode == MODE_PARTIAL)
    if not carried.any():
        return
    beams = np.einsum("kj,mrj->mrk", A_b, v_ref_b)  # A v_ref: the beams' share of the velocity
    column = np.einsum("mrik,mrk->mri", H[..., STATE.b_dvl], beams)
    sf_col = STATE.sf_dvl.start
    H[..., sf_col] = np.where(carried[..., None], column, H[..., sf_col])


class VelocityAverage:
    """The average ``v_ref`` of the filters' body velocity, one per method and run.

    ``v_ref <- v_ref + (1 - exp(-dt / tau)) (v_b - v_ref)`` at every ping, ``dt`` the time since the
    last; started at the first ping's estimate.
    """

    def __init__(self, tau_s: float) -> None:
        """``tau_s``: the time constant [s] (> 0)."""
        self.tau_s = float(tau_s)
        self.v_ref_b: np.ndarray | None = None  # (M, R, 3) [m/s]
        self.t_s = math.nan  # the ping it was last updated at [s]

    def reference(self, v_b: np.ndarray) -> np.ndarray:
        """The average to evaluate a ping's rows at, (M, R, 3) [m/s]; at the first ping the estimate
        ``v_b`` (M, R, 3) [m/s] itself."""
        if self.v_ref_b is None:
            self.v_ref_b = np.array(v_b, dtype=float)
        return self.v_ref_b

    def update(self, v_b: np.ndarray, t_s: float, restart: np.ndarray) -> None:
        """Take the velocity after a ping's correction.

        Parameters
        ----------
        v_b : numpy.ndarray
            Body velocity of every filter after the ping, (M, R, 3) [m/s], b-frame (FRD).
        t_s : float
            The ping's time [s].
        restart : numpy.ndarray
            Shape (M, R) bool: filters whose velocity was reset at this ping (the average restarts
            at ``v_b``).
        """
        if self.v_ref_b is None or math.isnan(self.t_s):
            weight = 1.0
        else:
            weight = -math.expm1(-max(t_s - self.t_s, 0.0) / self.tau_s)
        ref = self.reference(v_b)
        ref += weight * (v_b - ref)
        ref[restart] = v_b[restart]
        self.t_s = float(t_s)
