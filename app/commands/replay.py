"""``tauv replay DIR``: the fusion methods on a recorded log, configured by the defaults, the log's
own configuration file, ``--config`` and the flags, each layer named in the output.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

from app.commands.outputs import json_target, write_json_atomic
from app.commands.values import UsageError, resolve_config
from app.payload import run_payload
from app.tables import summary_table
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.validation import one_line, show, show_path


def cmd_replay(args: argparse.Namespace) -> int:
    """``tauv replay DIR``: the methods on a recorded log (tauvcore.logs, tauvcore.eval.replay),
    configured by the defaults, the log's own configuration file, ``--config``, then the flags."""
    from tauvcore.engine.mission import run
    from tauvcore.eval.replay import judged, log_config, prepare, start_description
    from tauvcore.logs import LogError, read_log

    try:
        log_raw, log_config_path = ({}, None) if args.no_log_config else log_config(args.log)
    except LogError as exc:
        raise UsageError(str(exc)) from None
    config = resolve_config(args, under=log_raw)
    imu_errors = None
    if args.imu_errors is not None:
        if args.imu_errors not in IMU_PROFILES:
            raise UsageError(
                f"--imu-errors: unknown IMU profile {show(args.imu_errors)} "
                f"(choose from {', '.join(IMU_PROFILES)})"
            )
        imu_errors = IMU_PROFILES[args.imu_errors]
    json_path = (
        json_target(args.json, [("the --config file", args.config), ("the log directory", args.log)])
        if args.json is not None
        else None
    )
    started = time.perf_counter()
    try:
        log = read_log(args.log)
        rng = np.random.default_rng(config.run.seed)
        config, sim = prepare(config, log, rng, imu_errors)
        results = judged(log, run(config, sim, rng))
    except LogError as exc:
        raise UsageError(str(exc)) from None
    for note in log.notes:  # after the run: a log refused is one line, its error
        print(f"tauv: note: {one_line(note)}", file=sys.stderr)
    elapsed = time.perf_counter() - started
    source = {
        "directory": str(args.log),
        "config_file": log_config_path,
        "configuration": replay_layers(args, log_raw, log_config_path),
        "start": start_description(config, log),
        "notes": list(log.notes),
    }
    if json_path is not None:
        assert args.json is not None  # json_path is set only when --json was given
        try:
            write_json_atomic(json_path, run_payload(config, results, log=source))
        except OSError as exc:
            raise UsageError(f"--json: cannot write {show_path(args.json)}: {exc.strerror or exc}") from None
    start = source["start"] + ("" if config.replay.initial_errors else " (--initial-errors: start off it)")
    preamble = ["configuration: " + " < ".join(source["configuration"]), start]
    print(
        summary_table(results, config, elapsed, source=f"log {show_path(str(args.log))}", preamble=preamble)
    )
    return 0


REPLAY_NOT_CONFIG = frozenset({"command", "log", "json", "config", "no_log_config"})
"""``tauv replay``'s arguments that are not configuration (what to read, where to write)."""


def replay_layers(
    args: argparse.Namespace, log_raw: dict[str, Any], log_config_path: str | None
) -> list[str]:
    """What configured a replay, lowest first: the defaults, the log's own file and the keys it
    sets, ``--config`` and its keys, the flags given."""

    from tauvcore.eval.replay import config_keys

    layers = ["defaults"]
    if log_config_path is not None:
        layers.append(f"the log's {show_path(log_config_path)} ({config_keys(log_raw) or 'empty'})")
    elif args.no_log_config:
        layers.append("the log's own configuration ignored (--no-log-config)")
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
