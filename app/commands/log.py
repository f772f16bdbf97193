"""``tauv log info PATH`` and ``tauv log convert PATH OUT_DIR``: what a ROS bag holds, and the bag
written as a log (tauvcore.logs' format), so that it can be inspected, edited, or replayed many
times fast.
"""

from __future__ import annotations

import argparse
import math
import typing
from pathlib import Path

from app.commands.values import UsageError
from tauvcore.validation import LogError, OutputDirError, show, show_path

if typing.TYPE_CHECKING:
    from tauvcore.logs.bags.mapping import BagMapping


def _mapping(args: argparse.Namespace) -> BagMapping:
    """The bag mapping of ``--bag-mapping``, else the one beside the bag (tauvcore.logs.bags.own_mapping;
    none: every table by type), once PATH is a bag."""
    from tauvcore.logs.bags import is_bag, own_mapping, read_mapping

    if not is_bag(args.bag, by_name=True):
        raise UsageError(
            f"{show_path(args.bag)}: not a ROS bag (a .bag or .mcap file, or a ROS 2 bag directory with "
            "metadata.yaml)"
        )
    try:
        if args.bag_mapping is None:
            return own_mapping(args.bag)
        return read_mapping(args.bag_mapping, label="--bag-mapping")
    except LogError as exc:
        raise UsageError(str(exc)) from None


def cmd_log_info(args: argparse.Namespace) -> int:
    """``tauv log info PATH``: the bag's topics, their types, message counts, rates and time spans,
    and the table each feeds under the mapping (or why the mapping does not apply)."""
    from tauvcore.logs.bags.info import bag_info

    mapping = _mapping(args)
    try:
        rows, problem, mounting = bag_info(args.bag, mapping)
    except LogError as exc:
        raise UsageError(str(exc)) from None
    header = ("topic", "type", "messages", "rate [Hz]", "from [s]", "to [s]", "feeds")
    table = [
        (
            r.topic,
            r.msgtype,
            str(r.count),
            "-" if math.isnan(r.rate_hz) else f"{r.rate_hz:.4g}",
            f"{r.start_s:.3f}",
            f"{r.end_s:.3f}",
            r.table or "-",
        )
        for r in rows
    ]
    widths = [max(len(h), *(len(row[i]) for row in table)) for i, h in enumerate(header)]
    print(
        f"bag {show_path(args.bag)}, mapping: {show_path(mapping.path) if mapping.path else 'none (by type)'}"
    )
    for row in (header, *table):
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip())
    if mounting is not None:
        print(f"dvl mounting: {mounting}")
    if problem is not None:
        print(f"the mapping does not apply: {problem}")
    return 0


def cmd_log_convert(args: argparse.Namespace) -> int:
    """``tauv log convert PATH OUT_DIR``: the bag's tables, checked as the log reader checks a log,
    written as a log with tauvcore.logs.writer (all or nothing), with the configuration the
    conversion used as the log's own ``log.toml`` (tauvcore.config.to_log_toml of the mapping's
    ``[config]`` and the DVL's lever arm from ``/tf_static``: its beam geometry, lever arm and
    every other section that differs from the defaults, as ``tauv run --save-log`` writes a
    simulation's), so that a replay of the log is configured as a replay of the bag; OUT_DIR
    follows the rule of every writer (tauvcore.logs.writer.output_dir: new in an existing
    directory, or empty), so nothing is ever overwritten."""
    from tauvcore.config import from_dict, to_log_toml
    from tauvcore.logs import log_from_tables
    from tauvcore.logs.bags import bag_config, bag_tables, with_tf_lever_arm
    from tauvcore.logs.writer import output_dir, write_log

    if args.log_format not in ("csv", "parquet"):
        raise UsageError(f"--log-format must be csv or parquet, got {show(args.log_format)}")
    mapping = _mapping(args)
    out = Path(args.out_dir)
    bag = Path(args.bag)
    inputs = [("the bag", args.bag), ("the --bag-mapping file", mapping.path)]
    try:
        output_dir(args.out_dir, "OUT_DIR", inputs=inputs)
    except OutputDirError as exc:
        raise UsageError(str(exc)) from None
    try:
        raw, source = bag_config(mapping)  # the lever arm from /tf_static: from the read, one open
        config = from_dict(raw)
        read = bag_tables(bag, mapping, config.dvl.A_b)
        lever = None if read.mounting is None else read.mounting.r_b_m
        raw, _ = with_tf_lever_arm(mapping, raw, source, bag, lever)
        config = from_dict(raw)  # what a replay of the bag takes: the log's own configuration
        log = log_from_tables(read.tables, read.source, read.names)  # every check, before anything is written
    except LogError as exc:
        raise UsageError(str(exc)) from None
    try:
        write_log(out, read.tables, args.log_format, config_toml=to_log_toml(config))
    except OSError as exc:
        raise UsageError(
            f"OUT_DIR: {show_path(args.out_dir)}: cannot be written: {exc.strerror or exc}"
        ) from None
    rows = ", ".join(f"{t} {len(c['t_s'])} rows ({read.rules[t].topic})" for t, c in read.tables.items())
    print(f"written {show_path(args.out_dir)} ({args.log_format}): {rows}; {log.duration_s:.3f} s of IMU")
    return 0
