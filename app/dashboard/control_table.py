"""The Mission tab's controls described once: :data:`CONTROLS`, in the page's order, one entry per
field of :class:`app.dashboard.inputs.Controls`, naming its label, how the GUI builds and reads it, its
folder, what it holds on a new page, and its key in the page's address (app.dashboard.links).

What iterates the table: :func:`build` adds the controls to the page
(app.dashboard.session_controls.ControlPanel keeps each as the attribute its entry names), :func:`read` and
:func:`write` get and set a field's value through them (ControlPanel.controls and set_controls),
:func:`handles` lists a field's handles (the controls confirmed with the page at Run), and
app.dashboard.links makes its KEYS of the entries. A group of controls is one entry: the methods' checkboxes
(address key ``m``), the four beams (``b``), the four outages (keys ``o1``..``o4``, one per beam),
and the plug-in sources of the registry (app.dashboard.controls: each keyed by its name, each field of its
section by ``<source>.<field>``).
"""

from __future__ import annotations

import contextlib
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import viser

from app.dashboard import inputs
from app.dashboard.controls import add_source_controls
from tauvcore.config import RUN_METHODS, Config
from tauvcore.sensors.dvl import CURRENT_STATES, WATER_TRACK
from tauvcore.truth import TRAJECTORIES, TRUTH_SOURCES

DEFAULT_METHODS = ("ins", "lc", "tc", "nsv", "elc")
"""The methods ticked on a new page."""
WIDGETS = (
    "source",
    "dropdown",
    "text",
    "checkbox",
    "methods",
    "beams",
    "outages",
    "plugins",
    "plugin_fields",
)
"""How an entry is built and read: one control ("source" is the dropdown of logs, there only with
``tauv serve --logs``), or a group: a checkbox per method (a dict by method), per beam (a list), a
start and end text per beam (a list of pairs), the plug-in sources' checkboxes (a dict by name;
built with the folders of their sections' fields, "plugin_fields": a dict by key)."""
FOLDERS = {
    "Methods": True,
    "Partial-beam methods": True,
    "DVL beams": True,
    inputs.SEABED_FOLDER: False,
    inputs.CURRENT_FOLDER: False,
    "Outages [s] (start = end: none)": False,
    "Aiding": False,
    "Sensors (Table 2)": False,
}
"""The Mission tab's folders of controls, each with whether it opens expanded."""


@dataclass(frozen=True)
class Control:
    """One field of app.dashboard.inputs.Controls as the Mission tab shows it."""

    field: str  # the app.dashboard.inputs.Controls field
    attr: str  # the control panel's attribute holding its handle(s)
    label: str  # its label (a group's: its name in messages)
    widget: str  # one of WIDGETS
    key: str  # its address key (app.dashboard.links; "o": o1..o4; "" for the plug-ins, keyed by the registry)
    kind: str  # how the address writes its value (app.dashboard.links.KINDS)
    folder: str = ""  # the folder of FOLDERS it sits in ("": the tab itself)
    initial: Callable[[Config], Any] = lambda d: None  # its value on a new page, of the defaults ``d``
    hint: str | None = None
    options: tuple[str, ...] = ()  # a dropdown's choices


def _text(value: float) -> str:
    return f"{value:g}"


def _current_speed(d: Config) -> str:
    """The horizontal speed of ``d``'s current at the start depth [m/s], as the control shows it."""
    return _text(math.hypot(*d.trajectory.current_n_mps[:2]))


def _current_toward(d: Config) -> str:
    """Where ``d``'s current (else its shear) flows toward, clockwise from north [deg]."""
    north, east = d.trajectory.current_n_mps[:2]
    if not (north or east):
        north, east = d.trajectory.current_shear_ne_per_s
    return _text(math.degrees(math.atan2(east, north)) % 360.0)


def _current_shear(d: Config) -> str:
    """The magnitude of ``d``'s shear [1/s] (the controls' shear is along the current)."""
    return _text(math.hypot(*d.trajectory.current_shear_ne_per_s))


CONTROLS = (
    Control("source", "source", inputs.SOURCE, "source", "src", "choice"),
    Control(
        "trajectory",
        "trajectory",
        inputs.TRAJECTORY,
        "dropdown",
        "traj",
        "choice",
        initial=lambda d: d.trajectory.name,
        options=TRAJECTORIES,
    ),
    Control(
        "truth",
        "truth",
        inputs.TRUTH,
        "dropdown",
        "truth",
        "choice",
        initial=lambda d: d.trajectory.truth,
        hint=inputs.TRUTH_HINT,
        options=TRUTH_SOURCES,
    ),
    # numeric fields are text: the server reads what was typed (see app.dashboard.inputs)
    Control(
        "duration",
        "duration",
        inputs.DURATION,
        "text",
        "dur",
        "number",
        initial=lambda d: _text(d.trajectory.duration_s),
    ),
    # both papers' methods, the first's then Yoo 2014's, then the registered ones (RUN_METHODS)
    Control("methods", "method_boxes", "Methods", "methods", "m", "methods", "Methods"),
    # each partial-beam method's assumption, visible and settable: VB's virtual-beam inflation
    # and NSV's sway variance
    Control(
        "vb_nf",
        "vb_nf",
        inputs.VB_NF,
        "text",
        "nf",
        "number",
        "Partial-beam methods",
        lambda d: _text(d.partial.vb_nf),
        inputs.VB_NF_HINT,
    ),
    Control(
        "nsv_epsilon",
        "nsv_epsilon",
        inputs.NSV_EPSILON,
        "text",
        "eps",
        "number_or_auto",
        "Partial-beam methods",
        lambda d: str(d.partial.nsv_epsilon_m2_per_s2),
        inputs.NSV_EPSILON_HINT,
    ),
    Control("beams", "beam_boxes", "DVL beams", "beams", "b", "beams", "DVL beams"),
    Control(
        "dropout",
        "dropout",
        inputs.DROPOUT,
        "text",
        "drop",
        "number",
        "DVL beams",
        lambda d: _text(d.dvl.dropout_probability),
        "chance that each beam misses each ping",
    ),
    Control(
        "rpm_fallback",
        "rpm_fallback",
        inputs.RPM_FALLBACK,
        "checkbox",
        "fb",
        "flag",
        "DVL beams",
        lambda d: d.run.rpm_fallback,
        inputs.RPM_FALLBACK_HINT,
    ),
    # Yoo 2014's mission: where the seabed is, how far the DVL sees it, where the VKF turns to the
    # propeller, and how noisy the propeller's RPM is
    Control(
        "seabed_depth",
        "seabed_depth",
        inputs.SEABED_DEPTH,
        "text",
        "sd",
        "number",
        inputs.SEABED_FOLDER,
        lambda d: _text(d.trajectory.seabed_depth_m),
        inputs.SEABED_DEPTH_HINT,
    ),
    Control(
        "dvl_max_altitude",
        "dvl_max_altitude",
        inputs.DVL_MAX_ALTITUDE,
        "text",
        "alt",
        "number",
        inputs.SEABED_FOLDER,
        lambda d: _text(d.dvl.max_altitude_m),
        inputs.DVL_MAX_ALTITUDE_HINT,
    ),
    # what the DVL measures where it has no bottom lock (or always), and whether the filters carry
    # the current its water-track beams measure against as states (tauvcore.aiding.dvl_water)
    Control(
        "water_track",
        "water_track",
        inputs.DVL_WATER_TRACK,
        "dropdown",
        "wt",
        "choice",
        inputs.SEABED_FOLDER,
        lambda d: d.dvl.water_track,
        inputs.DVL_WATER_TRACK_HINT,
        WATER_TRACK,
    ),
    Control(
        "current_states",
        "current_states",
        inputs.DVL_CURRENT_STATES,
        "dropdown",
        "cst",
        "choice",
        inputs.SEABED_FOLDER,
        lambda d: d.dvl.current_states,
        inputs.DVL_CURRENT_STATES_HINT,
        CURRENT_STATES,
    ),
    Control(
        "switch_altitude",
        "switch_altitude",
        inputs.SWITCH_ALTITUDE,
        "text",
        "sw",
        "number",
        inputs.SEABED_FOLDER,
        lambda d: _text(d.vkf.switch_altitude_m),
        inputs.SWITCH_ALTITUDE_HINT,
    ),
    Control(
        "rpm_noise",
        "rpm_noise",
        inputs.RPM_NOISE,
        "text",
        "rpmn",
        "number",
        inputs.SEABED_FOLDER,
        lambda d: _text(d.rpm.noise_rpm),
        inputs.RPM_NOISE_HINT,
    ),
    # the ocean current the truth flies in (tauvcore.truth.current), as an engineer states it: speed,
    # the direction it flows toward, its shear along that direction and a slowly varying part
    *(
        Control(field, field, label, "text", key, "number", inputs.CURRENT_FOLDER, initial, hint)
        for field, label, key, initial, hint in (
            ("current_speed", inputs.CURRENT_SPEED, "cur", _current_speed, inputs.CURRENT_SPEED_HINT),
            ("current_toward", inputs.CURRENT_TOWARD, "cto", _current_toward, inputs.CURRENT_TOWARD_HINT),
            ("current_shear", inputs.CURRENT_SHEAR, "csh", _current_shear, inputs.CURRENT_SHEAR_HINT),
            (
                "current_variation",
                inputs.CURRENT_VARIATION,
                "cvar",
                lambda d: _text(d.trajectory.current_variation_mps),
                inputs.CURRENT_VARIATION_HINT,
            ),
        )
    ),
    Control("outages", "outage", "Outages", "outages", "o", "outage", "Outages [s] (start = end: none)"),
    # the aiding sources (tauvcore.aiding.sources: depth, magnetometer, USBL), each with its section's
    # controls (app.dashboard.controls)
    Control("aid_sources", "source_boxes", "Aiding sources", "plugins", "", "flag", "Aiding"),
    Control("source_fields", "source_fields", "Aiding settings", "plugin_fields", "", "", "Aiding"),
    *(
        Control(field, field, label, "text", key, "number", "Sensors (Table 2)", initial)
        for field, label, key, initial in (
            ("accel_bias", inputs.ACCEL_BIAS, "ab", lambda d: _text(d.imu.accel_bias_mg)),
            ("gyro_bias", inputs.GYRO_BIAS, "gb", lambda d: _text(d.imu.gyro_bias_deg_per_h)),
            ("accel_noise", inputs.ACCEL_NOISE, "an", lambda d: _text(d.imu.accel_noise_mps_per_sqrt_h)),
            ("gyro_noise", inputs.GYRO_NOISE, "gn", lambda d: _text(d.imu.gyro_noise_deg_per_sqrt_h)),
            ("dvl_noise", inputs.DVL_NOISE, "dn", lambda d: _text(d.dvl.noise_mps)),
            ("dvl_bias", inputs.DVL_BIAS, "db", lambda d: _text(d.dvl.bias_mps)),
            ("dvl_sf", inputs.DVL_SF, "dsf", lambda d: _text(d.dvl.scale_factor_pct)),
        )
    ),
    Control("seed", "seed", inputs.SEED, "text", "seed", "integer", initial=lambda d: str(d.run.seed)),
    Control(
        "runs",
        "runs",
        inputs.RUNS,
        "text",
        "runs",
        "integer",
        initial=lambda d: "1",
        hint=f"Monte Carlo runs (1 to {inputs.RUNS_MAX}); > 1 plots RMS curves",
    ),
    # the fixed-interval smoother after the forward pass, and its record's memory
    Control(
        "smoother",
        "smoother",
        inputs.SMOOTHER,
        "checkbox",
        "sm",
        "flag",
        initial=lambda d: False,
        hint=inputs.SMOOTHER_HINT,
    ),
    Control(
        "smoother_mb",
        "smoother_mb",
        inputs.SMOOTHER_MB,
        "text",
        "smmb",
        "number",
        initial=lambda d: _text(inputs.SMOOTHER_MB_DEFAULT),
        hint=inputs.SMOOTHER_MB_HINT,
    ),
)
"""Every field of app.dashboard.inputs.Controls, in the page's order."""
SOURCE_HINT = (
    "simulation, or a recorded log or ROS bag (tauv serve --logs): replayed with these methods, beams, "
    "outages and tuning; its own length"
)


def _build(gui: viser.GuiApi, c: Control, d: Config, logs: dict[str, str]) -> dict[str, Any]:
    """The handle(s) of entry ``c``, by the attribute each goes in."""
    if c.widget == "source":
        return {
            c.attr: gui.add_dropdown(
                c.label, (inputs.SIMULATION, *logs), initial_value=inputs.SIMULATION, hint=SOURCE_HINT
            )
            if logs
            else None
        }
    if c.widget == "dropdown":
        return {c.attr: gui.add_dropdown(c.label, c.options, initial_value=c.initial(d), hint=c.hint)}
    if c.widget == "text":
        return {c.attr: gui.add_text(c.label, c.initial(d), hint=c.hint)}
    if c.widget == "checkbox":
        return {c.attr: gui.add_checkbox(c.label, c.initial(d), hint=c.hint)}
    if c.widget == "methods":
        return {
            c.attr: {
                m: gui.add_checkbox(m.upper(), m in DEFAULT_METHODS, hint=inputs.METHOD_HINTS.get(m))
                for m in RUN_METHODS
            }
        }
    if c.widget == "beams":
        return {c.attr: [gui.add_checkbox(f"Beam {k}", True) for k in range(1, 5)]}
    if c.widget == "outages":
        return {
            c.attr: [
                tuple(gui.add_text(label, "0") for label in inputs.outage_labels(k)) for k in range(1, 5)
            ]
        }
    if c.widget == "plugins":
        boxes, fields = add_source_controls(gui)
        return {c.attr: boxes, PLUGIN_FIELDS_ATTR: fields}
    return {}  # "plugin_fields": built with the plug-ins' checkboxes


PLUGIN_FIELDS_ATTR = next(c.attr for c in CONTROLS if c.widget == "plugin_fields")


def build(gui: viser.GuiApi, logs: dict[str, str]) -> dict[str, Any]:
    """Add every control of :data:`CONTROLS` where ``gui`` adds controls now, each folder of
    FOLDERS around its entries; return the handles by attribute. ``logs``: the Source dropdown's
    logs (none: no Source control, its attribute None)."""
    d = Config()
    handles: dict[str, Any] = {}
    for folder, entries in itertools.groupby(CONTROLS, key=lambda c: c.folder):
        with (
            gui.add_folder(folder, expand_by_default=FOLDERS[folder]) if folder else contextlib.nullcontext()
        ):
            for c in entries:
                handles.update(_build(gui, c, d, logs))
    return handles


def read(panel: Any, c: Control) -> Any:
    """The value of field ``c`` as ``panel``'s controls hold it (the Controls field's)."""
    held = getattr(panel, c.attr)
    if c.widget == "source":
        return held.value if held is not None else inputs.SIMULATION
    if c.widget == "methods":
        return tuple(m for m in RUN_METHODS if held[m].value)
    if c.widget == "beams":
        return tuple(k for k in range(1, 5) if held[k - 1].value)
    if c.widget == "outages":
        return tuple((start.value, end.value) for start, end in held)
    if c.widget == "plugins":
        return tuple(name for name, box in held.items() if box.value)
    if c.widget == "plugin_fields":
        return tuple((key, handle.value) for key, handle in held.items())
    return held.value


def _put(handle: Any, value: Any) -> None:
    if handle.value != value:
        handle.value = value


def write(panel: Any, c: Control, value: Any) -> None:
    """Set ``panel``'s controls of field ``c`` to ``value`` (a control already holding its value is
    left alone)."""
    held = getattr(panel, c.attr)
    if c.widget == "source":
        if held is not None:
            _put(held, value)
    elif c.widget in ("methods", "plugins"):
        for name, box in held.items():
            _put(box, name in value)
    elif c.widget == "beams":
        for k, box in enumerate(held, start=1):
            _put(box, k in value)
    elif c.widget == "outages":
        for (start, end), (start_text, end_text) in zip(held, value):
            _put(start, start_text)
            _put(end, end_text)
    elif c.widget == "plugin_fields":
        for key, field_value in value:
            _put(held[key], field_value)
    else:
        _put(held, value)


def handles(panel: Any, c: Control) -> list[Any]:
    """``panel``'s handles of field ``c``."""
    held = getattr(panel, c.attr)
    if c.widget == "source":
        return [held] if held is not None else []
    if c.widget in ("methods", "plugins", "plugin_fields"):
        return list(held.values())
    if c.widget == "beams":
        return list(held)
    if c.widget == "outages":
        return [h for pair in held for h in pair]
    return [held]


TEXT_LABELS = tuple(
    c.label for c in CONTROLS if c.widget == "text" and c.label in set(inputs.FIELD_LABELS.values())
)
"""The text controls a preset or a log's configuration may fill in (those of a configuration
field: all but Runs), by label."""
FILLED_LABELS = TEXT_LABELS + (inputs.DVL_WATER_TRACK, inputs.DVL_CURRENT_STATES)
"""The controls a preset or a log's configuration may fill in: the text controls, and the DVL's
choices (a log's water-track and current states are its configuration's until the page changes
them, as its noise is)."""
