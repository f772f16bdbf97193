"""Velocity Kalman filter (VKF) of Yoo 2014, section 2.2, eq. 20-29: propeller RPM to forward speed.

Model
-----
The propeller's RPM maps to the forward speed (eq. 20)::

    V_rpm = rpm * sf - b                    sf [m/s per rpm], b [m/s]

A three-state Kalman filter (eq. 23) ``x = [V_rpm, sf, b]`` learns ``sf`` and ``b`` from the DVL
while the DVL has bottom lock. Step k (one DVL ping, ``step_s`` apart) uses that step's RPM
(eq. 24, 22)::

    x_k = F_k x_k-1 + w_k,     F_k = [[0, rpm_k, -1],     w_k ~ N(0, Q)
                                      [0, 1,      0],
                                      [0, 0,      1]]

    Q = diag(v_noise_mps^2, sf_rw^2 step_s, b_rw^2 step_s)

so ``V_k = rpm_k sf_k-1 - b_k-1 + w_V``: V has no memory of its own (F's first column is zero),
its process noise is the per-step error of the map eq. 20 (unmodelled propeller and hull
dynamics), while sf and b are slow random walks. The measurement is the DVL forward speed
(eq. 25-26)::

    z_k = H x_k + v_k,     H = [1, 0, 0],     v_k ~ N(0, R),   R = dvl_forward_noise_mps^2

fused only where the DVL has bottom lock (``valid``); elsewhere the filter only predicts, and
V keeps being computed from the last sf and b ("the finally assumed value", section 2.2).

Observability: with a constant RPM only ``rpm sf - b`` is observed; sf and b separately need RPM
changes. The filter stays well behaved meanwhile (the unobserved direction keeps its prior
covariance plus the random walks', P stays symmetric positive definite; semi-definite when V's
process noise is zero, since V = rpm sf - b is then exact), and the tests that check convergence
use speed profiles with RPM steps.

Forward speed from the DVL (eq. 21): the paper takes the norm of the DVL velocity in NED,
``|v_dvl_n|``. We default to its body-x component ``(C_nb^T v_dvl_n)_x`` (``forward_speed =
"body_x"``): the propeller drives the vehicle along its body x axis, sway and heave are not
propeller speed, and the norm is biased upward by them (and is never negative). ``"norm"``
reproduces the paper; this default is a departure from it.

Aiding velocity (eq. 27-28): ``v_rpm_n = C_nb [V_rpm, 0, 0]^T`` (the first column of C_nb,
whose entries eq. 28 spells out: c11 = cos(theta) cos(psi), c21 = cos(theta) sin(psi),
c31 = -sin(theta), the ZYX C_nb of tauvcore.conventions). The switch (eq. 29): if the echo
sounder's altitude exceeds alpha (``switch_altitude_m``, the DVL's 100 m range), the aiding
velocity is v_rpm_n, else the DVL's NED velocity. An altitude of NaN (the echo sounder sees no
bottom) counts as above alpha: the vehicle is then certainly beyond the DVL's range.

Notes on the paper's text
-------------------------
- Eq. 22 writes the system as continuous time, ``x_dot = F x + w``; eq. 24's F is a discrete
  transition (a continuous F with these entries would make ``sf_dot = sf``, an exponential
  growth, and ``V_dot = rpm sf - b``, a speed that integrates). We use it as ``x_k = F_k x_k-1``.
- Eq. 21 calls the norm of the NED velocity "the forward velocity of body frame"; it is the
  speed over ground, which includes sway and heave (see above).
- Eq. 16 gives the measurement noise as ``v ~ N(0, Q(t))``; it is R (the text says so below).
- The equation numbers skip 19 (18 is followed by 20); eq. 29 writes ``V_VFK`` for the VKF's
  velocity; eq. 27 names the NED components ``u, v, w_rpm``, letters usually kept for body
  velocities (figure 2 calls them ``v_N,rpm, v_E,rpm, v_D,rpm``).
- The paper gives no VKF noise values ("R has been properly adjusted") and no RPM numbers: every
  default below says where it comes from.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.validation import (
    require_choice,
    require_finite,
    require_nonnegative,
    require_positive,
    require_range,
)

FORWARD_SPEED = ("body_x", "norm")
DIM_X = 3
"""State ``[V_rpm, sf, b]`` (eq. 23): indices below are this module's own layout, not the ESKF's."""
V, SF, B = 0, 1, 2


@dataclass(frozen=True)
class VkfConfig:
    """VKF noise model and switch (Yoo 2014 section 2.2); 1-sigma values."""

    initial_sf_mps_per_rpm: float = 0.0025  # sf at start [m/s per rpm]: not in the paper; a propeller
    # rating near the TAUV's own 2.35e-3 (tauvcore.truth.vehicle,
    # tauvcore.sensors.rpm), 10 kn at ~2000 rpm
    initial_sf_sigma_mps_per_rpm: float = 0.0004  # its 1-sigma [m/s per rpm], > 0: ~17 % of sf, a propeller
    # known to within a sixth before any DVL data
    initial_b_mps: float = 0.0  # b at start [m/s] (eq. 20's bias): none assumed
    initial_b_sigma_mps: float = 0.3  # its 1-sigma [m/s], > 0: 6 % of the cruise speed
    initial_v_mps: float = 0.0  # V_rpm at start [m/s]; forgotten at the first step (F's first
    # column is zero), kept for the state's completeness
    initial_v_sigma_mps: float = 1.0  # its 1-sigma [m/s], >= 0 (likewise forgotten)
    step_s: float = 0.2  # filter step = DVL ping period [s] (Yoo section 3.2: 5 Hz),
    # (0, 60]: one step a minute is already no filter of speed
    v_noise_mps: float = 0.02  # V's process noise, std PER STEP [m/s], >= 0 (white: V has no
    # memory): eq. 20's model error; not in the paper
    sf_rw_mps_per_rpm_per_sqrt_s: float = 1e-6  # sf random-walk DENSITY [m/s/rpm/sqrt(s)], >= 0: 2.4e-5
    # (0.4 % of sf) in 10 min (fouling, load); not in the paper
    b_rw_mps_per_sqrt_s: float = 1e-4  # b random-walk DENSITY [m/s/sqrt(s)], >= 0: 2.4 mm/s in
    # 10 min; not in the paper
    dvl_forward_noise_mps: float = 0.087  # R's 1-sigma: the DVL forward speed [m/s], > 0: a Janus DVL's
    # body-x axis with Tal 2017 Table 2's 0.042 m/s per beam at
    # 20 deg beam pitch, 0.042 / (sqrt(2) sin 20 deg)
    switch_altitude_m: float = 100.0  # alpha of eq. 29 [m], (0, 11000]: the DVL's range (Yoo
    # section 3.2); the deepest ocean bounds it
    forward_speed: str = "body_x"  # eq. 21: "body_x" (default, a departure) or "norm" (paper)

    def __post_init__(self) -> None:
        require_finite("vkf.initial_sf_mps_per_rpm", self.initial_sf_mps_per_rpm)
        require_positive("vkf.initial_sf_sigma_mps_per_rpm", self.initial_sf_sigma_mps_per_rpm)
        require_finite("vkf.initial_b_mps", self.initial_b_mps)
        require_positive("vkf.initial_b_sigma_mps", self.initial_b_sigma_mps)
        require_finite("vkf.initial_v_mps", self.initial_v_mps)
        require_nonnegative("vkf.initial_v_sigma_mps", self.initial_v_sigma_mps)
        require_range("vkf.step_s", self.step_s, 0.0, 60.0, low_open=True)
        require_nonnegative("vkf.v_noise_mps", self.v_noise_mps)
        require_nonnegative("vkf.sf_rw_mps_per_rpm_per_sqrt_s", self.sf_rw_mps_per_rpm_per_sqrt_s)
        require_nonnegative("vkf.b_rw_mps_per_sqrt_s", self.b_rw_mps_per_sqrt_s)
        # R > 0: the innovation variance S = P_VV + R must stay positive even when P_VV is zero
        require_positive("vkf.dvl_forward_noise_mps", self.dvl_forward_noise_mps)
        require_range("vkf.switch_altitude_m", self.switch_altitude_m, 0.0, 11000.0, low_open=True)
        require_choice("vkf.forward_speed", self.forward_speed, FORWARD_SPEED)

    @property
    def x0(self) -> np.ndarray:
        """Initial state ``[V, sf, b]`` (3,)."""
        return np.array([self.initial_v_mps, self.initial_sf_mps_per_rpm, self.initial_b_mps])

    @property
    def P0(self) -> np.ndarray:
        """Initial covariance (3, 3), diagonal."""
        return np.diag(
            np.square([self.initial_v_sigma_mps, self.initial_sf_sigma_mps_per_rpm, self.initial_b_sigma_mps])
        )

    @property
    def Q(self) -> np.ndarray:
        """Process noise per step (3, 3): V's per-step variance, the walks' density^2 * step_s."""
        return np.diag(
            [
                self.v_noise_mps**2,
                self.sf_rw_mps_per_rpm_per_sqrt_s**2 * self.step_s,
                self.b_rw_mps_per_sqrt_s**2 * self.step_s,
            ]
        )

    @property
    def R(self) -> float:
        """Variance of the DVL forward speed [m^2/s^2]."""
        return self.dvl_forward_noise_mps**2
