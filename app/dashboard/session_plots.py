"""The plot tabs of a dashboard tab: the workbench's Plots (error norms, the ELC's choice),
Components, Consistency (NEES), Innovations and Sensors (raw measurements, the estimated current of
a run with current states, estimated sensor errors), and the Mission tab group's Vehicle (fins and
propeller, the current at the vehicle) and Seabed (altitude, the VKF's propeller model) tabs.

:data:`PLOT_GROUPS` names each group of the workbench's plots, the tab it is in and what draws
it: :meth:`PlotTabs.refresh_plots` draws the groups a change asks for, and a full redraw draws
the quick ones at once and leaves the others (innovations, components) to a thread of their own
that waits until the tab is still. The overlay of kept runs comes from app.dashboard.session_runs (the
``overlay_runs`` this room is given).
"""

from __future__ import annotations

import dataclasses
import functools
import threading
import time
from collections.abc import Callable
from typing import Any

import plotly.graph_objects as go
import viser

from app.dashboard import page_scripts
from app.dashboard.hardening import display_error
from app.dashboard.session_map import MapRoom
from app.dashboard.session_runs import KeptRun
from app.dashboard.session_spread import SpreadTab
from app.dashboard.session_state import TabState, drawing
from app.figures.error_figures import (
    AUTO,
    COMPONENTS,
    QUANTITIES,
    compare_figure,
    components_figure,
    elc_choice_figure,
    error_components,
    error_figure,
    nees_blocks,
    nees_figure,
    overlay_figure,
)
from app.figures.event_traces import with_events
from app.figures.innovation_figures import innovation_figure, innovation_sources
from app.figures.sensor_figures import (
    PANEL_HEIGHT_PX,
    raw_sensor_figure,
    sensor_error_figure,
    sensor_panels,
    source_states_figure,
    state_methods,
)
from app.figures.shared import CARD_WIDTH_PX, SENT_CURSOR_S, card_aspect, placeholder_figure, with_cursor
from app.figures.vehicle_figures import (
    actuator_figure,
    altitude_figure,
    current_figure,
    vkf_figure,
    water_and_ground_speed_mps,
)
from app.reports.markdown_tables import identical_methods, identical_note
from tauvcore.config import Config
from tauvcore.engine.results import BLOCK_DIMS, MethodResult
from tauvcore.eval.envelope import is_decimated
from tauvcore.eval.events import Event, run_events
from tauvcore.filter.families import FAMILIES, FIRST

PLOTTED_QUANTITIES = (
    "vel",
    "tilt",
    "heading",
    "att",
    "pos",
)  # the error plots, top to bottom ("att" on demand)
CONSISTENCY_NOTE = (
    "NEES/dim: the squared estimation error weighed by the filter's own covariance, divided by the "
    "block's dimension, averaged over the runs. **1: the method knows its error**; above the grey 99 % "
    "band it is over-confident (its sigma is too small), below it cautious. The band narrows as runs "
    "are added; the Results tab sums it up per method."
)
VEHICLE_NOTES = {
    "dynamic": (
        "Fins (positive: pushing along the fin's normal) and propeller of the 6-DOF vehicle the dynamic "
        "truth flies; in the 3-D view the fins, coloured as here, turn with the time slider."
    ),
    "kinematic": (
        "No fins or propeller: the **kinematic** truth is closed-form motion, no vehicle flies it. "
        "Choose **Truth: dynamic** and press **Run** to see the 6-DOF vehicle's fins and propeller."
    ),
    "log": "No fins or propeller: a recorded log has no actuator record.",
    "none": (
        "Fins and propeller of the dynamic truth show here after a run with **Truth: dynamic**; "
        "the current at the vehicle after a run in a current (either truth)."
    ),
    "current": (
        "The current at the vehicle, north and east as the truth met it (the 3-D view's arrow shows it at "
        "the slider's time), and the vehicle's speed **through the water** against its speed **over "
        "ground**. The DVL's bottom lock measures the ground, the propeller's RPM the water: the current "
        "is their difference, a velocity the RPM aiding (VKF, RPM fallback) does not see."
    ),
}
"""The Vehicle tab's notes: for each kind of truth (the actuator figure shows for the dynamic truth
only), and above the current figure (a mission in a current, either truth; none in still water)."""
SEABED_NOTES = {
    "simulation": (
        "Height above the seabed straight below (an ideal echo sounder). Above the DVL's range its "
        "beams find no bottom (drawn aqua, *lost*, in the 3-D view); above the switch the velocity "
        "filter uses the propeller RPM instead (shaded). Choose **Trajectory: longrange** for the "
        "paper's mission over two trenches."
    ),
    "log": "No altitude: a recorded log has no seabed.",
    "none": "The altitude above the seabed shows here after a run.",
}
"""The Seabed tab's note (its figure shows for simulated missions)."""
VKF_NOTES = {
    "shown": (
        "What the velocity Kalman filter (method **VKF**, Yoo 2014 eq. 20-26) learned of the propeller: "
        "scale factor and bias with their 1-sigma, against the RPM model's truth (dashed; none on the dynamic "
        "truth). Shaded where eq. 29 aids with the RPM instead of the DVL: there it only predicts."
    ),
    "running": "The VKF's scale factor and bias show here as the run goes.",
    "stopped": "The run ended before the VKF's first results arrived.",
    "none": (
        "The VKF's propeller scale factor and bias show here after a run with **VKF** checked "
        "(Mission tab, Methods)."
    ),
}
"""The note above the Seabed tab's VKF figure (shown when the run's methods include ``vkf``)."""
EVENTS_HINT = (
    "on every time plot: scheduled DVL outages and unscheduled beam losses shaded, the RPM velocity in "
    "place of the DVL as a strip along the top, gate rejections, lock-out resets and divergence flags "
    "marked (hover a marker for what, when and which beams; the legend names each colour)"
)
SMOOTHED_HINT = (
    "the fixed-interval smoother's errors (dashed; dotted: its 1-sigma) beside the filter's, for the "
    "methods of a run with the Smoother (Mission tab); usable once such a run ends"
)
OTHER_FAMILIES_DIMS = "; ".join(
    f"{', '.join(m.upper() for m in family.methods)}: {family.block_dims['full']}"
    + ("" if family.position_state else ", no position")
    for family in FAMILIES.values()
    if family.error_state != FIRST.error_state
)
"""The NEES dimension of the other filter families' whole state, for the block's hint."""
PLOT_ASPECT = 0.42  # each error plot's height / width before its first run (then: its legend's rows added)
ERROR_AXES = (AUTO, "linear", "log")
ERROR_AXES_HINT = (
    "auto: log where the errors span more than a decade, linear where they span less or start at zero "
    "(a replay starts on its reference); log: zeros left out"
)
"""The error plots' y-axes (app.figures.error_figures.log_axis)."""
DIAGNOSTICS_DELAY_S = 0.05  # the innovations and components plots follow the others by this much,
QUIET_S = 1.0  # once the tab has had no action for this long
LIVE_DIAGNOSTICS_S = 5.0  # during a run, the deferred plots are redrawn at most this often (wall time)
COMPONENTS_NOTE = (
    "Signed errors, estimate minus truth: position north/east/down, body velocity surge/sway/heave, Euler "
    "angles roll/pitch/heading. The truth's velocity is the central difference of its positions at the output "
    "epochs. With several runs the curves are the RMS over runs."
)
INNOVATION_NOTE = (
    "Each method's innovations (measurement minus prediction) with its filter's 3-sigma envelope "
    "(+-3 sqrt(S)); crosses mark what the gate rejected. A consistent filter keeps about 99.7 % inside. "
    "INS (and any method without this source) has none. Source **water**: the DVL's water-track beams, "
    "fused against the current states (Mission tab: Current states)."
)
SENSORS_NOTE = (
    "The run's raw measurements (the IMU at the output epochs, every source at its own epochs; a beam "
    "that did not return is a gap, and its state is in the DVL beams panel), then, with **Current states** "
    "on (Mission tab), every method's estimate of the current, then what the chosen method estimated of "
    "the sensors' errors with its 3-sigma against their truth (a simulation's; a log has none)."
)
STATES_NOTE = (
    "The current at the vehicle as each method's filter estimates it from the DVL's water-track beams "
    "(line, with its 1-sigma band) against the truth (dashed): north and east. Water-track measures the "
    "velocity through the water, so a method sees the current as the difference between it and its own "
    "velocity over ground; turns make both axes observable. Its NEES: Consistency tab, block current."
)
"""The note above the Sensors tab's figure of the sources' states
(app.figures.sensor_figures.source_states_figure)."""
SENSOR_ERRORS_NOT_RECORDED = (
    "**Sensor errors not recorded**: their records would exceed 64 MiB (20 runs of five methods "
    "over 250 s, 10 runs over 1 h) or the memory budget (`TAUV_RUN_BUDGET_MB`). Fewer runs, "
    "methods or a shorter mission record them."
)
SENSOR_PLOT_WIDTH_PX = 480  # the workbench's plot width the Sensors tab's aspect is reckoned for
INITIAL_INNOVATION_SOURCES: tuple[str, ...] = ("dvl",)
"""The Innovations tab's choices before a run: any source name (a run's own replace them), so
``str``, not the literal "dvl"."""
INITIAL_SENSOR_METHODS: tuple[str, ...] = ("lc",)
"""The Sensors tab's method choices before a run (a run's own replace them)."""


class PlotTabs:
    """The plot tabs: the workbench's four (added to ``workbench``) and Vehicle and Seabed (added
    to the Mission tab group ``tabs``)."""

    def __init__(
        self,
        state: TabState,
        workbench: viser.PanelHandle,
        tabs: viser.GuiTabGroupHandle,
        overlay_runs: Callable[[], list[KeptRun]],
        add_run_widgets: Callable[[], None],
        notify: Callable[..., None],
    ) -> None:
        self.state = state
        self.draw_lock = state.draw_lock
        self.overlay_runs = overlay_runs  # the kept runs ticked for overlay (app.dashboard.session_runs)
        self.add_run_widgets = add_run_widgets  # the Runs tab's new entries, drawn with the diagnostics
        self.notify = notify
        self.diagnostics_due = False
        self.diagnostics_thread: threading.Thread | None = None
        self.last_diagnostics_s = 0.0  # time.monotonic() of the latest diagnostics (or run start)
        gui = state.client.gui
        self._add_error_tabs(gui, workbench)
        self._add_consistency_tab(gui, workbench)
        self._add_innovations_tab(gui, workbench)
        self._add_sensors_tab(gui, workbench)
        self.spread = SpreadTab(state, workbench)  # a Monte Carlo's spread (app.dashboard.session_spread)
        self.map = MapRoom(state, workbench)  # the Map tab (app.dashboard.session_map)
        self._add_mission_tabs(gui, tabs)
        # each option redraws only the plots it changes (a full redraw is ten figures)
        self.show_sigma.on_update(lambda _: self._option_changed("errors"))
        self.log_y.on_update(lambda _: self._option_changed("errors"))
        self.show_att_norm.on_update(lambda _: self._att_norm_changed())
        self._unticking = False  # _smoothed_boxes unticks a box: its callback does not redraw
        self.show_smoothed.on_update(lambda _: None if self._unticking else self._option_changed("errors"))
        self.show_smoothed_nees.on_update(lambda _: None if self._unticking else self._option_changed("nees"))
        self.nees_block.on_update(lambda _: self._option_changed("nees"))
        self.innovation_source.on_update(lambda _: self._option_changed("innovations"))
        self.innovation_run.on_update(lambda _: self._option_changed("innovations"))
        self.sensor_method.on_update(lambda _: self._option_changed("sensors"))
        self.sensor_run.on_update(lambda _: self._option_changed("sensors"))
        self.show_events.on_update(lambda _: self._events_toggled())
        self._events_of: tuple[Any, list[Event]] = (None, [])  # (results, config, run) -> their events

    def _add_error_tabs(self, gui: viser.GuiApi, workbench: viser.PanelHandle) -> None:
        """The Plots tab (the error norms, the ELC's choice) and the Components tab."""
        with workbench.add_tab("Plots"):
            self.show_sigma = gui.add_checkbox("Show 1-sigma", False)
            self.log_y = gui.add_dropdown("Error axes", ERROR_AXES, initial_value=AUTO, hint=ERROR_AXES_HINT)
            self.show_att_norm = gui.add_checkbox(
                "Attitude norm", False, hint="also plot |attitude error| (tilt and heading together)"
            )
            self.show_smoothed = gui.add_checkbox("Smoothed", False, disabled=True, hint=SMOOTHED_HINT)
            self.show_events = gui.add_checkbox("Events", True, hint=EVENTS_HINT)
            self.plots_note = gui.add_markdown("")
            self.plots = {
                q: gui.add_plotly(
                    placeholder_figure(f"{QUANTITIES[q][2]} [{QUANTITIES[q][3]}]"),
                    aspect=PLOT_ASPECT,
                    visible=q != "att",
                )
                for q in PLOTTED_QUANTITIES
            }
            self.elc_plot = gui.add_plotly(go.Figure(), aspect=0.4, visible=False)
        with workbench.add_tab("Components"):
            self.components_note = gui.add_markdown(COMPONENTS_NOTE)
            self.component_plots = {
                q: gui.add_plotly(placeholder_figure(f"{COMPONENTS[q][1]} [{COMPONENTS[q][2]}]"), aspect=0.75)
                for q in COMPONENTS
            }

    def _add_consistency_tab(self, gui: viser.GuiApi, workbench: viser.PanelHandle) -> None:
        """The Consistency tab: the NEES of a block, with its note."""
        with workbench.add_tab("Consistency"):
            self.nees_block = gui.add_dropdown(
                "NEES block",
                tuple(BLOCK_DIMS),
                initial_value="full",
                hint=f"full: all {BLOCK_DIMS['full']} error states ({OTHER_FAMILIES_DIMS}); or one block of "
                "them; current: the DVL's current states (a run with Current states on)",
            )
            self.show_smoothed_nees = gui.add_checkbox(
                "Smoothed NEES", False, disabled=True, hint=SMOOTHED_HINT
            )
            self.nees_plot = gui.add_plotly(
                placeholder_figure("NEES/dim"), aspect=0.6
            )  # viser: height / width
            gui.add_markdown(CONSISTENCY_NOTE)

    def _add_innovations_tab(self, gui: viser.GuiApi, workbench: viser.PanelHandle) -> None:
        """The Innovations tab: one aiding source's innovations in one run."""
        with workbench.add_tab("Innovations"):
            self.innovation_source = gui.add_dropdown(
                "Aiding source", INITIAL_INNOVATION_SOURCES, initial_value=INITIAL_INNOVATION_SOURCES[0]
            )
            self.innovation_run = gui.add_number(
                "Run", 1, min=1, max=1, step=1, hint="which Monte Carlo run's innovations", visible=False
            )
            self.innovation_plot = gui.add_plotly(placeholder_figure("Innovations"), aspect=0.85)
            self.innovation_note = gui.add_markdown(INNOVATION_NOTE)

    def _add_sensors_tab(self, gui: viser.GuiApi, workbench: viser.PanelHandle) -> None:
        """The Sensors tab: the raw measurements, the sources' states and one method's sensor errors."""
        with workbench.add_tab("Sensors"):
            gui.add_markdown(SENSORS_NOTE)
            self.raw_plot = gui.add_plotly(placeholder_figure("Raw sensors"), aspect=0.6)
            self.sensor_run = gui.add_number(
                "Estimates of run",
                1,
                min=1,
                max=1,
                step=1,
                hint="which Monte Carlo run's estimates (the current's and the sensor errors')",
                visible=False,
            )
            # the states the sources add (the DVL's current), every method's: a run with them only
            self.state_note = gui.add_markdown("")
            self.state_plot = gui.add_plotly(go.Figure(), aspect=0.6, visible=False)
            self.sensor_method = gui.add_dropdown(
                "Sensor errors of",
                INITIAL_SENSOR_METHODS,
                initial_value=INITIAL_SENSOR_METHODS[0],
                hint="the method whose estimates are drawn",
            )
            self.sensor_note = gui.add_markdown("")
            self.sensor_plot = gui.add_plotly(placeholder_figure("Sensor errors"), aspect=0.6)

    def _add_mission_tabs(self, gui: viser.GuiApi, tabs: viser.GuiTabGroupHandle) -> None:
        """The Vehicle and Seabed tabs, in the Mission tab group ``tabs``."""
        with tabs.add_tab("Vehicle"):
            self.vehicle_note = gui.add_markdown(VEHICLE_NOTES["none"])
            self.vehicle_plot = gui.add_plotly(go.Figure(), aspect=1.0, visible=False)
            self.current_note = gui.add_markdown(VEHICLE_NOTES["current"], visible=False)
            self.current_plot = gui.add_plotly(go.Figure(), aspect=1.0, visible=False)
        with tabs.add_tab("Seabed"):
            self.seabed_note = gui.add_markdown(SEABED_NOTES["none"])
            self.seabed_plot = gui.add_plotly(go.Figure(), aspect=0.8, visible=False)
            self.vkf_note = gui.add_markdown(VKF_NOTES["none"])
            self.vkf_plot = gui.add_plotly(go.Figure(), aspect=1.0, visible=False)

    def _option_changed(self, only: str) -> None:
        """An option of the plots changed: redraw the group ``only`` it changes, the page showing
        its busy sign if that takes longer than page_scripts.BUSY_DELAY_S (the wait for the draw
        lock included)."""
        page_scripts.run(self.state.client, page_scripts.busy(True))
        try:
            self.refresh_plots(only=only)
        finally:
            page_scripts.run(self.state.client, page_scripts.busy(False))

    @drawing
    def refresh_plots(self, only: str | None = None, live: bool = False) -> None:
        """Redraw the workbench's plots: the error norms of the current run (or of the kept runs
        ticked for overlay), their components, NEES and innovations, each with the time cursor;
        ``only`` one group of them ("errors", "nees", "innovations": what an option changes).
        A figure whose JSON equals the one the page has is not sent again (viser skips it).

        ``live``: a running run's results so far, whose deferred plots (innovations, components,
        sensors: most of what the page renders) are drawn at most every LIVE_DIAGNOSTICS_S; a run
        shorter than that draws them once, with its final results."""
        if only is not None:
            self.state.last_action_s = time.monotonic()
        results = self.state.results
        if not results:
            return
        if only is None:  # the Smoothed boxes: usable once a run's smoothed results are here
            self._smoothed_boxes(has_smoothed(results), final=not live)
        for group in PLOT_GROUPS:  # a full redraw leaves the deferred ones to the diagnostics' thread
            if only == group.name or (only is None and not group.deferred):
                group.draw(self, results)
        if only is None:
            self.spread.show(results, live)  # a Monte Carlo's final results only
        now = time.monotonic()
        if only is None and (not live or now - self.last_diagnostics_s >= LIVE_DIAGNOSTICS_S):
            self.schedule_diagnostics()
            self.last_diagnostics_s = now

    def _smoothed_boxes(self, usable: bool, final: bool = True) -> None:
        """The Smoothed boxes for results with (``usable``) or without smoothed series: without,
        disabled, and unticked once the run's results are ``final`` (a box ticked and greyed would
        claim a curve that is not drawn; a smoothed run's live results have none yet); with,
        enabled as the user left them (never ticked for them)."""
        for box in (self.show_smoothed, self.show_smoothed_nees):
            if not usable and final and box.value:
                self._unticking = True  # the plots are redrawn next: the box's own redraw waits
                try:
                    box.value = False
                finally:
                    self._unticking = False
            if box.disabled == usable:
                box.disabled = not usable

    def run_started(self) -> None:
        """A run starts: its first live diagnostics come LIVE_DIAGNOSTICS_S from now."""
        self.last_diagnostics_s = time.monotonic()

    def _draw_nees(self, results: dict[str, MethodResult]) -> None:
        blocks = nees_blocks(results)  # the 20-state filter's, and the current's with current states
        if tuple(self.nees_block.options) != blocks:
            self.nees_block.options = blocks
        block = self.nees_block.value if self.nees_block.value in blocks else "full"
        overlay = self.overlay_runs()
        figure = (
            overlay_figure([(r.label, nees_figure(r.results, block)) for r in overlay])
            if len(overlay) >= 2
            else nees_figure(results, block, smoothed=self.show_smoothed_nees.value)
        )
        self._fit(self.nees_plot, figure, CARD_WIDTH_PX)
        self.nees_plot.figure = self._with_events(with_cursor(figure, SENT_CURSOR_S))

    def schedule_diagnostics(self) -> None:
        """Draw the innovations, components and ELC plots soon, one figure at a time in a thread of
        their own (called under the draw lock). They are half of a full redraw; drawn inline they
        held the draw lock, so this tab's slider and Run waited behind them (8 tabs: p95 300 ms
        in tests/server/test_load.py). They wait until the tab has been still for QUIET_S (the
        slider, a control, an option), so what the user does now is answered first. New results
        while they are drawn start them again."""
        self.diagnostics_due = True
        if self.diagnostics_thread is None:
            self.diagnostics_thread = threading.Thread(target=self._diagnostics_loop, daemon=True)
            self.diagnostics_thread.start()

    def _diagnostics_loop(self) -> None:
        while True:
            time.sleep(DIAGNOSTICS_DELAY_S)  # what the user acted on goes out first
            if time.monotonic() - self.state.last_action_s < QUIET_S:
                continue  # still busy in this tab: wait
            with self.draw_lock:
                if not self.diagnostics_due:
                    self.diagnostics_thread = None
                    return
                self.diagnostics_due = False
                results = self.state.results
            steps: list[Callable[[dict[str, MethodResult]], None]] = [
                functools.partial(group.draw, self) for group in PLOT_GROUPS if group.deferred
            ]
            for step in (*steps, lambda _: self.add_run_widgets()):
                with self.draw_lock:
                    if self.diagnostics_due or not results:
                        break  # newer results: draw those instead
                    try:
                        step(results)
                    except Exception as exc:  # noqa: BLE001 - a display bug must not kill the thread silently
                        title, text, error = display_error(exc)
                        self.notify(title, text, error=error)
                time.sleep(0.0)

    def _draw_error_plots(self, results: dict[str, MethodResult]) -> None:
        t = SENT_CURSOR_S
        log_y = {AUTO: AUTO, "linear": False, "log": True}.get(self.log_y.value, AUTO)
        overlay = self.overlay_runs()
        same = identical_methods(results)
        notes = []
        if len(overlay) >= 2:
            notes.append(
                f"**Overlay of {', '.join(r.label for r in overlay)}** (Runs tab; line styles in the titles). "
                "Untick them there to see the current run alone."
            )
        if same:
            notes.append(identical_note(same))
        note = "\n\n".join(notes)
        if self.plots_note.content != note:
            self.plots_note.content = note
        for q, handle in self.plots.items():
            shown = q != "att" or self.show_att_norm.value
            if handle.visible != shown:
                handle.visible = shown
            if shown:
                figure = (
                    compare_figure([(r.label, r.results) for r in overlay], q, log_y=log_y)
                    if len(overlay) >= 2
                    else error_figure(
                        results,
                        q,
                        show_sigma=self.show_sigma.value,
                        log_y=log_y,
                        smoothed=self.show_smoothed.value,
                    )
                )
                self._fit(handle, figure, CARD_WIDTH_PX)
                handle.figure = self._with_events(with_cursor(figure, t))

    def _att_norm_changed(self) -> None:
        """Attitude norm ticked or unticked: redraw the error plots, and bring the norm's plot,
        added below the others, into view."""
        self._option_changed("errors")
        if self.show_att_norm.value and self.state.results:
            title = f"{QUANTITIES['att'][2]} [{QUANTITIES['att'][3]}]"
            page_scripts.run(self.state.client, page_scripts.scroll_to_plot(title))

    def _draw_components_and_elc(self, results: dict[str, MethodResult]) -> None:
        t = SENT_CURSOR_S
        tv = self.state.truth_view
        if tv is not None:
            components = {
                m: error_components(r, tv["t_s"], tv["pos_n"], tv["C_nb"], tv.get("vel_n"))
                for m, r in results.items()
                if len(r.t_s)
            }
            for q, handle in self.component_plots.items():
                figure = components_figure(results, components, q)
                self._fit(handle, figure, CARD_WIDTH_PX)
                handle.figure = self._with_events(with_cursor(figure, t))
        if "elc" in results:
            figure = elc_choice_figure(results["elc"])
            self._fit(self.elc_plot, figure, CARD_WIDTH_PX)
            self.elc_plot.figure = self._with_events(with_cursor(figure, t))
            self.elc_plot.visible = True
        else:
            self.elc_plot.visible = False

    def _draw_innovations(self, results: dict[str, MethodResult]) -> None:
        t = SENT_CURSOR_S
        sources = innovation_sources(results)
        if sources:
            if tuple(self.innovation_source.options) != sources:
                self.innovation_source.options = sources
            source = self.innovation_source.value if self.innovation_source.value in sources else sources[0]
            runs = max(r.updates[source].innovation.shape[1] for r in results.values() if source in r.updates)
            if self.innovation_run.max != runs:  # a Monte Carlo run's innovations, one run at a time
                self.innovation_run.max = runs
                self.innovation_run.visible = runs > 1
            run = min(max(int(self.innovation_run.value), 1), runs) - 1
            figure = innovation_figure(results, source, run=run)
            # each panel keeps its height as panels and legend rows are added
            self._fit(self.innovation_plot, figure, CARD_WIDTH_PX)
            self.innovation_plot.figure = self._with_events(with_cursor(figure, t), run)
            without = [m.upper() for m, r in results.items() if source not in r.updates]
            self.innovation_note.content = INNOVATION_NOTE + (
                f" No {source.upper()} updates: {', '.join(without)}." if without else ""
            )

    def _draw_sensors(self, results: dict[str, MethodResult]) -> None:
        t = SENT_CURSOR_S
        view = self.state.sensor_view
        if view is not None and len(view["t_s"]):
            figure = raw_sensor_figure(view)
            self._fit(self.raw_plot, figure)
            self.raw_plot.figure = self._with_events(with_cursor(figure, t))
        estimates = [a for r in results.values() for a in (r.sensor_est, r.state_est) if a is not None]
        runs = max((a.shape[1] for a in estimates), default=1)
        if self.sensor_run.max != runs:  # a Monte Carlo run's estimates, one run at a time
            self.sensor_run.max = runs
            self.sensor_run.visible = runs > 1
        run = min(max(int(self.sensor_run.value), 1), runs) - 1
        self._draw_states(results, run)
        methods = tuple(m for m, r in results.items() if r.sensor_est is not None and len(r.t_s))
        note = "" if methods else SENSOR_ERRORS_NOT_RECORDED
        if self.sensor_note.content != note:
            self.sensor_note.content = note
        if self.sensor_plot.visible != bool(methods):
            self.sensor_plot.visible = bool(methods)
        if not methods:
            return
        if tuple(self.sensor_method.options) != methods:
            self.sensor_method.options = methods
        method = self.sensor_method.value if self.sensor_method.value in methods else methods[0]
        result = results[method]
        assert result.sensor_est is not None
        run = min(run, result.sensor_est.shape[1] - 1)
        figure = sensor_error_figure(
            result, run=run, height_px=PANEL_HEIGHT_PX * len(sensor_panels(method)) + 70
        )
        self._fit(self.sensor_plot, figure)
        self.sensor_plot.figure = self._with_events(with_cursor(figure, t), run)

    def _draw_states(self, results: dict[str, MethodResult], run: int) -> None:
        """The Sensors tab's figure of the states the sources add (the DVL's current), for run
        ``run`` (0-based) of every method that estimates them, under a note naming those that do
        not; hidden, with no note, for a run without such states."""
        methods = state_methods(results)
        note = ""
        if methods:
            others = [m.upper() for m in results if m not in methods]
            note = STATES_NOTE + (
                f" Not drawn: {', '.join(others)} (no aiding, or no current states)." if others else ""
            )
            if any(is_decimated(results[m]) for m in methods):
                note += " A run this long is reduced to time bins: each bin's last estimate."
        if self.state_note.content != note:
            self.state_note.content = note
        if self.state_plot.visible != bool(methods):
            self.state_plot.visible = bool(methods)
        if methods:
            figure = source_states_figure(results, run=run)
            self._fit(self.state_plot, figure)
            self.state_plot.figure = self._with_events(with_cursor(figure, SENT_CURSOR_S), run)

    def _with_events(self, figure: go.Figure, run: int = 0) -> go.Figure:
        """``figure`` with run ``run``'s events on its time axes (app.figures.event_traces; the
        scheduled outages alone before results come), unless the Events box is off."""
        config = self.state.config
        if not self.show_events.value or config is None:
            return figure
        results = self.state.results or {}
        key = (results, config, run)
        cached_key, events = self._events_of
        if not (isinstance(cached_key, tuple) and all(a is b for a, b in zip(cached_key, key, strict=True))):
            events = run_events(results, config, run)
            self._events_of = (key, events)
        return with_events(figure, events)

    def _events_toggled(self) -> None:
        """The Events box changed: every time plot and the map again, with or without them (the
        Session redraws the 3-D track's)."""
        self.state.events_shown = bool(self.show_events.value)
        self.map.redraw()
        self.refresh_plots()
        self.draw_vehicle_plot()
        self.draw_seabed_plot()
        results, config = self.state.results, self.state.config
        if results and config is not None and "vkf" in results:
            self.draw_vkf_plot(results["vkf"], config)

    @staticmethod
    def _fit(handle: viser.GuiPlotlyHandle, figure: go.Figure, card_px: int = SENSOR_PLOT_WIDTH_PX) -> None:
        """Size ``handle`` for ``figure``'s height, reckoned for a card ``card_px`` wide (its
        panels; its legend's rows: app.figures.shared.legend_bottom): viser sets a plot's height
        as aspect x width."""
        aspect = card_aspect(figure, card_px)
        if handle.aspect != aspect:
            handle.aspect = aspect

    @drawing
    def draw_seabed_plot(self) -> None:
        """The Seabed tab: the altitude above the seabed of a simulated mission, otherwise a note."""
        tv, config = self.state.truth_view, self.state.config
        if tv is None or config is None:
            return
        altitude_m = tv.get("altitude_m")
        if altitude_m is None:
            self.seabed_plot.visible = False
            self.seabed_note.content = SEABED_NOTES["log" if self.state.replaying else "none"]
            return
        self.seabed_plot.figure = self._with_events(
            with_cursor(
                altitude_figure(
                    tv["t_s"], altitude_m, config.dvl.max_altitude_m, config.vkf.switch_altitude_m
                ),
                SENT_CURSOR_S,
            )
        )
        self.seabed_plot.visible = True
        self.seabed_note.content = SEABED_NOTES["simulation"]

    @drawing
    def draw_vkf_plot(self, result: MethodResult | None, config: Config) -> None:
        """The Seabed tab's VKF figure: what the velocity Kalman filter learned (``result``, the
        ``vkf`` method's), or a note: the run has no VKF, or its results are still to come."""
        trace = result.vkf_trace if result is not None else None
        if trace is not None and len(trace["t_s"]):
            self.vkf_plot.figure = self._with_events(with_cursor(vkf_figure(trace), SENT_CURSOR_S))
            self.vkf_plot.visible = True
            self.vkf_note.content = VKF_NOTES["shown"]
            return
        self.vkf_plot.visible = False
        self.vkf_note.content = VKF_NOTES["running" if "vkf" in config.run.methods else "none"]

    @drawing
    def draw_vehicle_plot(self) -> None:
        """The Vehicle tab: fins and propeller of a dynamic truth, otherwise a note saying why none;
        below, in a current (either truth), the current at the vehicle and its speed through the
        water against over ground (app.figures.vehicle_figures.current_figure)."""
        tv, config = self.state.truth_view, self.state.config
        if tv is None or config is None:
            return
        current_n_mps, vel_water_b = tv.get("current_n_mps"), tv.get("vel_water_b")
        if current_n_mps is not None and vel_water_b is not None:
            water, ground = water_and_ground_speed_mps(tv["C_nb"], vel_water_b, current_n_mps)
            self.current_plot.figure = self._with_events(
                with_cursor(current_figure(tv["t_s"], current_n_mps, water, ground), SENT_CURSOR_S)
            )
        self.current_plot.visible = self.current_note.visible = current_n_mps is not None
        fin_angles_rad, propeller_rpm = tv.get("fin_angles_rad"), tv.get("propeller_rpm")
        if fin_angles_rad is not None and propeller_rpm is not None:
            self.vehicle_plot.figure = self._with_events(
                with_cursor(actuator_figure(tv["t_s"], fin_angles_rad, propeller_rpm), SENT_CURSOR_S)
            )
            self.vehicle_plot.visible = True
            self.vehicle_note.content = VEHICLE_NOTES["dynamic"]
            return
        self.vehicle_plot.visible = False
        self.vehicle_note.content = VEHICLE_NOTES["log" if self.state.replaying else config.trajectory.truth]


def has_smoothed(results: dict[str, MethodResult]) -> bool:
    """Whether some method of ``results`` carries smoothed results (``MethodResult.smoothed``).

    Parameters
    ----------
    results : dict[str, MethodResult]
        Method name -> its results.

    Returns
    -------
    bool
        True when the Smoothed boxes have something to draw.
    """
    return any(r.smoothed is not None and len(r.smoothed.t_s) for r in results.values())


@dataclasses.dataclass(frozen=True)
class PlotGroup:
    """One group of the workbench's plots: what :meth:`PlotTabs.refresh_plots` calls it
    (``only=``), the tab it is in, and what draws it from a run's results."""

    name: str
    tab: str  # the workbench tab
    draw: Callable[[PlotTabs, dict[str, MethodResult]], Any]
    deferred: bool  # a full redraw leaves it to the diagnostics' thread (drawn once the tab is still)


PLOT_GROUPS = (
    PlotGroup("errors", "Plots", PlotTabs._draw_error_plots, deferred=False),
    PlotGroup("nees", "Consistency", PlotTabs._draw_nees, deferred=False),
    PlotGroup("innovations", "Innovations", PlotTabs._draw_innovations, deferred=True),
    PlotGroup("components", "Components", PlotTabs._draw_components_and_elc, deferred=True),
    PlotGroup("sensors", "Sensors", PlotTabs._draw_sensors, deferred=True),
    PlotGroup("map", "Map", lambda tabs, results: tabs.map.draw(results), deferred=True),
)
"""The workbench's plot groups, in the order a full redraw draws them (the ELC's choice, in the
Plots tab, is drawn with the components)."""
