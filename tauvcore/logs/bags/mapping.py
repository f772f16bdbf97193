"""The bag mapping: which topic feeds which table of the log, in which frames, on which clock.

A mapping is a TOML file (docs/bags.md has a worked example)::

    frame = "flu_enu"          # every topic's frame convention unless its table says otherwise
    time = "header"            # header stamps, or "receive": the bag's receive times
    base_frame = "base_link"   # the body's frame in /tf_static (the DVL's mounting: tauvcore.logs.bags.tf)
    msg_paths = ["msgs/my_msgs/msg/MyDvl.msg"]   # more .msg definitions (<package>/msg/<Type>.msg)

    [imu]
    topic = "/imu/data"
    offset_s = 0.0             # added to the topic's times [s] (its clock's offset)
    # form = "increments"      # the IMU as increments: topic = "/imu/dq" (its angle increments),
    # velocity_topic = "/imu/dv"   # and its velocity increments (:data:`IMU_FORMS`)

    [dvl]
    topic = "/dvl"
    frame = "frd_ned"
    mounting_rpy_deg = [0.0, 0.0, 0.0]   # the DVL's frame in the body, v_b = C_b_dvl v_dvl (ZYX);
                                         # without it, /tf_static's (tauvcore.logs.bags.tf)
    # water_track = true       # every velocity of the topic is water-track (false: bottom-track);
                               # without it, each message's velocity_mode where it has one
    # water_track_topic = "/dvl/water"   # a second DVL topic, all water-track, merged ping by ping
    # ping_tolerance_s = 0.005 # a water-track and a bottom-track message this close are one ping

    [usbl]                     # a plug-in source's table: only by name, of a type it declares
    topic = "/usbl/fix"

    [config.dvl]               # a partial tauv configuration, as a log's own log.toml
    lever_arm_m = [0.6, 0.0, 0.15]

Sections ``imu``, ``dvl``, ``depth``, ``attitude`` and ``reference`` name the log's tables
(tauvcore.logs); a plug-in source's table (``[usbl]``) may be named too, its topic of a type the
source declares (:attr:`tauvcore.aiding.source.AidingSource.bag_messages`, :data:`PLUGIN_MESSAGES`),
and is never found by type. A table the mapping does not name is found by message type as without a mapping
(:data:`DEFAULT_TYPES`: exactly one topic of those types, none: the log has no such table);
``topic = ""`` leaves a table out. Each table's keys are :data:`TABLE_KEYS`; every bad key or
value is one :class:`~tauvcore.validation.LogError` naming the file, the key and the value.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tauvcore.aiding.source import BagMessage
from tauvcore.aiding.sources import SOURCES
from tauvcore.config import read_toml
from tauvcore.logs.bags.frames import FRAMES
from tauvcore.validation import ConfigError, LogError, show, show_path

TIMES = ("header", "receive")
"""Where a topic's times come from: its messages' header stamps, or the bag's receive times."""
DVL_PER_BEAM = (
    "marine_acoustic_msgs/msg/Dvl",
    "ds_sensor_msgs/msg/Dvl",
    "cola2_msgs/msg/DVL",
    "uuv_sensor_ros_plugins_msgs/msg/DVL",
    "waterlinked_a50_ros_driver/msg/DVL",
)
"""The DVL messages with per-beam data (the definitions ship in tauvcore/logs/bags/msgs)."""
TWISTS = ("geometry_msgs/msg/TwistWithCovarianceStamped", "geometry_msgs/msg/TwistStamped")
"""Body velocity only: projected onto the configured beams, as a log's ``vel_x_mps`` columns are."""
POSES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "geometry_msgs/msg/PoseStamped",
)
INCREMENT_ANGLES = ("geometry_msgs/msg/QuaternionStamped", "geometry_msgs/msg/Vector3Stamped")
"""An IMU's angle increments over each sample: the rotation as a quaternion (the Xsens MTi driver's
``/imu/dq``) or as a rotation vector [rad]."""
INCREMENT_VELOCITIES = ("geometry_msgs/msg/Vector3Stamped",)
"""An IMU's velocity increments over each sample [m/s] (the Xsens MTi driver's ``/imu/dv``)."""
ACCEPTED: dict[str, tuple[str, ...]] = {
    "imu": ("sensor_msgs/msg/Imu", *INCREMENT_ANGLES),
    "dvl": DVL_PER_BEAM + TWISTS,
    "depth": ("sensor_msgs/msg/FluidPressure", "std_msgs/msg/Float64", "std_msgs/msg/Float32"),
    "attitude": ("geometry_msgs/msg/QuaternionStamped", "sensor_msgs/msg/Imu", *POSES),
    "reference": (*POSES, "sensor_msgs/msg/NavSatFix"),
}
"""The message types that can feed each table."""
DEFAULT_TYPES: dict[str, tuple[str, ...]] = {
    "imu": ("sensor_msgs/msg/Imu",),
    "dvl": DVL_PER_BEAM + TWISTS,
    "depth": ("sensor_msgs/msg/FluidPressure",),
    "attitude": ("geometry_msgs/msg/QuaternionStamped",),
    "reference": POSES,
}
"""The types a table is found by when the mapping does not name its topic (exactly one topic of
them, or none)."""
COMMON_KEYS = ("topic", "frame", "time", "offset_s")
BUILT_IN_KEYS: dict[str, tuple[str, ...]] = {
    "imu": COMMON_KEYS + ("form", "velocity_topic"),
    "dvl": COMMON_KEYS
    + (
        "mounting_rpy_deg",
        "form",
        "beam_ids",
        "beam_velocity_sign",
        "beam_tolerance_deg",
        "water_track",
        "water_track_topic",
        "ping_tolerance_s",
    ),
    "depth": COMMON_KEYS + ("water_density_kgpm3", "gravity_mps2", "atmospheric_pa"),
    "attitude": COMMON_KEYS,
    "reference": COMMON_KEYS + ("orientation_topic", "depth_topic"),
}
PLUGIN_MESSAGES: dict[str, dict[str, BagMessage]] = {
    source.table: {m.msgtype: m for m in source.bag_messages}
    for source in SOURCES.values()
    if source.bag_messages and source.table not in BUILT_IN_KEYS
}
"""A plug-in source's table -> the message types it may be read from -> what each field fills
(each source's own :attr:`~tauvcore.aiding.source.AidingSource.bag_messages`)."""
PLUGIN_COLUMNS: dict[str, tuple[str, ...]] = {
    source.table: tuple(c.name for c in source.columns)
    for source in SOURCES.values()
    if source.table in PLUGIN_MESSAGES
}
"""A plug-in source's table -> its columns besides ``t_s`` (those no message field fills are NaN)."""
ACCEPTED.update({table: tuple(messages) for table, messages in PLUGIN_MESSAGES.items()})
TABLE_KEYS: dict[str, tuple[str, ...]] = {
    **BUILT_IN_KEYS,
    **dict.fromkeys(PLUGIN_MESSAGES, COMMON_KEYS),
}
"""Each table's keys (docs/bags.md): ``topic``, ``frame`` (:data:`~tauvcore.logs.bags.frames.FRAMES`),
``time`` (:data:`TIMES`), ``offset_s`` [s]; the DVL's mounting, form, beams and mode; the depth's water
and air; a geodetic reference's orientation and depth topics; a plug-in source's table
(:data:`PLUGIN_MESSAGES`) the common keys."""
BASE_FRAME = "base_link"
"""The body's frame in the bag's ``/tf_static`` unless the mapping's ``base_frame`` says otherwise."""
TOP_KEYS = ("frame", "time", "base_frame", "msg_paths", "config", *TABLE_KEYS)
EXTRA_TOPICS = ("orientation_topic", "depth_topic", "velocity_topic", "water_track_topic")
"""A table's keys that name a topic besides its ``topic``: a geodetic reference's orientation and
depth, an IMU's velocity increments, a DVL's water-track velocities (tauvcore.logs.bags.dvl_table)."""
IMU_FORMS = ("rates", "increments")
"""``rates``: a ``sensor_msgs/Imu`` topic (angular velocity, linear acceleration); ``increments``:
angle increments on ``topic`` (:data:`INCREMENT_ANGLES`) and velocity increments on
``velocity_topic`` (:data:`INCREMENT_VELOCITIES`), a message of each per sample, on the same
stamps (tauvcore.logs.bags.increments)."""
DVL_FORMS = ("auto", "beams", "body")
"""``auto``: per-beam velocities where the message has them (and its beams are the configured
ones), else the body velocity; ``beams``: per-beam or refuse; ``body``: the body velocity."""
WATER_DENSITY_KGPM3 = 1025.0
"""Sea water's density [kg/m^3] (surface water at 35 PSU, 15 C) for depth from pressure."""
GRAVITY_MPS2 = 9.80665
"""Gravity [m/s^2] for depth from pressure (standard gravity)."""
ATMOSPHERIC_PA = 101_325.0
"""The air's pressure at the surface [Pa] (the standard atmosphere), subtracted from an absolute
pressure before it becomes depth: ``depth = (p - p_atm) / (rho g)``."""
DVL_BEAM_TOLERANCE_DEG = 3.0
"""Largest angle [deg] between a message's beam direction and the configured beam it is taken for."""
DVL_PING_TOLERANCE_S = 0.005
"""Largest difference [s] between the times of a water-track and a bottom-track DVL message taken
for one ping (tauvcore.logs.bags.dvl_table): a driver stamps both outputs of a ping alike (up to its
rounding), and 5 ms is below the shortest interval between pings (40 ms at 25 Hz) and half an IMU
sample at 100 Hz."""
_RANGES: dict[str, tuple[float, float]] = {
    "offset_s": (-1e6, 1e6),
    "water_density_kgpm3": (950.0, 1100.0),
    "gravity_mps2": (9.7, 9.9),
    "atmospheric_pa": (0.0, 2e5),
    "beam_tolerance_deg": (0.1, 30.0),
    "ping_tolerance_s": (0.0, 1.0),
}


@dataclass(frozen=True)
class TopicRule:
    """Which topic feeds one table, and how its messages are read."""

    table: str  # the log's table: imu, dvl, depth, attitude, reference
    topic: str  # the bag's topic
    msgtype: str = ""  # its message type (sensor_msgs/msg/Imu)
    frame: str = "flu_enu"  # frame convention (tauvcore.logs.bags.frames)
    time: str = "header"  # "header" stamps or "receive" times
    offset_s: float = 0.0  # [s] added to the topic's times
    options: Mapping[str, Any] = field(default_factory=dict)  # the table's own keys (TABLE_KEYS)

    def option(self, key: str, default: Any) -> Any:
        """The table's own key ``key``, or ``default`` where the mapping does not set it."""
        return self.options.get(key, default)


@dataclass(frozen=True)
class BagMapping:
    """A bag mapping as read (module docstring); the tables it names, the defaults for others."""

    path: str | None = None  # the mapping file; None: no mapping (every table by type)
    frame: str = "flu_enu"
    time: str = "header"
    base_frame: str = BASE_FRAME  # the body's frame id in /tf_static (tauvcore.logs.bags.tf)
    tables: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)  # table -> its keys
    msg_paths: tuple[Path, ...] = ()  # extra .msg definitions
    config: Mapping[str, Any] = field(default_factory=dict)  # a partial tauv configuration
    tf_static: bool = True  # the DVL's mounting may come from /tf_static (False: --no-log-config)


def _where(path: str, key: str) -> str:
    return f"the bag mapping {show_path(path)}: {key}"


def read_mapping(path: str | os.PathLike | None, label: str = "the bag mapping") -> BagMapping:
    """The mapping file at ``path`` read and checked key by key (None: the empty mapping).

    Parameters
    ----------
    path : str or os.PathLike or None
        A TOML file (module docstring).
    label : str
        What a message calls the file when it cannot be read (the flag that named it).

    Returns
    -------
    BagMapping
        Its defaults, the tables it names with their keys checked, the extra ``.msg`` paths
        (relative to the file's directory) and its ``[config]`` table, raw.

    Raises
    ------
    LogError
        For a file that cannot be read or is not TOML, an unknown key, a value of the wrong kind
        or out of range, naming the file, the key and the value.
    """
    if path is None:
        return BagMapping()
    name = os.fspath(path)
    try:
        raw = read_toml(name, label=label)  # a small regular UTF-8 file, never a FIFO
    except ConfigError as exc:
        raise LogError(str(exc)) from None
    for key in raw:
        if key not in TOP_KEYS:
            raise LogError(f"{_where(name, show(key))}: unknown key (keys: {', '.join(TOP_KEYS)})")
    frame = _choice(name, "frame", raw.get("frame", "flu_enu"), FRAMES)
    time = _choice(name, "time", raw.get("time", "header"), TIMES)
    base_frame = raw.get("base_frame", BASE_FRAME)
    if not isinstance(base_frame, str) or not base_frame:
        raise LogError(f"{_where(name, 'base_frame')}: a frame id (text) is needed, got {show(base_frame)}")
    paths = raw.get("msg_paths", [])
    if not isinstance(paths, list) or not all(isinstance(p, str) for p in paths):
        raise LogError(f"{_where(name, 'msg_paths')}: a list of .msg file paths is needed, got {show(paths)}")
    base = Path(name).parent
    msg_paths = tuple(base / p for p in paths)
    config = raw.get("config", {})
    if not isinstance(config, dict):
        raise LogError(
            f"{_where(name, 'config')}: a table (a partial configuration) is needed, got {show(config)}"
        )
    tables = {}
    for table, keys in TABLE_KEYS.items():
        if table not in raw:
            continue
        section = raw[table]
        if not isinstance(section, dict):
            raise LogError(f"{_where(name, table)}: a table ([{table}]) is needed, got {show(section)}")
        for key in section:
            if key not in keys:
                raise LogError(
                    f"{_where(name, f'{table}.{show(key)}')}: unknown key (keys: {', '.join(keys)})"
                )
        tables[table] = {key: _value(name, f"{table}.{key}", key, value) for key, value in section.items()}
    return BagMapping(name, frame, time, base_frame, tables, msg_paths, config)


def _choice(path: str, key: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise LogError(f"{_where(path, key)}: {show(value)} is not one of {', '.join(choices)}")
    return value


def _number(path: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise LogError(f"{_where(path, key)}: a finite number is needed, got {show(value)}")
    return float(value)


def _value(path: str, key: str, name: str, value: Any) -> Any:
    """One table key's value, checked (:data:`TABLE_KEYS`)."""
    if name == "topic" or name in EXTRA_TOPICS:
        if not isinstance(value, str):
            raise LogError(f"{_where(path, key)}: a topic name (text) is needed, got {show(value)}")
        if value == "" and (name in EXTRA_TOPICS or key == "imu.topic"):
            needed = "a replay needs an IMU" if key == "imu.topic" else "leave the key out for none"
            raise LogError(f"{_where(path, key)}: a topic name is needed, got '' ({needed})")
        return value
    if name == "frame":
        return _choice(path, key, value, FRAMES)
    if name == "time":
        return _choice(path, key, value, TIMES)
    if name == "form":
        return _choice(path, key, value, IMU_FORMS if key.startswith("imu.") else DVL_FORMS)
    if name == "mounting_rpy_deg":
        if not isinstance(value, list) or len(value) != 3:
            raise LogError(f"{_where(path, key)}: three angles [deg] are needed, got {show(value)}")
        angles = tuple(_number(path, key, v) for v in value)
        if any(abs(a) > 360.0 for a in angles):
            raise LogError(f"{_where(path, key)}: {show(value)} is beyond +-360 deg")
        return angles
    if name == "beam_ids":
        if (
            not isinstance(value, list)
            or len(value) != 4
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in value)
            or len(set(value)) != 4
        ):
            raise LogError(
                f"{_where(path, key)}: four distinct beam ids (the message's, for the configured beams "
                f"1 to 4) are needed, got {show(value)}"
            )
        return tuple(value)
    if name == "water_track":
        if not isinstance(value, bool):
            raise LogError(
                f"{_where(path, key)}: true (the topic's velocities are water-track) or false "
                f"(bottom-track) is needed, got {show(value)}"
            )
        return value
    if name == "beam_velocity_sign":
        if value not in (1, -1) or isinstance(value, bool):
            raise LogError(f"{_where(path, key)}: 1 or -1 is needed, got {show(value)}")
        return float(value)
    number = _number(path, key, value)
    low, high = _RANGES[name]
    if not low <= number <= high:
        raise LogError(f"{_where(path, key)}: {show(value)} is outside [{low:g}, {high:g}]")
    return number


def resolve(mapping: BagMapping, topics: Mapping[str, str], bag: str) -> dict[str, TopicRule]:
    """The topic rule of each table the bag feeds: the mapping's, else found by type (among the
    topics the mapping does not name for a table; a plug-in source's table never by type).

    Parameters
    ----------
    mapping : BagMapping
        The mapping as read.
    topics : Mapping of str to str
        The bag's topics -> their message types (``sensor_msgs/msg/Imu``).
    bag : str
        The bag's path, for the messages.

    Returns
    -------
    dict of str to TopicRule
        Table -> its rule, for each table that has a topic.

    Raises
    ------
    LogError
        A topic the bag does not have, a type that cannot feed the table, or two topics of a
        table's default types with no mapping to choose: naming the topics.
    """
    rules = {}
    where = f"the bag mapping {show_path(mapping.path)}" if mapping.path else "no bag mapping"
    named = {  # never found by type
        keys[k] for keys in mapping.tables.values() for k in ("topic", "water_track_topic") if keys.get(k)
    }
    for table in TABLE_KEYS:
        keys = mapping.tables.get(table, {})
        topic = keys.get("topic")
        if topic is None and table == "imu" and keys.get("form") == "increments":
            raise LogError(
                f"{where}: imu.topic: form = 'increments' needs the angle increments' topic "
                f"(a {', '.join(INCREMENT_ANGLES)} topic of {show_path(bag)})"
            )
        if topic is None:
            default = DEFAULT_TYPES.get(table, ())  # a plug-in's table: only by name
            found = sorted(t for t, kind in topics.items() if kind in default and t not in named)
            if not found and table == "dvl" and keys.get("water_track_topic") in topics:
                water = keys["water_track_topic"]
                if topics[water] in default:
                    raise LogError(
                        f"{where}: dvl.water_track_topic: {show(water)} is the DVL's own topic ([dvl] names no "
                        f"topic, and {show_path(bag)} has no other DVL topic): a topic of both modes needs no "
                        "second topic (each message's velocity_mode says which it is; water_track = true: all "
                        "water-track)"
                    )
            if len(found) > 1:
                raise LogError(
                    f"{show_path(bag)}: topics {', '.join(show(t) for t in found)} could each feed the "
                    f"{table} table ({where} names one): name it in a mapping, [{table}] topic = "
                    f"{show(found[0])} (--bag-mapping FILE; docs/bags.md)"
                )
            if not found:
                continue
            topic = found[0]
        elif topic == "":
            continue
        elif topic not in topics:
            raise LogError(
                f"{where}: {table}.topic: {show(topic)} is not a topic of {show_path(bag)} "
                f"(its topics: {', '.join(show(t) for t in sorted(topics)) or 'none'})"
            )
        kind = topics[topic]
        accepted = _accepted(table, keys)
        if kind not in accepted:
            raise LogError(
                f"{where}: {table}.topic: {show(topic)} of {show_path(bag)} holds {kind}, which cannot feed "
                f"the {table} table{_form(table, keys)} (it takes {', '.join(accepted)})"
            )
        for extra in EXTRA_TOPICS:
            other = keys.get(extra)
            if other is not None and other not in topics:
                raise LogError(f"{where}: {table}.{extra}: {show(other)} is not a topic of {show_path(bag)}")
        if table == "imu":
            _check_increments(where, topic, keys, topics, bag)
        if table == "dvl":
            _check_water_topic(where, topic, keys, topics, bag)
            _check_dvl_form(where, topic, keys, topics, bag)
        options = {k: v for k, v in keys.items() if k not in COMMON_KEYS}
        rules[table] = TopicRule(
            table=table,
            topic=topic,
            msgtype=kind,
            frame=keys.get("frame", mapping.frame),
            time=keys.get("time", mapping.time),
            offset_s=keys.get("offset_s", 0.0),
            options=options,
        )
    return rules


def _accepted(table: str, keys: Mapping[str, Any]) -> tuple[str, ...]:
    """The types the table's ``topic`` may hold under its keys (an IMU's by its ``form``)."""
    if table == "imu":
        return INCREMENT_ANGLES if keys.get("form") == "increments" else ("sensor_msgs/msg/Imu",)
    return ACCEPTED[table]


def _form(table: str, keys: Mapping[str, Any]) -> str:
    return f" as {keys['form']}" if table == "imu" and "form" in keys else ""


def _check_water_topic(
    where: str, topic: str, keys: Mapping[str, Any], topics: Mapping[str, str], bag: str
) -> None:
    """A DVL's ``water_track_topic`` is another topic of a DVL type."""
    water = keys.get("water_track_topic")
    if water is None:
        return
    if water == topic:
        raise LogError(
            f"{where}: dvl.water_track_topic: {show(water)} is the DVL's topic itself (a topic of both "
            "modes needs no second topic: each message's velocity_mode says which it is)"
        )
    if topics[water] not in ACCEPTED["dvl"]:
        raise LogError(
            f"{where}: dvl.water_track_topic: {show(water)} of {show_path(bag)} holds {topics[water]}, which "
            f"cannot feed the dvl table (it takes {', '.join(ACCEPTED['dvl'])})"
        )


def _check_dvl_form(
    where: str, topic: str, keys: Mapping[str, Any], topics: Mapping[str, str], bag: str
) -> None:
    """``form = 'beams'`` only on topics of per-beam messages (the DVL's and its water-track topic)."""
    if keys.get("form") != "beams":
        return
    for key, name in (("topic", topic), ("water_track_topic", keys.get("water_track_topic"))):
        if name is not None and topics[name] in TWISTS:
            raise LogError(
                f"{where}: dvl.form: 'beams' needs per-beam velocities, and {show(name)} (dvl.{key}) of "
                f"{show_path(bag)} holds {topics[name]}, a body velocity only (form = 'body' or 'auto' reads it)"
            )


def _check_increments(
    where: str, topic: str, keys: Mapping[str, Any], topics: Mapping[str, str], bag: str
) -> None:
    """An IMU as increments names both its topics, two of them; an IMU as rates has no ``velocity_topic``."""
    velocity = keys.get("velocity_topic")
    if velocity is not None and velocity == topic:
        raise LogError(
            f"{where}: imu.velocity_topic: {show(velocity)} is imu.topic itself (the angle increments' topic; "
            "the velocity increments come on a topic of their own)"
        )
    if keys.get("form") != "increments":
        if velocity is not None:
            raise LogError(
                f"{where}: imu.velocity_topic: {show(velocity)} is for form = 'increments' "
                f"(form is {show(keys.get('form', 'rates'))})"
            )
        return
    if velocity is None:
        raise LogError(
            f"{where}: imu.velocity_topic: form = 'increments' needs the velocity increments' topic "
            f"(a {', '.join(INCREMENT_VELOCITIES)} topic of {show_path(bag)})"
        )
    if topics[velocity] not in INCREMENT_VELOCITIES:
        raise LogError(
            f"{where}: imu.velocity_topic: {show(velocity)} of {show_path(bag)} holds {topics[velocity]}, "
            f"not velocity increments (it takes {', '.join(INCREMENT_VELOCITIES)})"
        )
