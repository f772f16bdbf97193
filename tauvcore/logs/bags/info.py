"""What a bag holds (``tauv log info``): its topics, their types, message counts, rates and time
spans, and the table each would feed under the mapping."""

from __future__ import annotations

import os
from dataclasses import dataclass

from tauvcore.logs.bags.mapping import EXTRA_TOPICS, BagMapping, resolve
from tauvcore.logs.bags.ros_reader import bag_errors, open_bag, typestore, why
from tauvcore.logs.bags.tf import dvl_mounting
from tauvcore.validation import LogError, one_line, show_path


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag."""

    topic: str
    msgtype: str  # e.g. sensor_msgs/msg/Imu
    count: int  # messages
    start_s: float  # first receive time [s] after the bag's first message
    end_s: float  # last receive time [s] after the bag's first message
    table: str  # the log's table it feeds under the mapping ('' for none)

    @property
    def rate_hz(self) -> float:
        """Messages per second over the topic's span (NaN for fewer than two)."""
        span = self.end_s - self.start_s
        return (self.count - 1) / span if self.count > 1 and span > 0 else float("nan")


def bag_info(path: str | os.PathLike, mapping: BagMapping) -> tuple[list[TopicInfo], str | None, str | None]:
    """The topics of the bag at ``path`` and the table each feeds under ``mapping``.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 bag, a ROS 2 bag directory or an MCAP file.
    mapping : BagMapping
        The bag mapping (``BagMapping()``: none, each table found by type).

    Returns
    -------
    tuple of list of TopicInfo, str or None and str or None
        The topics in name order; why the mapping does not apply to this bag (a topic it names
        missing, two topics of a table's type with no mapping, ...) or None; where the DVL's
        mounting comes from (the mapping's ``mounting_rpy_deg``, ``/tf_static``, or "none";
        tauvcore.logs.bags.tf), None without a DVL topic or when the mapping does not apply. The
        topics are listed either way.

    Raises
    ------
    LogError
        A bag that cannot be read, naming it.
    """
    bag = os.fspath(path)
    reader = open_bag(bag, typestore(mapping.msg_paths, mapping.path))
    try:
        topics = {c.topic: c.msgtype for c in reader.connections}
        first: dict[str, int] = {}
        last: dict[str, int] = {}
        count = dict.fromkeys(topics, 0)
        try:
            for connection, received, _ in reader.messages():
                first.setdefault(connection.topic, received)
                last[connection.topic] = received
                count[connection.topic] += 1
        except bag_errors() as exc:  # a corrupt chunk part-way through
            raise LogError(one_line(f"{show_path(bag)}: cannot be read as a ROS bag: {why(exc)}")) from None
        problem = mounting = None
        feeds: dict[str, list[str]] = {}
        try:
            rules = resolve(mapping, topics, bag)
            for table, rule in rules.items():
                feeds.setdefault(rule.topic, []).append(table)
                for key in EXTRA_TOPICS:
                    if key in rule.options:
                        feeds.setdefault(rule.options[key], []).append(f"{table} ({key})")
            if "dvl" in rules:
                found = dvl_mounting(reader, bag, mapping, rules)
                t = found.r_b_m
                mounting = found.source + (
                    "" if t is None else f" (translation {[round(float(v), 4) for v in t]} m FRD)"
                )
        except LogError as exc:
            problem = str(exc)
        except bag_errors() as exc:
            problem = one_line(
                f"{show_path(bag)}: /tf_static or the DVL's first message cannot be read: {why(exc)}"
            )
    finally:
        reader.close()
    origin = min(first.values(), default=0)
    rows = [
        TopicInfo(
            topic,
            kind,
            count[topic],
            (first.get(topic, origin) - origin) * 1e-9,
            (last.get(topic, origin) - origin) * 1e-9,
            ", ".join(feeds.get(topic, [])),
        )
        for topic, kind in sorted(topics.items())
    ]
    return rows, problem, mounting
