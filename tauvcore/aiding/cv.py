"""Constant body velocity: a pseudo-measurement for a filter with no DVL (method ``cv``).

The worked example of adding a fusion method (docs/adding_a_method.md): this file and one line in
:data:`tauvcore.aiding.registry.REGISTRY`. An AUV under its autopilot holds its commanded speed
and, having no side thrusters, little sway or heave: its body velocity stays near the cruise
velocity ``[U, 0, 0]`` (``trajectory.speed_mps``). Fused as a measurement with a large variance,
that belief bounds the velocity drift of an unaided INS, and with it the position error's
growth from quadratic to linear in time, at no sensor cost::

    z = [U, 0, 0]^T,   h(x) = v_b = C_nb^T v_n,   H = [0, 0, I, 0, 0, 0, 0]   (pos, att, vel, ba, bg, b_dvl, sf)
    R = diag(sigma_surge^2, sigma_sway^2, sigma_heave^2)

The velocity error state is the body velocity's (tauvcore.filter.layout), so H has no attitude
column (tests/unit/tauvcore/aiding/test_registry.py checks it against a finite difference of ``predict``). The
assumption's error is not white: it lasts a whole turn (up to 0.1 m/s of sway on the paper's
trajectories) or a speed change. Hence the sigmas cover the largest departure, not its RMS, and
the pseudo-measurement is fused at 1 Hz rather than at the IMU rate: fused faster, the same
correlated error would be counted as independent news and the filter would grow over-confident.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tauvcore.aiding.fusion_method import FusionMethod, Sections
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE

CV_SIGMA_MPS = (0.15, 0.15, 0.1)
"""1-sigma of the assumption, surge, sway, heave [m/s]: the autopilot holds speed to a few percent
of 2 m/s, the paper's turns make up to 0.105 m/s of sway (the kinematic truth's turn sideslip),
a depth change a few cm/s of heave; each rounded up to cover the largest, not the RMS, departure."""

CV_RATE_HZ = 1.0
"""Fusion rate [Hz]: about once per correlation time of the assumption's error (a turn lasts tens of
seconds, so even 1 Hz counts it many times: the sigmas above are the margin)."""


@dataclass(frozen=True)
class ConstantVelocitySetup:
    z: np.ndarray  # (B, 3) assumed body velocity [m/s]
    R: np.ndarray  # (B, 3, 3) its covariance [m^2/s^2]


@dataclass(frozen=True)
class ConstantVelocity:
    """The pseudo-measurement "the body velocity is the cruise velocity", small and pure."""

    speed_mps: float  # commanded surge speed U [m/s]
    sigma_mps: tuple[float, float, float] = CV_SIGMA_MPS  # 1-sigma surge, sway, heave [m/s]

    name = "cv"

    def __post_init__(self) -> None:
        if not np.isfinite(self.speed_mps):
            raise ValueError(f"speed_mps must be finite, got {self.speed_mps!r}")
        if len(self.sigma_mps) != 3 or not all(np.isfinite(s) and s > 0 for s in self.sigma_mps):
            raise ValueError(f"sigma_mps must be three positive numbers, got {self.sigma_mps!r}")

    @classmethod
    def from_config(cls, config: Sections) -> ConstantVelocity:
        """The model a run uses: the mission's commanded speed, the default sigmas."""
        return cls(speed_mps=float(config.section("trajectory").speed_mps))

    def prepare(self, batch: tuple[int, ...]) -> ConstantVelocitySetup:
        z = np.broadcast_to(np.array([self.speed_mps, 0.0, 0.0]), batch + (3,))
        R = np.broadcast_to(np.diag(np.square(self.sigma_mps)), batch + (3, 3))
        return ConstantVelocitySetup(z=np.ascontiguousarray(z), R=np.ascontiguousarray(R))

    def predict(self, nom: Nominal, setup: ConstantVelocitySetup) -> np.ndarray:
        """h(x) = v_b (B, 3) [m/s]."""
        return nom.vel_b

    def jacobian(self, nom: Nominal, setup: ConstantVelocitySetup) -> np.ndarray:
        """H (B, 3, 20): identity on the velocity block."""
        H = np.zeros(setup.R.shape[:-2] + (3, STATE.dim))
        H[..., STATE.vel] = np.eye(3)
        return H

    def measure(self, nom: Nominal) -> Measurement:
        batch = nom.vel_b.shape[:-1]
        setup = self.prepare(batch)
        return Measurement(
            z=setup.z,
            innovation=setup.z - self.predict(nom, setup),
            H=self.jacobian(nom, setup),
            R=setup.R,
            valid=np.ones(batch, dtype=bool),
        )


METHOD = FusionMethod(
    name="cv",
    source="cv",
    rate_hz=CV_RATE_HZ,
    model=ConstantVelocity.from_config,
    summary="no DVL: the body velocity held near the cruise velocity [U, 0, 0] (pseudo-measurement)",
)
"""The registry's entry (tauvcore.aiding.registry.MODULES names this module)."""
