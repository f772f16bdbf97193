"""A DVL's mounting from the bag's ``/tf_static`` (``tf2_msgs/msg/TFMessage``).

A static transform whose parent (``header.frame_id``) is the body's frame (the mapping's
``base_frame``, ``base_link`` by default) and whose child (``child_frame_id``) is the DVL
message's ``header.frame_id`` is the DVL's pose in the body: ``p_body = R(q) p_dvl + t``
(tf's convention), so ``R(q)`` rotates the DVL's frame into the body's and ``t`` is the DVL's
origin in the body. The transform the other way round (the DVL the parent) is inverted. Between
two FLU frames (ROS REP-103, a ``flu_enu`` topic) it is converted to FRD,
``C_b_dvl = D R D``, ``r_b = D t`` (``D = diag(1, -1, -1)``, tauvcore.logs.bags.frames); a ``frd_ned``
topic's frames are FRD already.

Between the body and the DVL there may be other frames (``base_link -> sensor_mount ->
dvl_link``): the shortest chain of transforms joining them, each taken in either direction, is
composed, ``(R, t) = (R_1, t_1) (R_2, t_2) ... `` with ``(R_1, t_1) (R_2, t_2) = (R_1 R_2,
R_1 t_2 + t_1)`` and a transform taken child to parent inverted, ``(R^T, -R^T t)``. The DVL's
frame absent from ``/tf_static``, the bag gives no mounting; present but joined to the body by no
chain, it is one :class:`~tauvcore.validation.LogError` naming both frames. A DVL whose frame is
the body's has no mounting from the bag.

The mapping's ``[dvl] mounting_rpy_deg`` wins over ``/tf_static``'s rotation, which leaves its
translation the lever arm (:func:`dvl_mounting`). A mapping whose ``tf_static`` is False
(``tauv replay --no-log-config``: the recording's own configuration ignored) takes neither.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.logs.bags.frames import D_FLU, matrix_from_quaternion, mounting_matrix
from tauvcore.logs.bags.mapping import BagMapping, TopicRule
from tauvcore.validation import LogError, show, show_path

TF_STATIC = "/tf_static"
"""The topic of the static transforms."""
TF_TYPE = "tf2_msgs/msg/TFMessage"
"""Its message type."""


@dataclass(frozen=True)
class Mounting:
    """A DVL's mounting as the replay takes it, and where it comes from."""

    C_b_dvl: np.ndarray  # (3, 3) the DVL's frame to the body (FRD): v_b = C_b_dvl v_dvl
    r_b_m: np.ndarray | None  # (3,) the DVL's origin in the body (FRD) [m]; None: not in the bag
    source: str  # where it comes from, for a person ("the mapping's mounting_rpy_deg", ...)


def _first_frame_id(reader: Any, topic: str) -> str:
    """The ``header.frame_id`` of the topic's first message ('' when it has none)."""
    connections = [c for c in reader.connections if c.topic == topic]
    for connection, _, raw in reader.messages(connections=connections):
        header = getattr(reader.deserialize(raw, connection.msgtype), "header", None)
        return str(header.frame_id) if header is not None else ""
    return ""


def static_transforms(reader: Any) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
    """Every transform of ``/tf_static``: (parent, child) -> (translation (3,), quaternion (4,)
    x, y, z, w); the last of one pair counts."""
    connections = [c for c in reader.connections if c.topic == TF_STATIC and c.msgtype == TF_TYPE]
    out: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for connection, _, raw in reader.messages(connections=connections):
        for tf in reader.deserialize(raw, connection.msgtype).transforms:
            t, q = tf.transform.translation, tf.transform.rotation
            out[(str(tf.header.frame_id), str(tf.child_frame_id))] = (
                np.array([t.x, t.y, t.z], dtype=float),
                np.array([q.x, q.y, q.z, q.w], dtype=float),
            )
    return out


def dvl_mounting(reader: Any, bag: str, mapping: BagMapping, rules: Mapping[str, TopicRule]) -> Mounting:
    """The DVL's mounting: the rotation the mapping's ``mounting_rpy_deg`` gives, else the
    ``/tf_static`` transform's between ``mapping.base_frame`` and the DVL message's frame (module
    docstring), else none (the identity); the lever arm that transform's translation (none where
    ``mapping.tf_static`` is False).

    Parameters
    ----------
    reader : rosbags.highlevel.AnyReader
        The open bag.
    bag : str
        The bag's path, for the messages.
    mapping : BagMapping
        The bag mapping.
    rules : Mapping of str to TopicRule
        The tables' rules (:func:`~tauvcore.logs.bags.mapping.resolve`); without ``dvl``, none.

    Returns
    -------
    Mounting
        The rotation, the lever arm where ``/tf_static`` gives one, and where they come from.

    Raises
    ------
    LogError
        A transform with a zero rotation, naming the bag. (A message that cannot be read raises
        rosbags' own error, :func:`tauvcore.logs.bags.ros_reader.bag_errors`, for the caller to name.)
    """
    rule = rules.get("dvl")
    mapped = rule is not None and "mounting_rpy_deg" in rule.options
    try:
        found = _from_tf(reader, bag, mapping, rule)
    except LogError:
        if not mapped:
            raise
        found = Mounting(np.eye(3), None, "none")  # no translation from a /tf_static that does not join
    if rule is not None and mapped:  # the rotation; /tf_static's translation
        rpy = rule.options["mounting_rpy_deg"]
        return Mounting(mounting_matrix(rpy), found.r_b_m, f"the mapping's mounting_rpy_deg {list(rpy)}")
    return found


def _from_tf(reader: Any, bag: str, mapping: BagMapping, rule: TopicRule | None) -> Mounting:
    """The mounting ``/tf_static`` gives (module docstring), or none (the identity)."""
    none = Mounting(np.eye(3), None, "none")
    if (
        rule is None
        or not mapping.tf_static
        or not any(c.topic == TF_STATIC and c.msgtype == TF_TYPE for c in reader.connections)
    ):
        return none
    transforms = static_transforms(reader)
    child = _first_frame_id(reader, rule.topic)
    base = mapping.base_frame
    if child == base or child not in {f for pair in transforms for f in pair}:
        return none
    path = chain(transforms, base, child)
    if path is None:
        raise LogError(
            f"{show_path(bag)}: topic {show(TF_STATIC)}: no chain of transforms joins the body's frame "
            f"{show(base)} to the DVL's frame {show(child)} (the DVL's frame is joined to "
            f"{', '.join(show(f) for f in sorted(_joined(transforms, child) - {child})) or 'nothing'}): "
            "set base_frame in the bag mapping, or the DVL's [dvl] mounting_rpy_deg and [config.dvl] lever_arm_m"
        )
    R, t = np.eye(3), np.zeros(3)
    for parent, kid in itertools.pairwise(path):
        if (parent, kid) in transforms:
            t_edge, q = transforms[(parent, kid)]
            R_edge = matrix_from_quaternion(q[None])[0]
        else:  # the transform is kid -> parent: inverted
            t_back, q = transforms[(kid, parent)]
            R_edge = matrix_from_quaternion(q[None])[0].T
            t_edge = -R_edge @ t_back
        if not np.isfinite(R_edge).all():
            raise LogError(
                f"{show_path(bag)}: topic {show(TF_STATIC)}: the transform between {show(parent)} and "
                f"{show(kid)} has a zero rotation"
            )
        R, t = R @ R_edge, R @ t_edge + t
    if rule.frame == "flu_enu":
        R, t = D_FLU @ R @ D_FLU, D_FLU @ t
    return Mounting(R, t, f"{TF_STATIC} {' -> '.join(path)}")


def _neighbours(transforms: Mapping[tuple[str, str], Any]) -> dict[str, list[str]]:
    """Each frame -> the frames one transform away, either direction, in name order."""
    out: dict[str, set[str]] = {}
    for parent, child in transforms:
        out.setdefault(parent, set()).add(child)
        out.setdefault(child, set()).add(parent)
    return {frame: sorted(others) for frame, others in out.items()}


def _joined(transforms: Mapping[tuple[str, str], Any], frame: str) -> set[str]:
    """The frames some chain of transforms joins to ``frame`` (``frame`` among them)."""
    near = _neighbours(transforms)
    seen, todo = {frame}, [frame]
    while todo:
        for other in near.get(todo.pop(), []):
            if other not in seen:
                seen.add(other)
                todo.append(other)
    return seen


def chain(transforms: Mapping[tuple[str, str], Any], start: str, end: str) -> list[str] | None:
    """The shortest chain of frames from ``start`` to ``end`` through ``transforms`` (each
    transform a step either way; breadth first, neighbours in name order), or None.

    Parameters
    ----------
    transforms : Mapping of (str, str) to Any
        The transforms by (parent, child) frame (:func:`static_transforms`).
    start : str
        The first frame (the body's).
    end : str
        The last frame (the DVL's).

    Returns
    -------
    list of str or None
        ``[start, ..., end]``; ``[start]`` when they are one frame; None when no chain joins them.
    """
    near = _neighbours(transforms)
    previous: dict[str, str | None] = {start: None}
    todo = [start]
    while todo:
        following: list[str] = []
        for frame in todo:
            if frame == end:
                path = [end]
                while (back := previous[path[-1]]) is not None:
                    path.append(back)
                return path[::-1]
            for other in near.get(frame, []):
                if other not in previous:
                    previous[other] = frame
                    following.append(other)
        todo = following
    return None
