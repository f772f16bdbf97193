"""What a mission's vehicle flies through besides the earth: the seabed under it (what an echo
sounder and the DVL's beams see) and the water's current (what a DVL's water-track and a
propeller's log see)."""

from __future__ import annotations

from dataclasses import dataclass

from tauvcore.truth.current import CurrentField, current_field
from tauvcore.truth.kinematic import TrajectoryConfig, bathymetry
from tauvcore.truth.seabed import Bathymetry


@dataclass(frozen=True)
class World:
    seabed: Bathymetry  # the seabed of the mission (tauvcore.truth.kinematic.bathymetry)
    current: CurrentField | None = None  # the water's current (tauvcore.truth.current); None: still water

    @classmethod
    def of(cls, trajectory: TrajectoryConfig) -> World:
        """The world of the mission ``trajectory``."""
        return cls(seabed=bathymetry(trajectory), current=current_field(trajectory))
