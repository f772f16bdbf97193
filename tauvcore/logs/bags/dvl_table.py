"""The DVL's table of a bag (tauvcore.logs.bags.ros_reader): the messages' per-beam velocities along the
configured Janus beams where they have them and those match (by direction, else by the mapping's
``beam_ids``), else their body velocity rotated into the body by the DVL's mounting; and each
velocity's mode, bottom- or water-track, from the mapping's ``water_track`` or the messages' own
``velocity_mode`` (tauvcore.logs.bags.messages).

A DVL that outputs both from one ping publishes two messages, one of each mode, on its topic or
on two (the mapping's ``water_track_topic``: all its messages water-track). A water-track
message and a bottom-track one within ``ping_tolerance_s`` of each other
(:data:`~tauvcore.logs.bags.mapping.DVL_PING_TOLERANCE_S`) are one ping, one row of the table: its
bottom-track velocity as a lone message's, its water-track velocity in ``beam1_water_mps`` ..
``beam4_water_mps`` (a body velocity projected onto the configured beams), as a log of
``water_track = "both"`` holds them (:func:`dvl_table`); a message of either mode without its
pair is a row of its own, the other mode's columns empty.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from tauvcore.logs.bags.frames import body_vectors
from tauvcore.logs.bags.mapping import DVL_BEAM_TOLERANCE_DEG, DVL_PING_TOLERANCE_S, TopicRule
from tauvcore.logs.bags.messages import require_finite
from tauvcore.units import DEG
from tauvcore.validation import LogError, show, show_path


def dvl_columns(
    bag: str,
    part: Mapping[str, np.ndarray],
    rule: TopicRule,
    A_b: np.ndarray,
    C_b_dvl: np.ndarray,
    notes: list[str],
) -> dict[str, np.ndarray]:
    """The DVL's table of the messages of its topic (module docstring).

    Parameters
    ----------
    bag : str
        The bag's path, for the messages.
    part : Mapping of str to numpy.ndarray
        The messages' rows by part (tauvcore.logs.bags.messages.LAYOUTS): ``body`` (M, 3) [m/s] and
        ``body_valid`` (M, 1) in the topic's frame; a per-beam message's ``beams`` (M, 4) [m/s],
        ``beam_valid`` (M, 4), ``dirs`` (M, 12), ``ids`` (M, 4) and ``water`` (M, 1).
    rule : TopicRule
        The topic's rule: its frame and the mapping's ``[dvl]`` keys (``form``, ``beam_ids``,
        ``beam_velocity_sign``, ``beam_tolerance_deg``, ``water_track``).
    A_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (FRD).
    C_b_dvl : numpy.ndarray
        The DVL's mounting (3, 3), ``v_b = C_b_dvl v_dvl``.
    notes : list of str
        Where a note is added when the messages' body velocity is taken for want of beams.

    Returns
    -------
    dict of str to numpy.ndarray
        The table's columns (M,) besides ``t_s``: ``beam1_mps`` .. ``beam4_mps`` [m/s] along the
        configured beams, or ``vel_x_mps``, ``vel_y_mps``, ``vel_z_mps`` [m/s] (body FRD) and
        ``valid``; with the modes (:func:`_water_track`) ``beam1_water_track`` ..
        ``beam4_water_track`` or ``water_track`` (1.0 water-track, 0.0 bottom-track).

    Raises
    ------
    LogError
        ``form = 'beams'`` without beams, or beams that are not the configured ones, naming the
        topic and the message.
    """
    form = rule.option("form", "auto")
    where = f"{show_path(bag)}: topic {show(rule.topic)} (dvl)"
    water = _water_track(part, rule)
    if "beams" in part and form != "body":
        require_finite(where, rule.msgtype, "beams", part["beams"], part["beam_valid"] > 0.5)
        beams = _beams(where, part, rule, A_b, C_b_dvl)
        if beams is not None:
            columns = {f"beam{k + 1}_mps": beams[:, k] for k in range(4)}
            if water is not None:
                columns.update({f"beam{k + 1}_water_track": water.copy() for k in range(4)})
            return columns
        if form == "beams":
            raise LogError(
                f"{where}: form = 'beams', but its messages have no beam velocities with beam directions "
                "(or, for a message without directions, no beam_ids in the mapping)"
            )
        notes.append(f"{where}: no per-beam data; its body velocity is projected onto the configured beams")
    require_finite(where, rule.msgtype, "body", part["body"], part["body_valid"][:, 0] == 1.0)
    body = body_vectors(part["body"], rule.frame) @ C_b_dvl.T
    columns = {
        "vel_x_mps": body[:, 0],
        "vel_y_mps": body[:, 1],
        "vel_z_mps": body[:, 2],
        "valid": part["body_valid"][:, 0],
    }
    if water is not None:
        columns["water_track"] = water
    return columns


def dvl_table(
    bag: str,
    part: Mapping[str, np.ndarray],
    rule: TopicRule,
    t_s: np.ndarray,
    water: tuple[Mapping[str, np.ndarray], str, np.ndarray] | None,
    A_b: np.ndarray,
    C_b_dvl: np.ndarray,
    notes: list[str],
) -> dict[str, np.ndarray]:
    """The DVL's table of its topic's messages and, where there is one, its water-track topic's,
    a ping's two messages merged into one row (module docstring).

    Parameters
    ----------
    bag : str
        The bag's path, for the messages.
    part : Mapping of str to numpy.ndarray
        The DVL topic's messages' rows by part, as :func:`dvl_columns` takes them.
    rule : TopicRule
        The DVL topic's rule (its ``ping_tolerance_s`` [s] among the mapping's ``[dvl]`` keys).
    t_s : numpy.ndarray
        The DVL topic's message times (M,) [s] on the log's clock.
    water : tuple or None
        The water-track topic (``water_track_topic``): its messages' rows by part, its type and
        their times (N,) [s] on the log's clock; None: the mapping names none.
    A_b : numpy.ndarray
        The configured Janus beams' unit vectors (4, 3) in the body frame (FRD).
    C_b_dvl : numpy.ndarray
        The DVL's mounting (3, 3), ``v_b = C_b_dvl v_dvl``.
    notes : list of str
        Where a note is added when a body velocity is taken or projected.

    Returns
    -------
    dict of str to numpy.ndarray
        ``t_s`` [s] and the columns of :func:`dvl_columns`, one row per message, where no
        message pairs with one of the other mode and there is no water-track topic; else one row
        per ping: the bottom-track columns of :func:`dvl_columns` without the mode columns (empty,
        ``valid`` 0, where a ping has no bottom-track message) and ``beam1_water_mps`` ..
        ``beam4_water_mps`` [m/s] along the configured beams (empty where it has no water-track
        message).

    Raises
    ------
    LogError
        As :func:`dvl_columns`, or for a topic whose times go back, naming the topic and the message.
    """
    columns = dvl_columns(bag, part, rule, A_b, C_b_dvl, notes)
    modes = [n for n in columns if n.endswith("water_track")]
    is_water = columns[modes[0]] == 1.0 if modes else np.zeros(t_s.size, bool)
    if water is None and not is_water.any():
        return {"t_s": t_s, **columns}
    tolerance = rule.option("ping_tolerance_s", DVL_PING_TOLERANCE_S)
    _check_order(bag, rule.topic, t_s)
    t_water, beams_water = t_s[is_water], _as_beams(columns, A_b)[is_water]
    if water is not None:
        water_part, kind, t_other = water
        topic = rule.option("water_track_topic", "")
        _check_order(bag, topic, t_other)
        other_rule = dataclasses.replace(
            rule, topic=topic, msgtype=kind, options={**rule.options, "water_track": True}
        )
        other = _as_beams(dvl_columns(bag, water_part, other_rule, A_b, C_b_dvl, notes), A_b)
        order = np.argsort(np.concatenate([t_water, t_other]), kind="stable")
        t_water = np.concatenate([t_water, t_other])[order]
        beams_water = np.concatenate([beams_water, other])[order]
    bottom = {n: v[~is_water] for n, v in columns.items() if n not in modes}
    t_bottom = t_s[~is_water]
    paired = _pairs(t_bottom, t_water, tolerance)
    if water is None and (paired < 0).all():  # no ping has both: the table as before
        return {"t_s": t_s, **columns}
    alone = paired < 0
    t_all = np.concatenate([t_bottom, t_water[alone]])
    order = np.argsort(t_all, kind="stable")
    out = {"t_s": t_all[order]}
    for n, v in bottom.items():
        empty = np.full(int(alone.sum()), 0.0 if n == "valid" else np.nan)
        out[n] = np.concatenate([v, empty])[order]
    water_rows = np.full((t_bottom.size, 4), np.nan)
    water_rows[paired[~alone]] = beams_water[~alone]
    water_rows = np.concatenate([water_rows, beams_water[alone]])[order]
    out.update({f"beam{k + 1}_water_mps": water_rows[:, k] for k in range(4)})
    return out


def _check_order(bag: str, topic: str, t_s: np.ndarray) -> None:
    """A topic whose messages are merged with another's may not go back in time (the merge would
    hide it): LogError naming the message."""
    back = np.flatnonzero(np.diff(t_s) < 0)
    if back.size:
        m = int(back[0]) + 2
        raise LogError(
            f"{show_path(bag)}: topic {show(topic)} (dvl), message {m}: its time {float(t_s[m - 1])!r} s goes "
            f"back from the message before ({float(t_s[m - 2])!r} s)"
        )


def _as_beams(columns: Mapping[str, np.ndarray], A_b: np.ndarray) -> np.ndarray:
    """The table's velocities along the configured beams (M, 4) [m/s], NaN where not valid: its
    beams, or its body velocity projected (``v_b . b_k``, as the replay projects a log's)."""
    if "beam1_mps" in columns:
        return np.stack([columns[f"beam{k + 1}_mps"] for k in range(4)], axis=-1)
    body = np.stack([columns[f"vel_{a}_mps"] for a in "xyz"], axis=-1)
    return np.where(columns["valid"][:, None] == 1.0, body @ A_b.T, np.nan)


def _pairs(t_bottom: np.ndarray, t_water: np.ndarray, tolerance_s: float) -> np.ndarray:
    """For each water-track message (N,), the bottom-track message of its ping: the nearest in
    time within ``tolerance_s`` [s] that no nearer water-track message takes (ties: the earlier);
    -1 where none."""
    paired = np.full(t_water.size, -1)
    if t_bottom.size == 0 or t_water.size == 0:
        return paired
    after = np.clip(np.searchsorted(t_bottom, t_water), 0, t_bottom.size - 1)
    before = np.clip(after - 1, 0, t_bottom.size - 1)
    nearest = np.where(np.abs(t_bottom[before] - t_water) <= np.abs(t_bottom[after] - t_water), before, after)
    gap = np.abs(t_bottom[nearest] - t_water)
    close = np.flatnonzero(gap <= tolerance_s)
    close = close[np.lexsort((gap[close], nearest[close]))]  # by bottom message, the nearest first
    first = np.ones(close.size, bool)
    first[1:] = nearest[close][1:] != nearest[close][:-1]
    paired[close[first]] = nearest[close[first]]
    return paired


def _water_track(part: Mapping[str, np.ndarray], rule: TopicRule) -> np.ndarray | None:
    """Each message's mode, 1.0 water-track or 0.0 bottom-track (M,): the mapping's
    ``water_track`` for every message where it sets one, else the message's own (its
    ``velocity_mode``; bottom-track where it has none); None where every message is bottom-track
    and the mapping says nothing (the table then has no mode columns, as before water-track)."""
    m = part["body"].shape[0]
    declared = rule.option("water_track", None)
    if declared is not None:
        return np.full(m, 1.0 if declared else 0.0)
    if "water" not in part:
        return None
    water = np.where(part["water"][:, 0] == 1.0, 1.0, 0.0)
    return water if water.any() else None


def _beams(
    where: str, part: Mapping[str, np.ndarray], rule: TopicRule, A_b: np.ndarray, C_b_dvl: np.ndarray
) -> np.ndarray | None:
    """The messages' beam velocities along the configured beams (M, 4), NaN where not valid; None
    where the messages have no beams that can be placed."""
    sign = rule.option("beam_velocity_sign", 1.0)
    velocity = np.where(part["beam_valid"] > 0.5, part["beams"] * sign, np.nan)
    m = velocity.shape[0]
    dirs = part["dirs"].reshape(m, 4, 3)
    have: np.ndarray = np.asarray(np.isfinite(dirs).all(axis=(1, 2)))  # the messages with directions
    out = np.full((m, 4), np.nan)
    if have.any():
        u = body_vectors(dirs.reshape(-1, 3), rule.frame).reshape(m, 4, 3) @ C_b_dvl.T
        with np.errstate(invalid="ignore", divide="ignore"):
            u = u / np.linalg.norm(u, axis=-1, keepdims=True)
        first = int(np.argmax(have))
        cos = u[first] @ A_b.T  # (message beam, configured beam)
        order = np.argmax(cos, axis=1)
        tolerance = rule.option("beam_tolerance_deg", DVL_BEAM_TOLERANCE_DEG)
        limit = np.cos(tolerance * DEG)
        cos_all = np.einsum("mij,ij->mi", u, A_b[order])  # each message beam against its configured beam
        off = have[:, None] & ~(cos_all >= limit)
        if len(set(order.tolist())) != 4 or off.any():
            row, beam = (int(v) for v in np.argwhere(off)[0]) if off.any() else (first, 0)
            angle = float(np.degrees(np.arccos(np.clip(cos_all[row, beam], -1.0, 1.0))))
            raise LogError(
                f"{where}, message {row + 1}: its beam {beam + 1} points {angle:.3g} deg from the nearest "
                f"configured beam (beam {int(order[beam]) + 1}; at most {tolerance:g} deg; the configured beams "
                "are a Janus at [dvl] beam_pitch_deg, yaw 45 + 90 (k - 1) deg): set the DVL's frame, "
                "mounting_rpy_deg or beam_pitch_deg, or form = 'body' to use its body velocity"
            )
        out[:, order] = np.where(have[:, None], velocity, np.nan)
        return out
    ids = rule.option("beam_ids", None)
    if ids is None or not np.isfinite(part["ids"]).any():
        return None
    for k, beam_id in enumerate(ids):
        match = part["ids"] == beam_id
        out[:, k] = np.where(match.any(axis=1), np.nansum(np.where(match, velocity, 0.0), axis=1), np.nan)
        out[match.any(axis=1) & np.isnan(np.where(match, velocity, 0.0)).any(axis=1), k] = np.nan
    return out
