"""What a mission's vehicle flies through besides the earth: the seabed under it (what an echo
sounder and the DVL's beams see)."""

from __future__ import annotations

from dataclasses import dataclass

from tauvcore.truth.kinematic import TrajectoryConfig, bathymetry
from tauvcore.truth.seabed import Bathymetry


@dataclass(frozen=True)
class World:
    seabed: Bathymetry  # the seabed of the mission (tauvcore.truth.kinematic.bathymetry)

    @classmethod
    def of(cls, trajectory: TrajectoryConfig) -> World:
        """The world of the mission ``trajectory``."""
        return cls(seabed=bathymetry(trajectory))
