"""The numbers each supported message holds: one flat row of floats per message, laid out per type
(:data:`LAYOUTS`), as the bag's own frames and units have them (tauvcore.bags.reader converts).

A DVL message with per-beam data gives its body velocity and validity, four beam velocities and
validities, four beam directions and four beam ids (NaN where the message has none):

- ``marine_acoustic_msgs/Dvl``: ``beam_velocity`` along ``beam_unit_vec``, valid where
  ``beam_velocities_valid``; the body velocity valid with at least 3 ``num_good_beams``;
- ``ds_sensor_msgs/Dvl``: ``raw_velocity`` along ``beam_unit_vec`` when ``coordinate_mode`` is
  beam coordinates (0), else no beams; the body velocity as marine_acoustic_msgs';
- ``cola2_msgs/DVL`` and ``uuv_sensor_ros_plugins_msgs/DVL``: four ``beams`` (else none), each
  valid where its ``range`` is not negative, its direction the x axis of its ``pose``; the body
  velocity invalid where ``velocity_covariance[0]`` is negative (their -1);
- ``waterlinked_a50_ros_driver/DVL``: four ``beams`` with their ``id`` and ``valid`` (no
  directions: the mapping's ``beam_ids`` says which is which); ``velocity_valid``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

NAN = float("nan")
_NO_BEAMS = (NAN,) * 4 + (0.0,) * 4 + (NAN,) * 12 + (NAN,) * 4


def _vec(v: Any) -> tuple[float, float, float]:
    return (v.x, v.y, v.z)


def _quat(q: Any) -> tuple[float, float, float, float]:
    return (q.x, q.y, q.z, q.w)


def _imu(m: Any) -> tuple[float, ...]:
    return (*_vec(m.angular_velocity), *_vec(m.linear_acceleration), *_quat(m.orientation))


def _odometry(m: Any) -> tuple[float, ...]:
    return (*_vec(m.pose.pose.position), *_quat(m.pose.pose.orientation), *_vec(m.twist.twist.linear))


def _beam_axis(q: Any) -> tuple[float, float, float]:
    """The x axis of the rotation of quaternion ``q``: a UUV Simulator beam's direction."""
    x, y, z, w = _quat(q)
    n = x * x + y * y + z * z + w * w
    return (1.0 - 2.0 * (y * y + z * z) / n, 2.0 * (x * y + w * z) / n, 2.0 * (x * z - w * y) / n)


def _marine_acoustic(m: Any) -> tuple[float, ...]:
    valid = 1.0 if m.beam_velocities_valid else 0.0
    dirs = [c for v in m.beam_unit_vec for c in _vec(v)]
    return (
        *_vec(m.velocity),
        1.0 if m.num_good_beams >= 3 else 0.0,
        *(float(v) for v in m.beam_velocity),
        *(valid,) * 4,
        *dirs,
        *(NAN,) * 4,
    )


def _ds(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 1.0 if m.num_good_beams >= 3 else 0.0)
    if m.coordinate_mode != 0:  # x, y, z, error: no beams
        return body + _NO_BEAMS
    dirs = [c for v in m.beam_unit_vec for c in _vec(v)]
    return body + (*(float(v) for v in m.raw_velocity), *(1.0,) * 4, *dirs, *(NAN,) * 4)


def _uuv(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 0.0 if m.velocity_covariance[0] < 0 else 1.0)
    beams = m.beams
    if len(beams) != 4:
        return body + _NO_BEAMS
    return body + (
        *(b.velocity for b in beams),
        *(1.0 if b.range >= 0 else 0.0 for b in beams),
        *(c for b in beams for c in _beam_axis(b.pose.pose.orientation)),
        *(NAN,) * 4,
    )


def _waterlinked(m: Any) -> tuple[float, ...]:
    body = (*_vec(m.velocity), 1.0 if m.velocity_valid else 0.0)
    beams = m.beams
    if len(beams) != 4:
        return body + _NO_BEAMS
    return body + (
        *(b.velocity for b in beams),
        *(1.0 if b.valid else 0.0 for b in beams),
        *(NAN,) * 12,
        *(float(b.id) for b in beams),
    )


_DVL = {"body": slice(0, 3), "body_valid": slice(3, 4), "beams": slice(4, 8), "beam_valid": slice(8, 12),
        "dirs": slice(12, 24), "ids": slice(24, 28)}  # fmt: skip
_POSE = {"position": slice(0, 3), "quaternion": slice(3, 7)}

EXTRACT: dict[str, Callable[[Any], tuple[float, ...]]] = {
    "sensor_msgs/msg/Imu": _imu,
    "geometry_msgs/msg/QuaternionStamped": lambda m: _quat(m.quaternion),
    "geometry_msgs/msg/PoseStamped": lambda m: (*_vec(m.pose.position), *_quat(m.pose.orientation)),
    "geometry_msgs/msg/PoseWithCovarianceStamped": lambda m: (
        *_vec(m.pose.pose.position),
        *_quat(m.pose.pose.orientation),
    ),
    "nav_msgs/msg/Odometry": _odometry,
    "sensor_msgs/msg/NavSatFix": lambda m: (m.latitude, m.longitude, m.altitude),
    "sensor_msgs/msg/FluidPressure": lambda m: (m.fluid_pressure,),
    "std_msgs/msg/Float64": lambda m: (m.data,),
    "std_msgs/msg/Float32": lambda m: (float(m.data),),
    "geometry_msgs/msg/TwistStamped": lambda m: (*_vec(m.twist.linear), 1.0),
    "geometry_msgs/msg/TwistWithCovarianceStamped": lambda m: (*_vec(m.twist.twist.linear), 1.0),
    "marine_acoustic_msgs/msg/Dvl": _marine_acoustic,
    "ds_sensor_msgs/msg/Dvl": _ds,
    "cola2_msgs/msg/DVL": _uuv,
    "uuv_sensor_ros_plugins_msgs/msg/DVL": _uuv,
    "waterlinked_a50_ros_driver/msg/DVL": _waterlinked,
}
"""Each supported type's row of numbers (:data:`LAYOUTS` names its parts)."""
LAYOUTS: dict[str, dict[str, slice]] = {
    "sensor_msgs/msg/Imu": {"gyro": slice(0, 3), "accel": slice(3, 6), "quaternion": slice(6, 10)},
    "geometry_msgs/msg/QuaternionStamped": {"quaternion": slice(0, 4)},
    "geometry_msgs/msg/PoseStamped": _POSE,
    "geometry_msgs/msg/PoseWithCovarianceStamped": _POSE,
    "nav_msgs/msg/Odometry": {**_POSE, "velocity_b": slice(7, 10)},
    "sensor_msgs/msg/NavSatFix": {"lat_lon_deg": slice(0, 2), "altitude": slice(2, 3)},
    "sensor_msgs/msg/FluidPressure": {"pressure": slice(0, 1)},
    "std_msgs/msg/Float64": {"value": slice(0, 1)},
    "std_msgs/msg/Float32": {"value": slice(0, 1)},
    "geometry_msgs/msg/TwistStamped": {"body": slice(0, 3), "body_valid": slice(3, 4)},
    "geometry_msgs/msg/TwistWithCovarianceStamped": {"body": slice(0, 3), "body_valid": slice(3, 4)},
    **dict.fromkeys(
        (
            "marine_acoustic_msgs/msg/Dvl",
            "ds_sensor_msgs/msg/Dvl",
            "cola2_msgs/msg/DVL",
            "uuv_sensor_ros_plugins_msgs/msg/DVL",
            "waterlinked_a50_ros_driver/msg/DVL",
        ),
        _DVL,
    ),
}
"""Each supported type's parts of its row: name -> columns."""
