"""The control panel of a dashboard tab: the Mission tab's controls (what a run reads, as
app.dashboard.inputs.Controls holds them), its Run and Stop buttons, progress and status; what the controls
hold and setting them, the scenarios' presets and a log's own configuration filling them in, the
page's own values confirmed at Run, and the page's address (app.dashboard.links) kept in step with them.
The controls themselves are described once, in app.dashboard.control_table.CONTROLS: built, read, set and
confirmed by iterating it.
"""

from __future__ import annotations

import contextlib
import json
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any

import viser

from app.dashboard import budget, control_checks, control_table, inputs, links, page_scripts
from app.dashboard.controls import PLUGIN_FIELDS
from app.dashboard.inputs import Controls, InputError, config_from_controls
from app.dashboard.session_state import TabState
from app.reports.settings_text import changed_settings, setting_name, setting_value
from tauvcore.config import Config, from_dict, merge
from tauvcore.logs import CONFIG_FILE, LogError
from tauvcore.logs.bags import MAPPING_SUFFIX, is_bag, mapping_beside
from tauvcore.validation import show

METHODS = next(c for c in control_table.CONTROLS if c.field == "methods")
CONFIRM_TIMEOUT_S = 10.0  # how long Run waits for the page to report its controls (software WebGL stalls)
SNAPSHOT_KEY_PREFIX = "tauv-controls-"  # + a fresh id per Run press: tabs of one browser share localStorage
CHECK_PAUSE_S = 0.4  # the controls are checked this long after the last change (a pause in typing)


def _can_hold(handle: Any, value: Any) -> bool:
    """Whether ``value``, as the page reported it, is one the control ``handle`` can hold: a
    checkbox true/false, a dropdown one of its options, a text box a string of bounded length."""
    if isinstance(handle, viser.GuiCheckboxHandle):
        return isinstance(value, bool)
    if isinstance(handle, viser.GuiDropdownHandle):
        return value in handle.options
    return isinstance(value, str) and len(value) <= 10 * inputs.TEXT_MAX_CHARS


SIMULATION_ONLY = {
    "trajectory": "set by the log: a replay flies the log's own track",
    "duration": "set by the log: a replay runs the log's whole length",
    "truth": "set by the log: a replay's reference is the log's own",
    "seabed_depth": "does not apply to a log: its seabed is the one it was recorded over",
    "dvl_max_altitude": "does not apply to a log: its DVL lost the seabed where it did",
    "switch_altitude": "does not apply to a log: the altitude is the log's",
    **{
        field: "does not apply to a log: the water it was recorded in is the log's"
        for field in control_checks.CURRENT_FIELDS
    },
}
"""The controls a replayed log does not read (app.dashboard.inputs.config_rows leaves them out of a
replay's table too), each with why, as its hint says while a log is the Source."""


def replay_settings_note(config: Config, log: str) -> str:
    """What a replay of ``log`` runs with beyond the defaults and the log's own track (the
    outages, the sensors' settings, the sources...: app.reports.settings_text.changed_settings),
    as the status line names it; empty when nothing is set."""
    changed = changed_settings(config, log=log)
    words = [
        f"{setting_name(key)} {setting_value(key, value)}"
        for key, value in changed.items()
        if key not in ("run.methods", "run.seed")
    ]
    return f"; with {', '.join(words)}" if words else ""


def bag_note(path: str) -> str:
    """What a notification says of the bag at ``path`` whose own mapping sets no configuration."""
    mapping = mapping_beside(path)
    if mapping is None:
        return (
            f"No mapping beside it (its name with {MAPPING_SUFFIX}): topics found by type; "
            "the controls apply as they are."
        )
    return f"Its mapping {mapping} has no [config]: the controls apply as they are."


class ControlPanel:
    """The Mission tab's controls down to the status line, added where the tab's GUI adds controls
    now; ``logs`` (name -> directory, from tauv serve --logs, never from the page) are offered as
    sources to replay. Each control of app.dashboard.control_table.CONTROLS is the attribute its entry names;
    those the code names are declared here."""

    source: viser.GuiDropdownHandle[str] | None  # only with logs
    trajectory: viser.GuiDropdownHandle[str]
    duration: viser.GuiTextHandle
    truth: viser.GuiDropdownHandle[str]
    method_boxes: dict[str, viser.GuiCheckboxHandle]
    beam_boxes: list[viser.GuiCheckboxHandle]
    source_fields: dict[str, Any]  # the plug-in fields' controls by key (app.dashboard.controls)

    def __init__(self, state: TabState, logs: dict[str, str], notify: Callable[..., None]) -> None:
        self.state = state
        self.client = state.client
        self.logs = logs
        self.notify = notify
        # the page's address carries the controls (app.dashboard.links): written only once the page's own
        # query has been read, so a link is never overwritten before it applies
        self.address_lock = threading.Lock()
        self.address_ready = False
        self.address_shown: str | None = None
        self.viser_params: tuple[str, ...] = ()
        # the page's view in the address besides the controls (app.dashboard.links.VIEW_KEYS): the
        # camera as the server last heard it; a link's view is shown by ``apply_view`` (the Session's)
        self.view: dict[str, Any] = {}
        self.apply_view: Callable[[dict[str, Any]], None] = lambda view: None
        gui = self.client.gui
        # Run, Stop, the progress and the status first: in view when the page opens, whatever
        # the window's height; the controls follow
        self.run_button = gui.add_button("Run", color="green")
        self.stop_button = gui.add_button("Stop", color="red", disabled=True)
        self.progress = gui.add_progress_bar(0.0, animated=False)
        self.status = gui.add_markdown("Ready. Choose a mission and press **Run**.")
        # every bad control named as you type (app.dashboard.control_checks), the fields marked on the page
        self.check_note = gui.add_markdown("")
        self.check_lock = threading.Lock()
        self.check_timer: threading.Timer | None = None
        self.marked: dict[str, str] = {}  # viser id -> message of the controls marked on the page
        # per log: the sections its Calibrate and Tune found and Apply laid over its own file
        # (app.dashboard.session_vehicle); they apply at Run beneath the controls, as the log's file does
        self.vehicle_sections: dict[str, dict[str, Any]] = {}
        self.own_hints: dict[
            str, str | None
        ] = {}  # the hints of SIMULATION_ONLY's controls, kept while a log's show
        for attr, handle in control_table.build(gui, self.logs).items():
            setattr(self, attr, handle)

        source = self.source
        if source is not None:
            # a log replays its own reference: the truth's generator and its current do not apply to it
            source.on_update(lambda _: self._simulation_only(source.value == inputs.SIMULATION))
            source.on_update(lambda event: self.apply_log_config() if event.client is not None else None)
        # a scenario's preset fills in the controls when the user picks it (not when the server
        # itself sets the dropdown to what the page shows, at Run: the page's values stand then)
        self.preset: str | None = None
        self.trajectory.on_update(
            lambda event: self.apply_trajectory_preset() if event.client is not None else None
        )
        for handle in self._confirmed_inputs().values():  # every control a run reads
            handle.on_update(lambda _: self.update_address())
            handle.on_update(lambda _: self.schedule_check())

    def _simulation_only(self, simulated: bool) -> None:
        """Enable the controls a replayed log does not read (:data:`SIMULATION_ONLY`: the mission,
        its length, the truth, the seabed, the current) for a simulation only; for a log each is
        disabled and its hint says why (its own hint back for a simulation)."""
        for attr, reason in SIMULATION_ONLY.items():
            handle = getattr(self, attr)
            own = self.own_hints.setdefault(attr, handle.hint)
            handle.disabled = not simulated
            hint = own if simulated else reason
            if handle.hint != hint:
                handle.hint = hint

    def show_log_facts(self, config: Config) -> None:
        """A replayed log's own configuration arrived: the disabled Trajectory and Duration say
        what the log set ("set by the log: 398 s")."""
        if self.source is None or self.source.value == inputs.SIMULATION:
            return
        self.duration.hint = f"set by the log: {config.trajectory.duration_s:g} s"
        self.trajectory.hint = f"set by the log: its own track, {config.trajectory.duration_s:g} s from {config.trajectory.depth_m:.3g} m"

    def apply_trajectory_preset(self) -> None:
        """Fill in the controls the chosen scenario's preset sets (longrange: Duration 1440 s,
        Seabed depth 110 m and the paper's IMU; tauvcore.config.trajectory_preset) and say so in
        the status and a notification. Leaving such a scenario for one without a preset puts those
        controls back to their defaults, so a figure eight does not fly 1440 s with the long-range
        IMU."""
        name = self.trajectory.value
        texts = inputs.preset_controls(name)
        previous, self.preset = self.preset, (name if texts else None)
        if texts:
            title, note, headline = (
                f"Preset {name} applied",
                inputs.preset_note(name),
                inputs.preset_headline(name),
            )
        elif previous is not None:
            texts = inputs.preset_controls(previous, Config())
            title = "Defaults restored"
            note = headline = (
                f"{', '.join(texts)} back to their defaults (the {previous} preset no longer applies)."
            )
        else:
            return
        fields = self._text_fields()
        for label, text in texts.items():
            if label in fields:
                fields[label].value = text
        self.status.content = note
        self.notify(title, headline)

    def _text_fields(self) -> dict[str, Any]:
        """The controls a preset or a log's configuration may fill in (the text fields, the DVL's
        water-track and current states: control_table.FILLED_LABELS), by label."""
        by_label = {c.label: c for c in control_table.CONTROLS}
        return {label: getattr(self, by_label[label].attr) for label in control_table.FILLED_LABELS}

    def apply_log_config(self) -> None:
        """The chosen log's own configuration file (tauvcore.logs.CONFIG_FILE) fills in the
        controls it sets, as a preset does, and a notification says what it sets; a file that
        cannot be used is a notification naming it (the Run would refuse it too)."""
        source = self.source.value if self.source is not None else inputs.SIMULATION
        if source not in self.logs:
            return
        try:
            raw = self.log_config(source)
        except InputError as exc:
            self.notify("Log configuration not applied", str(exc), error=True)
            return
        bag = is_bag(self.logs[source])
        if not raw:
            self.notify(
                f"{'Bag' if bag else 'Log'} {source}",
                bag_note(self.logs[source])
                if bag
                else "No configuration file of its own: the controls apply as they are.",
            )
            return
        filled, hidden = self.fill_fields(raw)
        parts = ([f"{', '.join(filled)} filled in"] if filled else []) + (
            [f"{', '.join(hidden)} apply at Run"] if hidden else []
        )
        what = (
            f"its mapping's [config] ({mapping_beside(self.logs[source])})" if bag else f"its {CONFIG_FILE}"
        )
        self.notify(f"{'Bag' if bag else 'Log'} {source}: {what} applied", "; ".join(parts) + ".")

    def fill_fields(self, raw: dict[str, Any]) -> tuple[list[str], list[str]]:
        """Set the controls that the sections ``raw`` (section -> key -> value, a configuration
        file's tables) name to its values; return the labels filled in and the ``section.key``s
        that have no control (they apply at Run: the log's own file, or :attr:`vehicle_sections`)."""
        config = from_dict(raw)
        fields = {
            **self._text_fields(),
            **{PLUGIN_FIELDS[key].label: handle for key, handle in self.source_fields.items()},
        }
        filled = []
        for key in sorted(
            {f"{sec}.{k}" for sec, values in raw.items() if isinstance(values, dict) for k in values}
        ):
            label = inputs.FIELD_LABELS.get(key)
            if label in fields:
                sec, name = key.split(".", 1)
                value = getattr(config.section(sec), name)
                fields[label].value = (
                    PLUGIN_FIELDS[key].shown(value) if key in PLUGIN_FIELDS else inputs.field_text(value)
                )
                filled.append(label)
        hidden = [
            f"{sec}.{k}"
            for sec, values in raw.items()
            if isinstance(values, dict)
            for k in values
            if inputs.FIELD_LABELS.get(f"{sec}.{k}") not in fields
        ]
        return filled, hidden

    def run_log_config(self, source: str) -> dict[str, Any] | None:
        """What a run of ``source`` lays under the controls: the log's own configuration file with
        the calibration and tuning applied to it in this tab (:attr:`vehicle_sections`) over it;
        None for a simulation."""
        if source not in self.logs:
            return None
        return merge(self.log_config(source), self.vehicle_sections.get(source, {}))

    def log_config(self, source: str) -> dict[str, Any]:
        """The raw tables of log ``source``'s own configuration file, or a bag's own mapping's
        ``[config]`` ({} without one); InputError naming the file (its key and value) when it
        cannot be read or does not check."""
        from tauvcore.eval.replay import log_config

        try:
            return log_config(self.logs[source])[0]
        except LogError as exc:
            raise InputError(f"{inputs.SOURCE} {source}: {exc}") from None

    def selected_methods(self) -> tuple[str, ...]:
        return control_table.read(self, METHODS)

    def _confirmed_inputs(self) -> dict[str, Any]:
        """The controls a run reads, keyed by their viser id."""
        return {h._impl.uuid: h for c in control_table.CONTROLS for h in control_table.handles(self, c)}

    def confirm_page_state(self) -> int:
        """Make the server's control values those the page shows; return how many differed.

        viser's page sends every control change through ONE sender throttled to a message per
        50 ms that keeps only the latest message, whatever control it is for
        (client/src/ControlPanel/Generated.tsx, WebsocketUtils.makeThrottledMessageSender): of
        three changes within 50 ms the middle one never leaves the browser, so the page shows it
        and the server never hears of it. The client is prebuilt, so here, when Run is pressed,
        the page reports every control as it shows it: a script (viser's RunJavascriptMessage)
        writes the values to the tab's localStorage and the server reads them back
        (LocalStorageGetItemRequest; the answer is sent unthrottled). Raises InputError if the
        page does not answer within CONFIRM_TIMEOUT_S.
        """
        by_id = self._confirmed_inputs()
        key = f"{SNAPSHOT_KEY_PREFIX}{uuid.uuid4().hex}"
        page_scripts.run(self.client, page_scripts.report(list(by_id), SNAPSHOT_KEY_PREFIX, key))
        try:
            raw = self.client.local_storage.get_item(key, timeout=CONFIRM_TIMEOUT_S)
        except TimeoutError:
            raise InputError(
                f"the page did not report its controls within {CONFIRM_TIMEOUT_S:g} s; press Run again"
            ) from None
        except RuntimeError as exc:
            if "disconnected" in str(exc):
                raise  # the tab is gone: start_run drops the Run quietly
            raise InputError(
                f"the page could not report its controls (its browser storage is blocked?): {show(str(exc))}"
            ) from None
        return self.apply_page_values(by_id, raw)

    @staticmethod
    def apply_page_values(by_id: dict[str, Any], raw: str | None) -> int:
        """Set each handle of ``by_id`` to the value the page reported in ``raw`` (the script's
        JSON answer); return how many differed. InputError if the answer cannot be read or a
        value cannot be the control's (a checkbox not true/false, a choice not among the options)."""
        if raw is None:
            # no page ran the script: a scripted (non-browser) client, whose controls are exactly
            # the messages it sent; a browser runs the script before it answers (one batch, in order)
            return 0
        try:
            answer = json.loads(raw)
        except ValueError:
            answer = None
        shown_values = answer.get("values") if isinstance(answer, dict) else None
        if not isinstance(shown_values, dict):
            raise InputError(
                "the page reported its controls in a form the server cannot read; reload the page"
            )
        changed = 0
        for uid, handle in by_id.items():
            if uid not in shown_values:
                continue  # not on the page (an unmounted panel): the server's value stands
            value = shown_values[uid]
            if not _can_hold(handle, value):
                raise InputError(
                    f"{handle.label}: the page shows {show(str(value))}, "
                    "which this control cannot hold; reload the page"
                )
            if value != handle.value:
                handle.value = value
                changed += 1
        return changed

    def controls(self) -> Controls:
        """What the controls hold (the server's copy; see :meth:`confirm_page_state`)."""
        return Controls(**{c.field: control_table.read(self, c) for c in control_table.CONTROLS})

    def set_controls(self, c: Controls) -> None:
        """Set every control to what ``c`` holds (the inverse of :meth:`controls`); a control
        already holding its value is left alone."""
        for entry in control_table.CONTROLS:
            control_table.write(self, entry, getattr(c, entry.field))

    # ------------------------------------------------------------------ the page's address
    def read_link(self) -> None:
        """Apply the setup the page's address carries (app.dashboard.links), then keep the address in step
        with the controls (runs in its own thread from the start of the session)."""
        try:
            query = links.read_address(self.client)
        except TimeoutError:
            self.notify(
                "Address not read",
                "The page did not report its address in time: the settings of its "
                "link were not applied, and the address will not follow the controls. Reload to retry.",
                error=True,
            )
            return
        except RuntimeError as exc:
            if "disconnected" not in str(exc):  # the tab's storage is blocked: say so; a closed tab is gone
                self.notify(
                    "Address not read", f"The page could not report its address: {show(str(exc))}", error=True
                )
            return
        if query is not None:  # None: no page ran the script (a scripted client)
            self.apply_link(query)
        self.address_ready = True
        self.update_address()

    def apply_link(self, query: str) -> None:
        """Set the controls a page's query (``location.search``) names (app.dashboard.links.parse): a
        trajectory first, with its preset when the link does not set every control the preset
        does; one notification lists what was refused, key and value."""
        sources = tuple(self.source.options) if self.source is not None else (inputs.SIMULATION,)
        link = links.parse(query, sources)
        self.viser_params = link.viser_params
        if link.view:
            self.view.update({k: v for k, v in link.view.items() if k not in links.VIEW_PAGE_KEYS})
            self.apply_view(link.view)
        if link.keys:
            name = link.values.get("trajectory")
            if name is not None and name != self.trajectory.value:
                self.trajectory.value = name
                preset = inputs.preset_controls(name)
                if set(preset) - link.labels():
                    self.apply_trajectory_preset()
                else:
                    self.preset = name if preset else None
            self.set_controls(links.apply(self.controls(), link))
            self.status.content = f"Ready. The page's address set {len(link.keys)} control(s); press **Run**."
        if link.problems:
            self.notify("Address: settings not applied", "; ".join(link.problems), error=True)

    def update_address(self, action: bool = True) -> None:
        """Show the controls' setup and the view (the time, the camera: :attr:`view`) in the page's
        address (app.dashboard.links), once its own query has been read (:meth:`read_link`); nothing
        is sent when it is unchanged. ``action``: a change the user made (the deferred plots wait)."""
        if action:
            self.state.last_action_s = time.monotonic()
        if not self.address_ready:
            return
        with self.address_lock:
            # a bad value never enters the address: such a control is written at its default
            safe = control_checks.without_problems(self.controls(), self.problems())
            view = {**self.view, "t": self.state.cursor_t}
            query = links.address(safe, self.viser_params, view)
            if query == self.address_shown:
                return
            self.address_shown = query
            links.show_address(self.client, query)

    # ------------------------------------------------------------------ checking as you type
    def schedule_check(self) -> None:
        """Check the controls CHECK_PAUSE_S after the last change (app.dashboard.control_checks)."""
        with self.check_lock:
            if self.check_timer is not None:
                self.check_timer.cancel()
            self.check_timer = threading.Timer(CHECK_PAUSE_S, self._check_quietly)
            self.check_timer.daemon = True
            self.check_timer.start()

    def _check_quietly(self) -> None:
        # a tab closed meanwhile has nothing to mark: the check ends without a word
        with contextlib.suppress(Exception):
            self.check_now()

    def problems(self) -> dict[str, str]:
        """Every bad control (label -> message) of what the controls hold now."""
        controls = self.controls()
        try:
            log_raw = self.run_log_config(controls.source)
        except InputError as exc:  # the log's own configuration file does not check
            return {inputs.SOURCE: str(exc)}
        return control_checks.problems(controls, log_raw)

    def check_now(self, scroll: bool = False) -> dict[str, str]:
        """Check every control, mark the bad ones on the page (``scroll``: the first into view),
        name them under the status line; returns them (label -> message)."""
        found = self.problems()
        ids_by_label: dict[str, list[str]] = {}
        for uid, handle in self._confirmed_inputs().items():
            ids_by_label.setdefault(handle.label, []).append(uid)
        marked = control_checks.labels_to_ids(found, ids_by_label)
        if marked != self.marked or scroll:
            page_scripts.run(self.client, page_scripts.mark(marked, scroll))
            self.marked = marked
        self.check_note.content = control_checks.notification(found) if found else ""
        return found

    def read_config(self) -> tuple[Config, int]:
        """The configuration the controls describe and its run count; InputError names every bad
        control and its value at once (app.dashboard.control_checks; the first is scrolled into view), also
        when the run would not fit the memory budget (app.dashboard.budget, with the smoother if asked:
        :meth:`smoother_budget_mb`)."""
        controls = self.controls()
        log_raw = self.run_log_config(controls.source)
        if control_checks.problems(controls, log_raw):
            raise InputError(control_checks.notification(self.check_now(scroll=True)))
        config, runs = config_from_controls(controls, log_raw)
        try:
            limit = budget.budget_bytes()
        except ValueError as exc:
            raise InputError(str(exc)) from None
        smooth_mb = inputs.smoother_mb_from_controls(controls)
        too_big = budget.over_budget_message(
            budget.estimate_run(config, runs, sensor_errors=False, smooth_mb=smooth_mb), limit
        )
        if too_big is not None:
            raise InputError(
                f"{inputs.DURATION} {config.trajectory.duration_s:g} s, {inputs.RUNS} {runs}: {too_big}"
            )
        return config, runs

    def smoother_budget_mb(self) -> float | None:
        """The smoother the controls ask for: its tape's memory [MB], None without it
        (app.dashboard.inputs.smoother_mb_from_controls; InputError naming the control when it is bad)."""
        return inputs.smoother_mb_from_controls(self.controls())
