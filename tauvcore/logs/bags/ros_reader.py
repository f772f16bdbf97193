"""Reading a ROS bag into the log's tables: the topics the mapping names (tauvcore.logs.bags.mapping),
their messages' numbers (tauvcore.logs.bags.messages) in tauvcore's frames (tauvcore.logs.bags.frames),
units and clock, one table per sensor as a log's files hold them (tauvcore.logs).

Time: a topic's times are its header stamps (or the bag's receive times, ``time = "receive"``)
less the origin, the IMU topic's first time, plus the topic's ``offset_s``:
``t_s = (stamp_ns - origin_ns) 1e-9 + offset_s``, in the bag's order; so a stamp that goes back
is refused by the log's reader at that message (``row N`` is the topic's N-th message).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from tauvcore.aiding.source import BagMessage
from tauvcore.geo.earth import ned_from_geodetic
from tauvcore.geo.rotations import euler_from_C_nb
from tauvcore.logs.bags.dvl_table import dvl_table
from tauvcore.logs.bags.files import BoundedPath, bag_errors, check_bag, msg_text, reset_short_read, why
from tauvcore.logs.bags.frames import (
    C_nb_from_quaternion,
    body_vectors,
    body_vectors_in_place,
    world_vectors,
    world_vectors_in_place,
)
from tauvcore.logs.bags.increments import increment_columns
from tauvcore.logs.bags.mapping import (
    ATMOSPHERIC_PA,
    EXTRA_TOPICS,
    GRAVITY_MPS2,
    PLUGIN_COLUMNS,
    PLUGIN_MESSAGES,
    WATER_DENSITY_KGPM3,
    BagMapping,
    TopicRule,
    resolve,
)
from tauvcore.logs.bags.messages import (
    EXTRACT,
    FIELDS,
    IMU_RATES,
    LAYOUTS,
    RawDecoder,
    plugin_row,
    require_finite,
)
from tauvcore.logs.bags.scan import NotScannedError, Ros1Reader, read_chunked
from tauvcore.logs.bags.tf import Mounting, dvl_mounting
from tauvcore.units import DEG
from tauvcore.validation import LogError, one_line, show, show_path

BAG_SUFFIXES = (".bag", ".mcap", ".db3")
"""A ROS 1 bag, an MCAP file (ROS 2), a ROS 2 sqlite3 file; a ROS 2 bag is also a directory with
``metadata.yaml``."""
MSGS = Path(__file__).with_name("msgs")
"""The shipped ``.msg`` definitions, ``<package>/msg/<Type>.msg`` (tauvcore/logs/bags/msgs/README.md)."""


def read_mounting(reader: Any, bag: str, mapping: BagMapping, rules: Mapping[str, TopicRule]) -> Mounting:
    """:func:`~tauvcore.logs.bags.tf.dvl_mounting` of the open ``reader``, a bag that cannot be read
    there one :class:`LogError` naming it.

    Parameters
    ----------
    reader : rosbags.highlevel.AnyReader
        The bag, open.
    bag : str
        Its path, for the message.
    mapping : BagMapping
        The bag mapping.
    rules : Mapping of str to TopicRule
        The tables' topics as resolved, ``dvl`` among them.

    Returns
    -------
    Mounting
        As :func:`~tauvcore.logs.bags.tf.dvl_mounting` gives it.

    Raises
    ------
    LogError
        ``/tf_static`` or the DVL's first message cannot be read, or as ``dvl_mounting``.
    """
    try:
        return dvl_mounting(reader, bag, mapping, rules)
    except bag_errors() as exc:
        raise LogError(
            one_line(f"{show_path(bag)}: /tf_static or the DVL's first message cannot be read: {why(exc)}")
        ) from None


def is_bag(path: str | os.PathLike, by_name: bool = False) -> bool:
    """Whether ``path`` is a ROS bag by its name: a ``.bag``, ``.mcap`` or ``.db3`` file (or
    anything so named but a directory: a FIFO, a link; opening it says what it is), or a directory
    holding ``metadata.yaml`` (a ROS 2 bag).

    Parameters
    ----------
    path : str or os.PathLike
        A file or directory.
    by_name : bool
        Also a directory named as a bag file (``d.bag``) that is not a log (no ``imu.csv`` nor
        ``imu.parquet``): what a command given a path takes for a bag, so that opening it says it
        is neither (:func:`~tauvcore.logs.bags.files.check_bag`).

    Returns
    -------
    bool
        True for a bag (it may still fail to read).
    """
    p = Path(path)
    named = p.suffix.lower() in BAG_SUFFIXES
    try:
        if p.is_dir():
            if (p / "metadata.yaml").is_file() or (by_name and os.path.lexists(p / "metadata.yaml")):
                return True
            return by_name and named and not any(os.path.lexists(p / f"imu{s}") for s in (".csv", ".parquet"))
    except OSError:
        return False
    return named


def _msg_type(path: Path, where: str) -> str:
    """The type name of a ``.msg`` file laid out as ``<package>/msg/<Type>.msg``."""
    if path.suffix != ".msg" or path.parent.name != "msg" or not path.parent.parent.name:
        raise LogError(
            f"{where}msg_paths: {show_path(str(path))} is not laid out as <package>/msg/<Type>.msg "
            "(the type's name is read from its path)"
        )
    return f"{path.parent.parent.name}/msg/{path.stem}"


def typestore(msg_paths: tuple[Path, ...] = (), mapping_path: str | None = None) -> Any:
    """The message types a bag without its own definitions is read with: ROS 2's standard ones,
    the shipped DVL messages and those of ``msg_paths`` (rosbags.typesys).

    Parameters
    ----------
    msg_paths : tuple of pathlib.Path
        Extra ``.msg`` files, each ``<package>/msg/<Type>.msg``.
    mapping_path : str or None
        The bag mapping that names them, for the messages.

    Returns
    -------
    rosbags.typesys.store.Typestore
        The types registered.

    Raises
    ------
    LogError
        A ``.msg`` file that cannot be read or parsed, naming the mapping and the file.
    """
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    where = f"the bag mapping {show_path(mapping_path)}: " if mapping_path else ""
    store = get_typestore(Stores.LATEST)
    types: dict = {}
    for path in [*sorted(MSGS.glob("*/msg/*.msg")), *msg_paths]:
        name = _msg_type(path, where)
        text = msg_text(path, where)
        try:
            types.update(get_types_from_msg(text, name))
        except bag_errors() as exc:  # rosbags' parser raises its own kinds: one line naming the file
            raise LogError(
                one_line(f"{where}msg_paths: {show_path(str(path))}: not a .msg definition: {exc}")
            ) from None
    try:
        store.register(types)
    except bag_errors() as exc:
        raise LogError(one_line(f"{where}msg_paths: the definitions do not register: {exc}")) from None
    return store


@dataclass(frozen=True)
class BagTables:
    """A bag read into the log's tables."""

    source: str  # the bag's path
    tables: dict[str, dict[str, np.ndarray]]  # table -> column -> (K,), as a log's files hold them
    names: dict[str, str]  # table -> its name in messages: '<bag>:<topic>'
    rules: dict[str, TopicRule]  # table -> the topic that fed it
    notes: tuple[str, ...] = ()  # what the conversion did that the user should know
    mounting: Mounting | None = None  # the DVL's mounting as taken (tauvcore.logs.bags.tf); None: no DVL


class _Topic:
    """One topic's messages as read: header stamps and receive times [ns] (K,), rows of numbers
    (K, C), filled batch by batch (:meth:`add`) into arrays of the size the bag's index gives
    (``expected``; grown if it has more), so no second copy of a topic is ever made."""

    def __init__(
        self, kind: str, expected: int = 0, extract: Any = None, fields: tuple[str, ...] | None = None
    ) -> None:
        self.kind = kind  # the message type
        self.fields = fields  # the row's fields where not all of FIELDS[kind] (messages.IMU_RATES)
        self.extract = extract if extract is not None else EXTRACT[kind]  # a message -> its row
        self.plugin = extract is not None  # read by a plug-in source's own fields (messages.plugin_row)
        self.count = 0  # messages read so far
        self.expected = expected
        self.stamps = np.empty(0, dtype=np.int64)
        self.received = np.empty(0, dtype=np.int64)
        self.rows: np.ndarray = np.empty((0, 0))

    def room(self, end: int, columns: int) -> None:
        """Arrays of at least ``end`` messages of ``columns`` numbers, those read kept."""
        if end > len(self.received) or columns != self.rows.shape[1]:
            size = max(self.expected, end, 2 * len(self.received))
            grown = (
                np.empty(size, dtype=np.int64),
                np.empty(size, dtype=np.int64),
                np.empty((size, columns)),
            )
            if self.count:  # more messages than the index said, or none before
                for new, old in zip(grown, (self.stamps, self.received, self.rows), strict=True):
                    new[: self.count] = old[: self.count]
            self.stamps, self.received, self.rows = grown

    def add(self, stamps: np.ndarray, received: np.ndarray, rows: np.ndarray) -> None:
        n, end = len(received), self.count + len(received)
        self.room(end, rows.shape[1])
        self.stamps[self.count : end] = stamps
        self.received[self.count : end] = received
        self.rows[self.count : end] = rows
        self.count += n

    def finish(self) -> None:
        """Trim the arrays to the messages read, in rosbags' order: by receive time, ties as read."""
        self.stamps, self.received, self.rows = (
            a[: self.count] for a in (self.stamps, self.received, self.rows)
        )
        if self.count > 1 and bool((self.received[1:] < self.received[:-1]).any()):
            order = np.argsort(self.received, kind="stable")
            self.stamps, self.received, self.rows = self.stamps[order], self.received[order], self.rows[order]

    def release(self) -> None:
        """Drop the messages (a table made of them holds what it needs)."""
        self.stamps, self.received, self.rows = (
            np.empty(0, dtype=np.int64),
            np.empty(0, dtype=np.int64),
            np.empty(0),
        )

    def times_ns(self, rule: TopicRule) -> np.ndarray:
        return self.stamps if rule.time == "header" else self.received


_NONE = np.empty(0, dtype=np.int64)
"""No stamps (tauvcore.logs.bags.scan.fixed_rows of a type without a header)."""
BATCH = 16_384
"""Messages of a topic read into its arrays at a time: the raw bytes held are at most this many
messages a topic (about 12 MB of a nav_msgs/Odometry topic)."""


def open_bag(path: str | os.PathLike, store: Any) -> Any:
    """An open rosbags ``AnyReader`` of the bag at ``path``, its files read through
    :class:`~tauvcore.logs.bags.files.BoundedPath` (a LogError naming it if it is not a bag file or
    directory, :func:`~tauvcore.logs.bags.files.check_bag`, or cannot be opened: truncated, corrupt)."""
    from rosbags.highlevel import AnyReader

    bag = os.fspath(path)
    check_bag(bag)
    reset_short_read()
    try:
        reader = AnyReader([BoundedPath(bag)], default_typestore=store)
        if not reader.is2:  # a ROS 1 bag: its message indexes read only where asked for
            reader.readers = [Ros1Reader(p) for p in reader.paths]
        reader.open()
    except bag_errors() as exc:  # rosbags, sqlite3, struct, lz4, zstd each raise their own
        raise LogError(one_line(f"{show_path(bag)}: cannot be read as a ROS bag: {why(exc)}")) from None
    return reader


def _deserialize(reader: Any, kind: str, raw: bytes) -> Any:
    return reader.deserialize(raw, kind)


class _Batch:
    """A topic's messages not yet read into its arrays: their bytes and receive times, read in
    one go (:class:`~tauvcore.logs.bags.messages.RawDecoder`) where the type's numbers are plain fields,
    else message by message with rosbags."""

    def __init__(self, bag: str, topic: str, reader: Any, entry: _Topic) -> None:
        self.bag, self.topic, self.reader, self.entry = bag, topic, reader, entry
        self.raws: list[bytes] = []
        self.received: list[int] = []
        kind = entry.kind
        deserialize = functools.partial(_deserialize, reader, kind)
        self.decoder = (
            RawDecoder(reader.typestore.fielddefs, kind, bool(reader.is2), deserialize, entry.fields)
            if kind in FIELDS and not entry.plugin
            else None
        )
        if self.decoder is not None:
            entry.extract = self.decoder.extract

    def flush(self) -> None:
        """Read the messages held into the topic's arrays."""
        if not self.raws:
            return
        received = np.array(self.received, dtype=np.int64)
        decoded = self.decoder.decode(self.raws) if self.decoder is not None else None
        if decoded is None:
            stamps, rows = self._one_by_one()
        else:
            rows, stamps = decoded
        self.entry.add(received if stamps is None else stamps, received, rows)
        self.raws, self.received = [], []

    def take(self, chunk: np.ndarray, received: np.ndarray, offset: np.ndarray, length: np.ndarray) -> None:
        """The topic's messages in one chunk (tauvcore.logs.bags.scan.read_chunked): bytes ``chunk``
        (B,) uint8, receive times [ns], offsets and lengths [bytes] (M,); read straight into the
        topic's arrays where the decoder lays them out, else held for :meth:`flush`."""
        done = 0
        if self.decoder is not None and not self.raws:
            entry, n = self.entry, received.size
            entry.room(entry.count + n, len(self.decoder.fields))
            stamped = self.decoder.stamped
            done = self.decoder.decode_chunk(
                chunk, offset, length, entry.rows, entry.stamps if stamped else _NONE, entry.count
            )
            entry.received[entry.count : entry.count + done] = received[:done]
            if not stamped:
                entry.stamps[entry.count : entry.count + done] = received[:done]
            entry.count += done
        for start, n, time_ns in zip(
            offset[done:].tolist(), length[done:].tolist(), received[done:].tolist(), strict=True
        ):
            self.raws.append(chunk[start : start + n].tobytes())
            self.received.append(time_ns)
            if len(self.raws) == BATCH:
                self.flush()

    def _one_by_one(self) -> tuple[np.ndarray, np.ndarray]:
        """Each message deserialised by rosbags: its stamps (None without a header) and rows;
        a message that cannot be read is one LogError naming its index in the topic."""
        kind, topic, reader = self.entry.kind, self.topic, self.reader
        stamps: list[int] = []
        rows: list[tuple[float, ...]] = []
        for i, (raw, received) in enumerate(zip(self.raws, self.received, strict=True)):
            index = self.entry.count + i + 1
            try:
                msg: Any = reader.deserialize(raw, kind)
                rows.append(self.entry.extract(msg))
                header = getattr(msg, "header", None)  # std_msgs' numbers have none
                stamp = header.stamp if header is not None else None
            except LogError:
                raise
            except AttributeError as exc:
                raise LogError(
                    one_line(
                        f"{show_path(self.bag)}: topic {show(topic)}, message {index}: "
                        f"{kind} has no field {show(exc.name)} here (its definition differs)"
                    )
                ) from None
            except bag_errors() as exc:
                raise LogError(
                    one_line(
                        f"{show_path(self.bag)}: topic {show(topic)}, message {index}: cannot be read: {why(exc)}"
                    )
                ) from None
            stamps.append(
                int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) if stamp is not None else int(received)
            )
        return np.array(stamps, dtype=np.int64), np.array(rows, dtype=float).reshape(len(rows), -1)


def _read_messages(reader: Any, connections: list[Any], batches: Mapping[str, _Batch]) -> None:
    """Every message of ``connections`` into its topic's batch as rosbags gives them."""
    messages = (
        reader.readers[0].messages(connections=connections)
        if len(reader.readers) == 1  # one bag: its messages in order, without the merge of several
        else reader.messages(connections=connections)
    )
    for connection, received, raw in messages:
        batch = batches[connection.topic]
        batch.raws.append(raw)
        batch.received.append(received)
        if len(batch.raws) == BATCH:
            batch.flush()


def read_topics(
    path: str | os.PathLike, mapping: BagMapping
) -> tuple[dict[str, TopicRule], dict[str, _Topic], Mounting | None]:
    """The mapping's rules for the bag at ``path``, the messages of every topic they need (by
    topic; each with its type as ``kind``) and the DVL's mounting (tauvcore.logs.bags.tf; None without
    a DVL topic)."""
    bag = os.fspath(path)
    reader = open_bag(bag, typestore(mapping.msg_paths, mapping.path))
    try:
        topics: dict[str, str] = {}
        for c in reader.connections:
            if topics.setdefault(c.topic, c.msgtype) != c.msgtype:
                raise LogError(
                    f"{show_path(bag)}: topic {show(c.topic)} holds both {topics[c.topic]} and {c.msgtype}"
                )
        rules = resolve(mapping, topics, bag)
        uses = [r.topic for r in rules.values()] + [  # each topic once for each table it feeds
            r.options[k] for r in rules.values() for k in EXTRA_TOPICS if k in r.options
        ]
        needed = set(uses)
        plugin = {r.topic: r for t, r in rules.items() if t in PLUGIN_MESSAGES}
        for topic, rule in plugin.items():
            others = [t for t, r in rules.items() if r.topic == topic and t != rule.table] + [
                f"{r.table} ({k})" for r in rules.values() for k in EXTRA_TOPICS if r.options.get(k) == topic
            ]
            if others:
                raise LogError(
                    f"{show_path(bag)}: topic {show(topic)} would feed both the {rule.table} table and the "
                    f"{others[0]} table: give each its own topic in the bag mapping"
                )
        for topic in sorted(needed):
            kind = topics[topic]
            if kind not in EXTRACT and topic not in plugin:
                raise LogError(f"{show_path(bag)}: topic {show(topic)}: {kind} is not a message tauv reads")
            if kind not in reader.typestore.fielddefs:
                raise LogError(
                    f"{show_path(bag)}: topic {show(topic)}: the bag has no definition of {kind} (add its .msg "
                    "with msg_paths in the bag mapping)"
                )
        counts = dict.fromkeys(needed, 0)
        for c in reader.connections:
            if c.topic in needed:
                counts[c.topic] += c.msgcount
        rates = rules["imu"].topic if "imu" in rules and uses.count(rules["imu"].topic) == 1 else None
        read = {
            t: _Topic(
                topics[t],
                counts[t],
                plugin_row(PLUGIN_MESSAGES[plugin[t].table][topics[t]]) if t in plugin else None,
                IMU_RATES if t == rates and topics[t] == "sensor_msgs/msg/Imu" else None,
            )
            for t in needed
        }
        batches = {t: _Batch(bag, t, reader, read[t]) for t in needed}
        connections = [c for c in reader.connections if c.topic in needed]
        try:
            try:
                read_chunked(reader, connections, {t: b.take for t, b in batches.items()})
            except NotScannedError:  # rosbags' own walk, message by message
                _read_messages(reader, connections, batches)
            for batch in batches.values():
                batch.flush()
        except LogError:
            raise
        except bag_errors() as exc:  # a truncated or corrupt chunk part-way through
            raise LogError(one_line(f"{show_path(bag)}: cannot be read as a ROS bag: {why(exc)}")) from None
        for entry in read.values():
            entry.finish()
        mounting = read_mounting(reader, bag, mapping, rules) if "dvl" in rules else None
    finally:
        reader.close()
    return rules, read, mounting


def bag_tables(path: str | os.PathLike, mapping: BagMapping, beam_directions_b: np.ndarray) -> BagTables:
    """The log's tables of the bag at ``path`` under ``mapping`` (module docstring).

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 bag, a ROS 2 bag directory or an MCAP file.
    mapping : BagMapping
        The mapping (tauvcore.logs.bags.mapping.read_mapping).
    beam_directions_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (FRD), which per-beam
        velocities are matched to (``config.dvl.A_b``).

    Returns
    -------
    BagTables
        The tables (``imu`` as rates, or increments where the mapping's ``form`` says, ``dvl`` as beams or a body velocity, ``depth``,
        ``attitude``, ``reference``), each with ``t_s`` on the IMU's clock.

    Raises
    ------
    LogError
        For any bad input, naming the bag, the topic, the mapping key or the message.
    """
    bag = os.fspath(path)
    rules, read, mounting = read_topics(bag, mapping)
    if "imu" not in rules:
        raise LogError(
            f"{show_path(bag)}: no sensor_msgs/msg/Imu topic{' named in the mapping' if mapping.path else ''}: "
            "a replay needs an IMU"
        )
    left_out = [
        f"{t}.topic = ''" for t in ("reference", "attitude") if mapping.tables.get(t, {}).get("topic") == ""
    ]
    if "reference" not in rules and "attitude" not in rules and left_out:
        raise LogError(
            f"the bag mapping {show_path(mapping.path or '')}: {' and '.join(left_out)}: the filters are left no "
            f"starting attitude (a reference or attitude topic of {show_path(bag)} is needed)"
        )
    if "reference" not in rules and "attitude" not in rules:
        raise LogError(
            f"{show_path(bag)}: no reference (nav_msgs/Odometry, geometry_msgs/PoseStamped, ...) nor attitude "
            "topic: the filters need a starting attitude; name one in the bag mapping ([reference] or [attitude])"
        )
    imu_entry = read[rules["imu"].topic]
    origin = int(imu_entry.times_ns(rules["imu"])[0]) if imu_entry.count else 0
    notes: list[str] = []
    tables: dict[str, dict[str, np.ndarray]] = {}
    later = [rule.topic for rule in rules.values()]  # each topic once for each table it feeds
    later += [r.options[k] for r in rules.values() for k in EXTRA_TOPICS if k in r.options]
    for table, rule in rules.items():
        later.remove(rule.topic)
        entry = read[rule.topic]
        if not entry.count:
            raise LogError(f"{show_path(bag)}: topic {show(rule.topic)} ({table}) has no messages")
        kind = rule.msgtype
        data = entry.rows
        t = (entry.times_ns(rule) - origin) * 1e-9 + rule.offset_s
        if table in PLUGIN_MESSAGES:
            columns = PLUGIN_COLUMNS[table]
            tables[table] = {"t_s": t, **_plugin(PLUGIN_MESSAGES[table][kind], data, rule, columns)}
            if rule.topic not in later:
                entry.release()
            continue
        part = _parts(kind, data)
        _require_finite_parts(bag, rule, table, part, read)
        own = rule.topic not in later  # its rows are the table's alone: converted where they are
        if table == "imu" and rule.option("form", "rates") == "increments":
            velocity = rule.options["velocity_topic"]
            later.remove(velocity)
            other = read[velocity]
            columns = increment_columns(bag, rule, kind, data, entry.stamps, other.rows, other.stamps)
            if velocity not in later:
                other.release()
        elif table == "imu":
            columns = _imu(part, rule, own)
        elif table == "dvl":
            assert mounting is not None  # read_topics finds it wherever there is a DVL
            water = _water_topic(bag, rule, read, origin, later)
            columns = dvl_table(bag, part, rule, t, water, beam_directions_b, mounting.C_b_dvl, notes)
            t = columns.pop("t_s")  # a ping's two messages one row (tauvcore.logs.bags.dvl_table)
        elif table == "depth":
            columns = {"depth_m": _depth(kind, part, rule)}
        elif table == "attitude":
            euler, _ = _attitude(part["quaternion"], rule.frame)
            columns = {f"{n}_rad": euler[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))}
        else:
            columns = _reference(bag, kind, part, rule, t, read, rules, origin, notes, own)
        tables[table] = {"t_s": t, **columns}
        del part, data
        if rule.topic not in later:  # what the table needs is in its columns now
            entry.release()
    if mounting is not None and mounting.source.startswith("/tf_static"):
        notes.append(f"{show_path(bag)}: the DVL's mounting rotation is {mounting.source}")
    names = {table: f"{bag}:{rule.topic}" for table, rule in rules.items()}
    return BagTables(bag, tables, names, rules, tuple(notes), mounting)


def _water_topic(
    bag: str, rule: TopicRule, read: Mapping[str, _Topic], origin: int, later: list[str]
) -> tuple[dict[str, np.ndarray], str, np.ndarray] | None:
    """The DVL's ``water_track_topic``: its messages' rows by part, its type and their times [s] on
    the log's clock (the DVL topic's ``time`` and ``offset_s``); None where the mapping names none."""
    topic = rule.options.get("water_track_topic")
    if topic is None:
        return None
    later.remove(topic)
    entry = read[topic]
    if not entry.count:
        raise LogError(f"{show_path(bag)}: topic {show(topic)} (dvl water-track) has no messages")
    t = (entry.times_ns(rule) - origin) * 1e-9 + rule.offset_s
    part = _parts(entry.kind, entry.rows)
    if topic not in later:
        entry.release()
    return part, entry.kind, t


USED_PARTS = {
    "imu": ("gyro", "accel", "quaternion", "vector"),  # rates, or an increments topic's
    "depth": ("pressure", "value"),
    "attitude": ("quaternion",),
    "reference": ("position", "quaternion", "velocity_b", "lat_lon_deg"),
}
"""The parts of a table's rows (messages.LAYOUTS) that must be finite (the DVL's: dvl_table's)."""


def _require_finite_parts(
    bag: str, rule: TopicRule, table: str, part: Mapping[str, np.ndarray], read: Mapping[str, _Topic]
) -> None:
    """Refuse a NaN or an infinity in the parts a table takes of its topic's rows and of the other
    topics it names (an IMU's velocity increments, a fix's orientation and depth), before any
    arithmetic (messages.require_finite); a fix's altitude only where no depth_topic replaces it."""
    used = USED_PARTS.get(table, ())
    if table == "reference" and "depth_topic" not in rule.options:
        used = (*used, "altitude")
    where = f"{show_path(bag)}: topic {show(rule.topic)} ({table})"
    for name, values in part.items():
        if name in used and not (
            table == "imu" and name == "quaternion" and rule.msgtype == "sensor_msgs/msg/Imu"
        ):
            require_finite(where, rule.msgtype, name, values)
    for key in ("velocity_topic", "orientation_topic", "depth_topic"):
        other = rule.options.get(key)
        if other is None or other not in read:
            continue
        entry = read[other]
        where = f"{show_path(bag)}: topic {show(other)} ({table} {key})"
        for name, values in _parts(entry.kind, entry.rows[: entry.count]).items():
            if name in ("vector", "quaternion", "value", "pressure"):
                require_finite(where, entry.kind, name, values)


def _parts(kind: str, data: np.ndarray) -> dict[str, np.ndarray]:
    return {name: data[:, cols] for name, cols in LAYOUTS[kind].items()}


def _imu(part: Mapping[str, np.ndarray], rule: TopicRule, own: bool = False) -> dict[str, np.ndarray]:
    """The IMU's rates in FRD; ``own``: converted in the topic's rows, the columns views of them."""
    if own:
        gyro, accel = (
            body_vectors_in_place(part["gyro"], rule.frame),
            body_vectors_in_place(part["accel"], rule.frame),
        )
    else:
        gyro, accel = body_vectors(part["gyro"], rule.frame), body_vectors(part["accel"], rule.frame)
    out = {f"gyro_{a}_rps": gyro[:, i] for i, a in enumerate("xyz")}
    out.update({f"accel_{a}_mps2": accel[:, i] for i, a in enumerate("xyz")})
    return out


def _depth(kind: str, part: Mapping[str, np.ndarray], rule: TopicRule) -> np.ndarray:
    """Depth [m] of a pressure (``(p - p_atm) / (rho g)``) or a depth topic's value."""
    if kind == "sensor_msgs/msg/FluidPressure":
        rho = rule.option("water_density_kgpm3", WATER_DENSITY_KGPM3)
        g = rule.option("gravity_mps2", GRAVITY_MPS2)
        return (part["pressure"][:, 0] - rule.option("atmospheric_pa", ATMOSPHERIC_PA)) / (rho * g)
    return part["value"][:, 0].copy()


def _plugin(
    spec: BagMessage, data: np.ndarray, rule: TopicRule, columns: tuple[str, ...]
) -> dict[str, np.ndarray]:
    """A plug-in source's ``columns`` of its rows (:func:`~tauvcore.logs.bags.messages.plugin_row`):
    world vectors in NED, a covariance's position variances as 1-sigma in NED (NaN where negative,
    ROS's "unknown"), scalars as they are; a column no field fills is NaN."""
    out: dict[str, np.ndarray] = {}
    col = 0
    for f in spec.fields:
        if f.kind == "scalar":
            out[f.columns[0]] = data[:, col].copy()
            col += 1
            continue
        values = data[:, col : col + 3]
        col += 3
        if f.kind == "world_vector":
            values = world_vectors(values, rule.frame)
        else:  # variances: the axes swap as a vector's do (north = ENU's y), a sign flip is no change
            values = values[:, [1, 0, 2]] if rule.frame == "flu_enu" else values
            with np.errstate(invalid="ignore"):
                values = np.sqrt(values)
        out.update({name: values[:, i].copy() for i, name in enumerate(f.columns)})
    return {c: out.get(c, np.full(data.shape[0], np.nan)) for c in columns}


def _reference(
    bag: str,
    kind: str,
    part: Mapping[str, np.ndarray],
    rule: TopicRule,
    t: np.ndarray,
    read: Mapping[str, _Topic],
    rules: Mapping[str, TopicRule],
    origin: int,
    notes: list[str],
    own: bool = False,
) -> dict[str, np.ndarray]:
    """The reference table: position (local NED, or geodetic for a NavSatFix), attitude and NED
    velocity (an Odometry's twist rotated into n; else the positions' central differences);
    ``own``: a local position, the attitude and the velocity written over the topic's rows (the
    columns views of them)."""
    where = f"{show_path(bag)}: topic {show(rule.topic)} (reference)"
    out: dict[str, np.ndarray] = {}
    if kind == "sensor_msgs/msg/NavSatFix":
        lat, lon = part["lat_lon_deg"][:, 0] * DEG, part["lat_lon_deg"][:, 1] * DEG
        depth = -part["altitude"][:, 0]
        depth_topic = rule.options.get("depth_topic")
        if depth_topic is not None:
            depth = _other(bag, depth_topic, read, rules, origin, t, "depth")
        orientation = rule.options.get("orientation_topic")
        if orientation is None:
            raise LogError(
                f"{where}: a sensor_msgs/NavSatFix reference needs an attitude: set reference.orientation_topic "
                "in the bag mapping (a topic with an orientation)"
            )
        quaternion = _other(bag, orientation, read, rules, origin, t, "orientation")
        out.update({"lat_rad": lat, "lon_rad": lon, "depth_m": depth})
        position = ned_from_geodetic(lat, lon, -depth, (float(lat[0]), float(lon[0]), float(-depth[0])))
    else:
        position = (world_vectors_in_place if own else world_vectors)(part["position"], rule.frame)
        quaternion = part["quaternion"]
        out.update({"north_m": position[:, 0], "east_m": position[:, 1], "down_m": position[:, 2]})
    odometry = kind == "nav_msgs/msg/Odometry"
    in_place = own and kind != "sensor_msgs/msg/NavSatFix"
    euler, vel_n = _attitude(
        quaternion, rule.frame, part["velocity_b"] if odometry else None, in_place=in_place
    )
    out.update({f"{n}_rad": euler[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))})
    if vel_n is None:
        vel_n = np.gradient(position, t, axis=0) if t.size > 1 else np.zeros_like(position)
        notes.append(f"{where}: {kind} has no velocity; the reference velocity is the positions' differences")
    out.update({f"vel_{a}_mps": vel_n[:, i] for i, a in enumerate(("north", "east", "down"))})
    return out


def _other(
    bag: str,
    topic: str,
    read: Mapping[str, _Topic],
    rules: Mapping[str, TopicRule],
    origin: int,
    t: np.ndarray,
    what: str,
) -> np.ndarray:
    """A geodetic reference's depth (K,) [m] or orientation quaternions (K, 4) from another topic,
    at the reference's times ``t``: linearly (an orientation: its nearest message, as it is sampled
    faster than the fixes)."""
    entry = read[topic]
    kind = entry.kind
    rule = TopicRule(
        table=what, topic=topic, msgtype=kind, frame=rules["reference"].frame, time=rules["reference"].time
    )
    data = entry.rows
    ts = (entry.times_ns(rule) - origin) * 1e-9
    part = _parts(kind, data)
    if what == "depth":
        depth_rule = rules["depth"] if "depth" in rules and rules["depth"].topic == topic else rule
        return np.interp(t, ts, _depth(kind, part, depth_rule))
    if "quaternion" not in part:
        raise LogError(
            f"{show_path(bag)}: reference.orientation_topic: {show(topic)} ({kind}) has no orientation"
        )
    nearest = np.clip(np.searchsorted(ts, t), 0, ts.size - 1)
    earlier = np.clip(nearest - 1, 0, ts.size - 1)
    nearest = np.where(np.abs(ts[earlier] - t) < np.abs(ts[nearest] - t), earlier, nearest)
    return part["quaternion"][nearest]


BLOCK = 65_536
"""Rows converted at a time from quaternions, so a 200 Hz topic's (K, 3, 3) rotation matrices are
never all held at once (each row's numbers are the same whatever the block)."""


def _attitude(
    quaternion: np.ndarray, frame: str, velocity_b: np.ndarray | None = None, in_place: bool = False
) -> tuple[np.ndarray, np.ndarray | None]:
    """Roll, pitch, yaw (K, 3) of orientation quaternions (K, 4) in ``frame`` (``C_nb`` of
    tauvcore.logs.bags.frames, its ZYX angles) and, given body velocities (K, 3), the NED velocities
    ``C_nb v_b`` (K, 3); block by block (:data:`BLOCK`). ``in_place``: the angles written over the
    quaternions' first three columns and the velocities over the body velocities (each block's
    read before it is written)."""
    k = quaternion.shape[0]
    euler = quaternion[:, :3] if in_place else np.empty((k, 3))
    vel_n = None if velocity_b is None else velocity_b if in_place else np.empty((k, 3))
    for start in range(0, k, BLOCK):
        rows = slice(start, min(start + BLOCK, k))
        C_nb = C_nb_from_quaternion(quaternion[rows], frame)
        euler[rows] = euler_from_C_nb(C_nb)
        if vel_n is not None and velocity_b is not None:
            vel_n[rows] = np.einsum("kij,kj->ki", C_nb, body_vectors(velocity_b[rows], frame))
    return euler, vel_n
