"""ROS bags as logs: a ROS 1 ``.bag``, a ROS 2 bag (a directory with ``metadata.yaml``, sqlite3 or
MCAP storage) or an ``.mcap`` file, read with rosbags (no ROS installation) into the tables of the
log format (tauvcore.logs), then assembled and checked exactly as a log's files are
(:func:`tauvcore.logs.log_from_tables`: gaps, irregular clocks, units by gravity, the physical
checks).

What feeds what is the bag mapping (tauvcore.logs.bags.mapping; docs/bags.md): for each table a topic,
its frame convention, its clock and offset. Without one, each table is found by message type:

============  ==========================================================================  ============================
table         message types                                                               columns
============  ==========================================================================  ============================
``imu``       ``sensor_msgs/Imu`` (angular_velocity, linear_acceleration); by mapping     ``gyro_*_rps``, ``accel_*_mps2``
              increments: ``QuaternionStamped`` and ``Vector3Stamped`` (bags.increments)    or ``dtheta_*_rad``, ``dv_*_mps``
``dvl``       ``marine_acoustic_msgs/Dvl``, ``ds_sensor_msgs/Dvl``, ``cola2_msgs/DVL``,      ``beam1_mps`` .. ``beam4_mps``
              ``uuv_sensor_ros_plugins_msgs/DVL``, ``waterlinked_a50_ros_driver/DVL``;      or ``vel_*_mps``, ``valid``
              ``geometry_msgs/TwistWithCovarianceStamped``, ``TwistStamped`` (body only)
``depth``     ``sensor_msgs/FluidPressure``; by mapping ``std_msgs/Float64``, ``Float32``  ``depth_m``
``attitude``  ``geometry_msgs/QuaternionStamped``; by mapping ``sensor_msgs/Imu``, poses    ``roll_rad`` .. ``yaw_rad``
``reference`` ``nav_msgs/Odometry``, ``geometry_msgs/PoseWithCovarianceStamped``,           ``north_m`` .. or ``lat_rad`` ..,
              ``PoseStamped``; by mapping ``sensor_msgs/NavSatFix``                         attitude, NED velocity
============  ==========================================================================  ============================

A plug-in source's table (``usbl``) is read only from the topic the mapping names, of a type the
source declares (:attr:`tauvcore.aiding.source.AidingSource.bag_messages`).

Frames (tauvcore.logs.bags.frames): ``flu_enu`` (the default, ROS REP-103: body forward-left-up, world
east-north-up) is converted to tauvcore's FRD/NED, ``v_b = diag(1, -1, -1) v_flu``,
``v_n = (v_enu_y, v_enu_x, -v_enu_z)``, ``C_nb = T R(q) D``; ``frd_ned`` is taken as it is. A
per-beam DVL message gives beam velocities when its beam directions, in the body after the frame
conversion and the mounting rotation, are the configured Janus beams (each to the nearest within
:data:`~tauvcore.logs.bags.mapping.DVL_BEAM_TOLERANCE_DEG`), else its body velocity, which the replay
projects onto the configured beams. Depth from pressure: ``(p - p_atm) / (rho g)``
(:data:`~tauvcore.logs.bags.mapping.WATER_DENSITY_KGPM3`, ...). Time (tauvcore.logs.bags.ros_reader): header
stamps, or receive times, less the IMU topic's first, plus each topic's ``offset_s``. The DVL's
mounting is the mapping's ``mounting_rpy_deg``, else the bag's ``/tf_static`` transform from
``base_frame`` to the DVL's frame, directly or through a chain of frames (tauvcore.logs.bags.tf), whose translation is also its lever arm
(:func:`bag_config`).

The definitions of the DVL messages ship in ``tauvcore/logs/bags/msgs`` (``<package>/msg/<Type>.msg``)
and are registered with rosbags.typesys where a bag carries none; the mapping's ``msg_paths`` adds
more.

A bag's own mapping (:func:`own_mapping`) is the TOML file beside it with its stem:
``mission.bag`` and ``mission.mcap`` -> ``mission.toml``, a ROS 2 bag directory ``run_01`` ->
``run_01.toml`` beside the directory; without one, every table is found by type. The dashboard
(``tauv serve --logs DIR``) lists the bags of ``DIR`` beside its logs (:func:`find_recordings`) and
replays each under its own mapping, as ``tauv replay PATH --bag-mapping`` that file does.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np

from tauvcore.config import from_dict
from tauvcore.logs.bags.mapping import BagMapping, TopicRule, read_mapping, resolve
from tauvcore.logs.bags.ros_reader import BagTables, bag_tables, is_bag, open_bag, read_mounting, typestore
from tauvcore.logs.bags.tf import TF_STATIC
from tauvcore.logs.log_record import Log
from tauvcore.logs.reader import find_logs, log_from_tables, read_log
from tauvcore.validation import ConfigError, LogError, show_path


def read_bag(path: str | os.PathLike, mapping: BagMapping, beam_directions_b: np.ndarray) -> Log:
    """Read the bag at ``path`` under ``mapping`` into a checked log, as tauvcore.logs.read_log reads
    a log's directory.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 bag, a ROS 2 bag directory or an MCAP file.
    mapping : BagMapping
        The bag mapping (:func:`~tauvcore.logs.bags.mapping.read_mapping`; ``BagMapping()``: none).
    beam_directions_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (``config.dvl.A_b``).

    Returns
    -------
    Log
        The validated log; a table's ``row N`` in a message is its topic's N-th message.

    Raises
    ------
    LogError
        For any bad input, naming the bag, the topic, the mapping's key, the message and the value.
    """
    return _read(path, mapping, beam_directions_b)[0]


def _read(
    path: str | os.PathLike, mapping: BagMapping, beam_directions_b: np.ndarray
) -> tuple[Log, BagTables]:
    """The bag's checked log (:func:`read_bag`) and its tables as read (their mounting)."""
    read = bag_tables(path, mapping, beam_directions_b)
    log = log_from_tables(read.tables, read.source, read.names, release=True)  # each freed once read
    return dataclasses.replace(log, notes=read.notes + log.notes), read


def read_bag_configured(
    path: str | os.PathLike,
    mapping: BagMapping,
    beam_directions_b: np.ndarray,
    raw: dict[str, Any],
    source: str | None,
) -> tuple[Log, dict[str, Any], str | None]:
    """:func:`read_bag` and, from the same read, the bag's configuration with the DVL's lever arm
    from ``/tf_static`` (:func:`with_tf_lever_arm`): the bag opened once.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 bag, a ROS 2 bag directory or an MCAP file.
    mapping : BagMapping
        The bag mapping (``tf_static`` False: no mounting from ``/tf_static``, so no lever arm).
    beam_directions_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (``config.dvl.A_b``; the
        lever arm does not change them).
    raw : dict
        The mapping's ``[config]`` as ``bag_config(mapping)`` gives it (without the bag).
    source : str or None
        Where ``raw`` comes from.

    Returns
    -------
    tuple of Log, dict and str or None
        The validated log; the configuration and its source, as ``bag_config(mapping, path)``
        gives them.

    Raises
    ------
    LogError
        As :func:`read_bag` and :func:`bag_config`.
    """
    log, read = _read(path, mapping, beam_directions_b)
    lever = None if read.mounting is None else read.mounting.r_b_m
    raw, source = with_tf_lever_arm(mapping, raw, source, path, lever)
    return log, raw, source


def bag_config(
    mapping: BagMapping, path: str | os.PathLike | None = None
) -> tuple[dict[str, Any], str | None]:
    """The mapping's ``[config]`` (a partial configuration, laid under ``--config`` as a log's own
    ``log.toml`` is), checked on its own, and where it comes from; given the bag, the DVL's lever
    arm from its ``/tf_static`` (tauvcore.logs.bags.tf) where ``[config.dvl]`` sets none.

    This opens the bag once for ``/tf_static``; a caller that reads the bag anyway takes the lever
    arm from that read instead (:func:`with_tf_lever_arm` of :attr:`BagTables.mounting`).

    Parameters
    ----------
    mapping : BagMapping
        The bag mapping.
    path : str or os.PathLike or None
        The bag, whose ``/tf_static`` may give ``dvl.lever_arm_m`` [m] (body FRD); None: not read.

    Returns
    -------
    tuple of dict and str or None
        The raw tables (section -> key -> value) and where they come from (the mapping's path,
        else ``'<bag>:/tf_static'``); ``({}, None)`` when there is nothing.

    Raises
    ------
    LogError
        Naming the mapping, for a configuration that does not check; a bag that cannot be read.
    """
    raw = (
        {k: dict(v) if isinstance(v, dict) else v for k, v in mapping.config.items()} if mapping.path else {}
    )
    source = mapping.path if raw else None
    dvl = raw.get("dvl", {})
    if path is not None and isinstance(dvl, dict) and "lever_arm_m" not in dvl:
        return with_tf_lever_arm(mapping, raw, source, path, _tf_lever_arm(os.fspath(path), mapping))
    return _checked(mapping, raw, source)


def with_tf_lever_arm(
    mapping: BagMapping,
    raw: dict[str, Any],
    source: str | None,
    path: str | os.PathLike,
    lever_arm_b_m: Any,
) -> tuple[dict[str, Any], str | None]:
    """The bag's configuration ``raw`` (:func:`bag_config` without the bag) with the DVL's lever
    arm from ``/tf_static`` laid in where ``[config.dvl]`` sets none, checked.

    Parameters
    ----------
    mapping : BagMapping
        The bag mapping, for the messages.
    raw : dict
        The mapping's ``[config]`` as :func:`bag_config` gives it (section -> key -> value).
    source : str or None
        Where ``raw`` comes from (the mapping's path), or None.
    path : str or os.PathLike
        The bag.
    lever_arm_b_m : array_like or None
        The DVL's origin in the body (FRD) [m] (3,) from ``/tf_static``
        (:attr:`~tauvcore.logs.bags.tf.Mounting.r_b_m`); None: the bag gives none.

    Returns
    -------
    tuple of dict and str or None
        As :func:`bag_config` gives them given the bag.

    Raises
    ------
    LogError
        Naming the mapping or the bag, for a configuration that does not check.
    """
    dvl = raw.get("dvl", {})
    if lever_arm_b_m is not None and isinstance(dvl, dict) and "lever_arm_m" not in dvl:
        raw = {**raw, "dvl": {**dvl, "lever_arm_m": [float(v) for v in lever_arm_b_m]}}
        source = source or f"{os.fspath(path)}:{TF_STATIC}"
    return _checked(mapping, raw, source)


def _checked(
    mapping: BagMapping, raw: dict[str, Any], source: str | None
) -> tuple[dict[str, Any], str | None]:
    if not raw:
        return {}, None
    try:
        from_dict(raw)
    except ConfigError as exc:
        where = f"the bag mapping {show_path(mapping.path)}" if mapping.path else show_path(source or "")
        raise LogError(f"{where}: [config]: {exc}") from None
    return raw, source


def _tf_lever_arm(bag: str, mapping: BagMapping) -> list[float] | None:
    """The DVL's origin in the body (FRD) [m] from the bag's ``/tf_static``, or None."""
    reader = open_bag(bag, typestore(mapping.msg_paths, mapping.path))
    try:
        topics = {c.topic: c.msgtype for c in reader.connections}
        if TF_STATIC not in topics:
            return None
        rules = resolve(mapping, topics, bag)
        if "dvl" not in rules:
            return None
        found = read_mounting(reader, bag, mapping, rules)
    finally:
        reader.close()
    return None if found.r_b_m is None else [float(v) for v in found.r_b_m]


MAPPING_SUFFIX = ".toml"
"""A bag's own mapping is the file beside it named as the bag with this suffix (:func:`mapping_beside`)."""


def mapping_beside(path: str | os.PathLike) -> str | None:
    """Where the bag at ``path`` keeps its own mapping, if it has one.

    The file beside it with its stem and ``.toml``: ``mission.bag`` or ``mission.mcap`` ->
    ``mission.toml``; a ROS 2 bag directory ``run_01`` -> ``run_01.toml`` beside that directory.
    Any entry of that name counts (a directory, a dangling link), so that reading it names it.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS bag (:func:`~tauvcore.logs.bags.ros_reader.is_bag`).

    Returns
    -------
    str or None
        The mapping file's path, or None when there is none (topics found by type).
    """
    bag = Path(os.path.normpath(os.fspath(path)))
    stem = bag.name if bag.is_dir() else bag.stem
    candidate = bag.parent / f"{stem}{MAPPING_SUFFIX}"
    return str(candidate) if os.path.lexists(candidate) else None


def own_mapping(path: str | os.PathLike) -> BagMapping:
    """The bag's own mapping (:func:`mapping_beside`) read and checked; ``BagMapping()`` (by type)
    without one.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS bag.

    Returns
    -------
    BagMapping
        As :func:`~tauvcore.logs.bags.mapping.read_mapping` reads it.

    Raises
    ------
    LogError
        Naming the mapping file, its key and the value, as ``--bag-mapping`` does.
    """
    return read_mapping(mapping_beside(path), label="the bag's mapping")


def bag_kind(path: str | os.PathLike) -> str:
    """What kind of bag ``path`` is, for a person: ``"ROS 1"``, ``"ROS 2, mcap"``, ``"ROS 2, sqlite3"``.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS bag: a ``.bag``, ``.mcap`` or ``.db3`` file, or a ROS 2 bag directory (its storage
        told by the files it holds; ``"ROS 2"`` when they do not tell).

    Returns
    -------
    str
        The bag's format and, for ROS 2, its storage.
    """
    p = Path(path)
    kinds = {".bag": "ROS 1", ".mcap": "ROS 2, mcap", ".db3": "ROS 2, sqlite3"}
    try:
        if p.is_dir():
            storages = sorted(
                {kinds[f.suffix.lower()] for f in p.iterdir() if f.suffix.lower() in (".mcap", ".db3")}
            )
            return storages[0] if len(storages) == 1 else "ROS 2"
    except OSError:
        return "ROS 2"
    return kinds.get(p.suffix.lower(), "ROS bag")


def _entries(directory: Path) -> list[Path]:
    """``directory``'s entries by name, but those whose name starts with a dot (a writer's temporary)."""
    return sorted(e for e in directory.iterdir() if not e.name.startswith("."))


def find_bags(directory: str | os.PathLike) -> dict[str, str]:
    """The ROS bags in ``directory`` by name.

    ``directory`` itself if it is a ROS 2 bag; else each bag among its entries (``.bag``, ``.mcap``
    and ``.db3`` files, ROS 2 bag directories) and among its subdirectories' entries, in name
    order (a bag directory's own files are not listed again). A name is the bag's path below
    ``directory`` and its kind (:func:`bag_kind`): ``"mission.bag (ROS 1)"``, ``"day2/run_01 (ROS 2,
    mcap)"``. A subdirectory that cannot be searched, or whose name starts with a dot, is left out.

    Parameters
    ----------
    directory : str or os.PathLike
        The directory to search.

    Returns
    -------
    dict of str to str
        Each bag's name -> its path.

    Raises
    ------
    OSError
        If ``directory`` itself cannot be listed.
    """
    root = Path(directory)
    if is_bag(root):
        return {f"{root.name or root} ({bag_kind(root)})": str(root)}
    found = {}
    for entry in _entries(root):
        try:
            if is_bag(entry):
                found[f"{entry.name} ({bag_kind(entry)})"] = str(entry)
            elif entry.is_dir():
                for inner in _entries(entry):
                    if is_bag(inner):
                        found[f"{entry.name}/{inner.name} ({bag_kind(inner)})"] = str(inner)
        except OSError:  # a subdirectory that cannot be searched holds no bag to offer
            continue
    return found


def find_recordings(directory: str | os.PathLike) -> dict[str, str]:
    """The logs (:func:`tauvcore.logs.find_logs`) and the ROS bags (:func:`find_bags`) in
    ``directory`` by name, ``directory`` itself first, then by path.

    Parameters
    ----------
    directory : str or os.PathLike
        The directory to search (``tauv serve --logs DIR``).

    Returns
    -------
    dict of str to str
        Each recording's name -> its path (a log's directory or a bag).

    Raises
    ------
    OSError
        If ``directory`` itself cannot be listed.
    """
    root = str(Path(directory))
    found = {**find_logs(directory), **find_bags(directory)}
    return dict(sorted(found.items(), key=lambda item: (item[1] != root, item[1])))


def read_recording(path: str | os.PathLike, beam_directions_b: np.ndarray) -> Log:
    """The recording at ``path`` read and checked: a log's directory as
    :func:`tauvcore.logs.read_log` reads it, a ROS bag as :func:`read_bag` under its own mapping
    (:func:`own_mapping`).

    Parameters
    ----------
    path : str or os.PathLike
        A log's directory or a ROS bag.
    beam_directions_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (``config.dvl.A_b``).

    Returns
    -------
    Log
        The validated log.

    Raises
    ------
    LogError
        For any bad input (the bag's mapping included), naming the file, topic, key and value.
    """
    if is_bag(path):
        return read_bag(path, own_mapping(path), beam_directions_b)
    return read_log(path)


__all__ = [
    "MAPPING_SUFFIX",
    "BagMapping",
    "BagTables",
    "TopicRule",
    "bag_config",
    "bag_kind",
    "bag_tables",
    "find_bags",
    "find_recordings",
    "is_bag",
    "mapping_beside",
    "open_bag",
    "own_mapping",
    "read_bag",
    "read_bag_configured",
    "read_mapping",
    "read_recording",
    "typestore",
    "with_tf_lever_arm",
]
