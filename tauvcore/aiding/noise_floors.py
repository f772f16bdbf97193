"""Variance floors of the measurement noises the filter assumes (zero noise is legal).

A configuration may set a sensor's noise to zero: the simulation then produces ideal
measurements (the truth sensors stay ideal, nothing here touches them), but a filter that took
the zero literally would divide by it (the DVL's least-squares weights ``1 / sigma^2``) or invert
a singular innovation covariance (a zero-noise depth while its position variance has collapsed).
So wherever the filter turns a configured noise into a measurement covariance it uses at least
the floor below. Each floor is far below the noise of any real instrument of its kind, so it
never changes a realistic configuration (a noise at or above the floor is used as given, bit for
bit), and it is large enough that the update stays well conditioned in double precision.
"""

from __future__ import annotations

import numpy as np

DVL_BEAM_NOISE_FLOOR_MPS = 1e-3
"""1 mm/s per beam: a 1/42 of Table 2's 0.042 m/s; the best bottom-tracking DVLs are specified at
a few mm/s per ping at low speed."""

DEPTH_NOISE_FLOOR_M = 1e-3
"""1 mm of depth (about 10 Pa): a twentieth of Table 2's 194 Pa (2 cm); the best quartz
pressure sensors resolve about 1e-4 of a 2 MPa range, 20 Pa."""

MAG_ATTITUDE_NOISE_FLOOR_RAD = 1e-4
"""0.006 deg of roll, pitch or yaw: two orders below any magnetometer/inclinometer attitude
(Table 2: 1.15 deg roll and pitch, 5.72 deg yaw)."""


def dvl_beam_sigma_mps(noise_mps: float) -> float:
    """The beam noise the filter assumes: ``max(noise_mps, DVL_BEAM_NOISE_FLOOR_MPS)``."""
    return max(float(noise_mps), DVL_BEAM_NOISE_FLOOR_MPS)


def depth_sigma_m(noise_m: float) -> float:
    """The depth noise the filter assumes: ``max(noise_m, DEPTH_NOISE_FLOOR_M)``."""
    return max(float(noise_m), DEPTH_NOISE_FLOOR_M)


def mag_attitude_sigma_rad(noise_rad: np.ndarray) -> np.ndarray:
    """(3,) roll, pitch, yaw noises the filter assumes, each at least the floor."""
    return np.maximum(np.asarray(noise_rad, dtype=float), MAG_ATTITUDE_NOISE_FLOOR_RAD)
