"""The dashboard's controls as typed, read strictly into the configuration a run uses.

Numeric controls are text fields: what the user typed reaches the server unchanged (the browser's
number field would drop an "e" and turn "1e3" into 13). A value is a number written in decimal or
scientific notation (``250``, ``0.5``, ``1e3``, ``-2.5E-1``; surrounding spaces ignored) and
finite; whole-number controls (Seed, Runs) take digits only (``2.5`` and ``1e30`` are refused,
not rounded). Anything else, empty, ``NaN``, ``inf``, hexadecimal or ``1_000``, is refused with
one message naming the control and the value as typed. Ranges are the configuration's own
(tauvcore.config): a value out of range is refused with the control's label in front of the
configuration's message. NSV's epsilon also takes the word ``auto`` (derived from the vehicle,
tauvcore.config.PartialConfig). The ocean current is typed as an engineer states it, speed and
the direction it flows toward in degrees, with a shear along that direction and a varying part
(:func:`current_fields` turns them into the NED fields of tauvcore.truth.current); a current the
configuration refuses (reaching the vehicle's speed, a crab beyond 45 deg) is named by its control
with the configuration's own line. The DVL's water-track and the filters' current states are choices
of tauvcore.sensors.dvl (WATER_TRACK, CURRENT_STATES); a combination the configuration refuses (a
water-track layer beyond the DVL's range, water-track beyond range with a log's noisy beams, the
current states with the smoother) is named by its control. A plug-in aiding source's controls
(app.dashboard.controls) are read the same way into its section (``Config.sources``), a 3-vector as three
numbers separated by commas; a ticked source joins ``run.aiding``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from app.dashboard.controls import DEFAULT_SOURCE_FIELDS, PLUGIN_FIELDS
from tauvcore.aiding.registry import REGISTRY
from tauvcore.aiding.sources import FUSED
from tauvcore.config import AUTO, RUN_METHODS, Config, from_dict, trajectory_preset
from tauvcore.engine.smooth_defaults import DEFAULT_BUDGET_MB
from tauvcore.sensors.dvl import DvlConfig, Outage
from tauvcore.truth import TrajectoryConfig
from tauvcore.validation import ConfigError, settings, show

TRAJECTORY = "Trajectory"
TRUTH = "Truth"
TRUTH_HINT = (
    "kinematic: closed-form motion along the trajectory; dynamic: the 6-DOF TAUV flown along it by its "
    "autopilot (fins and propeller in the Vehicle tab and the 3-D view). A log replays its own reference"
)
SOURCE = "Source"
SIMULATION = "simulation"
"""The Source dropdown's first choice (``tauv serve --logs`` adds the logs it found)."""
DURATION = "Duration [s]"
DROPOUT = "Dropout probability"
ACCEL_BIAS = "Accel bias [mg]"
GYRO_BIAS = "Gyro bias [deg/h]"
ACCEL_NOISE = "Accel noise [m/s/sqrt(h)]"
GYRO_NOISE = "Gyro noise [deg/sqrt(h)]"
DVL_NOISE = "DVL noise [m/s]"
DVL_BIAS = "DVL bias [m/s]"
DVL_SF = "DVL scale factor [%]"
VB_NF = "VB n_f"
NSV_EPSILON = "NSV epsilon [m^2/s^2]"
VB_NF_HINT = (
    "n_f of eq. 28, 1 to 100: how many times the virtual beam's predicted sigma is inflated "
    "(VB, VHV, ELC); small values fuse the filter's own prediction as news"
)
NSV_EPSILON_HINT = (
    'variance of the "sway = 0" assumption (NSV, ELC), (0, 100] m^2/s^2, or "auto": '
    "derived from the vehicle's sideslip in its tightest turn"
)
RPM_FALLBACK = "RPM fallback"
RPM_FALLBACK_HINT = (
    "the first paper's DVL methods fuse the propeller's velocity (RPM through the VKF's learned "
    "scale factor and bias) at pings that give them no DVL velocity; neither paper does"
)
SEABED_FOLDER = "Seabed and RPM"
"""The folder of the seabed's, the DVL's range's and the propeller's controls (Yoo 2014's mission)."""
SEABED_DEPTH = "Seabed depth [m]"
DVL_MAX_ALTITUDE = "DVL max altitude [m]"
SWITCH_ALTITUDE = "Switch altitude [m]"
RPM_NOISE = "RPM noise [rpm]"
SEABED_DEPTH_HINT = (
    "depth of the seabed (flat, or the terrain's mean; longrange cuts its two trenches below it), "
    "(0, 11000] m"
)
DVL_MAX_ALTITUDE_HINT = (
    "the DVL's bottom lock reaches this altitude, (0, 11000] m; higher, its beams find no seabed (lost)"
)
SWITCH_ALTITUDE_HINT = (
    "alpha of Yoo 2014 eq. 29, (0, 11000] m: above this altitude the VKF aids with the "
    "propeller RPM instead of the DVL"
)
RPM_NOISE_HINT = "white noise of the propeller's shaft speed (VKF, RPM fallback), [0, 1000] rpm; 0: ideal"
CURRENT_FOLDER = "Ocean current"
"""The folder of the current the truth flies in (tauvcore.truth.current): still water on a new page."""
CURRENT_SPEED = "Current [m/s]"
CURRENT_TOWARD = "Current toward [deg]"
CURRENT_SHEAR = "Current shear [1/s]"
CURRENT_VARIATION = "Current variation [m/s]"
CURRENT_SPEED_MAX_MPS = 3.0
"""Fastest current the controls take [m/s]: the configuration's bound on each component
(trajectory.current_n_mps), beyond the strongest tidal streams an AUV works in."""
CURRENT_SHEAR_MAX_PER_S = 0.1
"""Strongest shear the controls take [1/s]: the configuration's bound on each component."""
CURRENT_SPEED_HINT = (
    f"horizontal speed of the water at the start depth, [0, {CURRENT_SPEED_MAX_MPS:g}] m/s; refused "
    "unless below the vehicle's speed (2 m/s; longrange 5.1) and, with the kinematic truth, needing "
    "a crab of at most 45 deg"
)
CURRENT_TOWARD_HINT = (
    "the direction the water flows toward, clockwise from north, [0, 360] deg: 90 flows east "
    "(the oceanographer's convention; a wind is named where it comes from)"
)
CURRENT_SHEAR_HINT = (
    "change of the current along Current toward per metre of depth below the start depth, "
    f"[-{CURRENT_SHEAR_MAX_PER_S:g}, {CURRENT_SHEAR_MAX_PER_S:g}] 1/s (ocean: 0.001 to 0.01); "
    "positive: faster deeper"
)
CURRENT_VARIATION_HINT = (
    "RMS of a slowly varying part on the north and east axes, [0, 3] m/s: periods of 600 s to "
    "80 min, seeded (the same for every run)"
)
DVL_WATER_TRACK = "Water-track"
DVL_CURRENT_STATES = "Current states"
_DVL_HINTS = {name: s.hint for name, _, s in settings(DvlConfig)}
DVL_WATER_TRACK_HINT = (
    f"{_DVL_HINTS['water_track']}: a water-tracking beam measures the DVL's velocity through a layer of "
    f"water below its head, not over ground; the filters fuse it only with {DVL_CURRENT_STATES} on"
)
DVL_CURRENT_STATES_HINT = (
    f"{_DVL_HINTS['current_states']} (north, east) as two more error states, observed by the water-track "
    "beams; its estimate in the Sensors tab, its NEES in the Consistency tab (block current)"
)
METHOD_HINTS = {
    "ins-dvl": "Yoo 2014's 12-state INS aided by the DVL's velocity (at least three beams); no position state",
    "vkf": (
        "Yoo 2014's 12-state INS aided by the DVL within the switch altitude (100 m) of the seabed, else by "
        "the propeller RPM through the velocity Kalman filter (eq. 29); its learned scale factor and bias in "
        "the Seabed tab"
    ),
}
METHOD_HINTS.update({m.name: m.summary for m in REGISTRY.values()})  # registered: their own summary
"""Hints of the method checkboxes that need one (Yoo 2014's, and the registered methods'; the first
paper's are named in the README's table of methods)."""
FULL_BEAM_METHODS = ("lc", "ins-dvl")
"""Methods that fuse no DVL velocity with fewer than three beams (tauvcore.engine.yoo_bank for INS-DVL)."""
SEED = "Seed"
RUNS = "Runs"
SMOOTHER = "Smoother"
SMOOTHER_HINT = (
    "after the run, the fixed-interval smoother (Rauch-Tung-Striebel) of every method over the "
    "whole run: the Plots and Consistency tabs' Smoothed box draws it beside the filter"
)
SMOOTHER_MB = "Smoother memory [MB]"
SMOOTHER_MB_HINT = (
    "the smoother's record of the run held in memory, (0, 4096] MB; beyond it, a temporary file"
)
SMOOTHER_MB_DEFAULT = DEFAULT_BUDGET_MB
"""What Smoother memory [MB] holds on a new page: the command line's ``--smooth-memory-mb`` default,
tauvcore.engine.smooth_defaults.DEFAULT_BUDGET_MB itself."""
SMOOTHER_MB_MAX = 4096.0
"""Most megabytes of the smoother's record a run may hold in memory (the run's budget bounds it too)."""
RUNS_MAX = 1000
"""Most Monte Carlo runs a tab may ask for (the memory budget of app.dashboard.budget bounds it further)."""
TEXT_MAX_CHARS = 40
"""Longest text a numeric control may hold (a double needs at most 24 characters)."""


def outage_labels(beam: int) -> tuple[str, str]:
    return f"Beam {beam} outage start", f"Beam {beam} outage end"


FIELD_LABELS = {
    "trajectory.duration_s": DURATION,
    "trajectory.truth": TRUTH,
    "imu.accel_bias_mg": ACCEL_BIAS,
    "imu.gyro_bias_deg_per_h": GYRO_BIAS,
    "imu.accel_noise_mps_per_sqrt_h": ACCEL_NOISE,
    "imu.gyro_noise_deg_per_sqrt_h": GYRO_NOISE,
    "dvl.noise_mps": DVL_NOISE,
    "dvl.bias_mps": DVL_BIAS,
    "dvl.scale_factor_pct": DVL_SF,
    "dvl.dropout_probability": DROPOUT,
    "dvl.outages": "Outages",
    "dvl.max_altitude_m": DVL_MAX_ALTITUDE,
    "dvl.water_track": DVL_WATER_TRACK,
    "dvl.current_states": DVL_CURRENT_STATES,
    "trajectory.seabed_depth_m": SEABED_DEPTH,
    "vkf.switch_altitude_m": SWITCH_ALTITUDE,
    "rpm.noise_rpm": RPM_NOISE,
    "partial.vb_nf": VB_NF,
    "partial.nsv_epsilon_m2_per_s2": NSV_EPSILON,
    "run.seed": SEED,
    **{f.key: f.label for f in PLUGIN_FIELDS.values()},  # the plug-in sources' (app.dashboard.controls)
}
"""Configuration field -> the control that sets it (for messages)."""

_FLOAT = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_INT = re.compile(r"[+-]?\d+")


class InputError(Exception):
    """A control holds a value the run cannot use; the message names it and the value."""


def _spelled(label: str, text: str, pattern: re.Pattern[str], what: str) -> str:
    """``text`` stripped if it spells ``what`` by ``pattern``, else InputError naming ``label``."""
    s = text.strip()
    if not s:
        raise InputError(f"{label}: empty; type {what}")
    if len(s) > TEXT_MAX_CHARS or not pattern.fullmatch(s):
        raise InputError(f"{label}: {show(text)} is not {what}")
    return s


def parse_float(label: str, text: str) -> float:
    """The finite number ``text`` spells, or InputError naming ``label`` and ``text``."""
    value = float(_spelled(label, text, _FLOAT, "a number"))
    if not math.isfinite(value):  # "1e999" matches the pattern and overflows
        raise InputError(f"{label}: {show(text)} is too large")
    return value


def parse_int(label: str, text: str) -> int:
    """The whole number ``text`` spells in digits, or InputError naming ``label`` and ``text``."""
    return int(_spelled(label, text, _INT, "a whole number (digits only)"))


def parse_float_or_auto(label: str, text: str) -> float | str:
    """``"auto"`` if ``text`` is that word (any case, spaces around ignored), else the finite
    number it spells as :func:`parse_float` reads it; InputError naming ``label`` and ``text``."""
    if text.strip().lower() == AUTO:
        return AUTO
    _spelled(label, text, _FLOAT, f'a number or "{AUTO}"')
    return parse_float(label, text)


def parse_vector(label: str, text: str) -> tuple[float, float, float]:
    """The three finite numbers ``text`` spells separated by commas (each as :func:`parse_float`
    reads it), or InputError naming ``label`` and ``text``."""
    parts = text.split(",")
    try:
        if len(parts) != 3:
            raise InputError(label)
        x, y, z = (parse_float(label, part) for part in parts)
    except InputError:
        raise InputError(f"{label}: {show(text)} is not three numbers separated by commas") from None
    return x, y, z


@dataclass(frozen=True)
class Controls:
    """What the page's controls hold: numeric fields as typed, checkboxes and choices as set."""

    trajectory: str
    duration: str
    methods: tuple[str, ...]  # selected, lower case
    vb_nf: str  # VB's n_f (also VHV, ELC), as typed
    nsv_epsilon: str  # NSV's epsilon [m^2/s^2] or "auto", as typed
    beams: tuple[int, ...]  # switched on, 1..4
    dropout: str
    outages: tuple[tuple[str, str], ...]  # (start, end) per beam 1..4, as typed [s]
    accel_bias: str
    gyro_bias: str
    accel_noise: str
    gyro_noise: str
    dvl_noise: str
    dvl_bias: str
    dvl_sf: str
    seabed_depth: str  # trajectory.seabed_depth_m, as typed [m]
    dvl_max_altitude: str  # dvl.max_altitude_m, as typed [m]
    switch_altitude: str  # vkf.switch_altitude_m, as typed [m]
    rpm_noise: str  # rpm.noise_rpm, as typed [rpm]
    seed: str
    runs: str
    source: str = SIMULATION  # "simulation" or the name of a log (tauv serve --logs)
    truth: str = TrajectoryConfig.truth  # one of tauvcore.truth.TRUTH_SOURCES (a simulation's only)
    rpm_fallback: bool = False  # run.rpm_fallback: DVL methods fuse the RPM velocity without DVL
    aid_sources: tuple[str, ...] = ()  # the plug-in sources ticked (app.dashboard.controls), by name
    source_fields: tuple[tuple[str, str | bool], ...] = DEFAULT_SOURCE_FIELDS  # "<source>.<field>" ->
    # as typed (a checkbox: on or off), every plug-in field in the registry's order
    smoother: bool = False  # run the fixed-interval smoother after the forward pass
    smoother_mb: str = f"{SMOOTHER_MB_DEFAULT:g}"  # its tape held in memory [MB], as typed
    current_speed: str = "0"  # horizontal speed of the current [m/s], as typed
    current_toward: str = "0"  # the direction it flows toward, clockwise from north [deg], as typed
    current_shear: str = "0"  # its change along that direction per metre of depth [1/s], as typed
    current_variation: str = "0"  # trajectory.current_variation_mps, as typed [m/s]
    water_track: str = DvlConfig.water_track  # dvl.water_track, one of tauvcore.sensors.dvl.WATER_TRACK
    current_states: str = DvlConfig.current_states  # dvl.current_states, one of CURRENT_STATES


def field_text(value: object) -> str:
    """A configuration value as a numeric control shows it (the text reads back as the same number
    to twelve significant digits)."""
    return f"{value:.12g}" if isinstance(value, float) else str(value)


def preset_controls(name: str, config: Config | None = None) -> dict[str, str]:
    """Control label -> text for each control the scenario ``name``'s preset sets
    (tauvcore.config.trajectory_preset; ``{}`` for a scenario that brings none): the preset's own
    values, or with ``config`` that configuration's (``Config()``: the defaults the controls had
    before the preset)."""
    preset = trajectory_preset(name)
    source = config if config is not None else from_dict(preset)
    return {
        FIELD_LABELS[f"{sec}.{key}"]: field_text(getattr(getattr(source, sec), key))
        for sec, values in preset.items()
        for key in values
        if f"{sec}.{key}" in FIELD_LABELS
    }


def preset_note(name: str) -> str:
    """What the scenario ``name``'s preset sets, in one Markdown paragraph: the controls it fills
    in on this tab, and the settings without a control that a Run of ``name`` takes from it."""
    preset = trajectory_preset(name)
    if not preset:
        return ""
    shown = ", ".join(f"{label} {text}" for label, text in preset_controls(name).items())
    hidden = ", ".join(
        f"{sec}.{key} {value:.4g}"
        for sec, values in preset.items()
        for key, value in values.items()
        if f"{sec}.{key}" not in FIELD_LABELS
    )
    return f"**{name}** preset applied: {shown} (on this tab); a Run of {name} also takes {hidden} from it."


def preset_headline(name: str) -> str:
    """:func:`preset_note` in one short line, for a notification ("" without a preset)."""
    preset = trajectory_preset(name)
    if not preset:
        return ""
    shown = preset_controls(name)
    hidden = sum(len(values) for values in preset.values()) - len(shown)
    return (
        f"{', '.join(shown)} filled in; {hidden} settings without a control apply at Run "
        "(listed under the Run button)."
    )


def _polar_ne(magnitude: float, toward_deg: float) -> tuple[float, float]:
    """North and east parts of ``magnitude`` toward ``toward_deg`` (clockwise from north), each to
    twelve significant digits and a part below 1e-12 of the magnitude zero (cos 90 deg is 6e-17)."""
    angle = math.radians(toward_deg)
    north, east = (
        0.0 if abs(v) <= 1e-12 * abs(magnitude) else float(f"{v:.12g}")
        for v in (magnitude * math.cos(angle), magnitude * math.sin(angle))
    )
    return north, east


def current_fields(c: Controls) -> dict[str, Any]:
    """The trajectory fields of the current the controls describe: speed and direction become
    ``current_n_mps = (s cos d, s sin d, 0)``, the shear along the same direction
    ``current_shear_ne_per_s = (g cos d, g sin d)`` (tauvcore.truth.current).

    Parameters
    ----------
    c : Controls
        What the page's controls hold (``current_speed`` [m/s], ``current_toward`` [deg],
        ``current_shear`` [1/s], ``current_variation`` [m/s], as typed).

    Returns
    -------
    dict[str, Any]
        ``current_n_mps`` (3,) NED [m/s], ``current_shear_ne_per_s`` (2,) [1/s] and
        ``current_variation_mps`` [m/s], for ``Config.replace("trajectory", ...)``.

    Raises
    ------
    InputError
        A control is not a number, or the speed, direction or shear out of range: one line naming
        the control and the value as typed (the variation's range is the configuration's).
    """
    speed = parse_float(CURRENT_SPEED, c.current_speed)
    toward = parse_float(CURRENT_TOWARD, c.current_toward)
    shear = parse_float(CURRENT_SHEAR, c.current_shear)
    variation = parse_float(CURRENT_VARIATION, c.current_variation)
    if not 0.0 <= speed <= CURRENT_SPEED_MAX_MPS:
        raise InputError(
            f"{CURRENT_SPEED}: {show(c.current_speed)} is out of range; a current's speed is "
            f"[0, {CURRENT_SPEED_MAX_MPS:g}] m/s ({CURRENT_TOWARD} turns it)"
        )
    if not 0.0 <= toward <= 360.0:
        raise InputError(
            f"{CURRENT_TOWARD}: {show(c.current_toward)} is out of range; the direction the water "
            "flows toward is [0, 360] deg clockwise from north"
        )
    if not abs(shear) <= CURRENT_SHEAR_MAX_PER_S:
        raise InputError(
            f"{CURRENT_SHEAR}: {show(c.current_shear)} is out of range; a shear is "
            f"[-{CURRENT_SHEAR_MAX_PER_S:g}, {CURRENT_SHEAR_MAX_PER_S:g}] 1/s"
        )
    return {
        "current_n_mps": (*_polar_ne(speed, toward), 0.0),
        "current_shear_ne_per_s": _polar_ne(shear, toward),
        "current_variation_mps": variation,
    }


def _current_label(message: str, current: dict[str, Any]) -> str | None:
    """The current's control a configuration ``message`` is about; None for another field's. The
    configuration refuses the current as a whole by ``trajectory.current_n_mps`` (reaching the
    vehicle's speed, a crab beyond 45 deg): named by the first of its controls set, speed first."""
    if message.startswith("trajectory.current_variation_mps"):
        return CURRENT_VARIATION
    if message.startswith("trajectory.current_shear_ne_per_s"):
        return CURRENT_SHEAR
    if not message.startswith("trajectory.current_n_mps"):
        return None
    if any(current["current_n_mps"]) or not (
        current["current_variation_mps"] or any(current["current_shear_ne_per_s"])
    ):
        return CURRENT_SPEED
    return CURRENT_VARIATION if current["current_variation_mps"] else CURRENT_SHEAR


def current_text(trajectory: TrajectoryConfig) -> str:
    """The mission's current in one line, as the controls name it: "still water", or its speed and
    direction at the start depth, a vertical part, its shear and its varying part where set.

    Parameters
    ----------
    trajectory : TrajectoryConfig
        The mission (``current_n_mps`` [m/s], ``current_shear_ne_per_s`` [1/s],
        ``current_variation_mps`` [m/s], ``current_variation_period_s`` [s], ``current_seed``).

    Returns
    -------
    str
        E.g. ``"0.5 m/s toward 90 deg, shear 0.01 1/s, variation 0.1 m/s RMS (600 s, seed 0)"``.
    """
    north, east, down = trajectory.current_n_mps
    shear_n, shear_e = trajectory.current_shear_ne_per_s
    variation = trajectory.current_variation_mps
    if not (any(trajectory.current_n_mps) or shear_n or shear_e or variation):
        return "still water"
    speed, shear = math.hypot(north, east), math.hypot(shear_n, shear_e)
    parts = [f"{speed:.3g} m/s toward {_bearing_deg(north, east):.3g} deg" if speed else "0 m/s"]
    if down:
        parts.append(f"down {down:.3g} m/s")
    along = (shear_n * north + shear_e * east) / speed if speed else 0.0
    if shear and speed and math.isclose(abs(along), shear, rel_tol=1e-9):  # along the current
        parts.append(f"shear {along:.3g} 1/s")
    elif shear:
        parts.append(f"shear {shear:.3g} 1/s toward {_bearing_deg(shear_n, shear_e):.3g} deg")
    if variation:
        parts.append(
            f"variation {variation:.3g} m/s RMS ({trajectory.current_variation_period_s:g} s, "
            f"seed {trajectory.current_seed})"
        )
    return ", ".join(parts)


def _bearing_deg(north: float, east: float) -> float:
    """The direction of (north, east), clockwise from north, in [0, 360) [deg]."""
    return math.degrees(math.atan2(east, north)) % 360.0


def _label_for(exc: ConfigError) -> str | None:
    message = str(exc)
    for field_name in sorted(FIELD_LABELS, key=len, reverse=True):
        if message.startswith(field_name):
            return FIELD_LABELS[field_name]
    return None


def smoother_mb_from_controls(c: Controls) -> float | None:
    """The smoother a run of the controls asks for, as the megabytes of its tape held in memory
    (tauvcore.engine.smoothing.SmoothOptions.budget_mb): None when the Smoother box is off.

    Parameters
    ----------
    c : Controls
        What the page's controls hold.

    Returns
    -------
    float or None
        Smoother memory [MB] as a number, or None (no smoother).

    Raises
    ------
    InputError
        Smoother memory [MB] is not a number in (0, SMOOTHER_MB_MAX] (with the box on or off: a
        bad value is named before the box is ticked); one line naming the control and the value
        as typed.
    """
    mb = parse_float(SMOOTHER_MB, c.smoother_mb)
    if not 0.0 < mb <= SMOOTHER_MB_MAX:
        raise InputError(
            f"{SMOOTHER_MB}: {show(c.smoother_mb)} is out of range; the smoother's memory is "
            f"(0, {SMOOTHER_MB_MAX:g}] MB"
        )
    if not c.smoother:
        return None
    return mb


def config_from_controls(c: Controls, log_config: dict[str, Any] | None = None) -> tuple[Config, int]:
    """The configuration and Monte Carlo run count the controls describe, over the chosen
    scenario's preset (tauvcore.config.trajectory_preset) where it sets what no control does;
    for a log (``c.source``), over the log's own configuration file instead (``log_config``, its
    raw tables: tauvcore.eval.replay.log_config), as ``tauv replay`` lays the flags over it.

    Raises InputError with one line naming the control and the value as typed.
    """
    methods, runs, seed, beams = _run_choices(c)
    typed = _number_texts(c)
    numbers = {label: parse_float(label, text) for label, text in typed.items()}
    epsilon = parse_float_or_auto(NSV_EPSILON, c.nsv_epsilon)
    current = current_fields(c)
    # what a message quotes of the controls the configuration may refuse (the plug-ins' join below)
    typed |= {SEED: c.seed, NSV_EPSILON: c.nsv_epsilon, CURRENT_SPEED: c.current_speed}
    typed |= {CURRENT_SHEAR: c.current_shear, CURRENT_VARIATION: c.current_variation}
    plugin_sections = _plugin_sections(c, typed)
    outages = _outages(c)
    aiding = ("dvl",) + tuple(name for name in FUSED if name in c.aid_sources)
    try:
        config = (
            _mission_config(c, log_config, numbers, epsilon, current, beams)
            .replace("run", methods=methods, aiding=aiding, seed=seed, rpm_fallback=c.rpm_fallback)
            .replace("dvl", outages=outages)
        )
        for name, changes in plugin_sections.items():
            config = config.replace(name, **changes)
    except ConfigError as exc:
        raise _input_error(exc, c, current, typed) from None
    return config, runs


def _run_choices(c: Controls) -> tuple[tuple[str, ...], int, int, tuple[int, ...]]:
    """The methods, Monte Carlo runs, seed and DVL beams the controls choose, each checked (a log
    replayed once, beams enough for the DVL methods; the smoother's controls with them)."""
    methods = tuple(m for m in RUN_METHODS if m in c.methods)
    if not methods:
        raise InputError("Methods: select at least one method")
    runs = parse_int(RUNS, c.runs)
    if not 1 <= runs <= RUNS_MAX:
        raise InputError(f"{RUNS}: {show(c.runs)} is out of range; Monte Carlo runs are 1 to {RUNS_MAX}")
    if c.source != SIMULATION and runs != 1:
        raise InputError(
            f"{RUNS}: {show(c.runs)} runs of the log {show(c.source)}; a recorded log is replayed "
            "once (set Runs to 1)"
        )
    smoother_mb_from_controls(c)  # the smoother's controls checked with the others
    seed = parse_int(SEED, c.seed)
    if seed < 0:
        raise InputError(f"{SEED}: {show(c.seed)} is negative; a seed is a whole number >= 0")
    beams = tuple(k for k in range(1, 5) if k in c.beams)
    dvl_methods = [m for m in methods if m != "ins"]
    if dvl_methods and not beams:
        raise InputError(
            "DVL beams: all four are off, so no DVL method can aid; switch a beam on or select INS only"
        )
    # with the RPM fallback LC fuses the propeller's velocity where it has too few beams
    full_beam = tuple(m for m in FULL_BEAM_METHODS if not (c.rpm_fallback and m == "lc"))
    if dvl_methods and set(dvl_methods) <= set(full_beam) and len(beams) < 3:
        names = " and ".join(m.upper() for m in dvl_methods)
        raise InputError(
            f"{names} need{'s' if len(dvl_methods) == 1 else ''} three or more beams, but only "
            f"{len(beams)} ({', '.join(map(str, beams)) or 'none'}) are on; add TC, an ELC method "
            "or VKF"
        )
    return methods, runs, seed, beams


def _number_texts(c: Controls) -> dict[str, str]:
    """Label -> text as typed of the numeric controls read as plain numbers, in the order they are read."""
    return {
        DURATION: c.duration,
        DROPOUT: c.dropout,
        ACCEL_BIAS: c.accel_bias,
        GYRO_BIAS: c.gyro_bias,
        ACCEL_NOISE: c.accel_noise,
        GYRO_NOISE: c.gyro_noise,
        DVL_NOISE: c.dvl_noise,
        DVL_BIAS: c.dvl_bias,
        DVL_SF: c.dvl_sf,
        VB_NF: c.vb_nf,
        SEABED_DEPTH: c.seabed_depth,
        DVL_MAX_ALTITUDE: c.dvl_max_altitude,
        SWITCH_ALTITUDE: c.switch_altitude,
        RPM_NOISE: c.rpm_noise,
    }


def _plugin_sections(c: Controls, typed: dict[str, str]) -> dict[str, dict[str, Any]]:
    """Section -> field -> value of the plug-in sources' controls (app.dashboard.controls), each
    field's text added to ``typed`` (label -> text, for messages)."""
    held = dict(c.source_fields)
    sections: dict[str, dict[str, Any]] = {}
    for f in PLUGIN_FIELDS.values():
        value = held.get(f.key, f.default)
        if f.kind == "flag":
            value = bool(value)
        else:
            typed[f.label] = text = str(value)
            value = (parse_vector if f.kind == "vector" else parse_float)(f.label, text)
        sections.setdefault(f.section, {})[f.field] = value
    return sections


def _outages(c: Controls) -> tuple[Outage, ...]:
    """The beams' outage windows the controls set (start = end = 0: none for that beam)."""
    outages = []
    for k, (start_text, end_text) in enumerate(c.outages, start=1):
        start_label, end_label = outage_labels(k)
        start, end = parse_float(start_label, start_text), parse_float(end_label, end_text)
        if start == end == 0.0:
            continue
        if end <= start:
            raise InputError(f"Beam {k} outage ends ({end:g} s) before it starts ({start:g} s)")
        outages.append(Outage(beams=(k,), start_s=start, end_s=end))
    return tuple(outages)


def _mission_config(
    c: Controls,
    log_config: dict[str, Any] | None,
    numbers: dict[str, float],
    epsilon: float | str,
    current: dict[str, Any],
    beams: tuple[int, ...],
) -> Config:
    """The scenario's preset (a log's own configuration) with the controls' mission, IMU, DVL,
    VKF, RPM and partial-beam settings laid over it (``numbers``: label -> value)."""
    simulation = c.source == SIMULATION
    # a log's truth is its own reference: the (then disabled) Truth control does not apply to it
    truth = c.truth if simulation else TrajectoryConfig.truth
    # ... nor does the current the truth flies in: the log's own configuration's stands
    water = current if simulation else {}
    # the scenario's own settings (longrange: the paper's speed, depth, IMU and DVL rate; its seabed
    # and IMU errors fill in controls) under the controls', as `tauv run --trajectory` lays them under a file's
    base = trajectory_preset(c.trajectory) if simulation else (log_config or {})
    return (
        from_dict(base)
        .replace(
            "trajectory",
            name=c.trajectory,
            duration_s=numbers[DURATION],
            truth=truth,
            seabed_depth_m=numbers[SEABED_DEPTH],
            **water,
        )
        .replace(
            "imu",
            accel_bias_mg=numbers[ACCEL_BIAS],
            gyro_bias_deg_per_h=numbers[GYRO_BIAS],
            accel_noise_mps_per_sqrt_h=numbers[ACCEL_NOISE],
            gyro_noise_deg_per_sqrt_h=numbers[GYRO_NOISE],
        )
        .replace(
            "dvl",
            noise_mps=numbers[DVL_NOISE],
            bias_mps=numbers[DVL_BIAS],
            scale_factor_pct=numbers[DVL_SF],
            beams=beams,
            dropout_probability=numbers[DROPOUT],
            max_altitude_m=numbers[DVL_MAX_ALTITUDE],
            water_track=c.water_track,
            current_states=c.current_states,
        )
        .replace("vkf", switch_altitude_m=numbers[SWITCH_ALTITUDE])
        .replace("rpm", noise_rpm=numbers[RPM_NOISE])
        .replace("partial", vb_nf=numbers[VB_NF], nsv_epsilon_m2_per_s2=epsilon)
    )


def _input_error(exc: ConfigError, c: Controls, current: dict[str, Any], typed: dict[str, str]) -> InputError:
    """The configuration's refusal ``exc`` as one line naming the control that set the field and,
    where it has one (``typed``: label -> text), its value as typed."""
    label = _current_label(str(exc), current) or _label_for(exc)
    if str(exc).startswith("dvl.water_layer_m"):
        # the layer has no control of its own: the DVL's range and the water-track refuse it together
        return InputError(
            f"{DVL_MAX_ALTITUDE}: {show(c.dvl_max_altitude)} is out of range with {DVL_WATER_TRACK} "
            f"{show(c.water_track)}: {exc}"
        )
    if label is None:
        return InputError(str(exc))
    value = f" {show(typed[label])} is out of range:" if label in typed else ""
    return InputError(f"{label}:{value} {exc}")


def config_rows(config: Config, runs: int, source: dict[str, Any] | None = None) -> list[tuple[str, str]]:
    """The configuration a run used as (setting, value) rows, settings named as the controls are
    (the Results tab's table, :func:`config_markdown`, and the HTML report, app.dashboard.export). A replay
    (``source``: what app.dashboard.worker sends of the log, as ``tauv replay --json``'s ``"log"``) is named
    by its log, what configured it and where its filters started, without the simulation's
    trajectory, truth and seabed."""
    d, imu, run = config.dvl, config.imu, config.run
    epsilon = config.partial.nsv_epsilon_m2_per_s2
    epsilon_text = (
        f"{AUTO} ({config.nsv_epsilon_value_m2_per_s2():.3g})" if isinstance(epsilon, str) else f"{epsilon:g}"
    )
    outages = (
        ", ".join(
            f"beam {o.beams[0] if len(o.beams) == 1 else o.beams} {o.start_s:g}-{o.end_s:g} s"
            for o in d.outages
        )
        or "none"
    )
    rows = [
        ("Trajectory", config.trajectory.name),
        (TRUTH, config.trajectory.truth),
        (DURATION, f"{config.trajectory.duration_s:g}"),
        ("Speed, depth", f"{config.trajectory.speed_mps:.3g} m/s at {config.trajectory.depth_m:g} m"),
        ("Seabed", f"{config.trajectory.seabed}, {config.trajectory.seabed_depth_m:g} m"),
        ("Current", current_text(config.trajectory)),
        ("Rates", f"IMU {imu.rate_hz:g} Hz, DVL {d.rate_hz:g} Hz"),
        (DVL_MAX_ALTITUDE, f"{d.max_altitude_m:g}"),
        (DVL_WATER_TRACK, _water_track_row(d)),
        (DVL_CURRENT_STATES, _current_states_row(d)),
        (SWITCH_ALTITUDE, f"{config.vkf.switch_altitude_m:g}"),
        (RPM_NOISE, f"{config.rpm.noise_rpm:g}"),
        ("Methods", ", ".join(m.upper() for m in run.methods)),
        (RPM_FALLBACK, "on" if run.rpm_fallback else "off"),
        (VB_NF, f"{config.partial.vb_nf:g}"),
        (NSV_EPSILON, epsilon_text),
        ("DVL beams", ", ".join(str(b) for b in d.beams) or "none"),
        ("Outages", outages),
        (DROPOUT, f"{d.dropout_probability:g}"),
        ("Aiding", ", ".join(run.aiding)),
        *(  # each plug-in source aided with: its section, as its controls name it
            (f.label, _field_row(f.kind, getattr(config.section(f.section), f.field)))
            for f in PLUGIN_FIELDS.values()
            if f.source in run.aiding
        ),
        (ACCEL_BIAS, f"{imu.accel_bias_mg:g}"),
        (GYRO_BIAS, f"{imu.gyro_bias_deg_per_h:g}"),
        (ACCEL_NOISE, f"{imu.accel_noise_mps_per_sqrt_h:g}"),
        (GYRO_NOISE, f"{imu.gyro_noise_deg_per_sqrt_h:g}"),
        (DVL_NOISE, f"{d.noise_mps:g}"),
        (DVL_BIAS, f"{d.bias_mps:g}"),
        (DVL_SF, f"{d.scale_factor_pct:g}"),
        (SEED, str(run.seed)),
        (RUNS, str(runs)),
    ]
    if source is not None:
        simulation_only = {"Trajectory", TRUTH, "Seabed", "Current", DVL_MAX_ALTITUDE, SWITCH_ALTITUDE}
        rows = [
            ("Source", f"log {source.get('name') or source['directory']}"),
            ("Log directory", str(source["directory"])),
            ("Log configuration", str(source.get("config_file") or "none")),
            *(
                [("Bag mapping", str(source["bag_mapping"] or "none: topics found by type"))]
                if "bag_mapping" in source
                else []
            ),
            ("Configured by", " < ".join(source.get("configuration", ()))),
            ("Start", str(source.get("start", ""))),
            *([("Reference", str(source["reference"]))] if "reference" in source else []),
            *(("Log note", str(note)) for note in source.get("notes", ())),
        ] + [
            (name, value)
            if name != "Speed, depth"
            else ("Starting depth", f"{config.trajectory.depth_m:.3g} m")
            for name, value in rows
            if name not in simulation_only
        ]
    return rows


def _water_track_row(d: DvlConfig) -> str:
    """dvl.water_track in one line: "off", or "always, layer 10 m below the head, noise 0.1 m/s"."""
    if d.water_track == "off":
        return "off"
    return (
        f"{d.water_track}, layer {d.water_layer_m:g} m below the head, noise {d.water_track_noise_mps:g} m/s"
    )


def _current_states_row(d: DvlConfig) -> str:
    """dvl.current_states in one line: "off", or the process model with its numbers."""
    if d.current_states == "off":
        return "off"
    if d.current_states == "gauss-markov":
        return f"gauss-markov, 1-sigma {d.current_sigma_mps:g} m/s, time constant {d.current_tau_s:g} s"
    walk = f"walk {d.current_walk_mps_per_sqrt_s:g} m/s/sqrt(s)"
    return f"{d.current_states}, 1-sigma {d.current_sigma_mps:g} m/s at the start, {walk}"


def _field_row(kind: str, value: Any) -> str:
    if kind == "flag":
        return "on" if value else "off"
    if kind == "vector":
        return ", ".join(f"{v:g}" for v in value)
    return f"{value:g}"


def config_markdown(config: Config, runs: int, source: dict[str, Any] | None = None) -> str:
    """The configuration a run used, as a Markdown table (shown beside its results)."""
    return "**Configuration run**\n\n| Setting | Value |\n|---|---|\n" + "\n".join(
        f"| {name} | {_cell_text(value)} |" for name, value in config_rows(config, runs, source)
    )


def _cell_text(value: str) -> str:
    """A value for a Markdown table cell: ``|`` escaped (a log's name or path may hold one)."""
    return value.replace("|", "\\|")
