"""The command line's values read into a configuration: each flag's text parsed and checked, a bad
one reported as one line naming the flag and the value (:class:`UsageError`), the flags laid over
the defaults, a replayed log's own configuration and the ``--config`` file (:func:`resolve_config`).
"""

from __future__ import annotations

import argparse
import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from tauvcore.aiding import AIDING_SOURCES
from tauvcore.config import (
    AUTO,
    METHODS,
    RUN_METHODS,
    Config,
    from_dict,
    merge,
    read_toml,
    trajectory_preset,
)
from tauvcore.geo.earth import EARTH_MODELS
from tauvcore.sensors.dvl import Outage
from tauvcore.sensors.imu import IMU_PROFILES
from tauvcore.truth import TRAJECTORIES, TRUTH_SOURCES
from tauvcore.validation import ConfigError, one_line, show


class UsageError(Exception):
    """Bad command-line input; the message is the one line shown to the user, after ``usage``
    (text printed before it, such as the list of commands of a bare ``tauv``) when there is one."""

    def __init__(self, message: str, usage: str = "") -> None:
        super().__init__(message)
        self.usage = usage


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
        choice(flag, item, choices, "value")
    if len(set(items)) != len(items):
        raise UsageError(f"{flag}: repeated value in {show(text)}")
    return items


def choice(flag: str, text: str, choices: Iterable[str], what: str) -> str:
    """``text`` if it is one of ``choices``, else one line naming the flag, ``what`` it is and the
    choices: "--imu: unknown IMU profile 'x' (choose from table2, ...)"."""
    if text not in choices:
        raise UsageError(f"{flag}: unknown {what} {show(text)} (choose from {', '.join(choices)})")
    return text


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
        duration = parse_flag("--duration", args.duration, float, "a number of seconds")
        replace_for_flag(
            "--duration", Config(), "trajectory", duration_s=duration
        )  # check it on its own first
        raw = merge(raw, {"trajectory": {"duration_s": duration}})
    name = getattr(args, "trajectory", None)
    if name is None and isinstance(raw.get("trajectory"), dict):
        name = raw["trajectory"].get("name")
    if isinstance(name, str):
        raw = merge(trajectory_preset(name), raw)  # the scenario's own values, under the file's
    config = from_dict(raw)
    if getattr(args, "imu", None) is not None:
        choice("--imu", args.imu, IMU_PROFILES, "IMU profile")
        config = replace_for_flag("--imu", config, "imu", **dataclasses.asdict(IMU_PROFILES[args.imu]))
    if getattr(args, "earth", None) is not None:
        config = config.replace("earth", model=choice("--earth", args.earth, EARTH_MODELS, "earth model"))
    if getattr(args, "trajectory", None) is not None:
        name = choice("--trajectory", args.trajectory, TRAJECTORIES, "trajectory")
        config = config.replace("trajectory", name=name)
    if getattr(args, "truth", None) is not None:
        truth = choice("--truth", args.truth, TRUTH_SOURCES, "truth source")
        config = replace_for_flag("--truth", config, "trajectory", truth=truth)
    if getattr(args, "seed", None) is not None:
        config = replace_for_flag(
            "--seed", config, "run", seed=parse_flag("--seed", args.seed, int, "a non-negative integer")
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
        config = replace_for_flag("--outage", config, "dvl", outages=config.dvl.outages + outages)
    if getattr(args, "dropout", None) is not None:
        probability = parse_flag("--dropout", args.dropout, float, "a probability in [0, 1]")
        config = replace_for_flag("--dropout", config, "dvl", dropout_probability=probability)
    if getattr(args, "vb_nf", None) is not None:
        config = replace_for_flag(
            "--vb-nf",
            config,
            "partial",
            vb_nf=parse_flag("--vb-nf", args.vb_nf, float, "a number in [1, 100]"),
        )
    if getattr(args, "nsv_epsilon", None) is not None:
        epsilon = (
            AUTO
            if args.nsv_epsilon == AUTO
            else parse_flag("--nsv-epsilon", args.nsv_epsilon, float, f"a number in (0, 100] or {AUTO!r}")
        )
        config = replace_for_flag("--nsv-epsilon", config, "partial", nsv_epsilon_m2_per_s2=epsilon)
    return config


def parse_flag(flag: str, text: str, cast: type, expected: str) -> Any:
    """``cast(text)``, or one line naming the flag, what it expects and what it got."""
    try:
        value = cast(text)
    except ValueError:  # also an integer of more than 4300 digits
        raise UsageError(f"{flag}: expected {expected}, got {show(text)}") from None
    if isinstance(value, float) and not np.isfinite(value):  # "nan", "-inf", or "9" * 500 overflowing to inf
        raise UsageError(f"{flag}: expected {expected}, got {show(text)}")
    return value


def replace_for_flag(flag: str, config: Config, section: str, **changes: Any) -> Config:
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


def check_dask(address: str) -> None:
    """Fail fast, with one line naming ``--dask`` and the address, if no Dask scheduler answers at
    ``address`` (``tauv mc``, ``tauv reproduce`` and ``tauv tune``)."""
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
