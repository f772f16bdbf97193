"""An IMU recorded as increments: angle and velocity increments over each sample on two topics, a
message of each per sample, as the Xsens MTi driver publishes them (``/imu/dq``, a
``geometry_msgs/QuaternionStamped``: the rotation of the sensor's frame over the sample;
``/imu/dv``, a ``geometry_msgs/Vector3Stamped``: the velocity increment [m/s]), both in the
sensor's frame and stamped alike.

The angle increment of a quaternion ``q = (x, y, z, w)`` (ROS order) is its rotation vector,
``dtheta = 2 atan2(|u|, w) u / |u|`` with ``u = (x, y, z)`` (the sign of ``q`` chosen so that
``w >= 0``: the shorter rotation; ``2 u / w`` as ``|u| -> 0``); a ``Vector3Stamped`` angle topic
holds the rotation vector [rad] itself. Both are body vectors: FLU converted to FRD as any
(``D v``, tauvcore.logs.bags.frames; a rotation vector turns with the frame as a vector does, ``D``
being a rotation). The messages pair one to one by index: the two topics must have as many
messages, on the same header stamps, else one :class:`~tauvcore.validation.LogError` names the
first message that does not pair. The table is the log's IMU as increments
(:data:`tauvcore.logs.columns.IMU_INCREMENTS`), each row's increments over the interval ending at
its time.
"""

from __future__ import annotations

import numpy as np

from tauvcore.logs.bags.frames import body_vectors
from tauvcore.logs.bags.mapping import TopicRule
from tauvcore.logs.columns import IMU_INCREMENTS
from tauvcore.validation import LogError, show, show_path


def rotation_vectors(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (K, 3) [rad] of quaternions (K, 4) in ROS order (x, y, z, w), normalised
    (module docstring); a zero quaternion gives NaN.

    Parameters
    ----------
    q : numpy.ndarray
        Quaternions (K, 4), x, y, z, w.

    Returns
    -------
    numpy.ndarray
        Their rotation vectors (K, 3) [rad], each of angle at most pi.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
        q = np.where(q[:, 3:] < 0.0, -q, q)
        u, w = q[:, :3], q[:, 3]
        s = np.linalg.norm(u, axis=-1)
        scale = np.where(s > 1e-12, 2.0 * np.arctan2(s, w) / np.where(s > 1e-12, s, 1.0), 2.0 / w)
    return u * scale[:, None]


def increment_columns(
    bag: str,
    rule: TopicRule,
    angle_kind: str,
    angles: np.ndarray,
    angle_stamps_ns: np.ndarray,
    velocities: np.ndarray,
    velocity_stamps_ns: np.ndarray,
) -> dict[str, np.ndarray]:
    """The IMU table's increment columns of an angle topic and a velocity topic (module docstring).

    Parameters
    ----------
    bag : str
        The bag's path, for the messages.
    rule : TopicRule
        The IMU's rule: its ``topic`` the angle increments', ``options['velocity_topic']`` the
        velocity increments', ``frame`` both topics' frame convention.
    angle_kind : str
        The angle topic's type (:data:`~tauvcore.logs.bags.mapping.INCREMENT_ANGLES`).
    angles : numpy.ndarray
        Its rows (K, 4) quaternions x, y, z, w, or (K, 3) rotation vectors [rad].
    angle_stamps_ns : numpy.ndarray
        Its header stamps (K,) [ns].
    velocities : numpy.ndarray
        The velocity topic's rows (M, 3) [m/s].
    velocity_stamps_ns : numpy.ndarray
        Its header stamps (M,) [ns].

    Returns
    -------
    dict of str to numpy.ndarray
        ``dtheta_x_rad`` .. ``dv_z_mps`` (K,) in the body frame (FRD).

    Raises
    ------
    LogError
        The two topics' messages do not pair one to one (a count or a stamp differs), naming the
        bag, both topics and the first message that does not pair.
    """
    velocity_topic = rule.options["velocity_topic"]
    k, m = len(angle_stamps_ns), len(velocity_stamps_ns)
    n = min(k, m)
    differ = np.flatnonzero(angle_stamps_ns[:n] != velocity_stamps_ns[:n])
    if differ.size or k != m:
        i = int(differ[0]) if differ.size else n
        topic, other = (velocity_topic, rule.topic) if i < m else (rule.topic, velocity_topic)
        stamps = velocity_stamps_ns if i < m else angle_stamps_ns
        theirs = angle_stamps_ns if i < m else velocity_stamps_ns
        there = f"stamped {int(theirs[i])} ns" if i < len(theirs) else "missing"
        raise LogError(
            f"{show_path(bag)}: topic {show(topic)} (imu), message {i + 1}: stamped {int(stamps[i])} ns, but "
            f"{show(other)}'s message {i + 1} is {there}: the angle and velocity increments pair one to one "
            f"({show(rule.topic)} has {k} messages, {show(velocity_topic)} {m}, on the same stamps)"
        )
    rotation = angles if angle_kind == "geometry_msgs/msg/Vector3Stamped" else rotation_vectors(angles)
    dtheta, dv = body_vectors(rotation, rule.frame), body_vectors(velocities, rule.frame)
    columns = {name: dtheta[:, i].copy() for i, name in enumerate(IMU_INCREMENTS[:3])}
    columns.update({name: dv[:, i].copy() for i, name in enumerate(IMU_INCREMENTS[3:])})
    return columns
