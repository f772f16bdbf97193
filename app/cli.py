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

Here are the parser, the flag tables derived from it and :func:`main`; each subcommand is a
module of app.commands.
"""

from __future__ import annotations

import argparse
import contextlib
import difflib
import os
import signal
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from app.commands.calibrate import cmd_calibrate
from app.commands.log import cmd_log_convert, cmd_log_info
from app.commands.mc import MAX_STUDY_RUNS, StudyFailedError, cmd_mc, cmd_reproduce
from app.commands.names import COMMANDS, DESCRIPTION, PROG
from app.commands.replay_log import cmd_replay
from app.commands.run import cmd_run
from app.commands.serve import cmd_serve
from app.commands.smooth_flags import MAX_SMOOTH_MEMORY_MB
from app.commands.tune import LOCAL_DASK, cmd_tune
from app.commands.values import UsageError, resolve_config
from tauvcore.aiding import AIDING_SOURCES
from tauvcore.aiding.registry import REGISTRY
from tauvcore.config import DEFAULT_METHODS, METHODS, RUN_METHODS, Config, to_toml
from tauvcore.geo.earth import EARTH_MODELS
from tauvcore.logs import SOURCE_TABLES
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.truth import TRAJECTORIES, TRUTH_SOURCES
from tauvcore.validation import ConfigError, one_line, shorten, show

EXIT_BAD_INPUT = 2
EXIT_STUDY_FAILED = 1


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line (no usage dump) and exits with 2.

    Abbreviated flags (``--dur 3``) are refused: an abbreviation that works today would change
    meaning silently when a flag with the same prefix is added.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        commands = self._commands()
        if commands and message.startswith("the following arguments are required: "):
            width = max(len(name) for name in commands)
            listing = "".join(f"  {name.ljust(width)}  {text}\n" for name, text in commands.items())
            where = self.prog.removeprefix("tauv").strip()
            raise UsageError(
                f"{where + ': ' if where else ''}a command is required ({self.prog} COMMAND --help for "
                "its flags)",
                f"{self.format_usage()}\ncommands:\n{listing}\n",
            )
        # argparse quotes values whole ("unrecognized arguments: <500 kB>"): shorten each word
        raise UsageError(" ".join(shorten(word) for word in message.split(" ")))

    def _commands(self) -> dict[str, str]:
        """This parser's subcommands and their one-line help, in the order they were added."""
        for action in self._actions:  # argparse keeps no public list of them
            if isinstance(action, argparse._SubParsersAction):
                return {a.dest: a.help or "" for a in action._choices_actions}
        return {}


def option_actions(parser: argparse.ArgumentParser) -> dict[str, list[argparse.Action]]:
    """The optional arguments of ``parser`` ('' for its own) and of each subcommand, by name.
    :data:`VALUE_FLAGS` and :data:`OTHER_FLAGS` are derived from them, so a flag added to the
    parser is known to :func:`attach_dash_values` and :func:`_require_text_values` at once."""
    found: dict[str, list[argparse.Action]] = {"": []}
    for action in parser._actions:  # argparse keeps no public list of them
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found[name] = [a for a in sub._actions if a.option_strings]
                for inner, actions in option_actions(sub).items():  # a subcommand's own (tauv log info)
                    if inner:
                        found[f"{name} {inner}"] = actions
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


def _path(text: str) -> str:
    """The argparse ``type`` of a flag that names a file or directory (:data:`PATH_FLAGS` is derived
    from it); the text is kept as given."""
    return text


def build_parser() -> argparse.ArgumentParser:
    """The ``tauv`` parser: one subcommand per module of app.commands, each bound to its command.

    Returns
    -------
    argparse.ArgumentParser
        The parser; ``parse_args`` puts the command to call in ``args.func``.
    """
    parser = _Parser(prog=PROG, description=DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _run_parser(sub)
    _replay_parser(sub)
    _calibrate_parser(sub)
    _tune_parser(sub)
    _mc_parser(sub)
    _reproduce_parser(sub)
    _serve_parser(sub)
    _log_parser(sub)
    _config_parser(sub)
    return parser


def _run_parser(sub: Any) -> None:
    """``tauv run``: a simulated mission and the fusion methods side by side (app.commands.run)."""
    r = sub.add_parser("run", help=COMMANDS["run"])
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
    _mcap_flag(r)
    r.add_argument(
        "--save-log",
        type=_path,
        metavar="DIR",
        help="also write the simulated sensors and truth as a log "
        "(tauv replay reads it; see docs/replay.md for the log format)",
    )
    r.add_argument("--log-format", default="csv", help="csv (default) or parquet, for --save-log")
    _smooth_flags(r)
    r.set_defaults(func=cmd_run)


def _mcap_flag(parser: Any) -> None:
    """``--mcap FILE`` of ``tauv run`` and ``tauv replay`` (app.commands.mcap_output)."""
    parser.add_argument(
        "--mcap",
        type=_path,
        metavar="FILE",
        help="write every method's estimate, 1-sigma, errors and innovations, and the truth or the "
        "log's reference, as ROS 2 messages in this MCAP file for Foxglove or PlotJuggler (run 0; "
        "written atomically)",
    )


def _replay_parser(sub: Any) -> None:
    """``tauv replay``: the fusion methods on a recorded log or bag (app.commands.replay_log)."""
    rl = sub.add_parser("replay", help=COMMANDS["replay"])
    rl.add_argument(
        "log",
        type=_path,
        metavar="PATH",
        help=f"the log directory (imu, reference, and {', '.join(('dvl', *SOURCE_TABLES.values()))} tables), "
        "a ROS 1 .bag, a ROS 2 bag directory (metadata.yaml) or an .mcap file",
    )
    _bag_mapping_flag(rl)
    _method_flags(rl)
    rl.add_argument(
        "--imu-errors",
        metavar="PROFILE",
        help=f"add a simulated IMU's errors to the log's IMU: "
        f"{', '.join(IMU_PROFILES)} (drawn from --seed; the "
        "filters are tuned for that IMU, or with --imu for that one)",
    )
    _imu_flag(rl)
    rl.add_argument(
        "--config",
        type=_path,
        help="TOML file: the filters' tuning and the DVL's geometry (see 'tauv config'), laid over "
        "the log's own DIR/log.toml",
    )
    rl.add_argument(
        "--no-log-config",
        action="store_true",
        help="ignore the configuration the recording carries: a log's DIR/log.toml; a bag's mapping's "
        "[config] and the DVL's mounting (rotation and lever arm) from its /tf_static (the mapping's "
        "topics, frames and mounting_rpy_deg still apply)",
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
    _mcap_flag(rl)
    _smooth_flags(rl)
    rl.set_defaults(func=cmd_replay)


def _calibrate_parser(sub: Any) -> None:
    """``tauv calibrate``: the DVL's mounting and the boresight from logs (app.commands.calibrate)."""
    ca = sub.add_parser("calibrate", help=COMMANDS["calibrate"])
    ca.add_argument(
        "logs",
        type=_path,
        nargs="+",
        metavar="LOG",
        help="log directories (or ROS bags, each with its own mapping beside it) with a reference, of one "
        "vehicle: one calibration is estimated from all of them together",
    )
    ca.add_argument(
        "--out",
        type=_path,
        required=True,
        metavar="FILE",
        help="the TOML file to write ([calibration], with each value's 1-sigma in comments); refused if it "
        "exists, without --replace",
    )
    ca.add_argument("--replace", action="store_true", help="replace --out if it exists")
    ca.add_argument(
        "--config",
        type=_path,
        help="TOML file laid over each log's own configuration: the DVL's beams and lever arm, the beams' and "
        "the IMU's bias 1-sigma the uncertainty takes (see 'tauv config')",
    )
    ca.add_argument(
        "--no-log-config",
        action="store_true",
        help="ignore the configuration each log carries (its log.toml; a bag's mapping's [config] and /tf_static)",
    )
    _imu_flag(ca)
    ca.set_defaults(func=cmd_calibrate)


def _mc_parser(sub: Any) -> None:
    """``tauv mc``: a seeded Monte Carlo study (app.commands.mc)."""
    mc = sub.add_parser("mc", help=COMMANDS["mc"])
    _mission_flags(mc)
    mc.add_argument("--runs", required=True, help=f"number of Monte Carlo runs, 1 to {MAX_STUDY_RUNS}")
    mc.add_argument(
        "--out",
        type=_path,
        required=True,
        help="output directory, new (created in an existing directory) or empty; files appear only when "
        "the study has finished",
    )
    _replace_flag(mc, "tauv mc")
    mc.add_argument("--workers", help="local processes computing chunks of runs (default 1; at most 64)")
    mc.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="send the chunks to this Dask scheduler instead, e.g. "
        "tcp://10.0.0.5:8786 (its workers need tauv installed)",
    )
    _smooth_flags(mc)
    mc.set_defaults(func=cmd_mc)


def _reproduce_parser(sub: Any) -> None:
    """``tauv reproduce``: the first paper's study beside its figures (app.commands.mc)."""
    rp = sub.add_parser("reproduce", help=COMMANDS["reproduce"])
    rp.add_argument("--out", type=_path, required=True, help="output directory (as for mc)")
    _replace_flag(rp, "tauv reproduce")
    rp.add_argument("--runs", help="Monte Carlo runs per trajectory (default 100, the paper's study)")
    rp.add_argument("--duration", help="run length [s] (default 250, the paper's; shorter for a quick check)")
    rp.add_argument("--seed", help="seed of the study (default 0)")
    rp.add_argument("--workers", help="local processes computing chunks of runs (default 1; at most 64)")
    rp.add_argument("--dask", metavar="ADDRESS", help="send the chunks to this Dask scheduler instead")
    rp.set_defaults(func=cmd_reproduce)


def _serve_parser(sub: Any) -> None:
    """``tauv serve``: the browser dashboard (app.commands.serve)."""
    sv = sub.add_parser("serve", help=COMMANDS["serve"])
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
        help="offer the recorded logs and ROS bags (.bag, .mcap, ROS 2 bag directories, each with "
        "its own mapping beside it: mission.bag -> mission.toml) in DIR (it, or its subdirectories) "
        "as sources to replay in the dashboard",
    )
    sv.set_defaults(func=cmd_serve)


def _log_parser(sub: Any) -> None:
    """``tauv log info`` and ``tauv log convert``: what a bag holds, a bag as a log (app.commands.log)."""
    lg = sub.add_parser("log", help=COMMANDS["log"])
    lg_sub = lg.add_subparsers(dest="log_command", required=True, parser_class=_Parser)
    li = lg_sub.add_parser(
        "info", help="a bag's topics, types, message counts, rates, time spans and the table each feeds"
    )
    _bag_argument(li)
    _bag_mapping_flag(li)
    li.set_defaults(func=cmd_log_info)
    lc = lg_sub.add_parser(
        "convert",
        help="write a bag as a log (the tables tauv replay reads), all or nothing, into a new directory",
    )
    _bag_argument(lc)
    lc.add_argument(
        "out_dir",
        type=_path,
        metavar="OUT_DIR",
        help="the log's directory, new (created in an existing directory) or empty",
    )
    _bag_mapping_flag(lc)
    lc.add_argument("--log-format", default="csv", help="csv (default) or parquet")
    lc.set_defaults(func=cmd_log_convert)


def _config_parser(sub: Any) -> None:
    """``tauv config``: the full configuration as TOML (:func:`cmd_config`)."""
    c = sub.add_parser("config", help=COMMANDS["config"])
    c.add_argument("--config", type=_path, help="TOML file to merge over the defaults before printing")
    _imu_flag(c)
    _earth_flag(c)
    c.set_defaults(func=cmd_config)


def _tune_parser(sub: Any) -> None:
    """``tauv tune``: the filter's noise parameters from recorded logs (app.commands.tune)."""
    from tauvcore.eval.tuning import DEFAULT_PARAMETERS, MAX_EVALUATIONS, OPTIMIZERS, PARAMETERS

    tn = sub.add_parser("tune", help=COMMANDS["tune"])
    tn.add_argument(
        "logs", nargs="+", type=_path, metavar="LOG", help="log directories (as tauv replay reads them)"
    )
    tn.add_argument(
        "--method",
        help="the one method to tune, a 20-state filter's (e.g. lc, tc, iekf); not ins (no innovations) "
        "nor Yoo 2014's ins-dvl and vkf",
    )
    tn.add_argument(
        "--params",
        help=f"comma-separated parameters to identify, from {', '.join(PARAMETERS)} "
        f"(default {','.join(DEFAULT_PARAMETERS)})",
    )
    tn.add_argument(
        "--out",
        type=_path,
        metavar="FILE",
        help="write the tuned values (and what --config and the flags set) as TOML, atomically, for "
        "tauv replay --config; an existing file only with --replace",
    )
    tn.add_argument("--replace", action="store_true", help="replace an existing --out file")
    tn.add_argument(
        "--config",
        type=_path,
        help="TOML file laid over each log's own log.toml (see 'tauv config'): the starting tuning",
    )
    tn.add_argument("--no-log-config", action="store_true", help="ignore each log's own log.toml")
    _imu_flag(tn)
    tn.add_argument("--aiding", help=f"comma-separated from {', '.join(AIDING_SOURCES)} (default: dvl)")
    tn.add_argument(
        "--seed", help="seed of the replays' random draws (the initial errors, DVL dropout; default 0)"
    )
    tn.add_argument(
        "--initial-errors",
        action="store_true",
        help="start the filters off each log's reference by the initial errors (as tauv replay "
        "--initial-errors)",
    )
    tn.add_argument(
        "--optimizer",
        default=OPTIMIZERS[0],
        help=f"scipy's search: {', '.join(OPTIMIZERS)} (default {OPTIMIZERS[0]})",
    )
    tn.add_argument(
        "--max-evaluations",
        metavar="N",
        help="most evaluations of the likelihood the search makes, each a replay of every log "
        f"(default {MAX_EVALUATIONS})",
    )
    tn.add_argument(
        "--dask",
        nargs="?",
        const=LOCAL_DASK,
        metavar="ADDRESS",
        help="evaluate the logs (and the points of a gradient) in parallel on Dask: local processes, "
        "one per core, or the scheduler at ADDRESS (its workers need tauv installed)",
    )
    tn.set_defaults(func=cmd_tune)


def _mission_flags(p: argparse.ArgumentParser) -> None:
    """The flags that describe a mission and its methods (``run`` and ``mc``)."""
    p.add_argument("--trajectory", help=f"one of {', '.join(TRAJECTORIES)} (default from config: straight)")
    p.add_argument("--duration", help="run length [s], 1 to 86400 (default 250)")
    p.add_argument(
        "--truth",
        metavar="SOURCE",
        help=f"how the truth is made: {', '.join(TRUTH_SOURCES)} "
        "(default kinematic: closed-form profiles; dynamic: the 6-DOF "
        "TAUV flown through the scenario by its autopilot, with fins "
        "and propeller)",
    )
    _method_flags(p)
    _imu_flag(p)
    p.add_argument("--config", type=_path, help="TOML file (partial files allowed; see 'tauv config')")


def _method_flags(p: argparse.ArgumentParser) -> None:
    """The flags of the methods, their aiding and the DVL's beams (``run``, ``mc`` and ``replay``)."""
    p.add_argument(
        "--method",
        help=f"comma-separated from {', '.join(RUN_METHODS)}, or 'all' ({', '.join(METHODS)}) "
        f"(default: {','.join(DEFAULT_METHODS)}). ins-dvl and vkf are Yoo 2014's 12-state filter, aided "
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

    p.add_argument(
        "--rpm-fallback",
        action="store_true",
        help="the DVL methods fuse the propeller RPM's velocity "
        "(Yoo 2014's velocity Kalman filter, learnt from the "
        "DVL) whenever they have no DVL velocity",
    )


def _smooth_flags(p: argparse.ArgumentParser) -> None:
    """The fixed-interval smoother's flags (``run``, ``replay`` and ``mc``)."""
    from tauvcore.engine.smooth_defaults import DEFAULT_BUDGET_MB

    p.add_argument(
        "--smooth",
        action="store_true",
        help="also run the fixed-interval (Rauch-Tung-Striebel) smoother over the whole run after the "
        "filter: smoothed RMS and NEES beside the filtered in the tables, the smoothed series beside the "
        "filtered in the outputs (every method)",
    )
    p.add_argument(
        "--smooth-memory-mb",
        metavar="MB",
        help=f"megabytes of the smoother's tape held in memory, the rest in a temporary directory "
        f"(default {DEFAULT_BUDGET_MB:g}; at least what one chunk needs, at most {MAX_SMOOTH_MEMORY_MB:.0f}: "
        "a terabyte, more than any machine has; the tape beyond it goes to disk)",
    )
    p.add_argument(
        "--smooth-dir",
        type=_path,
        metavar="DIR",
        help="an existing directory for the smoother's temporary files (default: the system's, TMPDIR); "
        "they are removed when the command ends",
    )


def _replace_flag(p: argparse.ArgumentParser, command: str) -> None:
    p.add_argument(
        "--replace",
        action="store_true",
        help=f"replace an earlier {command} study in --out (without it a directory that holds one is "
        "refused; a directory holding anything else always is)",
    )


def _bag_argument(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "bag", type=_path, metavar="PATH", help="a ROS 1 .bag, a ROS 2 bag directory or an .mcap file"
    )


def _bag_mapping_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--bag-mapping",
        type=_path,
        metavar="FILE",
        help="TOML file: which topic feeds which table, frames, time, offsets, extra .msg "
        "definitions (see docs/bags.md); default: the TOML file beside the bag with its stem "
        "(mission.bag: mission.toml), else each table's topic found by message type",
    )


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
        "Yoo 2014 Table 1, a 1 deg/h IMU at 100 Hz; phins: a navigation-grade "
        "fibre-optic IMU of the PHINS class, for real data of that class). Replaces the "
        "file's [imu] section",
    )


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
                flag = {"log": "PATH", "bag": "PATH", "out_dir": "OUT_DIR"}.get(
                    attr, f"--{attr.replace('_', '-')}"
                )
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
        try:
            args = build_parser().parse_args(attach_dash_values(argv))
        except UsageError as exc:
            hints = did_you_mean(argv)
            if not hints:
                raise
            shown = (
                f"did you mean {hints[0][1]}?"
                if len(hints) == 1 and str(exc).startswith("unrecognized arguments")
                else "; ".join(f"{flag}: did you mean {near}?" for flag, near in hints)
            )
            raise UsageError(f"{exc} ({shown})", exc.usage) from None
        _require_file_names(args)
        _require_text_values(args)
        code = args.func(args)
        sys.stdout.flush()  # inside the try: a closed pipe is reported here, not at exit
        return code
    except (UsageError, ConfigError) as exc:
        sys.stderr.write(getattr(exc, "usage", ""))
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


def did_you_mean(argv: Sequence[str]) -> list[tuple[str, str]]:
    """The flags of ``argv`` that its command does not have, each with the nearest one it has
    (``--trajectroy``: ``--trajectory``; difflib's closeness, at least 0.75), as (flag as given,
    shortened; the nearest) pairs; a flag with none near is left out."""
    command, options = "", OPTIONS[""]
    for token in argv:
        if token == "--":
            break
        if token.startswith("-"):
            continue
        inner = f"{command} {token}".strip()
        if inner in OPTIONS:  # the command, then a subcommand's own (tauv log convert)
            command, options = inner, OPTIONS[inner]
        elif command:
            break  # a positional argument (a path): the command is known
    known = sorted({s for a in options + OPTIONS[""] for s in a.option_strings})
    hints: list[tuple[str, str]] = []
    for token in argv:
        if token == "--":
            break
        flag = token.split("=", 1)[0]
        if not flag.startswith("--") or flag in known:
            continue
        near = difflib.get_close_matches(flag, known, n=1, cutoff=0.75)
        if near:
            hints.append((shorten(flag), near[0]))
    return hints


def _require_text_values(args: argparse.Namespace) -> None:
    """argparse drops a value of exactly ``--`` (``--method=--``) and leaves an empty list (in
    the list of a repeatable flag, ``--outage=--``)."""
    command = " ".join(c for c in (args.command, getattr(args, "log_command", None)) if c)
    for action in OPTIONS[""] + OPTIONS.get(command, []):
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


def _path_dests(parser: argparse.ArgumentParser) -> set[str]:
    """The ``args`` attributes of every argument typed :func:`_path`, in every (sub)command."""
    found = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                found |= _path_dests(sub)
        elif action.type is _path:
            found.add(action.dest)
    return found


PATH_FLAGS = frozenset(_path_dests(build_parser()))
"""The arguments that name files or directories (``args`` attributes: the flags and the log
directory typed :func:`_path`, from the parser)."""


if __name__ == "__main__":
    raise SystemExit(main())
