"""Truth generators: each returns a :class:`~tauvcore.truth.record.Truth`."""

from tauvcore.truth.kinematic import TRAJECTORIES, TrajectoryConfig, generate
from tauvcore.truth.record import Truth

__all__ = ["TRAJECTORIES", "TrajectoryConfig", "Truth", "generate"]
