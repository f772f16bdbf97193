"""A run's configuration in words: each setting's name and value in plain words with its unit
("DVL outages: beams 3,4 off 100-150 s", "current: 0.3 m/s towards 45°"), and what tells a run
from the defaults, as a label for people and as a file name.

What a run changed is found, not listed by hand: :func:`changed_settings` compares the run's
:func:`flat_config` with the default configuration's (``tauvcore.config.Config()``), so a setting
added to the configuration is named the day it exists. A replayed log sets the mission's length,
starting depth, origin and IMU rate itself: its trajectory and earth sections are the log's, not a
choice, and are left out (the log is named instead), as are the DVL's range and the VKF's switch
altitude, which a replay does not read.

The file name (:func:`file_stem`) holds only letters, digits, ``.``, ``_`` and ``-``, is at most
:data:`FILE_STEM_MAX` characters (a longer one is cut and ends in a hash of the whole, so two
different runs keep different names) and is the same for the same run, every time.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Iterable
from typing import Any

from tauvcore.config import Config, to_dict

FILE_STEM_MAX = 120
"""Most characters of a file's name before its extension (:func:`file_stem`)."""
_HASH_CHARS = 8  # hex digits of the hash that ends a cut file name
_SAFE = re.compile(r"[^A-Za-z0-9._-]+")
_STEM_KEYS = ("trajectory.name", "trajectory.duration_s", "run.seed")
"""Settings every label and file name carries first, whatever their value."""
_LOG_KEYS = ("trajectory.", "earth.", "dvl.max_altitude_m", "vkf.switch_altitude_m")
"""Prefixes of the settings a replayed log fixes itself (tauvcore.eval.replay.replay_config) or
does not read (app.dashboard.inputs.config_rows)."""
_SECTION_WORDS = {
    "dvl": "DVL",
    "imu": "IMU",
    "rpm": "RPM",
    "vkf": "VKF",
    "usbl": "USBL",
    "echo_sounder": "echo sounder",
}
_SECTION_TOKENS = {"trajectory": "", "echo_sounder": "echo", "initial_error": "init", "magnetometer": "mag"}
_UNITS = (  # a field's unit suffix -> its unit in words; the longest suffix first
    ("_deg_per_s_per_sqrt_s", "°/s/√s"),
    ("_mps2_per_sqrt_s", "m/s²/√s"),
    ("_mps_per_rpm_per_sqrt_s", "m/s/rpm/√s"),
    ("_mps_per_sqrt_h", "m/s/√h"),
    ("_deg_per_sqrt_h", "°/√h"),
    ("_mps_per_sqrt_s", "m/s/√s"),
    ("_pct_per_sqrt_s", "%/√s"),
    ("_per_sqrt_s", "/√s"),
    ("_mps_per_rpm", "m/s/rpm"),
    ("_deg_per_h", "°/h"),
    ("_m2_per_s2", "m²/s²"),
    ("_ne_per_s", "1/s"),
    ("_kg_m3", "kg/m³"),
    ("_n_mps", "m/s"),
    ("_n_m", "m"),
    ("_b_m", "m"),
    ("_mps", "m/s"),
    ("_mrad", "mrad"),
    ("_ppm", "ppm"),
    ("_pct", "%"),
    ("_deg", "°"),
    ("_rpm", "rpm"),
    ("_hz", "Hz"),
    ("_pa", "Pa"),
    ("_mg", "mg"),
    ("_m", "m"),
    ("_s", "s"),
)
_TOKEN_UNITS = {"°": "deg", "%": "pct", "m/s": "mps", "Hz": "hz"}
"""Units a file name keeps (the others are dropped from it: the setting's name says which)."""


def flat_config(config: Config, runs: int | None = None) -> dict[str, Any]:
    """``config`` (tauvcore.config.to_dict) as "section.field" -> value (nested records joined by
    dots, lists as they are); ``runs``: also the Monte Carlo run count, as "runs"."""
    out: dict[str, Any] = {}

    def walk(prefix: str, value: Any) -> None:
        if isinstance(value, dict):
            for key, v in value.items():
                walk(f"{prefix}.{key}" if prefix else key, v)
        else:
            out[prefix] = value

    walk("", to_dict(config))
    if runs is not None:
        out["runs"] = runs
    return out


_DEFAULTS = flat_config(Config())


def _split(key: str) -> tuple[str, str, str]:
    """``key`` as (section, field's words without the unit, the unit in words)."""
    section, _, field = key.rpartition(".")
    for suffix, unit in _UNITS:
        if field.endswith(suffix) and len(field) > len(suffix):
            return section, field[: -len(suffix)].replace("_", " "), unit
    return section, field.replace("_", " "), ""


def setting_name(key: str) -> str:
    """A setting of :func:`flat_config` in plain words: "dvl.noise_mps" -> "DVL noise"."""
    special = {
        "trajectory.current_n_mps": "current",
        "dvl.outages": "DVL outages",
        "dvl.beams": "DVL beams",
        "run.methods": "methods",
        "run.aiding": "aiding",
        "smoother": "smoother",
        "runs": "runs",
    }
    if key in special:
        return special[key]
    section, words, _ = _split(key)
    return f"{_SECTION_WORDS.get(section, section.replace('_', ' '))} {words}".strip()


def _number(value: float) -> str:
    return f"{value:g}"


def _outage_text(outage: dict[str, Any]) -> str:
    beams = ",".join(str(b) for b in outage.get("beams", ()))
    return f"beams {beams} off {_number(outage['start_s'])}-{_number(outage['end_s'])} s"


def _current_text(current_n_mps: list[float]) -> str:
    """A current's velocity (north, east, down) [m/s] as its horizontal speed, the bearing it
    flows towards (clockwise from north) and its vertical part."""
    north, east, down = (float(v) for v in current_n_mps)
    speed = math.hypot(north, east)
    text = (
        f"{speed:.3g} m/s towards {math.degrees(math.atan2(east, north)) % 360.0:.3g}°" if speed else "still"
    )
    if down:
        text += f", {abs(down):.3g} m/s {'down' if down > 0 else 'up'}"
    return text


def setting_value(key: str, value: Any) -> str:
    """The value of setting ``key`` (:func:`flat_config`) in plain words with its unit: never a
    Python list or dict ("beams 3,4 off 100-150 s", "0.3 m/s towards 45°", "LC TC", "1,2,3")."""
    if value is None:
        return "-"
    if key == "dvl.outages":
        return "; ".join(_outage_text(o) for o in value) or "none"
    if key == "trajectory.current_n_mps":
        return _current_text(value)
    if key in ("run.methods", "run.aiding"):
        return " ".join(str(m).upper() for m in value) or "none"
    if key == "dvl.beams":
        return ",".join(str(b) for b in value) or "none"
    if isinstance(value, bool):
        return "on" if value else "off"
    unit = _split(key)[2]
    if isinstance(value, (list, tuple)):
        text = ", ".join(_number(v) if isinstance(v, float) else str(v) for v in value) or "none"
    elif isinstance(value, dict):
        text = ", ".join(f"{k} {setting_value(k, v)}" for k, v in value.items())
    elif isinstance(value, float):
        text = _number(value)
    else:
        text = str(value)
    return f"{text} {unit}".strip() if unit and text not in ("none", "auto") else text


def setting_token(key: str, value: Any) -> str:
    """Setting ``key`` at ``value`` as a short part of a file name (letters, digits, ``.``,
    ``_`` and ``-``): "wt_both", "current0.3mps_to45deg", "b34off100_150s", "dvl_noise0.05"."""
    if key == "dvl.outages":
        parts = [
            f"b{''.join(map(str, o.get('beams', ())))}off{_number(o['start_s'])}_{_number(o['end_s'])}s"
            for o in value
        ]
        token = "_".join(parts) or "no_outages"
    elif key == "trajectory.current_n_mps":
        north, east, down = (float(v) for v in value)
        token = f"current{math.hypot(north, east):.3g}mps_to{math.degrees(math.atan2(east, north)) % 360.0:.3g}deg"
        token += f"_down{down:.3g}" if down else ""
    elif key == "dvl.water_track":
        token = f"wt_{value}"
    elif key in ("run.methods",):
        token = "_".join(value)
    elif key == "run.aiding":
        token = "aid_" + "_".join(value)
    elif key == "dvl.beams":
        token = "beams" + "".join(map(str, value))
    elif key == "smoother":
        token = "smoothed"
    elif key == "runs":
        token = f"{value}runs"
    else:
        section, words, unit = _split(key)
        prefix = _SECTION_TOKENS.get(section, section)
        name = "_".join(filter(None, (prefix, words.replace(" ", "_"))))
        if isinstance(value, bool):
            token = name if value else f"no_{name}"
        elif isinstance(value, (list, tuple)):
            token = name + "_".join(_number(v) if isinstance(v, float) else str(v) for v in value)
        elif isinstance(value, str):
            token = f"{name}_{value}"
        else:
            token = name + (_number(value) if isinstance(value, float) else str(value))
            token += _TOKEN_UNITS.get(unit, "")
    return _SAFE.sub("_", token).strip("_") or "x"


def changed_settings(
    config: Config, runs: int = 1, log: str | None = None, smoothed: bool = False
) -> dict[str, Any]:
    """The settings of ``config`` (:func:`flat_config` keys) whose values differ from the default
    configuration's, in the configuration's order; a replayed ``log`` leaves out what the log
    fixes (its trajectory and earth sections); ``"smoother": True`` when the run was smoothed and
    ``"runs"`` when it is a Monte Carlo of more than one run."""
    flat = flat_config(config)
    out = {
        key: value
        for key, value in flat.items()
        if value != _DEFAULTS.get(key) and not (log is not None and key.startswith(_LOG_KEYS))
    }
    if runs > 1 and out.get("initial_error.mode") == "random":
        del out["initial_error.mode"]  # a Monte Carlo draws each run's initial errors: its run count says so
    if smoothed:
        out["smoother"] = True
    if runs > 1:
        out["runs"] = runs
    return out


def run_words(config: Config, runs: int = 1, log: str | None = None, smoothed: bool = False) -> list[str]:
    """What tells a run from the defaults, in plain words: the mission (or "log NAME") and its
    length, the seed, the methods, then every other setting that differs from the defaults
    (:func:`changed_settings`), "smoother", and the runs of a Monte Carlo."""
    tr = config.trajectory
    words = [f"log {log}" if log is not None else tr.name, f"{tr.duration_s:g} s", f"seed {config.run.seed}"]
    words.append(setting_value("run.methods", config.run.methods))
    for key, value in changed_settings(config, runs, log, smoothed).items():
        if key in (*_STEM_KEYS, "run.methods"):
            continue
        words.append(_phrase(key, value))
    return words


def _phrase(key: str, value: Any) -> str:
    """Setting ``key`` at ``value`` as a short phrase of a label."""
    if key == "dvl.outages":
        return setting_value(key, value)
    if key == "dvl.beams":
        return f"beams {setting_value(key, value)}"
    if key == "dvl.water_track":
        return f"water-track {value}"
    if key == "trajectory.current_n_mps":
        return f"current {setting_value(key, value)}"
    if key == "smoother":
        return "smoother"
    if key == "runs":
        return f"{value} runs"
    if key == "trajectory.truth":
        return f"{value} truth"
    return f"{setting_name(key)} {setting_value(key, value)}"


def file_stem(config: Config, runs: int = 1, log: str | None = None, smoothed: bool = False) -> str:
    """The file name (without extension) of a run's outputs: ``tauv-<trajectory or log-NAME>-<duration>s-seed<seed>``
    and a token (:func:`setting_token`) for every setting that differs from the defaults
    (:func:`changed_settings`); safe characters only, at most :data:`FILE_STEM_MAX` of them."""
    what = f"log-{log}" if log is not None else config.trajectory.name
    parts = [f"tauv-{what}-{config.trajectory.duration_s:g}s-seed{config.run.seed}"]
    changed = changed_settings(config, runs, log, smoothed)
    if "run.methods" in changed:  # the methods first, as in the label
        changed = {"run.methods": changed.pop("run.methods"), **changed}
    parts += [setting_token(k, v) for k, v in changed.items() if k not in _STEM_KEYS]
    return _bounded(_SAFE.sub("_", "-".join(parts)))


def _bounded(stem: str) -> str:
    """``stem`` cut to FILE_STEM_MAX characters, ending in a hash of the whole when cut."""
    if len(stem) <= FILE_STEM_MAX:
        return stem
    digest = hashlib.sha1(stem.encode("utf-8")).hexdigest()[:_HASH_CHARS]
    return f"{stem[: FILE_STEM_MAX - _HASH_CHARS - 1].rstrip('-_.')}-{digest}"


def has_smoothed(results: Iterable[Any]) -> bool:
    """True when any of ``results`` (tauvcore.engine.results.MethodResult) carries the
    smoother's results."""
    return any(getattr(r, "smoothed", None) is not None for r in results)
