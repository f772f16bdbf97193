"""ROS bags as logs: a ROS 1 ``.bag``, a ROS 2 bag (a directory with ``metadata.yaml``, sqlite3 or
MCAP storage) or an ``.mcap`` file, read with rosbags (no ROS installation) into the tables of the
log format (tauvcore.logs), then assembled and checked exactly as a log's files are
(:func:`tauvcore.logs.log_from_tables`: gaps, irregular clocks, units by gravity, the physical
checks).

What feeds what is the bag mapping (tauvcore.bags.mapping; docs/bags.md): for each table a topic,
its frame convention, its clock and offset. Without one, each table is found by message type:

============  ==========================================================================  ============================
table         message types                                                               columns
============  ==========================================================================  ============================
``imu``       ``sensor_msgs/Imu`` (angular_velocity, linear_acceleration)                  ``gyro_*_rps``, ``accel_*_mps2``
``dvl``       ``marine_acoustic_msgs/Dvl``, ``ds_sensor_msgs/Dvl``, ``cola2_msgs/DVL``,      ``beam1_mps`` .. ``beam4_mps``
              ``uuv_sensor_ros_plugins_msgs/DVL``, ``waterlinked_a50_ros_driver/DVL``;      or ``vel_*_mps``, ``valid``
              ``geometry_msgs/TwistWithCovarianceStamped``, ``TwistStamped`` (body only)
``depth``     ``sensor_msgs/FluidPressure``; by mapping ``std_msgs/Float64``, ``Float32``  ``depth_m``
``attitude``  ``geometry_msgs/QuaternionStamped``; by mapping ``sensor_msgs/Imu``, poses    ``roll_rad`` .. ``yaw_rad``
``reference`` ``nav_msgs/Odometry``, ``geometry_msgs/PoseWithCovarianceStamped``,           ``north_m`` .. or ``lat_rad`` ..,
              ``PoseStamped``; by mapping ``sensor_msgs/NavSatFix``                         attitude, NED velocity
============  ==========================================================================  ============================

Frames (tauvcore.bags.frames): ``flu_enu`` (the default, ROS REP-103: body forward-left-up, world
east-north-up) is converted to tauvcore's FRD/NED, ``v_b = diag(1, -1, -1) v_flu``,
``v_n = (v_enu_y, v_enu_x, -v_enu_z)``, ``C_nb = T R(q) D``; ``frd_ned`` is taken as it is. A
per-beam DVL message gives beam velocities when its beam directions, in the body after the frame
conversion and the mounting rotation, are the configured Janus beams (each to the nearest within
:data:`~tauvcore.bags.mapping.DVL_BEAM_TOLERANCE_DEG`), else its body velocity, which the replay
projects onto the configured beams. Depth from pressure: ``(p - p_atm) / (rho g)``
(:data:`~tauvcore.bags.mapping.WATER_DENSITY_KGPM3`, ...). Time (tauvcore.bags.reader): header
stamps, or receive times, less the IMU topic's first, plus each topic's ``offset_s``.

The definitions of the DVL messages ship in ``tauvcore/bags/msgs`` (``<package>/msg/<Type>.msg``)
and are registered with rosbags.typesys where a bag carries none; the mapping's ``msg_paths`` adds
more.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from tauvcore.bags.mapping import BagMapping, TopicRule, read_mapping
from tauvcore.bags.reader import BagTables, bag_tables, is_bag, open_bag, typestore
from tauvcore.config import from_dict
from tauvcore.log_record import Log
from tauvcore.logs import log_from_tables
from tauvcore.validation import ConfigError, LogError, show_path


def read_bag(path: str | os.PathLike, mapping: BagMapping, beam_directions_b: np.ndarray) -> Log:
    """Read the bag at ``path`` under ``mapping`` into a checked log, as tauvcore.logs.read_log reads
    a log's directory.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 bag, a ROS 2 bag directory or an MCAP file.
    mapping : BagMapping
        The bag mapping (:func:`~tauvcore.bags.mapping.read_mapping`; ``BagMapping()``: none).
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
    read = bag_tables(path, mapping, beam_directions_b)
    log = log_from_tables(read.tables, read.source, read.names)
    return dataclasses.replace(log, notes=read.notes + log.notes)


def bag_config(mapping: BagMapping) -> tuple[dict[str, Any], str | None]:
    """The mapping's ``[config]`` (a partial configuration, laid under ``--config`` as a log's own
    ``log.toml`` is), checked on its own, and where it comes from.

    Parameters
    ----------
    mapping : BagMapping
        The bag mapping.

    Returns
    -------
    tuple of dict and str or None
        The raw tables (section -> key -> value) and the mapping's path; ``({}, None)`` when it has
        no ``[config]``.

    Raises
    ------
    LogError
        Naming the mapping, for a configuration that does not check.
    """
    if not mapping.config or mapping.path is None:
        return {}, None
    raw = {k: dict(v) if isinstance(v, dict) else v for k, v in mapping.config.items()}
    try:
        from_dict(raw)
    except ConfigError as exc:
        raise LogError(f"the bag mapping {show_path(mapping.path)}: [config]: {exc}") from None
    return raw, mapping.path


__all__ = [
    "BagMapping",
    "BagTables",
    "TopicRule",
    "bag_config",
    "bag_tables",
    "is_bag",
    "open_bag",
    "read_bag",
    "read_mapping",
    "typestore",
]
