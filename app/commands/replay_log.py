"""``tauv replay PATH``: the fusion methods on a recorded log or a ROS bag, configured by the defaults, the log's
own configuration file, ``--config`` and the flags, each layer named in the output.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from typing import Any

import numpy as np

from app.commands.mcap_output import McapOutput, TruthTap, mcap_target
from app.commands.outputs import json_target
from app.commands.smooth_flags import smooth_options, smoothing
from app.commands.values import UsageError, choice, resolve_config
from app.reports.tables import summary_table
from tauvcore.config import Config
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.validation import one_line, show_path


def cmd_replay(args: argparse.Namespace) -> int:
    """``tauv replay DIR``: the methods on a recorded log (tauvcore.logs, tauvcore.eval.replay),
    configured by the defaults, the log's own configuration file, ``--config``, then the flags.

    The log is read whole; its truth and IMU rows are made chunk by chunk as the engine asks for
    them (tauvcore.eval.replay.LogRows; with ``--imu-errors`` at once), and the results reduced
    chunk by chunk as the engine hands them out (tauvcore.eval.replay.replay_chunked: the
    summary's sums, tauvcore.eval.running; the ``--json`` document spooled to disk,
    app.commands.json_stream), so that only the log takes memory that grows with its length.
    ``--smooth``: as ``tauv run``'s (app.commands.run.cmd_run), the smoothed results judged as the
    filtered. ``--mcap``: as ``tauv run``'s, stamped by the log's times (its first IMU time added),
    the log's reference as the truth (app.commands.mcap_output.TruthTap)."""
    from app.commands.json_stream import RunReduction
    from tauvcore.eval.replay import prepare_rows, replay_chunked
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.bags import read_bag_configured

    bag = _is_bag(args)
    mapping, log_raw, log_config_path = _recording_config(args, bag)
    config = resolve_config(args, under=log_raw)
    smooth = smooth_options(args, config)
    imu_errors = None
    if args.imu_errors is not None:
        imu_errors = IMU_PROFILES[choice("--imu-errors", args.imu_errors, IMU_PROFILES, "IMU profile")]
    inputs = [("the --config file", args.config), ("the log directory", args.log)]
    json_path = json_target(args.json, inputs) if args.json is not None else None
    mcap_path = mcap_target(args, inputs)
    started = time.perf_counter()
    reduction = mcap = None
    try:
        if bag:  # one open of the bag: its tables and the DVL's lever arm from its /tf_static
            log, with_lever, with_path = read_bag_configured(
                args.log, mapping, config.dvl.A_b, log_raw, log_config_path
            )
            if with_lever != log_raw:
                log_raw, log_config_path = with_lever, with_path
                config = resolve_config(args, under=log_raw)
        else:
            log = read_log(args.log)
        rng = np.random.default_rng(config.run.seed)
        # --imu-errors P tunes the filters for P; --imu Q with it tunes them for Q (tauvcore.eval.replay.prepare)
        imu_tuning = config.imu if imu_errors is not None and args.imu is not None else None
        config, sim = prepare_rows(config, log, rng, imu_errors, imu_tuning)
        source = _log_source(args, config, log, log_raw, log_config_path)
        if bag:  # the mapping read (--bag-mapping, else the file beside the bag; None: by type), as the dashboard's
            source["bag_mapping"] = mapping.path
        reduction = RunReduction(config, json_path, args.json, log=source, smoothed=smooth is not None)
        on_chunk, on_smoothed = reduction.add, reduction.add_smoothed
        if (
            mcap_path is not None
        ):  # stamped by the log's times (its first IMU time added); its reference as the truth
            mcap = McapOutput(mcap_path, args.mcap, config, origin_s=float(log.imu_t_s[0]))
            on_chunk, on_smoothed = _mcap_too(reduction, mcap)
            sim = TruthTap(sim, mcap.add_truth) if log.ref_t_s is not None else sim
        with smoothing(smooth) as options:
            replay_chunked(config, sim, log, rng, on_chunk, smooth=options, on_smoothed_chunk=on_smoothed)
        if mcap is not None:
            mcap.finish()
    except BaseException as exc:
        if reduction is not None:
            reduction.discard()
        if mcap is not None:
            mcap.discard()
        if isinstance(exc, LogError):
            raise UsageError(str(exc)) from None
        raise
    for note in log.notes:  # after the run: a log refused is one line, its error
        print(f"tauv: note: {one_line(note)}", file=sys.stderr)
    elapsed = time.perf_counter() - started
    summaries = reduction.finish()
    start = source["start"] + ("" if config.replay.initial_errors else " (--initial-errors: start off it)")
    preamble = ["configuration: " + " < ".join(source["configuration"]), start, source["reference"]]
    preamble += [source["imu"]] if "imu" in source else []
    print(
        summary_table(
            summaries,
            config,
            elapsed,
            source=f"log {show_path(str(args.log))}",
            preamble=preamble,
            smoothed=reduction.smoothed_summaries,
        )
    )
    return 0


def _mcap_too(reduction: Any, mcap: McapOutput) -> tuple[Any, Any]:
    """The engine's ``on_chunk`` and ``on_smoothed_chunk`` feeding both the reduction and ``--mcap``."""
    from app.commands.mcap_output import chained

    return chained(reduction.add, mcap.add), chained(reduction.add_smoothed, mcap.add_smoothed)


def _is_bag(args: argparse.Namespace) -> bool:
    """Whether ``PATH`` names a ROS bag (else a log directory), refusing an empty name and
    ``--bag-mapping`` for a log directory."""
    from tauvcore.logs.bags import is_bag

    if not args.log.strip():  # not the current directory: a name that names nothing
        raise UsageError(f"PATH: {show_path(args.log)} is not a log's name (the current directory is '.')")
    bag = is_bag(args.log, by_name=True)
    if args.bag_mapping is not None and not bag:
        raise UsageError(
            f"--bag-mapping {show_path(args.bag_mapping)}: {show_path(args.log)} is not a ROS bag (a .bag or .mcap file, or a ROS 2 bag "
            "directory with metadata.yaml); a log directory needs none"
        )
    return bag


def _recording_config(args: argparse.Namespace, bag: bool) -> tuple[Any, dict[str, Any], str | None]:
    """The bag's mapping (a log directory's: none) and the configuration the recording carries,
    raw, with the file it is in (none with ``--no-log-config``)."""
    from tauvcore.eval.replay import log_config
    from tauvcore.logs import LogError
    from tauvcore.logs.bags import BagMapping, bag_config, own_mapping, read_mapping

    try:
        if not bag:
            mapping = BagMapping()
        elif args.bag_mapping is not None:
            mapping = read_mapping(args.bag_mapping, label="--bag-mapping")
        else:  # the mapping beside the bag (its stem, .toml), as the dashboard reads it; or by type
            mapping = own_mapping(args.log)
        if args.no_log_config:  # a bag's too: its mapping's [config] and the DVL's mounting from /tf_static
            return dataclasses.replace(mapping, tf_static=False), {}, None
        # a bag's own configuration is its mapping's [config] (the /tf_static lever arm: from the read)
        log_raw, log_config_path = bag_config(mapping) if bag else log_config(args.log)
    except LogError as exc:
        raise UsageError(str(exc)) from None
    return mapping, log_raw, log_config_path


def _log_source(
    args: argparse.Namespace, config: Config, log: Any, log_raw: dict[str, Any], log_config_path: str | None
) -> dict[str, Any]:
    """The log as ``--json``'s ``"log"`` describes it: its directory, its configuration file, what
    configured the run, where the filters started, what the NEES is measured against, the
    reader's notes and, with ``--imu-errors``, the IMU and what the filters are tuned for."""
    from tauvcore.eval.replay import start_description

    source = {
        "directory": str(args.log),
        "config_file": log_config_path,
        "configuration": replay_layers(args, log_raw, log_config_path),
        "start": start_description(config, log),
        "reference": config.reference.describe(log.ref_t_s is not None),
        "notes": list(log.notes),
    }
    if args.imu_errors is not None:  # what the IMU is and what the filters are tuned for
        source["imu"] = (
            f"IMU: the log's with the errors of {args.imu_errors} added (drawn from seed {config.run.seed}); "
            f"the filters tuned for {args.imu if args.imu is not None else args.imu_errors}"
        )
    return source


REPLAY_NOT_CONFIG = frozenset(
    {"command", "func", "log", "json", "mcap", "config", "no_log_config", "bag_mapping"}
    | {"smooth", "smooth_memory_mb", "smooth_dir"}
)
"""``tauv replay``'s arguments that are not configuration (what to read, where to write, the smoother)."""


def replay_layers(
    args: argparse.Namespace, log_raw: dict[str, Any], log_config_path: str | None
) -> list[str]:
    """What configured a replay, lowest first: the defaults, the log's own file and the keys it
    sets, ``--config`` and its keys, the flags given."""

    from tauvcore.eval.replay import config_keys
    from tauvcore.logs.bags import is_bag

    layers = ["defaults"]
    if log_config_path is not None:
        kind = "the bag mapping's [config] in" if is_bag(args.log) else "the log's"
        if log_config_path.endswith(":/tf_static"):  # the DVL's lever arm from the bag (bag_config)
            kind = "the bag's"
        layers.append(f"{kind} {show_path(log_config_path)} ({config_keys(log_raw) or 'empty'})")
    elif args.no_log_config:
        ignored = (
            "the bag's own configuration ignored (--no-log-config: its mapping's [config], the DVL's "
            "mounting rotation and lever arm from /tf_static)"
            if is_bag(args.log)
            else "the log's own configuration ignored (--no-log-config)"
        )
        layers.append(ignored)
    if args.config:
        layers.append(f"--config {show_path(args.config)}")
    flags = [
        f"--{name.replace('_', '-')}"
        for name, value in vars(args).items()
        if name not in REPLAY_NOT_CONFIG and value not in (None, False, [])
    ]
    if flags:
        layers.append("flags " + " ".join(flags))
    return layers
