"""The ``tauv`` command line: run scenarios and print or save their results.

    tauv run --trajectory figure8 --method ins,lc --duration 250 --seed 1 --json out.json
    tauv run --method all --beams 1,2            # only beams 1 and 2 return (the paper's case)
    tauv run --method lc,tc,elc --outage 3,4@50:200 --dropout 0.05
    tauv run --method vb,nsv --beams 1,2 --vb-nf 10 --nsv-epsilon 0.05   # the partial methods' assumptions
    tauv config > my.toml          # full default configuration; edit and pass back with --config
    tauv serve --port 8080         # the browser dashboard

Bad input (unknown trajectory or method, a value outside its range, malformed or unknown TOML,
a configuration that is not a small regular UTF-8 file, ...) prints one line naming the field,
flag or file and the value (shortened if long) and exits with 2. ``--json`` is written
atomically (a temporary file in the same directory, then renamed), so no half-written file is
ever left; it is strict JSON (non-finite numbers become null).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import os
import signal
import stat
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from typing import Any, NoReturn

import numpy as np

from app.payload import config_to_json, run_payload
from app.tables import study_table, summary_table
from tauvcore.aiding import AIDING_SOURCES
from tauvcore.aiding.registry import REGISTRY
from tauvcore.config import (
    AUTO,
    METHODS,
    RUN_METHODS,
    Config,
    from_dict,
    merge,
    read_toml,
    to_toml,
    trajectory_preset,
)
from tauvcore.geo.earth import EARTH_MODELS
from tauvcore.sensors.dvl import Outage
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.truth import PAPER_TRAJECTORIES, TRAJECTORIES, TRUTH_SOURCES
from tauvcore.validation import ConfigError, one_line, shorten, show, show_path

EXIT_BAD_INPUT = 2
MAX_STUDY_RUNS = 100_000
"""Most runs of one ``tauv mc`` study: memory stays flat (chunks are reduced as they finish), so
the bound is time: 100,000 runs of 250 s are hours even on a cluster."""
MAX_WORKERS = 64


EXIT_STUDY_FAILED = 1


class StudyFailedError(Exception):
    """A study could not finish for a reason outside its input (a worker process died, the Dask
    scheduler or a worker went away); the message is the one line shown to the user."""


class UsageError(Exception):
    """Bad command-line input; the message is the one line shown to the user."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line (no usage dump) and exits with 2.

    Abbreviated flags (``--dur 3``) are refused: an abbreviation that works today would change
    meaning silently when a flag with the same prefix is added.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        # argparse quotes values whole ("unrecognized arguments: <500 kB>"): shorten each word
        raise UsageError(" ".join(shorten(word) for word in message.split(" ")))


def option_actions(parser: argparse.ArgumentParser) -> dict[str, list[argparse.Action]]:
    """The optional arguments of ``parser`` ('' for its own) and of each subcommand, by name.
    :data:`VALUE_FLAGS` and :data:`OTHER_FLAGS` are derived from them, so a flag added to the
    parser is known to :func:`attach_dash_values` and :func:`_require_text_values` at once."""
    found: dict[str, list[argparse.Action]] = {"": []}
    for action in parser._actions:  # argparse keeps no public list of them
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found[name] = [a for a in sub._actions if a.option_strings]
        elif action.option_strings:
            found[""].append(action)
    return found


def attach_dash_values(argv: Sequence[str]) -> list[str]:
    """``--flag -value`` -> ``--flag=-value`` for every flag that takes a value.

    argparse reads a token that begins with ``-`` as an option unless it looks like a negative
    number, so ``--dropout -inf`` would fail with "expected one argument" and no value. Joined,
    the value reaches the flag's own check, whose message names the flag and the value. A token
    that is itself a known flag is left alone (``--dropout --json x``: the value is missing).
    """
    out: list[str] = []
    i = 0
    while i < len(argv):
        token = argv[i]
        if token == "--":
            out.extend(argv[i:])
            break
        nxt = argv[i + 1] if i + 1 < len(argv) else None
        if (
            token in VALUE_FLAGS
            and nxt is not None
            and nxt.startswith("-")
            and nxt not in VALUE_FLAGS | OTHER_FLAGS
            and nxt != "--"
        ):
            out.append(f"{token}={nxt}")
            i += 2
        else:
            out.append(token)
            i += 1
    return out


def _csv(
    flag: str,
    text: str,
    choices: Sequence[str],
    allow_all: bool = False,
    all_means: Sequence[str] | None = None,
) -> tuple[str, ...]:
    items = tuple(s.strip() for s in text.split(",") if s.strip())
    if allow_all and items == ("all",):
        return tuple(choices if all_means is None else all_means)
    if not items:
        raise UsageError(
            f"{flag}: expected a comma-separated list from {', '.join(choices)}, got {show(text)}"
        )
    for item in items:
        if item not in choices:
            raise UsageError(f"{flag}: unknown value {show(item)} (choose from {', '.join(choices)})")
    if len(set(items)) != len(items):
        raise UsageError(f"{flag}: repeated value in {show(text)}")
    return items


def _path(text: str) -> str:
    """The argparse ``type`` of a flag that names a file or directory (:data:`PATH_FLAGS` is derived
    from it); the text is kept as given."""
    return text


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="tauv", description="Underwater INS/DVL navigation lab (Tal, Klein & Katz 2017).")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    r = sub.add_parser("run", help="simulate a mission and run fusion methods side by side")
    _mission_flags(r)
    r.add_argument(
        "--ideal", action="store_true", help="zero every sensor and initial error (verification mode)"
    )
    r.add_argument(
        "--json",
        type=_path,
        help="write the configuration, per-epoch results and consistency (NEES, NIS) to this "
        "JSON file (strict JSON, written atomically; not the --config file)",
    )
    r.add_argument(
        "--save-log",
        type=_path,
        metavar="DIR",
        help="also write the simulated sensors and truth as a log "
        "(tauv replay reads it; see the README's log format)",
    )
    r.add_argument("--log-format", default="csv", help="csv (default) or parquet, for --save-log")
    rl = sub.add_parser(
        "replay", help="run the fusion methods on a recorded log (a directory of sensor tables)"
    )
    rl.add_argument(
        "log",
        type=_path,
        metavar="DIR",
        help="the log directory (imu, reference, and dvl, depth, attitude tables)",
    )
    _method_flags(rl)
    rl.add_argument(
        "--imu-errors",
        metavar="PROFILE",
        help=f"add a simulated IMU's errors to the log's IMU: "
        f"{', '.join(IMU_PROFILES)} (drawn from --seed; the "
        "filters are tuned for that IMU)",
    )
    rl.add_argument(
        "--config",
        type=_path,
        help="TOML file: the filters' tuning and the DVL's geometry (see 'tauv config'), laid over "
        "the log's own DIR/log.toml",
    )
    rl.add_argument(
        "--no-log-config",
        action="store_true",
        help="ignore the log's own configuration file (DIR/log.toml)",
    )
    rl.add_argument(
        "--initial-errors",
        action="store_true",
        help="start the filters off the log's reference by the initial errors, as a simulation does "
        "([initial_error]: fixed values, or drawn from --seed with mode = random); default: on the "
        "reference's first row, with those errors as the starting sigmas",
    )
    rl.add_argument(
        "--json", type=_path, help="write the configuration and per-epoch results to this JSON file"
    )
    mc = sub.add_parser(
        "mc", help="Monte Carlo study: N seeded runs, summary.json, runs.parquet and report.html"
    )
    _mission_flags(mc)
    mc.add_argument("--runs", required=True, help=f"number of Monte Carlo runs, 1 to {MAX_STUDY_RUNS}")
    mc.add_argument(
        "--out",
        type=_path,
        required=True,
        help="output directory (created if missing; files appear only when the study has finished)",
    )
    mc.add_argument("--workers", help="local processes computing chunks of runs (default 1; at most 64)")
    mc.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="send the chunks to this Dask scheduler instead, e.g. "
        "tcp://10.0.0.5:8786 (its workers need tauv installed)",
    )
    rp = sub.add_parser(
        "reproduce",
        help="the first paper's study: 3 trajectories, beams 3 and 4 lost, 100 runs, "
        "with every figure of its section 4.2 beside ours",
    )
    rp.add_argument("--out", type=_path, required=True, help="output directory (as for mc)")
    rp.add_argument("--runs", help="Monte Carlo runs per trajectory (default 100, the paper's study)")
    rp.add_argument("--duration", help="run length [s] (default 250, the paper's; shorter for a quick check)")
    rp.add_argument("--seed", help="seed of the study (default 0)")
    rp.add_argument("--workers", help="local processes computing chunks of runs (default 1; at most 64)")
    rp.add_argument("--dask", metavar="ADDRESS", help="send the chunks to this Dask scheduler instead")
    sv = sub.add_parser("serve", help="start the browser dashboard")
    sv.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1; 0.0.0.0 in Docker)"
    )
    sv.add_argument("--port", default="8080", help="TCP port (default 8080)")
    sv.add_argument(
        "--workers", help="runs computed at once, one process each (default: min(2, CPUs); at most 64)"
    )
    sv.add_argument(
        "--logs",
        type=_path,
        metavar="DIR",
        help="offer the recorded logs in DIR (it, or its subdirectories) as "
        "sources to replay in the dashboard",
    )
    c = sub.add_parser("config", help="print the full configuration as TOML")
    c.add_argument("--config", type=_path, help="TOML file to merge over the defaults before printing")
    _imu_flag(c)
    _earth_flag(c)
    for subparser, command in (
        (r, cmd_run),
        (rl, cmd_replay),
        (mc, cmd_mc),
        (rp, cmd_reproduce),
        (sv, cmd_serve),
        (c, cmd_config),
    ):
        subparser.set_defaults(func=command)
    return parser


def _mission_flags(p: argparse.ArgumentParser) -> None:
    """The flags that describe a mission and its methods (``run`` and ``mc``)."""
    p.add_argument("--trajectory", help=f"one of {', '.join(TRAJECTORIES)} (default from config: straight)")
    p.add_argument("--duration", help="run length [s], 1 to 36000 (default 250)")
    p.add_argument(
        "--truth",
        metavar="SOURCE",
        help=f"how the truth is made: {', '.join(TRUTH_SOURCES)} "
        "(default kinematic: closed-form profiles; dynamic: the 6-DOF "
        "TAUV flown through the scenario by its autopilot, with fins "
        "and propeller)",
    )
    _method_flags(p)
    p.add_argument(
        "--rpm-fallback",
        action="store_true",
        help="the DVL methods fuse the propeller RPM's velocity "
        "(Yoo 2014's velocity Kalman filter, learnt from the "
        "DVL) whenever they have no DVL velocity",
    )
    _imu_flag(p)
    p.add_argument("--config", type=_path, help="TOML file (partial files allowed; see 'tauv config')")


def _method_flags(p: argparse.ArgumentParser) -> None:
    """The flags of the methods, their aiding and the DVL's beams (``run``, ``mc`` and ``replay``)."""
    p.add_argument(
        "--method",
        help=f"comma-separated from {', '.join(RUN_METHODS)}, or 'all' (the first paper's "
        "eight) (default: ins,lc). ins-dvl and vkf are Yoo 2014's 12-state filter, aided "
        "by the DVL, or by its velocity Kalman filter switching to the propeller RPM "
        "beyond DVL range; "
        + "; ".join(f"{m.name}: {m.summary}" for m in REGISTRY.values())
        + " (registered in tauvcore/aiding/registry.py)",
    )
    p.add_argument("--seed", help="seed of the random generator: noise, initial errors, dropout (default 0)")
    p.add_argument("--aiding", help=f"comma-separated from {', '.join(AIDING_SOURCES)} (default: dvl)")
    p.add_argument(
        "--beams", help="comma-separated beams that return for the whole run, e.g. 1,2 (default 1,2,3,4)"
    )
    p.add_argument(
        "--outage",
        action="append",
        default=[],
        metavar="BEAMS@START:END",
        help="beams lost in a window, e.g. 3,4@50:200 (seconds); repeatable",
    )
    p.add_argument("--dropout", help="probability in [0, 1] that each beam misses each ping")
    p.add_argument(
        "--vb-nf",
        metavar="N",
        help="n_f of VB's virtual beam (also inflates VHV's predicted heave), "
        f"a number in [1, 100] (default {Config().partial.vb_nf:g})",
    )
    p.add_argument(
        "--nsv-epsilon",
        metavar="E",
        help="NSV's (and ELC's) variance of the 'sway = 0' assumption "
        "[m^2/s^2], a number in (0, 100] or 'auto' (default auto: "
        "from the vehicle's sideslip in its tightest turn)",
    )
    _earth_flag(p)


def _earth_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--earth",
        metavar="MODEL",
        help=f"earth model: {', '.join(EARTH_MODELS)} (default wgs84: "
        "geodetic position, gravity and earth rate along the path, "
        "transport rate; flat: the paper's tangent plane with constant "
        "gravity). The origin is [earth] latitude_deg, longitude_deg "
        "and [trajectory] depth_m",
    )


def _imu_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--imu",
        metavar="PROFILE",
        help=f"IMU error model by name: {', '.join(IMU_PROFILES)} "
        "(default table2: Tal et al. 2017 Table 2; yoo-table1: "
        "Yoo 2014 Table 1, a 1 deg/h IMU at 100 Hz). Replaces the "
        "file's [imu] section",
    )


def resolve_config(args: argparse.Namespace, under: dict[str, Any] | None = None) -> Config:
    """Defaults, then ``under`` (a replayed log's own configuration), then the --config file, then
    the command-line flags.

    The run length is applied together with the file, so a file's outage after the default 250 s
    is valid when --duration makes the run long enough.
    """
    if getattr(args, "config", None) is not None and not args.config.strip():
        raise UsageError(f"--config: expected a TOML file name, got {show(args.config)}")
    raw = merge(under or {}, read_toml(args.config) if args.config else {})
    if getattr(args, "duration", None) is not None:
        duration = _parse("--duration", args.duration, float, "a number of seconds")
        _replace("--duration", Config(), "trajectory", duration_s=duration)  # check it on its own first
        raw = merge(raw, {"trajectory": {"duration_s": duration}})
    name = getattr(args, "trajectory", None)
    if name is None and isinstance(raw.get("trajectory"), dict):
        name = raw["trajectory"].get("name")
    if isinstance(name, str):
        raw = merge(trajectory_preset(name), raw)  # the scenario's own values, under the file's
    config = from_dict(raw)
    if getattr(args, "imu", None) is not None:
        if args.imu not in IMU_PROFILES:
            raise UsageError(
                f"--imu: unknown IMU profile {show(args.imu)} (choose from {', '.join(IMU_PROFILES)})"
            )
        config = _replace("--imu", config, "imu", **dataclasses.asdict(IMU_PROFILES[args.imu]))
    if getattr(args, "earth", None) is not None:
        if args.earth not in EARTH_MODELS:
            raise UsageError(
                f"--earth: unknown earth model {show(args.earth)} (choose from {', '.join(EARTH_MODELS)})"
            )
        config = config.replace("earth", model=args.earth)
    if getattr(args, "trajectory", None) is not None:
        if args.trajectory not in TRAJECTORIES:
            raise UsageError(
                f"--trajectory: unknown trajectory {show(args.trajectory)} "
                f"(choose from {', '.join(TRAJECTORIES)})"
            )
        config = config.replace("trajectory", name=args.trajectory)
    if getattr(args, "truth", None) is not None:
        if args.truth not in TRUTH_SOURCES:
            raise UsageError(
                f"--truth: unknown truth source {show(args.truth)} (choose from {', '.join(TRUTH_SOURCES)})"
            )
        config = _replace("--truth", config, "trajectory", truth=args.truth)
    if getattr(args, "seed", None) is not None:
        config = _replace(
            "--seed", config, "run", seed=_parse("--seed", args.seed, int, "a non-negative integer")
        )
    if getattr(args, "method", None) is not None:
        config = config.replace(
            "run", methods=_csv("--method", args.method, RUN_METHODS, allow_all=True, all_means=METHODS)
        )
    if getattr(args, "aiding", None) is not None:
        config = config.replace("run", aiding=_csv("--aiding", args.aiding, AIDING_SOURCES))
    if getattr(args, "ideal", False):
        config = config.replace("run", ideal=True)
    if getattr(args, "rpm_fallback", False):
        config = config.replace("run", rpm_fallback=True)
    if getattr(args, "initial_errors", False):
        config = config.replace("replay", initial_errors=True)
    if getattr(args, "beams", None) is not None:
        config = config.replace("dvl", beams=_beam_list("--beams", args.beams))
    if getattr(args, "outage", None):
        outages = tuple(_outage(text) for text in args.outage)
        config = _replace("--outage", config, "dvl", outages=config.dvl.outages + outages)
    if getattr(args, "dropout", None) is not None:
        probability = _parse("--dropout", args.dropout, float, "a probability in [0, 1]")
        config = _replace("--dropout", config, "dvl", dropout_probability=probability)
    if getattr(args, "vb_nf", None) is not None:
        config = _replace(
            "--vb-nf", config, "partial", vb_nf=_parse("--vb-nf", args.vb_nf, float, "a number in [1, 100]")
        )
    if getattr(args, "nsv_epsilon", None) is not None:
        epsilon = (
            AUTO
            if args.nsv_epsilon == AUTO
            else _parse("--nsv-epsilon", args.nsv_epsilon, float, f"a number in (0, 100] or {AUTO!r}")
        )
        config = _replace("--nsv-epsilon", config, "partial", nsv_epsilon_m2_per_s2=epsilon)
    return config


def _parse(flag: str, text: str, cast: type, expected: str) -> Any:
    """``cast(text)``, or one line naming the flag, what it expects and what it got."""
    try:
        value = cast(text)
    except ValueError:  # also an integer of more than 4300 digits
        raise UsageError(f"{flag}: expected {expected}, got {show(text)}") from None
    if isinstance(value, float) and not np.isfinite(value):  # "nan", "-inf", or "9" * 500 overflowing to inf
        raise UsageError(f"{flag}: expected {expected}, got {show(text)}")
    return value


def _replace(flag: str, config: Config, section: str, **changes: Any) -> Config:
    """``config.replace`` with a validation error reported against the flag that caused it."""
    try:
        return config.replace(section, **changes)
    except ConfigError as exc:
        raise UsageError(f"{flag}: {exc}") from None


def _beam_list(flag: str, text: str, whole: str | None = None) -> tuple[int, ...]:
    """Parse the comma-separated beams ``text`` (``1,2``); ``whole``: the flag's whole value
    that ``text`` is part of (``--outage``'s ``3,4@50:200``), for the messages."""
    shown = show(text if whole is None else whole)
    if not text.strip():
        raise UsageError(f"{flag}: no beams in {shown} (expected comma-separated beams from 1, 2, 3, 4)")
    beams = []
    for item in text.split(","):
        item = item.strip()
        if not item:
            raise UsageError(f"{flag}: an empty beam in {shown} (beams are 1, 2, 3, 4)")
        if item not in ("1", "2", "3", "4"):
            raise UsageError(f"{flag}: unknown beam {show(item)} in {shown} (beams are 1, 2, 3, 4)")
        if int(item) in beams:
            raise UsageError(f"{flag}: beam {item} repeated in {shown}")
        beams.append(int(item))
    return tuple(beams)


def _outage(text: str) -> Outage:
    """Parse ``3,4@50:200``."""
    beams_text, at, window = text.partition("@")
    start_text, colon, end_text = window.partition(":")
    if not at or not colon:
        raise UsageError(f"--outage: expected BEAMS@START:END such as 3,4@50:200, got {show(text)}")
    if not beams_text.strip():
        raise UsageError(
            f"--outage: no beams before '@' in {show(text)} (expected BEAMS@START:END such as 3,4@50:200)"
        )
    beams = _beam_list("--outage", beams_text, text)
    try:
        start, end = float(start_text), float(end_text)
    except ValueError:
        raise UsageError(
            f"--outage: start and end must be seconds, got {show(window)} in {show(text)}"
        ) from None
    try:
        return Outage(beams=beams, start_s=start, end_s=end)
    except ConfigError as exc:
        raise UsageError(f"--outage {show(text)}: {exc}") from None


Inputs = Sequence[tuple[str, str | None]]
"""What a command reads (or writes elsewhere), as (description, path) pairs such as
``("the --config file", args.config)`` or ``("the log directory", args.log)``; a directory
stands for every file in it. An output may be none of them (:func:`json_target`)."""


def json_target(path: str, inputs: Inputs = ()) -> str:
    """The real path ``--json`` will replace, checked before the run starts.

    Refused: an empty name, one of ``inputs`` (:func:`_refuse_input`: the --config file, a
    replayed log's tables and its log.toml, by real path or inode), a directory, anything but a
    regular file (``/dev/null`` would be replaced by a file), a missing or unwritable directory,
    and a name the system cannot resolve (loops, too long).
    """
    if not path.strip():
        raise UsageError(f"--json: expected a file name, got {show(path)}")
    name = show_path(path)
    if "\x00" in path:
        raise UsageError(f"--json: a file name cannot contain a NUL character, got {name}")
    real = os.path.realpath(path)
    _refuse_input("--json", path, inputs)
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise UsageError(f"--json: cannot write {name}: {exc.strerror or exc}") from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise UsageError(f"--json: cannot write {name}: is a directory")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise UsageError(f"--json: cannot write {name}: not a regular file")
    directory = os.path.dirname(real)
    if not os.path.isdir(directory):
        raise UsageError(f"--json: cannot write {name}: no such directory")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise UsageError(f"--json: cannot write {name}: directory not writable")
    return real


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _real(path: str | None) -> str | None:
    """The real path of ``path``; None for none or a name no system call takes (a NUL, which
    the command refuses where it reads the file)."""
    if not path:
        return None
    try:
        return os.path.realpath(path)
    except (OSError, ValueError):
        return None


def _inside(path: str, directory: str) -> bool:
    """Whether the real path ``path`` is the real path ``directory`` or below it."""
    return os.path.commonpath([path, directory]) == directory


def _same_as_one_in(path: str, directory: str) -> str | None:
    """The file directly in ``directory`` that is the file ``path`` (a hard link, or a symlink of
    either to the other), if any."""
    if not os.path.lexists(path) or not os.path.isdir(directory):
        return None
    try:
        with os.scandir(directory) as entries:
            return next((e.path for e in entries if _same_file(path, e.path)), None)
    except OSError:
        return None


def _refuse_input(flag: str, path: str, inputs: Inputs) -> None:
    """UsageError if writing the file ``path`` for ``flag`` would replace one of ``inputs``: the
    same real path (symlinks resolved) or the same file (a hard link), a path inside an input
    directory, or the same file as one in it."""
    real, name = os.path.realpath(path), show_path(path)
    for what, source in inputs:
        source_real = _real(source)
        if source is None or source_real is None:
            continue
        if real == source_real or _same_file(source_real, real):
            raise UsageError(f"{flag}: {name} is {what}; writing it would overwrite it")
        if _inside(real, source_real):
            raise UsageError(
                f"{flag}: {name} is in {what} {show_path(source)}; writing it could overwrite its files"
            )
        twin = _same_as_one_in(real, source_real)
        if twin is not None:
            raise UsageError(
                f"{flag}: {name} is the same file as {show_path(os.path.join(source, os.path.basename(twin)))} "
                f"in {what} {show_path(source)}; writing it would overwrite it"
            )


def _refuse_holding_inputs(flag: str, given: str, directory: str, inputs: Inputs) -> None:
    """UsageError if the output directory ``directory`` (``given`` on the command line) holds
    one of ``inputs``, or is in an input directory: its writer could replace them."""
    out_real = os.path.realpath(directory)
    for what, source in inputs:
        source_real = _real(source)
        if source is None or source_real is None:
            continue
        if _inside(source_real, out_real) or _same_as_one_in(source_real, out_real) is not None:
            raise UsageError(
                f"{flag}: {show_path(given)} holds {what} {show_path(source)}; choose another directory"
            )
        if os.path.isdir(source_real) and _inside(out_real, source_real):
            raise UsageError(
                f"{flag}: {show_path(given)} is in {what} {show_path(source)}; choose another directory"
            )


def _log_table(directory: str) -> str | None:
    """The name of the imu table that makes ``directory`` a log (tauvcore.logs.find_logs), if any."""
    for ext in ("csv", "parquet"):
        if os.path.lexists(os.path.join(directory, f"imu.{ext}")):
            return f"imu.{ext}"
    return None


def write_json_atomic(path: str, payload: Any) -> None:
    """Write ``payload`` as strict JSON to ``path``: a temporary file in the same directory,
    flushed to disk, then renamed over ``path``. On any failure or interruption the temporary
    file is removed and ``path`` is untouched, so no half-written file is ever left."""
    directory = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(prefix=".tauv-", suffix=".json.tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            json.dump(payload, fh, allow_nan=False)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, _new_file_mode(path))
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _new_file_mode(path: str) -> int:
    """The mode the file would have got from ``open``: its own if it exists, else 0o666 less umask."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def cmd_run(args: argparse.Namespace) -> int:
    """``tauv run``: simulate, run the methods, print the summary; with ``--save-log`` the
    simulation as a log (all or nothing, the directory locked meanwhile), with ``--json`` the
    results (atomically). Every output is checked before the run, and none may be an input."""
    config = resolve_config(args)
    log_dir = _save_log_target(args)
    inputs = [("the --config file", args.config), ("the --save-log directory", args.save_log)]
    json_path = json_target(args.json, inputs) if args.json is not None else None
    started = time.perf_counter()
    rng = np.random.default_rng(config.run.seed)
    from tauvcore.engine.mission import run_streaming

    lock = _lock_save_log(args, log_dir) if log_dir is not None else None
    try:
        chunks: list = []
        results = run_streaming(config, rng, on_sim_chunk=chunks.append if lock is not None else None)
        elapsed = time.perf_counter() - started
        if log_dir is not None:
            from app.study_output import os_reason
            from tauvcore.log_writer import simulation_tables, write_log

            try:
                write_log(log_dir, simulation_tables(chunks), args.log_format)
            except OSError as exc:
                raise UsageError(
                    f"--save-log: cannot write {show_path(args.save_log)}: {os_reason(exc)}"
                ) from None
    except BaseException:
        if lock is not None:
            lock.release(remove_created=True)
        raise
    if lock is not None:
        lock.release()
    if json_path is not None:
        assert args.json is not None  # json_path is set only when --json was given
        try:
            write_json_atomic(json_path, run_payload(config, results))
        except OSError as exc:
            raise UsageError(f"--json: cannot write {show_path(args.json)}: {exc.strerror or exc}") from None
    print(summary_table(results, config, elapsed))
    return 0


def _save_log_target(args: argparse.Namespace) -> str | None:
    """The --save-log directory, checked before the run: it must not be a file, a log already,
    or hold the --config file; it must be writable, or creatable in a writable directory."""
    if args.log_format not in ("csv", "parquet"):
        raise UsageError(f"--log-format: expected csv or parquet, got {show(args.log_format)}")
    if args.save_log is None:
        return None
    if not args.save_log.strip():
        raise UsageError(f"--save-log: expected a directory, got {show(args.save_log)}")
    target = os.path.abspath(args.save_log)
    if os.path.exists(target) and not os.path.isdir(target):
        raise UsageError(f"--save-log: {show_path(args.save_log)} is a file, not a directory")
    if os.path.isdir(target) and _log_table(target) is not None:
        raise UsageError(
            f"--save-log: {show_path(args.save_log)} already holds a log; choose another directory"
        )
    _refuse_holding_inputs("--save-log", args.save_log, target, [("the --config file", args.config)])
    if os.path.isdir(target):
        if not os.access(target, os.W_OK | os.X_OK):
            raise UsageError(f"--save-log: cannot write into {show_path(args.save_log)}: permission denied")
        return target
    parent = os.path.dirname(target)
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(
            f"--save-log: cannot create {show_path(args.save_log)} (its parent is not a writable directory)"
        )
    return target


def _lock_save_log(args: argparse.Namespace, target: str) -> Any:
    """The --save-log directory created if need be and locked for this run
    (app.study_output.DirectoryLock), or one line if another tauv holds it or has meanwhile
    written a log there."""
    from app.study_output import DirectoryLock, OutputDirError

    try:
        lock = DirectoryLock(target, name=args.save_log)
    except OutputDirError as exc:
        raise UsageError(f"--save-log: {exc}") from None
    if _log_table(target) is not None:
        lock.release(remove_created=True)
        raise UsageError(
            f"--save-log: {show_path(args.save_log)} already holds a log; choose another directory"
        )
    return lock


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


def _count(flag: str, text: str | None, low: int, high: int, default: int) -> int:
    if text is None:
        return default
    value = _parse(flag, text, int, f"a whole number from {low} to {high}")
    if not low <= value <= high:
        raise UsageError(f"{flag}: must be a whole number from {low} to {high}, got {show(text)}")
    return value


def _study_setup(args: argparse.Namespace, default_runs: int) -> tuple[int, int, str | None, Any]:
    """Runs, workers, Dask address and the output writer of a study command (holding the
    output directory's lock), every check done before anything is computed or created: the
    output directory must not be a log or hold the --config file."""
    from app.study_output import OutputDirError, StudyWriter, check_out_dir

    num_runs = _count("--runs", args.runs, 1, MAX_STUDY_RUNS, default_runs)
    workers = _count("--workers", args.workers, 1, MAX_WORKERS, 1)
    if args.dask is not None and not args.dask.strip():
        raise UsageError(
            f"--dask: expected a scheduler address such as tcp://host:8786, got {show(args.dask)}"
        )
    if args.dask is not None and args.workers is not None:
        raise UsageError("--workers: not with --dask (the Dask cluster has its own workers)")
    try:
        out_dir = check_out_dir(args.out)
    except OutputDirError as exc:
        raise UsageError(f"--out: {exc}") from None
    _refuse_log_dir(args.out, out_dir)
    _refuse_holding_inputs("--out", args.out, out_dir, [("the --config file", getattr(args, "config", None))])
    if args.dask is not None:
        _check_dask(args.dask)
    try:
        writer = StudyWriter(out_dir, name=args.out)
    except OutputDirError as exc:
        raise UsageError(f"--out: {exc}") from None
    try:
        _refuse_log_dir(args.out, out_dir)  # again, now that no other tauv writes there
    except BaseException:
        writer.abort()
        raise
    return num_runs, workers, args.dask, writer


def _refuse_log_dir(given: str, out_dir: str) -> None:
    """UsageError if the output directory ``out_dir`` (``given`` as ``--out``) is a log."""
    table = _log_table(out_dir)
    if table is not None:
        raise UsageError(
            f"--out: {show_path(given)} is a log directory (it holds {table}); choose another directory"
        )


def cmd_mc(args: argparse.Namespace) -> int:
    """``tauv mc``: a seeded Monte Carlo study written to ``--out`` (see app.study_output)."""
    from app.study_output import OutputDirError
    from app.study_report import report_html
    from tauvcore.eval.study import run_study

    config = resolve_config(args)
    trajectory = config.trajectory.name
    num_runs, workers, dask, writer = _study_setup(args, 1)
    started = time.perf_counter()
    try:
        with _progress_bar(num_runs) as bar, _study_failures(dask):
            acc = run_study(
                config,
                num_runs,
                config.run.seed,
                workers=workers,
                dask_address=dask,
                on_chunk=lambda chunk: writer.add_chunk(trajectory, chunk),
                progress=lambda done, total: bar.update(done - bar.n),
            )
        summary = acc.summary()
        description = (
            f"{num_runs} seeded Monte Carlo runs (seed {config.run.seed}), {config.trajectory.duration_s:g} s, "
            f"methods {', '.join(config.run.methods)}, beams {','.join(map(str, config.dvl.beams))}, "
            f"aiding {','.join(config.run.aiding) or 'none'}; tauv mc"
        )
        writer.finish(
            {
                "config": config_to_json(config),
                "num_runs": num_runs,
                "seed": config.run.seed,
                "trajectories": {trajectory: summary},
            },
            report_html("tauv Monte Carlo study", description, {trajectory: summary}),
        )
        written = writer.commit()
    except OutputDirError as exc:  # a file of the study cannot be written: full disk, size limit
        writer.abort()
        raise UsageError(f"--out: {exc}") from None
    except BaseException:
        writer.abort()
        raise
    elapsed = time.perf_counter() - started
    print(study_table(summary, trajectory, num_runs, elapsed))
    for path in written:
        print(f"wrote {path}")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``tauv reproduce``: Tal et al. 2017 section 4.2 (three trajectories, beams 3 and 4 lost,
    INS, TC and the ELC methods; LC with four beams as the reference), every stated figure
    beside ours with a verdict."""
    from app.study_output import OutputDirError
    from app.study_report import report_html
    from tauvcore.eval.paper import TWO_BEAM_METHODS, comparison_table
    from tauvcore.eval.study import (
        ERROR_SERIES,
        local_pool,
        paper_chunk_runs,
        run_study,
        submit_chunks,
    )

    # the paper's earth: a tangent plane with constant gravity (its F has a zero position column);
    # over 250 s and 500 m the round Earth changes its figures in the fourth digit at most
    base = Config().replace("earth", model="flat")
    if args.duration is not None:
        base = _replace(
            "--duration",
            base,
            "trajectory",
            duration_s=_parse("--duration", args.duration, float, "a number of seconds"),
        )
    if args.seed is not None:
        base = _replace(
            "--seed", base, "run", seed=_parse("--seed", args.seed, int, "a non-negative integer")
        )
    summaries, tables = {}, []
    studies = [
        (name, beams, methods)
        for name in PAPER_TRAJECTORIES
        for beams, methods in (((1, 2, 3, 4), ("lc",)), ((1, 2), TWO_BEAM_METHODS))
    ]
    num_runs, workers, dask, writer = _study_setup(args, 100)
    started = time.perf_counter()
    try:
        configs = [
            base.replace("trajectory", name=name).replace("dvl", beams=beams).replace("run", methods=methods)
            for name, beams, methods in studies
        ]
        sizes = [paper_chunk_runs(c) for c in configs]
        with (
            _progress_bar(num_runs * len(studies)) as bar,
            local_pool(workers if dask is None else 1) as pool,
        ):
            # every study's chunks queued at once (they wait as files): no worker idles between studies
            with _study_failures(dask):
                queued = [
                    submit_chunks(c, num_runs, base.run.seed, pool, size) if pool is not None else None
                    for c, size in zip(configs, sizes, strict=True)
                ]
            for (name, _, _), config, size, submitted in zip(studies, configs, sizes, queued, strict=True):
                done_before = bar.n
                with _study_failures(dask):
                    acc = run_study(
                        config,
                        num_runs,
                        base.run.seed,
                        workers=workers,
                        dask_address=dask,
                        on_chunk=lambda chunk, name=name: writer.add_chunk(name, chunk),
                        progress=lambda done, total, b=done_before: bar.update(b + done - bar.n),
                        chunk_runs=size,
                        pool=pool,
                        submitted=submitted,
                    )
                part = acc.summary()
                if name in summaries:
                    summaries[name]["methods"].update(part["methods"])
                else:
                    summaries[name] = part
        order = ("ins", "lc") + TWO_BEAM_METHODS[1:]
        for s in summaries.values():
            s["methods"] = {m: s["methods"][m] for m in order}
        finals = {
            name: {m: {n: s["methods"][m]["final_rms"][n] for n in ERROR_SERIES} for m in s["methods"]}
            for name, s in summaries.items()
        }
        table = comparison_table(finals)
        description = (
            f"Tal, Klein & Katz 2017, section 4.2: {num_runs} seeded runs per trajectory (seed "
            f"{base.run.seed}), {base.trajectory.duration_s:g} s, beams 3 and 4 lost (LC with all four as "
            "the reference), DVL aiding only; tauv reproduce"
        )
        writer.finish(
            {
                "config": config_to_json(base),
                "num_runs": num_runs,
                "seed": base.run.seed,
                "trajectories": summaries,
                "paper_comparison": table,
            },
            report_html("tauv reproduce: Tal, Klein & Katz 2017", description, summaries),
            table,
        )
        written = writer.commit()
    except OutputDirError as exc:  # a file of the study cannot be written: full disk, size limit
        writer.abort()
        raise UsageError(f"--out: {exc}") from None
    except BaseException:
        writer.abort()
        raise
    elapsed = time.perf_counter() - started
    for name, s in summaries.items():
        tables.append(study_table(s, name, num_runs, elapsed))
    print("\n\n".join(tables))
    print("\nEvery figure of the paper's section 4.2 beside ours\n")
    print(table)
    print(f"\n({elapsed:.1f} s wall)")
    for path in written:
        print(f"wrote {path}")
    return 0


@contextlib.contextmanager
def _study_failures(dask: str | None):
    """A worker process that dies (out of memory, killed) or a Dask cluster that goes away ends
    the study with one line and exit status 1, not a traceback; nothing is written."""
    from concurrent.futures.process import BrokenProcessPool

    try:
        yield
    except BrokenProcessPool as exc:
        raise StudyFailedError(
            f"a worker process died during the study ({one_line(str(exc)) or 'killed'}); nothing was written"
        ) from None
    except (OSError, TimeoutError) as exc:
        if dask is None:
            raise
        raise StudyFailedError(
            f"--dask {dask}: the cluster failed during the study ({type(exc).__name__}: "
            f"{one_line(str(exc))}); nothing was written"
        ) from None


def _check_dask(address: str) -> None:
    """Fail fast, with one line, if no Dask scheduler answers at ``address``."""
    try:
        from distributed import Client
    except ImportError:
        raise UsageError("--dask: the 'distributed' package is not installed") from None
    from tauvcore.eval.study import DASK_CONNECT_TIMEOUT_S

    try:
        with Client(address, timeout=DASK_CONNECT_TIMEOUT_S):
            pass
    except (OSError, TimeoutError, ValueError) as exc:
        raise UsageError(
            f"--dask: cannot reach a scheduler at {show(address)}: {one_line(str(exc)) or type(exc).__name__}"
        ) from None


@contextlib.contextmanager
def _progress_bar(total: int):
    """A tqdm bar on stderr (runs done of total); silent when stderr is not a terminal."""
    from tqdm import tqdm

    bar = tqdm(
        total=total,
        unit="run",
        desc="tauv mc",
        file=sys.stderr,
        disable=not sys.stderr.isatty(),
        dynamic_ncols=True,
    )
    try:
        yield bar
    finally:
        bar.close()


@contextlib.contextmanager
def viser_console_muted() -> Iterator[None]:
    """Mute rich's console for the duration: viser (1.x) prints its own address box there when
    the server starts, whatever its ``verbose`` (``http://127.0.0.1:8080``, beside the
    dashboard's ``http://localhost:8080``), and "(viser) Server stopped" at the end. In the
    server nothing else writes to it: callbacks' tracebacks reach stderr through plain print,
    and the dashboard's own lines through ``print``."""
    # viser's dependency: imported when serving only, as viser is
    import rich

    console = rich.get_console()
    quiet, console.quiet = console.quiet, True
    try:
        yield
    finally:
        console.quiet = quiet


def _raw_layouts_in(directory: str) -> str:
    """The vendor hint (tauvcore.logs.raw_layout_hint) of the first subdirectory that has one."""
    from tauvcore.logs import raw_layout_hint

    with contextlib.suppress(OSError):
        for entry in sorted(os.scandir(directory), key=lambda e: e.name):
            hint = raw_layout_hint(entry.path) if entry.is_dir() else ""
            if hint:
                return f"; {entry.name!r}{hint.replace('; it holds', ' holds', 1)}"
    return ""


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        port = int(args.port)
    except ValueError:
        raise UsageError(f"--port: expected a TCP port number, got {show(args.port)}") from None
    if not 1 <= port <= 65535:
        raise UsageError(f"--port: must be within 1-65535, got {port}")
    if not args.host.strip():
        raise UsageError(f"--host: expected an address such as 127.0.0.1, got {show(args.host)}")
    workers = None
    if args.workers is not None:
        workers = _parse("--workers", args.workers, int, "a whole number of worker processes")
        if not 1 <= workers <= 64:
            raise UsageError(f"--workers: must be within 1-64, got {workers}")
    from app import budget

    try:
        budget.budget_bytes()  # a bad TAUV_RUN_BUDGET_MB is refused now, not at the first Run
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    logs = None
    if args.logs is not None:
        from tauvcore.logs import find_logs

        if not os.path.isdir(args.logs):
            raise UsageError(f"--logs: {show_path(args.logs)} is not a directory")
        try:
            logs = find_logs(args.logs)
        except OSError as exc:
            raise UsageError(f"--logs: cannot list {show_path(args.logs)}: {exc.strerror or exc}") from None
        if not logs:
            raise UsageError(
                f"--logs: no log in {show_path(args.logs)} (a log is a directory with imu.csv or "
                f"imu.parquet; see the README){_raw_layouts_in(args.logs)}"
            )
    from app.dashboard import main as serve_main
    from app.hardening import exit_now  # viser only when serving

    try:
        with viser_console_muted():  # the dashboard prints the one address to open
            serve_main(args.host, port, workers, logs)
    except OSError as exc:
        raise UsageError(
            f"--host/--port: cannot listen on {args.host}:{port}: {exc.strerror or exc}"
        ) from None
    except KeyboardInterrupt:
        pass
    # Stopped by SIGTERM/SIGINT, the workers already gone: leave without the interpreter's
    # finalization, whose garbage collection of the tabs' sessions took 0.5-1.1 s on a loaded
    # machine (docker stop's SIGTERM must end the container within 2 s: tests/release).
    exit_now()


def _require_file_names(args: argparse.Namespace) -> None:
    """A file name the system cannot encode (a lone surrogate such as '\\ud800', which
    ``main(argv)`` can be given though no shell passes one) is refused naming its flag, before
    any system call raises UnicodeEncodeError on it."""
    for attr in PATH_FLAGS:
        value = getattr(args, attr, None)
        if isinstance(value, str):
            try:
                os.fsencode(value)
            except UnicodeError:
                flag = "DIR" if attr == "log" else f"--{attr.replace('_', '-')}"
                raise UsageError(f"{flag}: the file name is not valid text, got {show(value)}") from None


def cmd_config(args: argparse.Namespace) -> int:
    sys.stdout.write(to_toml(resolve_config(args)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tauv`` console script.

    Exit status 0 on success (also when the reader of stdout goes away, as ``| head -1`` does),
    2 on bad input with one line on stderr, 130 when interrupted.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    # past a file-size limit a write fails with EFBIG (one line, nothing left half-written)
    # instead of the signal killing the process mid-file
    with contextlib.suppress(ValueError):  # only the main thread may set it (main() in a thread: left alone)
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        args = build_parser().parse_args(attach_dash_values(argv))
        _require_file_names(args)
        _require_text_values(args)
        code = args.func(args)
        sys.stdout.flush()  # inside the try: a closed pipe is reported here, not at exit
        return code
    except (UsageError, ConfigError) as exc:
        print(f"tauv: error: {one_line(str(exc))}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except StudyFailedError as exc:
        print(f"tauv: error: {one_line(str(exc))}", file=sys.stderr)
        return EXIT_STUDY_FAILED
    except BrokenPipeError:
        _silence_stdout()
        return 0
    except KeyboardInterrupt:
        print("tauv: interrupted", file=sys.stderr)
        return 130


def _require_text_values(args: argparse.Namespace) -> None:
    """argparse drops a value of exactly ``--`` (``--method=--``) and leaves an empty list (in
    the list of a repeatable flag, ``--outage=--``)."""
    for action in OPTIONS[""] + OPTIONS.get(args.command, []):
        value = getattr(args, action.dest, None)
        if action.nargs == 0 or value is None:
            continue
        values = value if isinstance(action, argparse._AppendAction) else [value]
        if any(v is not None and not isinstance(v, str) for v in values):
            raise UsageError(f"{action.option_strings[-1]}: expected a value, got '--'")


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush does not fail a second time."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)


OPTIONS = option_actions(build_parser())
"""Every subcommand's optional arguments, by subcommand ('' for ``tauv``'s own): :func:`option_actions`."""
VALUE_FLAGS = frozenset(
    s for actions in OPTIONS.values() for a in actions if a.nargs != 0 for s in a.option_strings
)
"""Flags that take a value, in any subcommand (from the parser); see :func:`attach_dash_values`."""
OTHER_FLAGS = frozenset(
    s for actions in OPTIONS.values() for a in actions if a.nargs == 0 for s in a.option_strings
)
"""Flags that take none (``--ideal``, ``--help``, ...), in any subcommand (from the parser)."""
PATH_FLAGS = frozenset(
    a.dest
    for action in build_parser()._actions
    if isinstance(action, argparse._SubParsersAction)
    for sub in action.choices.values()
    for a in sub._actions
    if a.type is _path
)
"""The arguments that name files or directories (``args`` attributes: the flags and the log
directory typed :func:`_path`, from the parser)."""


if __name__ == "__main__":
    raise SystemExit(main())
