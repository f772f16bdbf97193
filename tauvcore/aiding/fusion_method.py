"""The record that registers a fusion method (tauvcore.aiding.registry): its name, when it fuses
and how (its measurement model, built from the run's configuration)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from tauvcore.filter.eskf import Measurement, Nominal

RESERVED = (
    "ins",
    "lc",
    "tc",
    "vb",
    "nsv",
    "plcf",
    "vhv",
    "elc",
    "ins-dvl",
    "vkf",
    "dvl",
    "depth",
    "mag",
    "rpm",
)
"""Names a registered method or its source may not take: the built-in methods and aiding sources."""


class Sections(Protocol):
    """What a model is built from: the run's configuration, read by section
    (:meth:`tauvcore.config.Config.section`; this layer sits below the configuration, which
    gathers the registry's methods, so it names no Config)."""

    def section(self, name: str) -> Any: ...


class MeasurementModel(Protocol):
    """What the bank calls at each of the method's epochs, for the whole batch (methods x runs)."""

    def measure(self, nom: Nominal) -> Measurement: ...


@dataclass(frozen=True)
class FusionMethod:
    """One registered method: its name, when it fuses, and how (its model, from the configuration)."""

    name: str  # in run.methods, --method and the results (lower case)
    source: str  # key of its update records in MethodResult.updates
    rate_hz: float  # fusion rate [Hz]; (0, 1000]
    model: Callable[[Sections], MeasurementModel]  # builds the model from the run's configuration
    summary: str  # one line: what the method fuses

    def __post_init__(self) -> None:
        for field_name, value in (("name", self.name), ("source", self.source)):
            if not isinstance(value, str) or not value or value != value.strip().lower() or "," in value:
                raise ValueError(
                    f"FusionMethod.{field_name} must be a lower-case name without commas, got {value!r}"
                )
            if value in RESERVED:
                raise ValueError(
                    f"FusionMethod.{field_name} {value!r} is taken by a built-in method or source"
                )
        if not 0.0 < self.rate_hz <= 1000.0:
            raise ValueError(f"FusionMethod.rate_hz must be in (0, 1000], got {self.rate_hz!r}")
