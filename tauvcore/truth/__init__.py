"""Truth generators: each returns a :class:`~tauvcore.truth.truth_record.Truth`.

``trajectory.truth`` picks the generator: ``kinematic`` (tauvcore.truth.kinematic, closed-form
profiles) or ``dynamic`` (tauvcore.truth.dynamic, the 6-DOF TAUV flying the same scenario; its
module is imported on first use, with numba).
"""

from __future__ import annotations

from tauvcore.geo.earth import Earth
from tauvcore.truth import kinematic
from tauvcore.truth.kinematic import (
    PAPER_TRAJECTORIES,
    TRAJECTORIES,
    TRUTH_SOURCES,
    TrajectoryConfig,
    TruthStream,
)
from tauvcore.truth.truth_record import Truth, VehicleRecord

__all__ = [
    "PAPER_TRAJECTORIES",
    "TRAJECTORIES",
    "TRUTH_SOURCES",
    "TrajectoryConfig",
    "Truth",
    "VehicleRecord",
    "generate",
    "truth_stream",
]


def generate(cfg: TrajectoryConfig, earth: Earth, rate_hz: float) -> Truth:
    """The whole mission's truth at the IMU rate ``rate_hz``, by the generator ``cfg.truth`` names."""
    if cfg.truth == "dynamic":
        from tauvcore.truth import dynamic

        return dynamic.generate(cfg, earth, rate_hz)
    return kinematic.generate(cfg, earth, rate_hz)


def truth_stream(cfg: TrajectoryConfig, earth: Earth, rate_hz: float, chunk_samples: int):
    """:func:`generate`'s truth in chunks of ``chunk_samples``: a TruthStream or a DynamicTruthStream
    (the same interface: ``num_samples``, ``dt_s``, ``len``, iteration yielding ``(k0, Truth)``)."""
    if cfg.truth == "dynamic":
        from tauvcore.truth import dynamic

        return dynamic.DynamicTruthStream(cfg, earth, rate_hz, chunk_samples)
    return TruthStream(cfg, earth, rate_hz, chunk_samples)
