"""Earth model for a local NED tangent frame over a mission area of a few kilometres.

Gravity is the WGS-84 normal (plumb-bob) gravity at the origin's latitude (Somigliana), which
already contains the centrifugal acceleration there. Over the mission area it is held constant:
its change with depth (free-air gradient 3.1e-6 s^-2, i.e. < 1e-4 m/s^2 over 30 m) and with
horizontal distance is below the accelerometer noise, and the paper's F_INS (eq. 4) has a zero
position column, i.e. neglects it too. Truth and INS use this same model, so it introduces no
inconsistency between them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from tauvcore import units
from tauvcore.validation import require_range

OMEGA_IE_RPS = 7.292115e-5
"""WGS-84 earth rotation rate [rad/s]."""
_GE = 9.7803253359          # WGS-84 normal gravity at the equator [m/s^2]
_K_SOMIGLIANA = 0.00193185265241
_E2 = 0.00669437999013       # WGS-84 first eccentricity squared


def normal_gravity_mps2(latitude_rad: float) -> float:
    """Somigliana normal gravity magnitude [m/s^2] on the ellipsoid at a geodetic latitude."""
    s2 = np.sin(latitude_rad) ** 2
    return float(_GE * (1.0 + _K_SOMIGLIANA * s2) / np.sqrt(1.0 - _E2 * s2))


@dataclass(frozen=True)
class Earth:
    """Earth quantities in the NED tangent frame n at the origin's latitude."""

    latitude_deg: float = 32.8  # origin latitude [deg]; default: off Haifa, where TAUV operates; [-89, 89]: the
                                # NED frame and Euler yaw are singular at the poles

    def __post_init__(self) -> None:
        require_range("earth.latitude_deg", self.latitude_deg, -89.0, 89.0)

    @property
    def latitude_rad(self) -> float:
        return self.latitude_deg * units.DEG

    @cached_property
    def g_n(self) -> np.ndarray:
        """Plumb-bob gravity vector in n [m/s^2] (positive down)."""
        return np.array([0.0, 0.0, normal_gravity_mps2(self.latitude_rad)])

    @cached_property
    def omega_ie_n(self) -> np.ndarray:
        """Earth rate in n [rad/s]: ``[cos(lat), 0, -sin(lat)] * omega_ie``."""
        lat = self.latitude_rad
        return OMEGA_IE_RPS * np.array([np.cos(lat), 0.0, -np.sin(lat)])
