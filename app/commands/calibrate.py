"""``tauv calibrate LOG... --out cal.toml``: the DVL's mounting misalignment and scale factor and the
IMU-to-reference boresight from logs with a reference (tauvcore.eval.calibration), printed as a
table with each quantity's 1-sigma and its parts, and written as a ``[calibration]`` section that
``tauv replay --config`` (and a log's own ``log.toml``, which the dashboard reads) applies.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import IO, TYPE_CHECKING

import tomli_w

from app.commands.outputs import output_target, write_text_atomic
from app.commands.values import UsageError, resolve_config
from app.reports.vehicle_reports import calibration_sections, calibration_table, number_to_sigma
from tauvcore.config import Config
from tauvcore.validation import show_path

if TYPE_CHECKING:
    from tauvcore.eval.calibration import Calibration
    from tauvcore.logs import Log


def cmd_calibrate(args: argparse.Namespace) -> int:
    """``tauv calibrate LOG... --out FILE``: read every log (a log directory, a ROS bag with the
    mapping beside it), each configured as ``tauv replay`` configures it (the defaults, the log's
    own configuration, ``--config``, ``--imu``), estimate the calibration of all of them together,
    print the table and write ``--out`` (refused if it exists, without ``--replace``)."""
    from tauvcore.eval.calibration import CalibrationError, calibrate

    out = output_target(
        "--out",
        args.out,
        [("the --config file", args.config), *(("a log", p) for p in args.logs)],
        None if args.replace else "exists; give --replace to replace it",
    )
    logs = []
    for path in args.logs:
        log, config = _read(args, path)
        logs.append((path, log, config))
    try:
        result = calibrate(logs)
    except CalibrationError as exc:
        raise UsageError(str(exc)) from None
    print(calibration_table(result))
    text = calibration_toml(result, [show_path(p) for p in args.logs])
    write_text_atomic(out, lambda fh: _write(fh, text))
    print(f"written {show_path(args.out)}: tauv replay LOG --config {show_path(args.out)} applies it")
    return 0


def _write(fh: IO[str], text: str) -> None:
    fh.write(text)


def _read(args: argparse.Namespace, path: str) -> tuple[Log, Config]:
    """One log read and configured as ``tauv replay`` does (the log's own file under ``--config``
    and the flags), a LogError as one line."""
    from tauvcore.eval.replay import log_config
    from tauvcore.logs import LogError, read_log
    from tauvcore.logs.bags import bag_config, is_bag, own_mapping, read_bag_configured

    if not path.strip():
        raise UsageError(f"LOG: {show_path(path)} is not a log's name (the current directory is '.')")
    try:
        bag = is_bag(path, by_name=True)
        if args.no_log_config:
            raw, where = {}, None
            mapping = own_mapping(path) if bag else None
        elif bag:
            mapping = own_mapping(path)
            raw, where = bag_config(mapping)
        else:
            mapping = None
            raw, where = log_config(path)
        config = resolve_config(args, under=raw)
        if bag:
            assert mapping is not None
            log, with_lever, _ = read_bag_configured(path, mapping, config.dvl.A_b, raw, where)
            if with_lever != raw:
                config = resolve_config(args, under=with_lever)
        else:
            log = read_log(path)
    except LogError as exc:
        raise UsageError(str(exc)) from None
    return log, config


def calibration_toml(result: Calibration, logs: Sequence[str]) -> str:
    """The ``[calibration]`` section of ``result`` as TOML, with comments: where it comes from and
    each value's 1-sigma."""
    comments = [
        "# tauv calibrate: the DVL's mounting misalignment and scale factor and the IMU-to-reference",
        f"# boresight, estimated together from {len(logs)} log{'s' if len(logs) != 1 else ''}: {', '.join(logs)}",
        "# (docs/calibration.md). tauv replay LOG --config THIS_FILE applies it; so does a log's own",
        "# log.toml holding this section (the dashboard reads that one).",
        "# value +- 1-sigma:",
    ]
    for est in (result.dvl, result.boresight):
        for name, unit, value, sigma in zip(est.names, est.units, est.value, est.sigma, strict=True):
            comments.append(f"#   {name}: {number_to_sigma(value, sigma)} +- {sigma:.2g} {unit}")
    return "\n".join(comments) + "\n" + tomli_w.dumps(calibration_sections(result))
