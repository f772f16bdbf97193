"""The reference's own uncertainty (``[reference]`` of tauvcore.config): the 1-sigma of the
reference a filter's errors and NEES are measured against, which the NEES takes with the filter's
covariance (tauvcore.filter.kernels.nees.add_reference_into)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.validation import require_range


@dataclass(frozen=True)
class ReferenceConfig:
    """The 1-sigma of the reference the errors and the NEES are measured against (a log's
    ``reference`` table; a simulation's truth). 0 everywhere (the default): exact, as a
    simulation's truth and a simulated log's reference are.

    The NEES is then taken against ``P + P_ref`` (tauvcore.filter.kernels.nees.add_reference_into),
    ``P_ref`` the reference's errors carried into the filter's error state at every epoch, in the
    frames of tauvcore.conventions: the position's (north and east ``pos_horizontal_m``, down
    ``pos_vertical_m``) on the n-frame position; the roll, pitch and yaw errors' (``roll_pitch_deg``,
    ``yaw_deg``) turned into the n-frame misalignment by the Euler angles' Jacobian at the
    reference's attitude; the velocity's (``vel_mps`` on each NED axis) on Yoo's NED velocity
    error as it is, and on the 20-state filter's body velocity error rotated into the body frame
    together with what the reference's attitude error does to its body velocity (``C^T [v x] e``,
    correlated with the misalignment). The reference's errors are taken as independent of the
    filter's and of each other. A replay starts the filters on the reference's first row, so an
    error the reference carries from its start is shared by the filters and shows in no NEES;
    state what it gets wrong after its start.
    """

    pos_horizontal_m: float = 0.0  # 1-sigma of each of the north and east position errors [m] (a
    # CEP50 figure r is r / 1.1774 per axis); [0, 1000]: beyond a kilometre a reference judges nothing
    pos_vertical_m: float = 0.0  # 1-sigma of the depth error [m]; [0, 1000]
    vel_mps: float = 0.0  # 1-sigma of each NED velocity component [m/s]; [0, 10], the bound of
    # initial_error.vel_mps
    roll_pitch_deg: float = 0.0  # 1-sigma of the roll and of the pitch error [deg]; [0, 10]: the
    # small-angle error model, as initial_error.roll_pitch_deg
    yaw_deg: float = 0.0  # 1-sigma of the heading error [deg]; [0, 30], as initial_error.yaw_deg

    def __post_init__(self) -> None:
        require_range("reference.pos_horizontal_m", self.pos_horizontal_m, 0.0, 1000.0)
        require_range("reference.pos_vertical_m", self.pos_vertical_m, 0.0, 1000.0)
        require_range("reference.vel_mps", self.vel_mps, 0.0, 10.0)
        require_range("reference.roll_pitch_deg", self.roll_pitch_deg, 0.0, 10.0)
        require_range("reference.yaw_deg", self.yaw_deg, 0.0, 30.0)

    @property
    def exact(self) -> bool:
        """Every 1-sigma zero: the reference taken as exact."""
        return not any(dataclasses.astuple(self))

    def variances(self) -> np.ndarray:
        """The reference's variances as the NEES kernel takes them
        (tauvcore.filter.kernels.nees.add_reference_into), in SI units.

        Returns
        -------
        numpy.ndarray
            Shape (9,): position north, east, down [m^2]; velocity north, east, down [m^2/s^2];
            roll, pitch, yaw [rad^2].
        """
        h, v = self.pos_horizontal_m, self.pos_vertical_m
        rp, yaw = self.roll_pitch_deg * units.DEG, self.yaw_deg * units.DEG
        return np.array([h * h, h * h, v * v, *(3 * [self.vel_mps**2]), rp * rp, rp * rp, yaw * yaw])

    def describe(self, has_reference: bool = True) -> str:
        """One line on what the errors and the NEES are measured against, for a replay's output.

        Parameters
        ----------
        has_reference : bool
            Whether there is a reference at all (a log may have none).

        Returns
        -------
        str
            "NEES against the reference with its stated 1-sigma: position 0.5 m horizontal, 0.1 m
            vertical; velocity 0.02 m/s; attitude 0.01/0.05 deg (roll/pitch, yaw)" (a quantity
            whose sigmas are all zero: "exact"), or "NEES against the reference as exact (no
            [reference] sigma)"; without a reference, that the errors and NEES are unknown.
        """
        if not has_reference:
            return "no reference: the errors and the NEES are unknown"
        if self.exact:
            return "NEES against the reference as exact (no [reference] sigma)"
        h, v, rp, yaw = self.pos_horizontal_m, self.pos_vertical_m, self.roll_pitch_deg, self.yaw_deg
        pos = f"{h:g} m horizontal, {v:g} m vertical" if h or v else "exact"
        vel = f"{self.vel_mps:g} m/s" if self.vel_mps else "exact"
        att = f"{rp:g}/{yaw:g} deg (roll/pitch, yaw)" if rp or yaw else "exact"
        stated = f"position {pos}; velocity {vel}; attitude {att}"
        return f"NEES against the reference with its stated 1-sigma: {stated}"
