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
- how a ROS bag carries its table (:attr:`AidingSource.bag_messages`): the message types a bag
  mapping's topic for it may hold and which field fills which columns (:class:`BagMessage`), read
  by tauvcore.logs.bags (which imports this layer, never the other way);
- what the user sees of it: a short label (the dashboard's checkbox), a summary and the names of
  its measurement's rows.

The engine fuses a registered source into every method of the 20-state bank that takes aiding
(all but the standalone INS), at its epochs, with the gate and the records of every source. A
source's data is measured at the IMU sample it is fused at (``SourceData.index``); a measurement
of an earlier instant (a latency) is the source's own business, in its model.

A source that is data for a method rather than a measurement of its own (:attr:`AidingSource.fused`
False: the echo sounder's altitude that switches Yoo 2014's filters, the propeller's RPM its velocity
filter reads) is simulated, logged and read the same way and handed to the banks in
``SimChunk.sources``; it has no model and no place in ``run.aiding``. What only a simulation knows
of a source (the RPM model's true scale factor) are its :attr:`AidingSource.truth_columns`: written
to a simulated log beside its columns, read back when a log has them (NaN when it does not).

The DVL (tauvcore.aiding.dvl_beams) is a source of a third kind: simulated, logged and read as the
others, it has no model of the engine's, because the methods are built around it and fuse its beams
themselves (:attr:`AidingSource.methods_fuse`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from tauvcore.filter.layout import StateBlock
from tauvcore.validation import SETTING, Setting, check_settings, setting, settings

if TYPE_CHECKING:
    from tauvcore.aiding.fusion_method import Sections
    from tauvcore.filter.eskf import Measurement, Nominal
    from tauvcore.sensors.timing import Rng
    from tauvcore.truth.truth_record import Truth
    from tauvcore.truth.world import World


@dataclass(frozen=True)
class Column:
    """One column of a source's log table: SI, its unit in its name."""

    name: str  # e.g. "north_m"
    unit: str  # e.g. "m"
    low: float  # physical bounds: a value beyond them is refused, naming the row and the column
    high: float
    what: str  # what a value beyond the bounds would be, in words ("farther than the earth is wide")
    allow_nan: bool = False  # an empty cell (NaN) means "no measurement in this row"
    angle: bool = False  # an angle [rad] named <stem>_rad; the table may give it in degrees, <stem>_deg

    @property
    def stem(self) -> str:
        """An angle's name without its unit (``roll`` of ``roll_rad``)."""
        return self.name.removesuffix("_rad")


@dataclass(frozen=True)
class SourceData:
    """A source's epochs within a chunk (or a whole mission), the run axis after time.

    ``index`` are the mission's IMU samples the epochs are fused at (global, sorted); ``values``
    one array per log column, (E, R); a NaN marks a row without a measurement (a dropout)."""

    t_s: np.ndarray  # (E,) [s]
    index: np.ndarray  # (E,) int
    values: Mapping[str, np.ndarray]  # column name -> (E, R)
    truth: Mapping[str, np.ndarray] = field(default_factory=dict)  # truth column name -> (E, R)
    # (AidingSource.truth_columns; NaN where a log has none)

    @classmethod
    def empty(cls, columns: Sequence[Column], num_runs: int) -> SourceData:
        """No epochs: the data of a source that measured nothing (a log without its table).

        Parameters
        ----------
        columns : Sequence[Column]
            The source's log columns (:attr:`AidingSource.columns`), one empty array each.
        num_runs : int
            Number of Monte Carlo runs R (the run axis of every value array).

        Returns
        -------
        SourceData
            Zero epochs: ``t_s`` (0,) [s], ``index`` (0,) int, each column's values (0, R) in the
            column's unit, no truth columns.
        """
        return cls(
            t_s=np.zeros(0),
            index=np.zeros(0, np.int64),
            values={c.name: np.zeros((0, num_runs)) for c in columns},
        )

    @classmethod
    def concatenate(cls, parts: Sequence[SourceData]) -> SourceData:
        """The epochs of consecutive chunks as one.

        Parameters
        ----------
        parts : Sequence[SourceData]
            The chunks' data in mission order, at least one, each with the same columns and truth
            columns and the same run count R.

        Returns
        -------
        SourceData
            Their epochs end to end: ``t_s`` (E,) [s], ``index`` (E,) int (the mission's IMU
            samples), each column (E, R) in its unit, E the sum of the parts' epochs.
        """
        return cls(
            t_s=np.concatenate([p.t_s for p in parts]),
            index=np.concatenate([p.index for p in parts]).astype(np.int64),
            values={k: np.concatenate([p.values[k] for p in parts]) for k in parts[0].values},
            truth={k: np.concatenate([p.truth[k] for p in parts]) for k in parts[0].truth},
        )

    def latest(self, name: str, k: int) -> np.ndarray:
        """Column (or truth column) ``name`` at the last epoch at or before an IMU sample.

        Parameters
        ----------
        name : str
            A column of :attr:`values`, else a truth column of :attr:`truth` (e.g. ``"altitude_m"``).
        k : int
            The mission's IMU sample index (global, as :attr:`index`).

        Returns
        -------
        numpy.ndarray
            The value of the latest epoch at or before ``k``, shape (R,), in the column's unit (its
            name says which, e.g. [m]); NaN before the first epoch.
        """
        values = self.values[name] if name in self.values else self.truth[name]
        j = int(np.searchsorted(self.index, k, side="right")) - 1
        return np.asarray(values[j], dtype=float) if j >= 0 else np.full(values.shape[1:], np.nan)

    def stacked(self, names: Sequence[str]) -> np.ndarray:
        """The columns ``names`` side by side.

        Parameters
        ----------
        names : Sequence[str]
            Columns of :attr:`values`, in the order wanted (e.g. ``("north_m", "east_m", "down_m")``).

        Returns
        -------
        numpy.ndarray
            Every epoch of those columns, shape (E, R, len(names)), each in its column's unit.
        """
        return np.stack([self.values[n] for n in names], axis=-1)

    def row(self, names: Sequence[str], j: int) -> np.ndarray:
        """Epoch ``j`` of the columns ``names`` side by side.

        ``stacked(names)[j]`` without stacking the other epochs (a model reads one epoch at a
        time; a replay's chunk is the whole log).

        Parameters
        ----------
        names : Sequence[str]
            Columns of :attr:`values`, in the order wanted.
        j : int
            The epoch within this data (0 <= j < E), not an IMU sample index.

        Returns
        -------
        numpy.ndarray
            Epoch ``j`` of those columns, shape (R, len(names)), each in its column's unit.
        """
        return np.stack([self.values[n][j] for n in names], axis=-1)


BAG_FIELD_KINDS = ("world_vector", "world_sigma", "scalar")
"""What a message field is to a source's table (:class:`BagField`)."""


@dataclass(frozen=True)
class BagField:
    """Columns of a source's log table read from one field of a ROS message.

    ``world_vector``: a vector (``x``, ``y``, ``z``) in the topic's world frame, three columns in
    NED (ENU converted for a ``flu_enu`` topic); ``world_sigma``: a 6 x 6 covariance (row-major, as
    ``PoseWithCovariance.covariance``) whose position diagonal's square roots fill three 1-sigma
    columns in NED; ``scalar``: a number taken as it is, one column.
    """

    columns: tuple[str, ...]  # the table's columns it fills, in order (three, or one for a scalar)
    path: str  # the field's dotted path in the message ("point", "pose.pose.position")
    kind: str = "world_vector"  # one of BAG_FIELD_KINDS

    def __post_init__(self) -> None:
        if self.kind not in BAG_FIELD_KINDS:
            raise ValueError(f"BagField.kind: {self.kind!r} is not one of {', '.join(BAG_FIELD_KINDS)}")
        if len(self.columns) != (1 if self.kind == "scalar" else 3):
            raise ValueError(
                f"BagField.columns: {self.kind} fills {1 if self.kind == 'scalar' else 3}, got {self.columns}"
            )


@dataclass(frozen=True)
class BagMessage:
    """A ROS message type a source's table may be read from in a bag, and what fills its columns
    (columns no field fills are NaN: a table's optional columns)."""

    msgtype: str  # e.g. "geometry_msgs/msg/PointStamped"
    fields: tuple[BagField, ...]


class SourceModel(Protocol):
    """What the bank calls at each epoch of the source, for the whole batch (methods x runs)."""

    def measure(self, nom: Nominal, data: SourceData, j: int) -> Measurement:
        """The measurement of epoch ``j`` for the whole batch.

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B (methods x runs, (M, R) in the 20-state bank): position
            ``pos_n`` (B, 3) [m] NED (latitude, longitude [rad], depth [m] on WGS-84), velocity
            ``vel_n`` (B, 3) [m/s] NED, attitude ``C_nb`` (B, 3, 3) body FRD to NED.
        data : SourceData
            The source's epochs within the chunk, each column (E, R).
        j : int
            The epoch within ``data`` (0 <= j < E).

        Returns
        -------
        Measurement
            ``z`` and ``innovation`` (B, m), ``H`` (B, m, 20), ``R`` (B, m, m) and ``valid`` (B,),
            in the source's units (SI), m its measurement's rows (:attr:`AidingSource.row_labels`).
        """
        ...


class AidingSource(ABC):
    """One aiding sensor: its configuration, simulation, log table and measurement model."""

    name: ClassVar[str]  # in --aiding, run.aiding and the records (MethodResult.updates) (lower case)
    section_name: ClassVar[str]  # its configuration section ([<section_name>] in TOML,
    # Config.section): its name unless the class says otherwise
    table: ClassVar[str]  # its log table's file name (<table>.csv or .parquet): its name unless the
    # class says otherwise
    aboard: ClassVar[bool] = False  # True: a sensor every vehicle of the lab carries, simulated and
    # written to a log whether or not run.aiding fuses it, its streams named after fields of
    # tauvcore.sensors.stream.SensorStreams (the streams the IMU and DVL draw beside); False: simulated
    # only when fused, its streams spawned for it (tauvcore.engine.source_streams)
    label: ClassVar[str]  # a few words: the dashboard's checkbox and the head of its controls' labels
    summary: ClassVar[str]  # one line: what it measures
    config_type: ClassVar[type]  # its section: a frozen dataclass, every field with a default (and
    # a Setting: setting())
    streams: ClassVar[tuple[str, ...]]  # its random streams, each its own generator per run
    columns: ClassVar[tuple[Column, ...]]  # its log table's columns besides t_s
    row_labels: ClassVar[tuple[str, ...]] = ()  # its measurement's rows, e.g. ("north", "east", "down")
    observes: ClassVar[tuple[str, ...]] = ()  # the blocks of the 20-state error (tauvcore.filter.layout.
    # STATE.names: "pos", "att", "vel", "ba", "bg", ...) its H may weigh; zero elsewhere (tested). Yoo
    # 2014's 12-state filter fuses a source whose blocks it has (tauvcore.engine.yoo_sources)
    fused: ClassVar[bool] = True  # False: data a method reads, no measurement of its own (no model,
    # not in run.aiding; the module docstring)
    methods_fuse: ClassVar[bool] = False  # True (with fused False): measurements the methods fuse
    # themselves (the DVL's beams: LC, TC, the partial-beam methods), named in run.aiding to turn
    # those methods' updates on
    truth_columns: ClassVar[tuple[Column, ...]] = ()  # what a simulation knows of it besides its
    # columns: in SourceData.truth, written to a simulated log, optional in a log's table
    bag_messages: ClassVar[tuple[BagMessage, ...]] = ()  # the message types a bag mapping's topic
    # for its table may hold ([<table>] topic = ...; tauvcore.logs.bags), never found by type alone

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        name = cls.__dict__.get("name")
        if isinstance(name, str):
            cls.section_name = cls.__dict__.get("section_name", name)
            cls.table = cls.__dict__.get("table", name)

    def rate_hz(self, section: Any) -> float:
        """Its measurement rate: the section's ``rate_hz`` unless overridden.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`).

        Returns
        -------
        float
            Epochs per second [Hz]; at most the IMU's rate (:class:`~tauvcore.config.Config` checks).
        """
        return section.rate_hz

    def initial_state(self, section: Any, num_runs: int, world: World) -> Any:
        """What :meth:`simulate_chunk` carries from one chunk to the next, before the first chunk.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`; zero-noise when the run
            is ideal: :meth:`ideal`).
        num_runs : int
            Number of Monte Carlo runs R.
        world : World
            What the vehicle flies through (the seabed, depths [m] NED).

        Returns
        -------
        Any
            The source's own state for the first chunk; None: nothing is carried.
        """
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
        """Its measurements fused within the chunk ``truth`` and the state for the next chunk.

        Parameters
        ----------
        truth : Truth
            The chunk's true motion, K samples at the IMU rate (positions (K, 3) [m] NED,
            attitude ``C_nb`` (K, 3, 3) body FRD to NED, ...); its row k is the mission's sample
            ``k0 + k``.
        k0 : int
            The mission's IMU sample index of the chunk's first row.
        epochs : numpy.ndarray
            The mission's IMU sample indices at :meth:`rate_hz` within the chunk, shape (E,) int,
            sorted, each in ``[k0, k0 + K)``.
        section : Any
            Its configuration section as given (zero-noise when the run is ideal: :meth:`ideal`).
        state : Any
            What the previous chunk handed on (:meth:`initial_state` before the first chunk).
        rngs : Mapping[str, Rng]
            A generator (or one per run) for each of :attr:`streams`, by stream name.
        num_runs : int
            Number of Monte Carlo runs R.
        num_samples : int
            The mission's length [IMU samples].

        Returns
        -------
        tuple[SourceData, Any]
            The epochs fused within the chunk (``t_s`` (E',) [s], ``index`` (E',) the mission's IMU
            samples, each column (E', R) in its unit) and the state for the next chunk.
        """

    def ideal(self, section: Any) -> Any:
        """The section with every error zeroed (``run.ideal``): the section's own ``ideal()`` if it
        has one, else the section as given, unless overridden.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`).

        Returns
        -------
        Any
            The same section type with every error (noise, bias, dropout, ...) zero.
        """
        ideal = getattr(section, "ideal", None)
        return section if ideal is None else ideal()

    def model(self, section: Any, config: Sections) -> SourceModel:
        """Its measurement model, from its section and the rest of the configuration.

        A :attr:`fused` source must define it.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`).
        config : Sections
            The run's configuration, read by section (e.g. ``config.section("earth")`` for the
            origin's latitude and longitude [rad]).

        Returns
        -------
        SourceModel
            What the bank calls at each of the source's epochs (:meth:`SourceModel.measure`).

        Raises
        ------
        TypeError
            Unless overridden: the source is data for a method, not a measurement: it has no model.
        """
        raise TypeError(f"source {self.name!r} is data for a method, not a measurement: it has no model")

    def states(self, section: Any) -> tuple[StateBlock, ...]:
        """The states it adds to the 20 of the filters' error state (none unless overridden).

        Each block follows the layout's 20 in the order of the sources (tauvcore.filter.layout.
        Layout); every filter of the bank carries it, every table and NEES block shows it, and the
        source's model (and any other) may see it through ``Nominal.extra`` and the columns of H
        after the 20.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`).

        Returns
        -------
        tuple[StateBlock, ...]
            The blocks, each with its states' names, initial 1-sigma and process (Gauss-Markov or
            random walk) in its unit.
        """
        return ()

    def states_truth(self, section: Any, truth: Truth) -> np.ndarray:
        """The true values of the states of :meth:`states` at the truth's samples.

        Parameters
        ----------
        section : Any
            Its configuration section (an instance of :attr:`config_type`).
        truth : Truth
            A chunk of the mission's truth (K samples).

        Returns
        -------
        numpy.ndarray
            Shape (K, E) in the states' units (E the states of :meth:`states`); NaN where unknown
            (a log).
        """
        return np.zeros((truth.num_samples, sum(b.dim for b in self.states(section))))


__all__ = [
    "SETTING",
    "AidingSource",
    "BagField",
    "BagMessage",
    "Column",
    "Setting",
    "SourceData",
    "SourceModel",
    "check_settings",
    "setting",
    "settings",
]
