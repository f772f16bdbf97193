"""An aiding source as one plug-in: everything about one sensor in one module.

A source (a subclass of :class:`AidingSource`, registered in one line of
:mod:`tauvcore.aiding.sources`) carries

- its configuration section: a frozen dataclass (:attr:`AidingSource.config_type`) whose
  ``__post_init__`` checks every field's range (``[<name>]`` in a TOML file, ``config.section(name)``
  in the library); each field declares its label, unit and range once, as a :class:`Setting` in its
  metadata (:func:`setting`), which :func:`check_settings` enforces and the dashboard shows;
- when it measures: :meth:`AidingSource.rate_hz`;
- its simulation from truth chunks with its own random streams (:attr:`AidingSource.streams`,
  :meth:`AidingSource.simulate_chunk`), carrying what it needs from chunk to chunk in a state of its
  own;
- the columns of its log table (:attr:`AidingSource.columns`, ``<name>.csv`` or ``.parquet``: the
  reader checks them and hands them over as :class:`SourceData`);
- its measurement model (:meth:`AidingSource.model`): ``measure(nom, data, j)`` returns the
  :class:`~tauvcore.filter.eskf.Measurement` (z, innovation, H, R, valid) of epoch ``j`` for the whole
  batch, with ``predict`` and ``jacobian`` for the finite-difference test;
- what the user sees of it: a short label (the dashboard's checkbox), a summary and the names of
  its measurement's rows.

The engine fuses a registered source into every method of the 20-state bank that takes aiding
(all but the standalone INS), at its epochs, with the gate and the records of every source. A
source's data is measured at the IMU sample it is fused at (``SourceData.index``); a measurement
of an earlier instant (a latency) is the source's own business, in its model.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from tauvcore.validation import ConfigError, require_range, require_vector3, show

if TYPE_CHECKING:
    from tauvcore.aiding.fusion_method import Sections
    from tauvcore.filter.eskf import Measurement, Nominal
    from tauvcore.sensors.timing import Rng
    from tauvcore.truth.record import Truth


SETTING = "tauv.setting"
"""The metadata key of a section field's :class:`Setting`."""


@dataclass(frozen=True)
class Setting:
    """What one field of a source's section is, for its check and for the dashboard's control.

    A float field is within ``[low, high]``; a bool field is true or false; a 3-vector field
    (a tuple of three floats) has each component within ``[-bound, bound]``. A range of its own on
    one component (a depth under the surface) is the section's ``__post_init__``'s to add."""

    label: str  # the control's words after the source's label, e.g. "fix interval"
    unit: str = ""  # e.g. "s", "m"; "" for a dimensionless number or a switch
    low: float | None = None  # a float's range
    high: float | None = None
    bound: float | None = None  # a 3-vector's bound on each component
    hint: str = ""  # one line: what it is (the range is added where it is shown)


def setting(
    default: Any,
    label: str,
    unit: str = "",
    low: float | None = None,
    high: float | None = None,
    *,
    bound: float | None = None,
    hint: str = "",
) -> Any:
    """A section field with its default and its :class:`Setting` (``dataclasses.field``)."""
    return field(default=default, metadata={SETTING: Setting(label, unit, low, high, bound, hint)})


def settings(section_type: type) -> tuple[tuple[str, Any, Setting], ...]:
    """(field name, default, setting) of every field of ``section_type`` that declares one, in order."""
    return tuple(
        (f.name, f.default, f.metadata[SETTING]) for f in fields(section_type) if SETTING in f.metadata
    )


def check_settings(name: str, section: Any) -> None:
    """Every declared field of ``section`` (the section of source ``name``) within its
    :class:`Setting`; ConfigError naming ``<name>.<field>`` and the value."""
    for key, default, s in settings(type(section)):
        value, where = getattr(section, key), f"{name}.{key}"
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise ConfigError(f"{where} must be true or false, got {show(value)}")
        elif isinstance(default, tuple):
            require_vector3(where, value, bound=s.bound)
        elif s.low is not None and s.high is not None:
            require_range(where, value, s.low, s.high)


@dataclass(frozen=True)
class Column:
    """One column of a source's log table: SI, its unit in its name."""

    name: str  # e.g. "north_m"
    unit: str  # e.g. "m"
    low: float  # physical bounds: a value beyond them is refused, naming the row and the column
    high: float
    what: str  # what a value beyond the bounds would be, in words ("farther than the earth is wide")
    allow_nan: bool = False  # an empty cell (NaN) means "no measurement in this row"


@dataclass(frozen=True)
class SourceData:
    """A source's epochs within a chunk (or a whole mission), the run axis after time.

    ``index`` are the mission's IMU samples the epochs are fused at (global, sorted); ``values``
    one array per log column, (E, R); a NaN marks a row without a measurement (a dropout)."""

    t_s: np.ndarray  # (E,) [s]
    index: np.ndarray  # (E,) int
    values: Mapping[str, np.ndarray]  # column name -> (E, R)

    @classmethod
    def empty(cls, columns: Sequence[Column], num_runs: int) -> SourceData:
        return cls(
            t_s=np.zeros(0),
            index=np.zeros(0, np.int64),
            values={c.name: np.zeros((0, num_runs)) for c in columns},
        )

    @classmethod
    def concatenate(cls, parts: Sequence[SourceData]) -> SourceData:
        """The epochs of consecutive chunks as one."""
        return cls(
            t_s=np.concatenate([p.t_s for p in parts]),
            index=np.concatenate([p.index for p in parts]).astype(np.int64),
            values={k: np.concatenate([p.values[k] for p in parts]) for k in parts[0].values},
        )

    def stacked(self, names: Sequence[str]) -> np.ndarray:
        """The columns ``names`` side by side: (E, R, len(names))."""
        return np.stack([self.values[n] for n in names], axis=-1)


class SourceModel(Protocol):
    """What the bank calls at each epoch of the source, for the whole batch (methods x runs)."""

    def measure(self, nom: Nominal, data: SourceData, j: int) -> Measurement: ...


class AidingSource(ABC):
    """One aiding sensor: its configuration, simulation, log table and measurement model."""

    name: ClassVar[str]  # in --aiding, run.aiding, the records (MethodResult.updates), its TOML section
    # and its log table's file name (lower case)
    label: ClassVar[str]  # a few words: the dashboard's checkbox and the head of its controls' labels
    summary: ClassVar[str]  # one line: what it measures
    config_type: ClassVar[type]  # its section: a frozen dataclass, every field with a default (and
    # a Setting: setting())
    streams: ClassVar[tuple[str, ...]]  # its random streams, each its own generator per run
    columns: ClassVar[tuple[Column, ...]]  # its log table's columns besides t_s
    row_labels: ClassVar[tuple[str, ...]]  # its measurement's rows, e.g. ("north", "east", "down")

    @abstractmethod
    def rate_hz(self, section: Any) -> float:
        """Its measurement rate [Hz]."""

    def initial_state(self, section: Any, num_runs: int) -> Any:
        """What :meth:`simulate_chunk` carries from one chunk to the next (None: nothing)."""
        return None

    @abstractmethod
    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: Any,
        state: Any,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, Any]:
        """Its measurements fused within the chunk ``truth`` (the mission's samples ``k0`` on) and
        the state for the next chunk. ``epochs``: the mission's samples at :meth:`rate_hz` within the
        chunk; ``rngs``: a generator (or one per run) for each of :attr:`streams`; ``num_samples``:
        the mission's length. ``section`` is as given (zero-noise when the run is ideal:
        :meth:`ideal`)."""

    def ideal(self, section: Any) -> Any:
        """The section with every error zeroed (``run.ideal``); as given unless overridden."""
        return section

    @abstractmethod
    def model(self, section: Any, config: Sections) -> SourceModel:
        """Its measurement model, from its section and the rest of the configuration."""
