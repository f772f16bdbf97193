"""Writing a simulated mission as ROS bags with rosbags' own writers (ROS 1, ROS 2 sqlite3, MCAP),
for the tests of tauvcore.logs.bags and the worked example of docs/bags.md.

``mission_tables`` makes the tables of a simulated mission in the form a bag can carry exactly
(IMU rates, times on whole nanoseconds, the DVL's beams rounded to float32 where a message holds
float32), ``write_bag`` writes the same numbers as messages, in FRD/NED or converted to FLU/ENU
(ROS REP-103), with the DVL as any of the supported messages. The writer streams: each topic's
messages are made as they are written, merged by time, so an hour at 200 Hz (1.4 million
messages) is written in constant memory (benchmarks/bag_replay.py imports this module).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.logs.bags.frames import D_FLU, T_ENU
from tauvcore.logs.bags.ros_reader import MSGS
from tauvcore.logs.writer import simulation_tables

ORIGIN_NS = 1_700_000_000_000_000_000
"""The bag's first IMU stamp [ns] (2023-11-14): a clock like a vehicle's."""
DVL_TYPES = (
    "marine_acoustic_msgs/msg/Dvl",
    "ds_sensor_msgs/msg/Dvl",
    "cola2_msgs/msg/DVL",
    "uuv_sensor_ros_plugins_msgs/msg/DVL",
    "waterlinked_a50_ros_driver/msg/DVL",
    "geometry_msgs/msg/TwistWithCovarianceStamped",
    "geometry_msgs/msg/TwistStamped",
)
FLOAT32_BEAMS = ("marine_acoustic_msgs/msg/Dvl", "ds_sensor_msgs/msg/Dvl")
TOPICS = {"imu": "/imu/data", "dvl": "/dvl", "depth": "/pressure", "attitude": "/ahrs", "reference": "/odom"}
FIX_TOPICS = {"topic": "/fix", "orientation_topic": "/fix/orientation", "depth_topic": "/fix/depth"}
"""A NavSatFix reference's topics (:func:`geodetic_tables`): the fix, its attitude, its depth."""
INCREMENT_TOPICS = {"topic": "/imu/dq", "velocity_topic": "/imu/dv"}
"""Where write_bag puts an IMU table of increments (the Xsens MTi driver's topics): the angle
increments as geometry_msgs/QuaternionStamped, the velocity increments as Vector3Stamped."""
USBL_TOPIC = "/usbl/fix"
"""Where write_bag puts a ``usbl`` table."""
LEVER_ARM_B_M = (0.6, 0.1, 0.15)
"""The DVL's origin in the body (FRD) [m] that write_bag's ``/tf_static`` gives."""
BEAM_ORDER = (2, 0, 3, 1)
"""The configured beam (0-3) each message beam is: a message lists its beams in its own order."""


def mission_config(duration_s: float = 20.0, imu_rate_hz: float = 50.0) -> Config:
    return (
        Config()
        .replace("trajectory", name="figure8", duration_s=duration_s)
        .replace("earth", model="flat")
        .replace("imu", rate_hz=imu_rate_hz)
        .replace("run", methods=("ins", "lc", "tc"), aiding=("dvl", "depth", "mag"))
    )


def mission_tables(config: Config, seed: int = 3) -> tuple[dict, dict]:
    """The mission's tables with the DVL as beams and, second, the same with the DVL as the body
    velocity (the truth's, at the pings), each as a bag carries them exactly."""
    sim = simulate(config, np.random.default_rng(seed))
    tables = simulation_tables([SimChunk.whole(sim)])
    t = tables["imu"]["t_s"]
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    imu = {"t_s": _on_ns(t)}
    for i, a in enumerate("xyz"):
        imu[f"gyro_{a}_rps"] = tables["imu"][f"dtheta_{a}_rad"] / dt
        imu[f"accel_{a}_mps2"] = tables["imu"][f"dv_{a}_mps"] / dt
    for i in range(3):  # row 0's increments are zero: its rates as row 1's
        imu[f"gyro_{'xyz'[i]}_rps"][0] = imu[f"gyro_{'xyz'[i]}_rps"][1]
        imu[f"accel_{'xyz'[i]}_mps2"][0] = imu[f"accel_{'xyz'[i]}_mps2"][1]
    dvl = tables["dvl"]
    beams = {"t_s": _on_ns(dvl["t_s"])}
    beams.update({f"beam{k}_mps": dvl[f"beam{k}_mps"].astype(np.float32).astype(float) for k in range(1, 5)})
    beams.update({n: dvl[n].astype(np.float32).astype(float) for n in (f"beam{k}_water_mps" for k in range(1, 5))
                  if n in dvl})  # water_track "both": water-track beside bottom-track
    ref = tables["reference"]
    euler = np.stack([ref["roll_rad"], ref["pitch_rad"], ref["yaw_rad"]], axis=-1)
    C = C_nb_from_euler(euler)
    from tauvcore.geo.rotations import euler_from_C_nb

    euler = euler_from_C_nb(C)  # yaw wrapped, as from a quaternion
    reference = {"t_s": _on_ns(ref["t_s"])}
    reference.update({n: ref[n] for n in ("north_m", "east_m", "down_m")})
    reference.update({f"{n}_rad": euler[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))})
    reference.update({n: ref[n] for n in ("vel_north_mps", "vel_east_mps", "vel_down_mps")})
    att = tables["attitude"]
    att_euler = euler_from_C_nb(C_nb_from_euler(np.stack([att[f"{n}_rad"] for n in ("roll", "pitch", "yaw")], -1)))
    attitude = {"t_s": _on_ns(att["t_s"])}
    attitude.update({f"{n}_rad": att_euler[:, i] for i, n in enumerate(("roll", "pitch", "yaw"))})
    depth = {"t_s": _on_ns(tables["depth"]["t_s"]), "depth_m": tables["depth"]["depth_m"].copy()}
    per_beam = {"imu": imu, "dvl": beams, "depth": depth, "attitude": attitude, "reference": reference}
    if "usbl" in tables:  # a plug-in source's table (--aiding ...,usbl), as a bag's USBL topic carries it
        per_beam["usbl"] = {**tables["usbl"], "t_s": _on_ns(tables["usbl"]["t_s"])}
    k = np.searchsorted(ref["t_s"], dvl["t_s"])
    vel_b = np.einsum("kji,kj->ki", C[k], np.stack([ref[n] for n in ("vel_north_mps", "vel_east_mps",
                                                                  "vel_down_mps")], -1)[k])
    body = {"t_s": beams["t_s"], "vel_x_mps": vel_b[:, 0], "vel_y_mps": vel_b[:, 1], "vel_z_mps": vel_b[:, 2]}
    return per_beam, {**per_beam, "dvl": body}


def increment_tables(tables: dict) -> dict:
    """``tables`` with the IMU as increments over each sample (``dtheta_*_rad``, ``dv_*_mps``): its
    rates times the interval ending at the row (the first row's, the second's interval)."""
    imu = tables["imu"]
    t = imu["t_s"]
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    out = {"t_s": t}
    out.update({f"dtheta_{a}_rad": imu[f"gyro_{a}_rps"] * dt for a in "xyz"})
    out.update({f"dv_{a}_mps": imu[f"accel_{a}_mps2"] * dt for a in "xyz"})
    return {**tables, "imu": out}


def geodetic_tables(tables: dict, config: Config) -> dict:
    """``tables`` with the reference as a sensor_msgs/NavSatFix carries it: latitude and longitude
    [deg] of the local positions about the configured origin, the depth, the attitude as it was,
    and the NED velocity as the bag reader makes a fix's (docs/bags.md: the positions' central
    differences, tauvcore.logs.bags.ros_reader), so the log and the bag hold the same numbers."""
    from tauvcore.geo.earth import geodetic_from_ned, ned_from_geodetic
    from tauvcore.units import DEG

    ref = tables["reference"]
    origin = (config.earth.latitude_deg * DEG, config.earth.longitude_deg * DEG, 0.0)
    lat, lon, height = geodetic_from_ned(np.stack([ref[n] for n in ("north_m", "east_m", "down_m")], -1), origin)
    fix = {"t_s": ref["t_s"], "lat_deg": lat / DEG, "lon_deg": lon / DEG, "depth_m": -height}
    fix.update({f"{n}_rad": ref[f"{n}_rad"] for n in ("roll", "pitch", "yaw")})
    lat, lon = fix["lat_deg"] * DEG, fix["lon_deg"] * DEG  # as the reader has them from the degrees
    position = ned_from_geodetic(lat, lon, height, (float(lat[0]), float(lon[0]), float(height[0])))
    vel_n = np.gradient(position, ref["t_s"], axis=0)
    fix.update({f"vel_{a}_mps": vel_n[:, i] for i, a in enumerate(("north", "east", "down"))})
    return {**tables, "reference": fix}


def _on_ns(t: np.ndarray) -> np.ndarray:
    """Times [s] as a bag's stamps give them back: whole nanoseconds after ORIGIN_NS."""
    return np.round(t * 1e9).astype(np.int64) * 1e-9


def store_for(storage: str) -> Any:
    """rosbags' typestore of ROS 1 (Noetic) or ROS 2 with the shipped DVL messages registered."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if storage == "ros1" else Stores.LATEST)
    types: dict = {}
    for path in sorted(MSGS.glob("*/msg/*.msg")):
        types.update(get_types_from_msg(path.read_text(), f"{path.parent.parent.name}/msg/{path.stem}"))
    if "tf2_msgs/msg/TFMessage" not in store.fielddefs:  # ROS 1's store lacks it: its one-line definition
        types.update(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"))
    store.register(types)
    return store


_DEFAULTS: dict[tuple[int, str], tuple[Any, dict[str, Any]]] = {}
"""(id of a typestore, type) -> (the typestore, its fields' zero values): found once a type, as a
writer makes a message a sample (the zero values are shared, never changed: messages are only
serialised)."""


def make(store: Any, name: str, **values: Any) -> Any:
    """A message of type ``name`` with every field zero (empty, false) but ``values``."""
    key = (id(store), name)
    if key not in _DEFAULTS:
        _DEFAULTS[key] = (store, {field: _default(store, desc) for field, desc in store.fielddefs[name][1]})
    return store.types[name](**{**_DEFAULTS[key][1], **values})


_NUMPY = {"float64": np.float64, "float32": np.float32, "uint8": np.uint8, "int8": np.int8, "uint16": np.uint16,
          "int16": np.int16, "uint32": np.uint32, "int32": np.int32, "uint64": np.uint64, "int64": np.int64,
          "bool": np.bool_}  # fmt: skip


def _default(store: Any, desc: Any) -> Any:
    kind, arg = desc
    kind = int(kind)
    if kind == 1:  # base
        base = arg[0]
        return "" if base == "string" else False if base == "bool" else 0.0 if base.startswith("float") else 0
    if kind == 2:  # a message
        return make(store, arg)
    sub, length = arg
    if int(sub[0]) == 1 and sub[1][0] in _NUMPY:
        return np.zeros(length if kind == 3 else 0, dtype=_NUMPY[sub[1][0]])
    return [_default(store, sub) for _ in range(length if kind == 3 else 0)]


def _quaternion(C: np.ndarray) -> np.ndarray:
    """The unit quaternion (x, y, z, w) of rotation matrices (K, 3, 3)."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(C).as_quat()


def _axis_quaternion(u: np.ndarray) -> np.ndarray:
    """A quaternion (x, y, z, w) whose rotation takes the x axis to the unit vector ``u``."""
    x = np.array([1.0, 0.0, 0.0])
    axis = np.cross(x, u)
    s = np.linalg.norm(axis)
    angle = np.arctan2(s, x @ u)
    axis = axis / s if s > 0 else np.array([0.0, 0.0, 1.0])
    return np.concatenate([axis * np.sin(angle / 2), [np.cos(angle / 2)]])


def write_bag(
    path: Path,
    storage: str,
    tables: dict,
    dvl_type: str,
    A_b: np.ndarray,
    frame: str = "frd_ned",
    depth_as: str = "pressure",
    imu_topics: tuple[str, ...] = (TOPICS["imu"],),
    usbl_as: str = "geometry_msgs/msg/PointStamped",
    C_b_dvl: np.ndarray | None = None,
    tf_static: bool = False,
    tf_chain: tuple[tuple[str, str, np.ndarray, np.ndarray], ...] = (),
    velocity_skip: int | None = None,
    water_topic: str | None = None,
) -> Path:
    """Write ``tables`` as a bag: ``storage`` ros1 (``path`` a .bag), sqlite3 (a directory) or mcap
    (a .mcap file: the ROS 2 writer's single storage file). The IMU (sensor_msgs/Imu), the DVL
    (``dvl_type``), the depth (FluidPressure: ``p = p_atm + rho g depth``), the attitude
    (QuaternionStamped) and the reference (nav_msgs/Odometry, its twist in the body) in ``frame``;
    a ``usbl`` table as ``usbl_as`` (PointStamped or PoseWithCovarianceStamped) on
    :data:`USBL_TOPIC`. ``C_b_dvl`` (3, 3) mounts the DVL rotated (its beam directions in its own
    frame, ``C_b_dvl.T`` of the body's); ``tf_static`` writes that mounting and :data:`LEVER_ARM_B_M`
    as the ``/tf_static`` transform base_link -> dvl; ``tf_chain`` (parent, child, C (3, 3), t (3,)
    in FRD: ``p_parent = C p_child + t``) writes those transforms instead. An IMU table of
    increments (:func:`increment_tables`) is written on :data:`INCREMENT_TOPICS`, the angle
    increments as quaternions, leaving out the velocity topic's message ``velocity_skip`` (0-based).
    A DVL table with ``beam1_water_mps`` .. (``water_track = "both"``) is written as a driver
    that outputs both publishes it: each ping's bottom-track message (where it has a bottom-track
    beam, or no water-track one) and its water-track message (``velocity_mode`` 2, where it has a
    water-track beam) on the same stamp, the water-track one on ``water_topic`` (default: the
    DVL's own topic, after the bottom-track one)."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    store = store_for(storage)
    flu = frame == "flu_enu"
    vec_b = (lambda v: v @ D_FLU.T) if flu else (lambda v: v)
    vec_n = (lambda v: v @ T_ENU.T) if flu else (lambda v: v)
    rot = (lambda C: T_ENU @ C @ D_FLU) if flu else (lambda C: C)
    seq = [0]

    def header(t_s: float, frame_id: str) -> Any:
        ns = ORIGIN_NS + int(round(t_s * 1e9))
        stamp = store.types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        seq[0] += 1
        extra = {"seq": seq[0]} if storage == "ros1" else {}
        return make(store, "std_msgs/msg/Header", stamp=stamp, frame_id=frame_id, **extra), ns

    def vector3(v: np.ndarray) -> Any:
        return make(store, "geometry_msgs/msg/Vector3", x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def quat(q: np.ndarray) -> Any:
        return make(store, "geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3])

    def imu_messages() -> Iterator[tuple[int, str, str, Any]]:
        imu = tables["imu"]
        if "dtheta_x_rad" in imu:
            yield from increment_messages(imu)
            return
        gyro = vec_b(np.stack([imu[f"gyro_{a}_rps"] for a in "xyz"], -1))
        accel = vec_b(np.stack([imu[f"accel_{a}_mps2"] for a in "xyz"], -1))
        level = quat(np.array([0.0, 0.0, 0.0, 1.0]))
        for k, t in enumerate(imu["t_s"]):
            h, ns = header(t, "imu")
            msg = make(store, "sensor_msgs/msg/Imu", header=h, angular_velocity=vector3(gyro[k]),
                       linear_acceleration=vector3(accel[k]), orientation=level)
            for topic in imu_topics:
                yield ns, topic, "sensor_msgs/msg/Imu", msg

    def increment_messages(imu: dict) -> Iterator[tuple[int, str, str, Any]]:
        dtheta = vec_b(np.stack([imu[f"dtheta_{a}_rad"] for a in "xyz"], -1))
        dv = vec_b(np.stack([imu[f"dv_{a}_mps"] for a in "xyz"], -1))
        angle = np.linalg.norm(dtheta, axis=-1)
        axis = dtheta / np.where(angle > 0, angle, 1.0)[:, None]
        dq = np.concatenate([axis * np.sin(angle / 2)[:, None], np.cos(angle / 2)[:, None]], axis=-1)
        for k, t in enumerate(imu["t_s"]):
            h, ns = header(t, "imu_link")
            yield ns, INCREMENT_TOPICS["topic"], "geometry_msgs/msg/QuaternionStamped", make(
                store, "geometry_msgs/msg/QuaternionStamped", header=h, quaternion=quat(dq[k]))
            if k != velocity_skip:
                yield ns, INCREMENT_TOPICS["velocity_topic"], "geometry_msgs/msg/Vector3Stamped", make(
                    store, "geometry_msgs/msg/Vector3Stamped", header=h, vector=vector3(dv[k]))

    def depth_messages() -> Iterator[tuple[int, str, str, Any]]:
        depth = tables["depth"]
        for t, d in zip(depth["t_s"], depth["depth_m"], strict=True):
            h, ns = header(t, "pressure")
            if depth_as == "pressure":
                msg = make(store, "sensor_msgs/msg/FluidPressure", header=h,
                           fluid_pressure=101325.0 + 1025.0 * 9.80665 * d)
                yield ns, TOPICS["depth"], "sensor_msgs/msg/FluidPressure", msg
            else:
                yield ns, "/depth", "std_msgs/msg/Float64", make(store, "std_msgs/msg/Float64", data=d)

    def attitude_messages() -> Iterator[tuple[int, str, str, Any]]:
        att = tables["attitude"]
        q_att = _quaternion(rot(C_nb_from_euler(np.stack([att[f"{n}_rad"] for n in ("roll", "pitch", "yaw")], -1))))
        for k, t in enumerate(att["t_s"]):
            h, ns = header(t, "ahrs")
            msg = make(store, "geometry_msgs/msg/QuaternionStamped", header=h, quaternion=quat(q_att[k]))
            yield ns, TOPICS["attitude"], "geometry_msgs/msg/QuaternionStamped", msg

    def reference_messages() -> Iterator[tuple[int, str, str, Any]]:
        ref = tables["reference"]
        C = C_nb_from_euler(np.stack([ref[f"{n}_rad"] for n in ("roll", "pitch", "yaw")], -1))
        q_ref = _quaternion(rot(C))
        if "lat_deg" in ref:  # a fix, its orientation and its depth on topics of their own
            for k, t in enumerate(ref["t_s"]):
                h, ns = header(t, "gps")
                yield ns, FIX_TOPICS["topic"], "sensor_msgs/msg/NavSatFix", make(
                    store, "sensor_msgs/msg/NavSatFix", header=h, latitude=ref["lat_deg"][k],
                    longitude=ref["lon_deg"][k], altitude=-ref["depth_m"][k])
                h, ns = header(t, "orientation")
                yield ns, FIX_TOPICS["orientation_topic"], "geometry_msgs/msg/QuaternionStamped", make(
                    store, "geometry_msgs/msg/QuaternionStamped", header=h, quaternion=quat(q_ref[k]))
                yield ns, FIX_TOPICS["depth_topic"], "std_msgs/msg/Float64", make(
                    store, "std_msgs/msg/Float64", data=ref["depth_m"][k])
            return
        pos = vec_n(np.stack([ref[n] for n in ("north_m", "east_m", "down_m")], -1))
        vel_b = vec_b(np.einsum("kji,kj->ki", C, np.stack([ref[f"vel_{a}_mps"] for a in ("north", "east", "down")],
                                                         -1)))
        del C
        for k, t in enumerate(ref["t_s"]):
            h, ns = header(t, "odom")
            pose = make(store, "geometry_msgs/msg/PoseWithCovariance", pose=make(
                store, "geometry_msgs/msg/Pose", position=make(store, "geometry_msgs/msg/Point", x=pos[k, 0],
                                                                y=pos[k, 1], z=pos[k, 2]), orientation=quat(q_ref[k])))
            twist = make(store, "geometry_msgs/msg/TwistWithCovariance", twist=make(
                store, "geometry_msgs/msg/Twist", linear=vector3(vel_b[k])))
            msg = make(store, "nav_msgs/msg/Odometry", header=h, child_frame_id="base_link", pose=pose, twist=twist)
            yield ns, TOPICS["reference"], "nav_msgs/msg/Odometry", msg

    def usbl_messages() -> Iterator[tuple[int, str, str, Any]]:
        usbl = tables.get("usbl")
        if usbl is None:
            return
        pos = vec_n(np.stack([usbl[n] for n in ("north_m", "east_m", "down_m")], -1))
        for k, t in enumerate(usbl["t_s"]):
            h, ns = header(t, "usbl")
            point = make(store, "geometry_msgs/msg/Point", x=pos[k, 0], y=pos[k, 1], z=pos[k, 2])
            if usbl_as == "geometry_msgs/msg/PointStamped":
                msg = make(store, usbl_as, header=h, point=point)
            else:
                covariance = np.zeros(36)
                covariance[[0, 7, 14]] = 0.25
                msg = make(store, usbl_as, header=h, pose=make(
                    store, "geometry_msgs/msg/PoseWithCovariance", covariance=covariance, pose=make(
                        store, "geometry_msgs/msg/Pose", position=point, orientation=quat(np.array([0, 0, 0, 1.0])))))
            yield ns, USBL_TOPIC, usbl_as, msg

    def tf_messages() -> Iterator[tuple[int, str, str, Any]]:
        if not tf_static and not tf_chain:
            return
        edges = tf_chain or (("base_link", "dvl", C_b_dvl if C_b_dvl is not None else np.eye(3),
                              np.asarray(LEVER_ARM_B_M)),)
        transforms = []
        for parent, child, C, t in edges:
            h, ns = header(0.0, parent)
            rotation = _quaternion(rot_b(np.asarray(C))[None])[0]
            transforms.append(make(store, "geometry_msgs/msg/TransformStamped", header=h, child_frame_id=child,
                                   transform=make(store, "geometry_msgs/msg/Transform",
                                                  translation=vector3(vec_b(np.asarray(t))), rotation=quat(rotation))))
        h, ns = header(0.0, "base_link")
        yield ns, "/tf_static", "tf2_msgs/msg/TFMessage", make(store, "tf2_msgs/msg/TFMessage", transforms=transforms)

    rot_b = (lambda C: D_FLU @ C @ D_FLU) if flu else (lambda C: C)
    dvl: list[tuple[int, str, str, Any]] = []
    dvl_A = A_b if C_b_dvl is None else A_b @ C_b_dvl  # each beam in the DVL's own frame (rows: C^T a)
    _dvl_messages(store, tables["dvl"], dvl_type, dvl_A, vec_b, header, vector3, quat, dvl, water_topic)
    # by receive time; at one time in this order (the order of a sort of them all: merge is stable)
    messages = heapq.merge(tf_messages(), imu_messages(), dvl, depth_messages(), attitude_messages(),
                           reference_messages(), usbl_messages(), key=lambda m: m[0])
    if storage == "ros1":
        writer: Any = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path if storage == "sqlite3" else path.with_suffix(""), version=9, storage_plugin=plugin)
    with writer:
        connections = {}
        serialize = store.serialize_ros1 if storage == "ros1" else store.serialize_cdr
        for ns, topic, kind, msg in messages:
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, kind, typestore=store)
            writer.write(connections[topic], ns, serialize(msg, kind))
    if storage == "mcap":  # the single storage file, as a recorder's .mcap
        directory = path.with_suffix("")
        mcap = next(directory.glob("*.mcap"))
        mcap.rename(path)
        for leftover in directory.iterdir():
            leftover.unlink()
        directory.rmdir()
    return path


def _dvl_messages(store: Any, dvl: dict, kind: str, A_b: np.ndarray, vec_b: Any, header: Any, vector3: Any,
                  quat: Any, messages: list, water_topic: str | None = None) -> None:
    """The DVL table as messages of ``kind``: its beams in :data:`BEAM_ORDER` with their directions
    (or ids), or its body velocity; a row whose ``beam1_water_track`` is 1 as a water-track ping
    (``velocity_mode`` 2, in the types that have it); a table with ``beam1_water_mps`` as
    :func:`write_bag` says."""
    if "beam1_water_mps" not in dvl:
        _dvl_rows(store, dvl, kind, A_b, vec_b, header, vector3, quat, messages, TOPICS["dvl"])
        return
    bottom = np.stack([dvl[f"beam{j}_mps"] for j in range(1, 5)], -1)
    water = np.stack([dvl[f"beam{j}_water_mps"] for j in range(1, 5)], -1)
    has_water = np.isfinite(water).any(axis=1)
    has_bottom = np.isfinite(bottom).any(axis=1) | ~has_water
    both: list = []
    _dvl_rows(store, {"t_s": dvl["t_s"][has_bottom], **{f"beam{j + 1}_mps": bottom[has_bottom, j] for j in range(4)}},
              kind, A_b, vec_b, header, vector3, quat, both, TOPICS["dvl"])
    flags = {f"beam{j + 1}_water_track": np.ones(int(has_water.sum())) for j in range(4)}
    _dvl_rows(store, {"t_s": dvl["t_s"][has_water], **{f"beam{j + 1}_mps": water[has_water, j] for j in range(4)},
                      **flags}, kind, A_b, vec_b, header, vector3, quat, both, water_topic or TOPICS["dvl"])
    messages.extend(sorted(both, key=lambda m: m[0]))  # stable: a ping's bottom-track message first


def _dvl_rows(store: Any, dvl: dict, kind: str, A_b: np.ndarray, vec_b: Any, header: Any, vector3: Any,
              quat: Any, messages: list, topic: str) -> None:
    """Each row of the DVL table ``dvl`` as a message of ``kind`` on ``topic`` (:func:`_dvl_messages`)."""
    order = list(BEAM_ORDER)
    dirs = vec_b(A_b[order])  # each message beam's direction in the message's frame
    for k, t in enumerate(dvl["t_s"]):
        h, ns = header(t, "dvl")
        mode = {"velocity_mode": 2} if "beam1_water_track" in dvl and dvl["beam1_water_track"][k] == 1.0 else {}
        if "beam1_mps" in dvl:
            beams = np.array([dvl[f"beam{j + 1}_mps"][k] for j in order])
            valid = np.isfinite(beams)
            beams = np.where(valid, beams, 0.0)
            body = np.zeros(3)
        else:
            beams, valid = np.zeros(4), np.zeros(4, bool)
            body = vec_b(np.array([dvl[f"vel_{a}_mps"][k] for a in "xyz"]))
        if kind.startswith("geometry_msgs/msg/Twist"):
            twist = make(store, "geometry_msgs/msg/Twist", linear=vector3(body))
            if kind.endswith("CovarianceStamped"):
                twist = make(store, "geometry_msgs/msg/TwistWithCovariance", twist=twist)
            msg = make(store, kind, header=h, twist=twist)
        elif kind == "marine_acoustic_msgs/msg/Dvl":
            msg = make(store, kind, header=h, velocity=vector3(body), num_good_beams=int(valid.sum()),
                       beam_velocities_valid=bool(valid.all()), beam_unit_vec=[vector3(d) for d in dirs],
                       beam_velocity=beams.astype(np.float32), **mode)
        elif kind == "ds_sensor_msgs/msg/Dvl":
            raw = np.where(valid, beams, np.nan).astype(np.float32)
            msg = make(store, kind, header=h, velocity=vector3(body), num_good_beams=int(valid.sum()),
                       beam_unit_vec=[vector3(d) for d in dirs], raw_velocity=raw, coordinate_mode=0, **mode)
        elif kind in ("cola2_msgs/msg/DVL", "uuv_sensor_ros_plugins_msgs/msg/DVL"):
            package = kind.split("/")[0]
            items = [make(store, f"{package}/msg/DVLBeam", range=10.0 if valid[i] else -1.0, velocity=float(beams[i]),
                          pose=make(store, "geometry_msgs/msg/PoseStamped", pose=make(
                              store, "geometry_msgs/msg/Pose", orientation=quat(_axis_quaternion(dirs[i])))))
                     for i in range(4)]
            msg = make(store, kind, header=h, velocity=vector3(body), beams=items)
        else:  # Water Linked: ids, no directions
            items = [make(store, "waterlinked_a50_ros_driver/msg/DVLBeam", id=order[i], velocity=float(beams[i]),
                          valid=bool(valid[i])) for i in range(4)]
            msg = make(store, kind, header=h, velocity=vector3(body), velocity_valid=bool(valid.all()), beams=items)
        messages.append((ns, topic, kind, msg))
