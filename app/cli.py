"""The ``tauv`` command line: run scenarios and print or save their results.

    tauv run --trajectory figure8 --method ins,lc --duration 250 --seed 1 --json out.json
    tauv run --method all --beams 1,2            # only beams 1 and 2 return (the paper's case)
    tauv run --method lc,tc,elc --outage 3,4@50:200 --dropout 0.05
    tauv config > my.toml          # full default configuration; edit and pass back with --config
    tauv serve --port 8080         # the browser dashboard

Bad input (unknown trajectory or method, non-positive duration, malformed or unknown TOML,
NaN or negative noise, ...) prints one line naming the field and the value and exits with 2.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Sequence
from typing import Any, NoReturn

import numpy as np

from tauvcore.aiding import AIDING_SOURCES
from tauvcore.config import (
    METHODS,
    Config,
    from_dict,
    merge,
    read_toml,
    to_dict,
    to_toml,
)
from tauvcore.eval.metrics import rms
from tauvcore.eval.runner import MethodResult, run, simulate
from tauvcore.sensors.dvl import Outage
from tauvcore.truth import TRAJECTORIES
from tauvcore.validation import ConfigError

EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad command-line input; the message is the one line shown to the user."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad argument in one line (no usage dump) and exits with 2."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message)


def _csv(flag: str, text: str, choices: Sequence[str], allow_all: bool = False) -> tuple[str, ...]:
    items = tuple(s.strip() for s in text.split(",") if s.strip())
    if allow_all and items == ("all",):
        return tuple(choices)
    if not items:
        raise UsageError(f"{flag}: expected a comma-separated list from {', '.join(choices)}, got {text!r}")
    for item in items:
        if item not in choices:
            raise UsageError(f"{flag}: unknown value {item!r} (choose from {', '.join(choices)})")
    if len(set(items)) != len(items):
        raise UsageError(f"{flag}: repeated value in {text!r}")
    return items


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="tauv", description="Underwater INS/DVL navigation lab (Tal, Klein & Katz 2017).")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    r = sub.add_parser("run", help="simulate a mission and run fusion methods side by side")
    r.add_argument("--trajectory", help=f"one of {', '.join(TRAJECTORIES)} (default from config: straight)")
    r.add_argument("--method", help=f"comma-separated from {', '.join(METHODS)}, or 'all' (default: ins,lc)")
    r.add_argument("--duration", help="run length [s] (default 250)")
    r.add_argument("--seed", help="seed of the random generator (default 0)")
    r.add_argument("--ideal", action="store_true", help="zero every sensor and initial error (verification mode)")
    r.add_argument("--aiding", help=f"comma-separated from {', '.join(AIDING_SOURCES)} (default: dvl)")
    r.add_argument("--beams", help="comma-separated beams that return for the whole run, e.g. 1,2 (default 1,2,3,4)")
    r.add_argument("--outage", action="append", default=[], metavar="BEAMS@START:END",
                   help="beams lost in a window, e.g. 3,4@50:200 (seconds); repeatable")
    r.add_argument("--dropout", help="probability in [0, 1] that each beam misses each ping")
    r.add_argument("--config", help="TOML file (partial files allowed; see 'tauv config')")
    r.add_argument("--json", help="write the configuration and per-epoch results to this JSON file")
    sv = sub.add_parser("serve", help="start the browser dashboard")
    sv.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1; 0.0.0.0 in Docker)")
    sv.add_argument("--port", default="8080", help="TCP port (default 8080)")
    c = sub.add_parser("config", help="print the full configuration as TOML")
    c.add_argument("--config", help="TOML file to merge over the defaults before printing")
    return parser


def resolve_config(args: argparse.Namespace) -> Config:
    """Defaults, then the --config file, then the command-line flags.

    The run length is applied together with the file, so a file's outage after the default 250 s
    is valid when --duration makes the run long enough.
    """
    raw = read_toml(args.config) if args.config else {}
    if getattr(args, "duration", None) is not None:
        duration = _parse("--duration", args.duration, float, "a number of seconds")
        _replace("--duration", Config(), "trajectory", duration_s=duration)   # check it on its own first
        raw = merge(raw, {"trajectory": {"duration_s": duration}})
    config = from_dict(raw)
    if getattr(args, "trajectory", None) is not None:
        if args.trajectory not in TRAJECTORIES:
            raise UsageError(f"--trajectory: unknown trajectory {args.trajectory!r} (choose from {', '.join(TRAJECTORIES)})")
        config = config.replace("trajectory", name=args.trajectory)
    if getattr(args, "seed", None) is not None:
        config = _replace("--seed", config, "run", seed=_parse("--seed", args.seed, int, "a non-negative integer"))
    if getattr(args, "method", None) is not None:
        config = config.replace("run", methods=_csv("--method", args.method, METHODS, allow_all=True))
    if getattr(args, "aiding", None) is not None:
        config = config.replace("run", aiding=_csv("--aiding", args.aiding, AIDING_SOURCES))
    if getattr(args, "ideal", False):
        config = config.replace("run", ideal=True)
    if getattr(args, "beams", None) is not None:
        config = config.replace("dvl", beams=_beam_list("--beams", args.beams))
    if getattr(args, "outage", None):
        outages = tuple(_outage(text) for text in args.outage)
        config = _replace("--outage", config, "dvl", outages=config.dvl.outages + outages)
    if getattr(args, "dropout", None) is not None:
        probability = _parse("--dropout", args.dropout, float, "a probability in [0, 1]")
        config = _replace("--dropout", config, "dvl", dropout_probability=probability)
    return config


def _parse(flag: str, text: str, cast: type, expected: str) -> Any:
    """``cast(text)``, or one line naming the flag, what it expects and what it got."""
    try:
        return cast(text)
    except ValueError:
        raise UsageError(f"{flag}: expected {expected}, got {text!r}") from None


def _replace(flag: str, config: Config, section: str, **changes: Any) -> Config:
    """``config.replace`` with a validation error reported against the flag that caused it."""
    try:
        return config.replace(section, **changes)
    except ConfigError as exc:
        raise UsageError(f"{flag}: {exc}") from None


def _beam_list(flag: str, text: str) -> tuple[int, ...]:
    beams = []
    for item in text.split(","):
        item = item.strip()
        if item not in ("1", "2", "3", "4"):
            raise UsageError(f"{flag}: unknown beam {item!r} in {text!r} (beams are 1, 2, 3, 4)")
        if int(item) in beams:
            raise UsageError(f"{flag}: beam {item} repeated in {text!r}")
        beams.append(int(item))
    return tuple(beams)


def _outage(text: str) -> Outage:
    """Parse ``3,4@50:200``."""
    beams_text, at, window = text.partition("@")
    start_text, colon, end_text = window.partition(":")
    if not at or not colon:
        raise UsageError(f"--outage: expected BEAMS@START:END such as 3,4@50:200, got {text!r}")
    beams = _beam_list("--outage", beams_text)
    try:
        start, end = float(start_text), float(end_text)
    except ValueError:
        raise UsageError(f"--outage: start and end must be seconds, got {window!r} in {text!r}") from None
    try:
        return Outage(beams=beams, start_s=start, end_s=end)
    except ConfigError as exc:
        raise UsageError(f"--outage {text}: {exc}") from None


def result_to_json(result: MethodResult, run_index: int = 0) -> dict[str, list[float]]:
    """Per-epoch series of one run, as in the CLI contract."""
    return {
        "t": result.t_s.tolist(),
        "vel_err_mps": result.vel_err_mps[:, run_index].tolist(),
        "att_err_deg": result.att_err_deg[:, run_index].tolist(),
        "pos_err_m": result.pos_err_m[:, run_index].tolist(),
        "vel_sigma_mps": result.vel_sigma_mps[:, run_index].tolist(),
        "att_sigma_deg": result.att_sigma_deg[:, run_index].tolist(),
        "pos_sigma_m": result.pos_sigma_m[:, run_index].tolist(),
    }


def summary_table(results: dict[str, MethodResult], config: Config, elapsed_s: float) -> str:
    tr = config.trajectory
    lines = [
        f"trajectory {tr.name}, {tr.duration_s:g} s, seed {config.run.seed}, aiding {','.join(config.run.aiding) or 'none'}"
        + (", IDEAL sensors" if config.run.ideal else "") + f"  ({elapsed_s:.1f} s wall)",
        "",
        f"{'method':<7} {'vel final':>10} {'vel RMS':>9} {'att final':>10} {'att RMS':>9} "
        f"{'pos final':>10} {'pos RMS':>9} {'vel 1-sig':>10} {'DVL fused/rej/coast':>20}",
        f"{'':<7} {'[m/s]':>10} {'[m/s]':>9} {'[deg]':>10} {'[deg]':>9} {'[m]':>10} {'[m]':>9} {'[m/s]':>10}",
    ]
    for name, r in results.items():
        dvl = r.updates.get("dvl")
        fused = (f"{int(dvl.fused.sum())}/{int(dvl.rejected.sum())}/{int((~dvl.valid).sum())}"
                 if dvl is not None else "-")
        lines.append(
            f"{name.upper():<7} {r.vel_err_mps[-1, 0]:>10.4f} {rms(r.vel_err_mps[:, 0]):>9.4f} "
            f"{r.att_err_deg[-1, 0]:>10.4f} {rms(r.att_err_deg[:, 0]):>9.4f} "
            f"{r.pos_err_m[-1, 0]:>10.3f} {rms(r.pos_err_m[:, 0]):>9.3f} {r.vel_sigma_mps[-1, 0]:>10.4f} {fused:>20}")
    return "\n".join(lines)


def cmd_run(args: argparse.Namespace) -> int:
    config = resolve_config(args)
    if args.json and not os.path.isdir(os.path.dirname(os.path.abspath(args.json))):
        raise UsageError(f"--json: cannot write {args.json!r}: no such directory")
    started = time.perf_counter()
    rng = np.random.default_rng(config.run.seed)
    sim = simulate(config, rng, num_runs=1)
    results = run(config, sim, rng)
    elapsed = time.perf_counter() - started
    if args.json:
        payload = {"config": to_dict(config), "results": {m: result_to_json(r) for m, r in results.items()}}
        try:
            with open(args.json, "w", encoding="utf-8") as fh:
                json.dump(payload, fh)
        except OSError as exc:
            raise UsageError(f"--json: cannot write {args.json!r}: {exc.strerror}") from None
    print(summary_table(results, config, elapsed))
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        port = int(args.port)
    except ValueError:
        raise UsageError(f"--port: expected a TCP port number, got {args.port!r}") from None
    if not 1 <= port <= 65535:
        raise UsageError(f"--port: must be within 1-65535, got {port}")
    if not args.host.strip():
        raise UsageError(f"--host: expected an address such as 127.0.0.1, got {args.host!r}")
    from app.dashboard import main as serve_main  # viser only when serving
    try:
        serve_main(args.host, port)
    except OSError as exc:
        raise UsageError(f"--host/--port: cannot listen on {args.host}:{port}: {exc.strerror or exc}") from None
    except KeyboardInterrupt:
        pass
    return 0


def cmd_config(args: argparse.Namespace) -> int:
    sys.stdout.write(to_toml(resolve_config(args)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tauv`` console script."""
    try:
        args = build_parser().parse_args(argv)
        if args.command == "run":
            return cmd_run(args)
        if args.command == "serve":
            return cmd_serve(args)
        return cmd_config(args)
    except (UsageError, ConfigError) as exc:
        print(f"tauv: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    raise SystemExit(main())
