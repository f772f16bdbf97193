"""The tauv dashboard: a viser server in which a navigation engineer flies a mission, switches
DVL beams off, picks fusion methods (and sets the partial-beam methods' assumptions) and watches
the navigation errors live, and whether each method knows its error (NEES against its 99 % band).

    tauv serve [--host 127.0.0.1] [--port 8080] [--workers N]

Every browser tab is a :class:`Session` with its own controls, scene, run and results; a run
goes in its own process (app.worker) so the server and the other tabs stay responsive.
viser's share tunnel (an external relay service) cannot be started: its button is off and its
message handlers are removed (app.hardening.disable_share_tunnel); nothing is fetched from the internet.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import queue as queue_mod
import signal
import threading
import time
import uuid
from collections.abc import Callable
from typing import Any

import numpy as np
import plotly.graph_objects as go
import viser
from viser import _messages as viser_messages

from app import budget, export, inputs, links, page_scripts, plot_click, worker
from app.controls import PLUGIN_FIELDS, add_source_controls
from app.error_figures import (
    AUTO,
    COMPONENTS,
    compare_figure,
    components_figure,
    elc_choice_figure,
    error_components,
    error_figure,
    nees_figure,
    overlay_figure,
)
from app.figures import TRUTH_COLOR, cursor_shape, decimate, method_color, with_cursor
from app.hardening import (
    RECLAIM,
    bound_malloc_arenas,
    check_listen,
    disable_share_tunnel,
    harden_client_messages,
    install_shutdown_handlers,
    shutdown,
)
from app.innovation_figures import innovation_figure, innovation_sources
from app.inputs import Controls, InputError, config_from_controls, config_markdown
from app.markdown_tables import (
    compare_markdown,
    config_diff_markdown,
    flat_config,
    identical_methods,
    identical_note,
    rms_markdown,
    summary_markdown,
)
from app.scene import (
    BEAM_COLOR_NAMES,
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    BEAM_THICKNESS_PX,
    CAMERA_FREE,
    CAMERA_MODES,
    CAMERA_SIDE,
    PLAYBACK_DEFAULT_SPEED,
    PLAYBACK_FPS,
    PLAYBACK_SPEEDS,
    SEABED_COLOR,
    MissionFrame,
    auv_parts_body,
    beam_label_positions_b,
    beam_readout,
    beam_segments_b,
    beam_states,
    beam_stub,
    chase_camera_view,
    compass_view,
    fin_wxyz_body,
    fit_camera_view,
    interpolate_pose,
    mission_frame,
    ned_to_view,
    playback_speed,
    playback_time,
    scale_bar_view,
    seabed_mesh_n,
    seabed_ranges_m,
    wxyz_view,
)
from app.vehicle_figures import FIN_COLORS, actuator_figure, altitude_figure, vkf_figure
from tauvcore.config import RUN_METHODS, Config, from_dict, to_dict
from tauvcore.engine.results import BLOCK_DIMS, YOO_BLOCK_DIMS, MethodResult
from tauvcore.eval.metrics import rms
from tauvcore.logs import CONFIG_FILE, LogError
from tauvcore.truth import TRAJECTORIES, TRUTH_SOURCES
from tauvcore.truth.kinematic import bathymetry
from tauvcore.validation import ConfigError, show

DEFAULT_METHODS = ("ins", "lc", "tc", "nsv", "elc")
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
    "none": "Fins and propeller of the dynamic truth show here after a run with **Truth: dynamic**.",
}
"""The Vehicle tab's note for each kind of truth (its figure shows for the dynamic truth only)."""
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
LEGEND_WIDTH_PX, LEGEND_HEIGHT_PX = 420, 118  # the floating legend over the 3-D view
WORKBENCH_WIDTH_PX = 640  # the plot panel docked left of the 3-D view (the user can resize or minimise it)
PLOT_ASPECT = 0.42  # each error plot's height / width: three or four in view at once
DIAGNOSTICS_DELAY_S = 0.05  # the innovations and components plots follow the others by this much,
QUIET_S = 1.0  # once the tab has had no action for this long
KEPT_RUNS_MAX = 5  # finished runs kept for comparison (memory: each holds its full results)
COMPONENTS_NOTE = (
    "Signed errors, estimate minus truth: position north/east/down, body velocity surge/sway/heave, Euler "
    "angles roll/pitch/heading. The truth's velocity is the central difference of its positions at the output "
    "epochs. With several runs the curves are the RMS over runs."
)
INNOVATION_NOTE = (
    "Each method's innovations (measurement minus prediction) with its filter's 3-sigma envelope "
    "(+-3 sqrt(S)); crosses mark what the gate rejected. A consistent filter keeps about 99.7 % inside. "
    "INS (and any method without this source) has none."
)
GO_TO_REFUSAL_DELAY_S = 0.8  # a bad "Go to [s]" is refused once it has stood this long (typing stopped)
INNOVATION_PANEL_ASPECT = 0.25  # each panel of the innovations plot: a quarter of the panel's width high
INITIAL_INNOVATION_SOURCES: tuple[str, ...] = ("dvl",)
"""The Innovations tab's choices before a run: any source name (a run's own replace them), so
``str``, not the literal "dvl"."""
RUNS_NOTE = (
    f"Every finished run is kept here with its configuration until removed (at most {KEPT_RUNS_MAX}: the "
    "oldest goes when another finishes). Tick two or more to overlay them in the Plots tab (one line style per "
    "run, the method colours kept) and to compare them below."
)
GUI_REFRESH_S = 1.5  # at most this often the plots are redrawn during a run (wall time)
FOLLOW_DISTANCE_M = 22.0  # chase-camera distance: the 3 m hull and its beams fill the view
TRAJECTORY_POINTS = 600  # points per drawn trajectory (a 250 s run has 2501 epochs)
REJECT_REFERENCE = (
    "tc",
    "elc",
    "nsv",
    "vb",
    "vhv",
    "plcf",
    "lc",
    "ins-dvl",
)  # whose gate decides the red beams
CONFIRM_TIMEOUT_S = 10.0  # how long Run waits for the page to report its controls (software WebGL stalls)
SNAPSHOT_KEY_PREFIX = "tauv-controls-"  # + a fresh id per Run press: tabs of one browser share localStorage
CHECKING_STATUS = "Checking the controls the page shows..."


@dataclasses.dataclass(frozen=True)
class KeptRun:
    """A finished run kept in the Runs tab for comparison."""

    number: int  # 1, 2, ... in the order the tab's runs finished
    config: Config  # what ran
    runs: int  # Monte Carlo runs
    results: dict[str, MethodResult]  # its final results

    @property
    def label(self) -> str:
        return f"run {self.number}"

    def description(self) -> str:
        tr = self.config.trajectory
        return f"{tr.name}, {tr.duration_s:g} s, {', '.join(m.upper() for m in self.config.run.methods)}" + (
            f", {self.runs} runs" if self.runs > 1 else ""
        )


def _hex_rgb(color: str) -> tuple[int, int, int]:
    return tuple(int(color[i : i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


def _drawing(method: Callable[..., None]) -> Callable[..., None]:
    """Run a Session method that changes the scene or plots under the session's draw lock."""

    @functools.wraps(method)
    def locked(self: Session, *args: Any, **kwargs: Any) -> None:
        with self.draw_lock:
            method(self, *args, **kwargs)

    return locked


def _can_hold(handle: Any, value: Any) -> bool:
    """Whether ``value``, as the page reported it, is one the control ``handle`` can hold: a
    checkbox true/false, a dropdown one of its options, a text box a string of bounded length."""
    if isinstance(handle, viser.GuiCheckboxHandle):
        return isinstance(value, bool)
    if isinstance(handle, viser.GuiDropdownHandle):
        return value in handle.options
    return isinstance(value, str) and len(value) <= 10 * inputs.TEXT_MAX_CHARS


class Session:
    """One browser tab: its controls, 3-D scene, background run and results."""

    def __init__(
        self, client: viser.ClientHandle, pool: worker.RunPool, logs: dict[str, str] | None = None
    ) -> None:
        self.client = client
        self.pool = pool
        self.logs = dict(logs or {})  # name -> directory, from tauv serve --logs (never from the page)
        self.lock = threading.Lock()
        # the run's message thread, the slider's callback and the playback thread all redraw the
        # scene and plots: one at a time (a beam re-added by one while another assigns to it
        # raised "Cannot assign to 'visible' on a removed LineSegmentsHandle")
        self.draw_lock = threading.RLock()
        self.handle: worker.RunHandle | None = None
        self.config: Config | None = None
        self.truth_view: worker.TruthView | None = None
        self.replaying = False  # the current run replays a log (tauv serve --logs)
        self.results: dict[str, MethodResult] | None = None
        self.playing = False
        self.run_log: str | None = None  # the log the current run replays (its name), None: a simulation
        self.run_source: dict[str, Any] | None = None  # that log as app.worker.replay_source describes it
        self.finished_run: export.FinishedRun | None = None  # what the Download buttons send
        # the page's address carries the controls (app.links): written only once the page's own
        # query has been read, so a link is never overwritten before it applies
        self.address_lock = threading.Lock()
        self.address_ready = False
        self.address_shown: str | None = None
        self.viser_params: tuple[str, ...] = ()
        self._build_gui()
        self._build_scene()
        plot_click.install(self.client)  # a click on any plot moves the playback (app.plot_click)
        threading.Thread(target=self.read_link, daemon=True).start()

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui = self.client.gui
        d = Config()
        # the colours' legend floats over the 3-D view's bottom-left corner, in its own small panel:
        # in view whatever the control panel or the workbench scrolls to (the user may move it)
        self.legend_panel = gui.add_panel()
        with self.legend_panel.add_tab("Legend"):
            self.legend = gui.add_html(self._legend_html(DEFAULT_METHODS))
        self.legend_panel.float(x=12, y=-12, width=LEGEND_WIDTH_PX, height=LEGEND_HEIGHT_PX)
        tabs = gui.add_tab_group()
        with tabs.add_tab("Mission"):
            self.source = (
                gui.add_dropdown(
                    inputs.SOURCE,
                    (inputs.SIMULATION, *self.logs),
                    initial_value=inputs.SIMULATION,
                    hint="simulation, or a recorded log (tauv serve --logs): replayed with "
                    "these methods, beams, outages and tuning; its own length",
                )
                if self.logs
                else None
            )
            self.trajectory = gui.add_dropdown(
                inputs.TRAJECTORY, TRAJECTORIES, initial_value=d.trajectory.name
            )
            self.truth = gui.add_dropdown(
                inputs.TRUTH, TRUTH_SOURCES, initial_value=d.trajectory.truth, hint=inputs.TRUTH_HINT
            )
            # numeric fields are text: the server reads what was typed (see app.inputs)
            self.duration = gui.add_text(inputs.DURATION, f"{d.trajectory.duration_s:g}")
            with gui.add_folder("Methods"):
                # both papers' methods, the first's then Yoo 2014's, then the registered ones
                # (tauvcore.config.RUN_METHODS)
                self.method_boxes = {
                    m: gui.add_checkbox(m.upper(), m in DEFAULT_METHODS, hint=inputs.METHOD_HINTS.get(m))
                    for m in RUN_METHODS
                }
            with gui.add_folder("Partial-beam methods"):
                # each method's assumption, visible and settable: VB's virtual-beam
                # inflation and NSV's sway variance
                self.vb_nf = gui.add_text(inputs.VB_NF, f"{d.partial.vb_nf:g}", hint=inputs.VB_NF_HINT)
                self.nsv_epsilon = gui.add_text(
                    inputs.NSV_EPSILON, str(d.partial.nsv_epsilon_m2_per_s2), hint=inputs.NSV_EPSILON_HINT
                )
            with gui.add_folder("DVL beams"):
                self.beam_boxes = [gui.add_checkbox(f"Beam {k}", True) for k in range(1, 5)]
                self.dropout = gui.add_text(
                    inputs.DROPOUT,
                    f"{d.dvl.dropout_probability:g}",
                    hint="chance that each beam misses each ping",
                )
                self.rpm_fallback = gui.add_checkbox(
                    inputs.RPM_FALLBACK, d.run.rpm_fallback, hint=inputs.RPM_FALLBACK_HINT
                )
            with gui.add_folder(inputs.SEABED_FOLDER, expand_by_default=False):
                # Yoo 2014's mission: where the seabed is, how far the DVL sees it, where
                # the VKF turns to the propeller, and how noisy the propeller's RPM is
                self.seabed_depth = gui.add_text(
                    inputs.SEABED_DEPTH, f"{d.trajectory.seabed_depth_m:g}", hint=inputs.SEABED_DEPTH_HINT
                )
                self.dvl_max_altitude = gui.add_text(
                    inputs.DVL_MAX_ALTITUDE, f"{d.dvl.max_altitude_m:g}", hint=inputs.DVL_MAX_ALTITUDE_HINT
                )
                self.switch_altitude = gui.add_text(
                    inputs.SWITCH_ALTITUDE, f"{d.vkf.switch_altitude_m:g}", hint=inputs.SWITCH_ALTITUDE_HINT
                )
                self.rpm_noise = gui.add_text(
                    inputs.RPM_NOISE, f"{d.rpm.noise_rpm:g}", hint=inputs.RPM_NOISE_HINT
                )
            with gui.add_folder("Outages [s] (start = end: none)", expand_by_default=False):
                self.outage = [
                    tuple(gui.add_text(label, "0") for label in inputs.outage_labels(k)) for k in range(1, 5)
                ]
            with gui.add_folder("Aiding", expand_by_default=False):
                self.aid_depth = gui.add_checkbox("Depth (pressure)", False)
                self.aid_mag = gui.add_checkbox("Magnetometer", False)
                # the plug-in sources (tauvcore.aiding.sources), each with its section's controls
                self.source_boxes, self.source_fields = add_source_controls(gui)
            with gui.add_folder("Sensors (Table 2)", expand_by_default=False):
                self.accel_bias = gui.add_text(inputs.ACCEL_BIAS, f"{d.imu.accel_bias_mg:g}")
                self.gyro_bias = gui.add_text(inputs.GYRO_BIAS, f"{d.imu.gyro_bias_deg_per_h:g}")
                self.accel_noise = gui.add_text(inputs.ACCEL_NOISE, f"{d.imu.accel_noise_mps_per_sqrt_h:g}")
                self.gyro_noise = gui.add_text(inputs.GYRO_NOISE, f"{d.imu.gyro_noise_deg_per_sqrt_h:g}")
                self.dvl_noise = gui.add_text(inputs.DVL_NOISE, f"{d.dvl.noise_mps:g}")
                self.dvl_bias = gui.add_text(inputs.DVL_BIAS, f"{d.dvl.bias_mps:g}")
                self.dvl_sf = gui.add_text(inputs.DVL_SF, f"{d.dvl.scale_factor_pct:g}")
            self.seed = gui.add_text(inputs.SEED, str(d.run.seed))
            self.runs = gui.add_text(
                inputs.RUNS, "1", hint=f"Monte Carlo runs (1 to {inputs.RUNS_MAX}); > 1 plots RMS curves"
            )
            self.run_button = gui.add_button("Run", color="green")
            self.stop_button = gui.add_button("Stop", color="red", disabled=True)
            self.progress = gui.add_progress_bar(0.0, animated=False)
            self.status = gui.add_markdown("Ready. Choose a mission and press **Run**.")
            with gui.add_folder("Playback"):
                self.time_slider = gui.add_slider("Time [s]", 0.0, d.trajectory.duration_s, 0.1, 0.0)
                self.go_to = gui.add_text(plot_click.GO_TO_LABEL, "", hint=plot_click.GO_TO_HINT)
                self.play_button = gui.add_button("Play")
                self.pause_button = gui.add_button("Pause")
                self.speed = gui.add_dropdown(
                    "Speed",
                    PLAYBACK_SPEEDS,
                    initial_value=PLAYBACK_DEFAULT_SPEED,
                    hint="seconds of mission per second of playback",
                )
                self.camera_mode = gui.add_dropdown(
                    "Camera",
                    CAMERA_MODES,
                    initial_value=CAMERA_SIDE,
                    hint="follow the AUV from its side or from above, or orbit freely",
                )
                self.fit_button = gui.add_button("Fit mission", hint="frame the whole mission (camera: free)")
                self.readout = gui.add_markdown("")
        # the workbench: plots, diagnostics, results and kept runs in a panel of their
        # own docked left of the 3-D view, several plots in view at once (viser: height = aspect x width)
        self.cursor_t: float | None = None
        self.kept_runs: list[KeptRun] = []
        self.kept_widgets: dict[int, Any] = {}  # run number -> its folder in the Runs tab
        self.run_number = 0
        self.workbench = gui.add_panel()
        self.workbench.dock_left()
        self.workbench.set_width(WORKBENCH_WIDTH_PX)
        with self.workbench.add_tab("Plots"):
            self.show_sigma = gui.add_checkbox("Show 1-sigma", False)
            self.log_y = gui.add_checkbox(
                "Log scale", True, hint="log y where the errors span more than a decade, linear elsewhere"
            )
            self.show_att_norm = gui.add_checkbox(
                "Attitude norm", False, hint="also plot |attitude error| (tilt and heading together)"
            )
            self.plots_note = gui.add_markdown("")
            self.plots = {
                q: gui.add_plotly(go.Figure(), aspect=PLOT_ASPECT, visible=q != "att")
                for q in PLOTTED_QUANTITIES
            }
            self.elc_plot = gui.add_plotly(go.Figure(), aspect=0.4, visible=False)
        with self.workbench.add_tab("Components"):
            self.components_note = gui.add_markdown(COMPONENTS_NOTE)
            self.component_plots = {q: gui.add_plotly(go.Figure(), aspect=0.75) for q in COMPONENTS}
        with self.workbench.add_tab("Consistency"):
            self.nees_block = gui.add_dropdown(
                "NEES block",
                tuple(BLOCK_DIMS),
                initial_value="full",
                hint=f"full: all {BLOCK_DIMS['full']} error states (INS-DVL, VKF: {YOO_BLOCK_DIMS['full']}, "
                "no position); or one block of them",
            )
            self.nees_plot = gui.add_plotly(go.Figure(), aspect=0.6)  # viser: height / width
            gui.add_markdown(CONSISTENCY_NOTE)
        with self.workbench.add_tab("Innovations"):
            self.innovation_source = gui.add_dropdown(
                "Aiding source", INITIAL_INNOVATION_SOURCES, initial_value=INITIAL_INNOVATION_SOURCES[0]
            )
            self.innovation_run = gui.add_number(
                "Run", 1, min=1, max=1, step=1, hint="which Monte Carlo run's innovations", visible=False
            )
            self.innovation_plot = gui.add_plotly(go.Figure(), aspect=0.85)
            self.innovation_note = gui.add_markdown(INNOVATION_NOTE)
        with tabs.add_tab("Vehicle"):
            self.vehicle_note = gui.add_markdown(VEHICLE_NOTES["none"])
            self.vehicle_plot = gui.add_plotly(go.Figure(), aspect=1.0, visible=False)
        with tabs.add_tab("Seabed"):
            self.seabed_note = gui.add_markdown(SEABED_NOTES["none"])
            self.seabed_plot = gui.add_plotly(go.Figure(), aspect=0.8, visible=False)
            self.vkf_note = gui.add_markdown(VKF_NOTES["none"])
            self.vkf_plot = gui.add_plotly(go.Figure(), aspect=1.0, visible=False)
        with self.workbench.add_tab("Results"):
            self.table = gui.add_markdown("No run yet.")
            with gui.add_folder("Download"):
                # the finished run's results as the CLI writes them, and an offline report (app.export)
                self.download_buttons = {
                    kind: gui.add_button(
                        label, disabled=True, icon=viser.Icon.DOWNLOAD, hint=export.FORMAT_HINTS[kind]
                    )
                    for kind, label in export.FORMATS.items()
                }
            self.run_config = gui.add_markdown("")
        with self.workbench.add_tab("Runs"):
            gui.add_markdown(RUNS_NOTE)
            self.runs_folder = gui.add_folder("Kept runs")
            with self.runs_folder:
                self.no_runs = gui.add_markdown("No finished run yet.")
            self.diff_table = gui.add_markdown("")
            self.compare_table = gui.add_markdown("")

        source = self.source
        if source is not None:
            # a log replays its own reference: the truth's generator does not apply to it
            source.on_update(lambda _: setattr(self.truth, "disabled", source.value != inputs.SIMULATION))
            source.on_update(lambda event: self.apply_log_config() if event.client is not None else None)
        # a scenario's preset fills in the controls when the user picks it (not when the server
        # itself sets the dropdown to what the page shows, at Run: the page's values stand then)
        self.preset: str | None = None
        self.trajectory.on_update(
            lambda event: self.apply_trajectory_preset() if event.client is not None else None
        )
        self.run_button.on_click(lambda _: self.start_run())
        self.stop_button.on_click(lambda _: self.stop_run())
        # each option redraws only the plots it changes (a full redraw is ten figures)
        self.show_sigma.on_update(lambda _: self.refresh_plots(only="errors"))
        self.log_y.on_update(lambda _: self.refresh_plots(only="errors"))
        self.show_att_norm.on_update(lambda _: self.refresh_plots(only="errors"))
        self.nees_block.on_update(lambda _: self.refresh_plots(only="nees"))
        self.innovation_source.on_update(lambda _: self.refresh_plots(only="innovations"))
        self.innovation_run.on_update(lambda _: self.refresh_plots(only="innovations"))
        self.time_slider.on_update(lambda _: self.move_cursor(self.time_slider.value))
        self.time_slider.on_update(self._slider_moved)
        self.go_to.on_update(self._go_to)
        self.play_button.on_click(lambda _: self.play())
        self.pause_button.on_click(lambda _: setattr(self, "playing", False))
        self.camera_mode.on_update(lambda _: self._camera_changed())
        self.fit_button.on_click(lambda _: self.fit_mission())
        for box in self.beam_boxes:  # before a run the 3-D beams show the boxes at once
            box.on_update(lambda _: self._beams_from_boxes())
        for kind, button in self.download_buttons.items():
            button.on_click(lambda _, kind=kind: self.download(kind))
        for handle in self._confirmed_inputs().values():  # every control a run reads
            handle.on_update(lambda _: self.update_address())

    @staticmethod
    def _legend_html(methods: tuple[str, ...]) -> str:
        items = [f'<span style="color:{TRUTH_COLOR}">&#9632;</span> truth']
        items += [f'<span style="color:{method_color(m)}">&#9632;</span> {m.upper()}' for m in methods]
        beams = [
            f'<span style="color:rgb{BEAM_COLORS[s]}">&#9646;</span> {s} ({BEAM_COLOR_NAMES[s]})'
            for s in (BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED)
        ]
        return (
            '<div id="tauv-legend" style="font-size:0.8em;line-height:1.6">Trajectories: '
            + " &nbsp; ".join(items)
            + "<br>Beams (numbered 1-4 in the view): "
            + " &nbsp; ".join(beams)
            + "</div>"
        )

    def notify(self, title: str, body: str, error: bool = False) -> None:
        self.client.add_notification(
            title, body, auto_close_seconds=None if error else 6.0, color="red" if error else "green"
        )

    # ------------------------------------------------------------------ inputs
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
        """The text controls a preset or a log's configuration may fill in, by label."""
        return {
            inputs.DURATION: self.duration,
            inputs.ACCEL_BIAS: self.accel_bias,
            inputs.GYRO_BIAS: self.gyro_bias,
            inputs.ACCEL_NOISE: self.accel_noise,
            inputs.GYRO_NOISE: self.gyro_noise,
            inputs.DVL_NOISE: self.dvl_noise,
            inputs.DVL_BIAS: self.dvl_bias,
            inputs.DVL_SF: self.dvl_sf,
            inputs.DROPOUT: self.dropout,
            inputs.VB_NF: self.vb_nf,
            inputs.NSV_EPSILON: self.nsv_epsilon,
            inputs.SEABED_DEPTH: self.seabed_depth,
            inputs.DVL_MAX_ALTITUDE: self.dvl_max_altitude,
            inputs.SWITCH_ALTITUDE: self.switch_altitude,
            inputs.RPM_NOISE: self.rpm_noise,
            inputs.SEED: self.seed,
        }

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
        if not raw:
            self.notify(f"Log {source}", "No configuration file of its own: the controls apply as they are.")
            return
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
        parts = ([f"{', '.join(filled)} filled in"] if filled else []) + (
            [f"{', '.join(hidden)} apply at Run"] if hidden else []
        )
        self.notify(f"Log {source}: its {CONFIG_FILE} applied", "; ".join(parts) + ".")

    def log_config(self, source: str) -> dict[str, Any]:
        """The raw tables of log ``source``'s own configuration file ({} without one);
        InputError naming the file when it cannot be read or does not check."""
        from tauvcore.eval.replay import log_config

        try:
            return log_config(self.logs[source])[0]
        except LogError as exc:
            raise InputError(f"{inputs.SOURCE} {source}: {exc}") from None

    def selected_methods(self) -> tuple[str, ...]:
        return tuple(m for m in RUN_METHODS if self.method_boxes[m].value)

    def _confirmed_inputs(self) -> dict[str, Any]:
        """The controls a run reads, keyed by their viser id."""
        handles: list[Any] = [
            *([self.source] if self.source is not None else []),
            self.trajectory,
            self.truth,
            self.duration,
            *self.method_boxes.values(),
            self.vb_nf,
            self.nsv_epsilon,
            *self.beam_boxes,
            self.dropout,
            self.rpm_fallback,
            *(h for pair in self.outage for h in pair),
            self.aid_depth,
            self.aid_mag,
            *self.source_boxes.values(),
            *self.source_fields.values(),
            self.accel_bias,
            self.gyro_bias,
            self.accel_noise,
            self.gyro_noise,
            self.dvl_noise,
            self.dvl_bias,
            self.dvl_sf,
            self.seabed_depth,
            self.dvl_max_altitude,
            self.switch_altitude,
            self.rpm_noise,
            self.seed,
            self.runs,
        ]
        return {h._impl.uuid: h for h in handles}

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
        return Controls(
            trajectory=self.trajectory.value,
            truth=self.truth.value,
            duration=self.duration.value,
            methods=self.selected_methods(),
            vb_nf=self.vb_nf.value,
            nsv_epsilon=self.nsv_epsilon.value,
            beams=tuple(k for k in range(1, 5) if self.beam_boxes[k - 1].value),
            dropout=self.dropout.value,
            outages=tuple((start.value, end.value) for start, end in self.outage),
            aid_depth=self.aid_depth.value,
            aid_mag=self.aid_mag.value,
            accel_bias=self.accel_bias.value,
            gyro_bias=self.gyro_bias.value,
            accel_noise=self.accel_noise.value,
            gyro_noise=self.gyro_noise.value,
            dvl_noise=self.dvl_noise.value,
            dvl_bias=self.dvl_bias.value,
            dvl_sf=self.dvl_sf.value,
            seabed_depth=self.seabed_depth.value,
            dvl_max_altitude=self.dvl_max_altitude.value,
            switch_altitude=self.switch_altitude.value,
            rpm_noise=self.rpm_noise.value,
            seed=self.seed.value,
            runs=self.runs.value,
            source=self.source.value if self.source is not None else inputs.SIMULATION,
            rpm_fallback=self.rpm_fallback.value,
            aid_sources=tuple(name for name, box in self.source_boxes.items() if box.value),
            source_fields=tuple((key, handle.value) for key, handle in self.source_fields.items()),
        )

    def set_controls(self, c: Controls) -> None:
        """Set every control to what ``c`` holds (the inverse of :meth:`controls`); a control
        already holding its value is left alone."""

        def put(handle: Any, value: Any) -> None:
            if handle.value != value:
                handle.value = value

        if self.source is not None:
            put(self.source, c.source)
        put(self.trajectory, c.trajectory)
        put(self.truth, c.truth)
        put(self.duration, c.duration)
        for m, box in self.method_boxes.items():
            put(box, m in c.methods)
        put(self.vb_nf, c.vb_nf)
        put(self.nsv_epsilon, c.nsv_epsilon)
        for k, box in enumerate(self.beam_boxes, start=1):
            put(box, k in c.beams)
        put(self.dropout, c.dropout)
        put(self.rpm_fallback, c.rpm_fallback)
        for (start, end), (start_text, end_text) in zip(self.outage, c.outages):
            put(start, start_text)
            put(end, end_text)
        for name, box in self.source_boxes.items():
            put(box, name in c.aid_sources)
        for key, value in c.source_fields:
            put(self.source_fields[key], value)
        for handle, value in (
            (self.aid_depth, c.aid_depth),
            (self.aid_mag, c.aid_mag),
            (self.accel_bias, c.accel_bias),
            (self.gyro_bias, c.gyro_bias),
            (self.accel_noise, c.accel_noise),
            (self.gyro_noise, c.gyro_noise),
            (self.dvl_noise, c.dvl_noise),
            (self.dvl_bias, c.dvl_bias),
            (self.dvl_sf, c.dvl_sf),
            (self.seabed_depth, c.seabed_depth),
            (self.dvl_max_altitude, c.dvl_max_altitude),
            (self.switch_altitude, c.switch_altitude),
            (self.rpm_noise, c.rpm_noise),
            (self.seed, c.seed),
            (self.runs, c.runs),
        ):
            put(handle, value)

    # ------------------------------------------------------------------ the page's address
    def read_link(self) -> None:
        """Apply the setup the page's address carries (app.links), then keep the address in step
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
        """Set the controls a page's query (``location.search``) names (app.links.parse): a
        trajectory first, with its preset when the link does not set every control the preset
        does; one notification lists what was refused, key and value."""
        sources = tuple(self.source.options) if self.source is not None else (inputs.SIMULATION,)
        link = links.parse(query, sources)
        self.viser_params = link.viser_params
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

    def update_address(self) -> None:
        """Show the controls' setup in the page's address (app.links), once its own query has
        been read (:meth:`read_link`); nothing is sent when it is unchanged."""
        self.last_action_s = time.monotonic()
        if not self.address_ready:
            return
        with self.address_lock:
            query = links.address(self.controls(), self.viser_params)
            if query == self.address_shown:
                return
            self.address_shown = query
            links.show_address(self.client, query)

    def read_config(self) -> tuple[Config, int]:
        """The configuration the controls describe and its run count; InputError names the bad
        control and its value, also when the run would not fit the memory budget (app.budget)."""
        controls = self.controls()
        log_raw = self.log_config(controls.source) if controls.source in self.logs else None
        config, runs = config_from_controls(controls, log_raw)
        try:
            limit = budget.budget_bytes()
        except ValueError as exc:
            raise InputError(str(exc)) from None
        too_big = budget.over_budget_message(budget.estimate_run(config, runs), limit)
        if too_big is not None:
            raise InputError(
                f"{inputs.DURATION} {config.trajectory.duration_s:g} s, {inputs.RUNS} {runs}: {too_big}"
            )
        return config, runs

    # ------------------------------------------------------------------ runs
    def start_run(self) -> None:
        with self.lock:
            if self.handle is not None:
                self.notify("Already running", "Press Stop first, or wait for the run to finish.", error=True)
                return
            # shown at once (a GUI-only message); the page's answer waits for one 3-D frame of it
            previous, self.status.content = self.status.content, CHECKING_STATUS
            try:
                self.confirm_page_state()
                config, runs = self.read_config()
            except (InputError, ConfigError) as exc:
                self.status.content = previous
                self.notify("Cannot run", str(exc), error=True)
                return
            except RuntimeError:  # the tab closed while it was asked for its controls
                return
            source = self.source.value if self.source is not None else inputs.SIMULATION
            log_dir = self.logs.get(source)
            self.config, self.results, self.truth_view = config, None, None
            self.replaying = log_dir is not None
            self.run_log = source if log_dir is not None else None
            self.run_source = None  # the worker describes a replayed log with its configuration
            self.handle = handle = self.pool.start(to_dict(config), runs, log_dir=log_dir)
        self.run_button.disabled, self.stop_button.disabled = True, False
        self._set_finished(None)
        self.progress.value = 0.0
        what = (
            f"log {source}"
            if log_dir is not None
            else f"{config.trajectory.name}, {config.trajectory.duration_s:g} s, {runs} run(s)"
        )
        self.status.content = f"Running {what}: {', '.join(m.upper() for m in config.run.methods)}"
        self.run_config.content = config_markdown(config, runs)
        self.legend.content = self._legend_html(config.run.methods)
        # the slider follows the new run until the user moves it
        self.slider_pinned, self.slider_set_s, self.slider_follow_sent = False, None, False
        self.time_slider.max = config.trajectory.duration_s
        self._clear_trajectories()
        self._draw_vkf_plot(None, config)
        threading.Thread(target=self._pump, args=(handle, config), daemon=True).start()

    def stop_run(self) -> None:
        with self.lock:
            handle = self.handle
        if handle is not None:
            handle.stop()

    def _pump(self, handle: worker.RunHandle, config: Config) -> None:
        """Read the worker's messages and update this tab (runs in a thread of this session).

        While every worker is busy the run waits in line, and the status says its place; a
        worker that dies ends the run with an "error" message (app.worker), shown as a
        notification like any failed run. The run's closing notification is sent only after the
        tab is ready for the next run (Run enabled, no run held): a Run pressed as soon as "Run
        complete" shows must start, not meet "Already running".
        """
        last_draw = 0.0
        pending: dict[str, MethodResult] | None = None
        finished = False
        running_status = self.status.content
        place = 0
        note: tuple[str, str, bool] | None = None
        try:
            while not finished:
                try:
                    msg = handle.queue.get(timeout=0.1)
                except queue_mod.Empty:
                    now_place = handle.position()
                    if now_place != place:
                        place = now_place
                        self.status.content = (
                            running_status
                            if place == 0
                            else f"Waiting for a free worker: {place - 1} run(s) ahead "
                            f"({self.pool.workers} compute at once)."
                        )
                    if handle.finished() and handle.queue.empty():
                        if pending is not None:
                            self._show_results(pending, config)
                        self.status.content = "Run stopped."
                        if self.results:  # the slider spans what was run
                            self._span_slider(float(next(iter(self.results.values())).t_s[-1]))
                        if "vkf" in config.run.methods and not (self.results and "vkf" in self.results):
                            self.vkf_note.content = VKF_NOTES["stopped"]  # killed before its first progress
                        note = ("Run stopped", "The run ended before completion.", False)
                        break
                    if pending is not None and time.monotonic() - last_draw > GUI_REFRESH_S:
                        self._show_results(pending, config)
                        pending, last_draw = None, time.monotonic()
                    continue
                kind = msg[0]
                if kind == "config":  # a replayed log: its own length, rate, origin and start
                    config, self.run_source = from_dict(msg[1]), msg[2]
                    with self.lock:
                        self.config = config
                    self.time_slider.max = config.trajectory.duration_s
                    self.run_config.content = config_markdown(config, 1, self.run_source)
                elif kind == "truth":
                    self.truth_view = msg[1]
                    self._draw_truth()
                    self._draw_vehicle_plot()
                    self._draw_seabed_plot()
                elif kind == "progress":
                    latest: dict[str, MethodResult] = msg[2]
                    pending = latest
                    self.progress.value = 100.0 * msg[1] / config.trajectory.duration_s
                    if time.monotonic() - last_draw > GUI_REFRESH_S:
                        self._show_results(latest, config)
                        pending, last_draw = None, time.monotonic()
                elif kind == "done":
                    results, stopped = msg[1], msg[2]
                    self._show_results(results, config)
                    self._keep_finished(results, config, stopped)
                    t_end = float(next(iter(results.values())).t_s[-1])
                    if stopped:
                        self.status.content = f"Stopped at {t_end:.1f} s."
                        note = ("Run stopped", f"Stopped at t = {t_end:.1f} s.", False)
                    else:
                        self.progress.value = 100.0
                        what = f"log {self.run_log}" if self.run_log is not None else config.trajectory.name
                        self.status.content = f"Run complete: {what}, {t_end:g} s."
                        note = ("Run complete", summary_line(results), False)
                    finished = True
                elif kind == "error":
                    self.status.content = "Run failed."
                    note = ("Run failed", msg[1], True)
                    finished = True
        except Exception as exc:  # noqa: BLE001 - a display bug must not leave the tab stuck in "running"
            self.status.content = "Display error."
            note = ("Display error", f"{type(exc).__name__}: {exc}", True)
        finally:
            with self.lock:
                self.handle = None
            self.run_button.disabled, self.stop_button.disabled = False, True
        if note is not None:
            self.notify(*note)

    # ------------------------------------------------------------------ results
    def _show_results(self, results: dict[str, MethodResult], config: Config) -> None:
        self.results = results
        self.refresh_plots()
        self.table.content = summary_markdown(results) + "\n\n" + rms_markdown(results)
        self._draw_estimates(results)
        if "vkf" in results:  # the VKF's learned scale factor and bias, as far as the run got
            self._draw_vkf_plot(results["vkf"], config)
        self._follow_run_time(float(next(iter(results.values())).t_s[-1]))

    def _keep_finished(self, results: dict[str, MethodResult], config: Config, stopped: bool) -> None:
        """The run's final results arrived (``stopped``: Stop ended it): offer them for download,
        and let the time slider span what was run."""
        self._set_finished(export.finished_run(config, results, self.run_log, stopped, self.run_source))
        if results:
            self.keep_run(config, results)  # the Runs tab keeps it for comparison
        if results:
            self._span_slider(float(next(iter(results.values())).t_s[-1]))

    # ------------------------------------------------------------------ kept runs
    def keep_run(self, config: Config, results: dict[str, MethodResult]) -> None:
        """Keep a finished run in the Runs tab (its description, an Overlay checkbox, a Remove
        button); beyond KEPT_RUNS_MAX the oldest goes, as the tab's note says (no notification:
        the run's own closing notification is the one a user waits for)."""
        with self.draw_lock:
            self.run_number += 1
            kept = KeptRun(
                self.run_number, config, int(next(iter(results.values())).vel_err_mps.shape[1]), results
            )
            self.kept_runs.append(kept)
            dropped, self.kept_runs = self.kept_runs[:-KEPT_RUNS_MAX], self.kept_runs[-KEPT_RUNS_MAX:]
            overlaid = any(
                old.number in self.kept_widgets and self.kept_widgets[old.number][1].value for old in dropped
            )
            for old in dropped:
                if old.number in self.kept_widgets:
                    self.kept_widgets.pop(old.number)[0].remove()
            if overlaid:
                self.refresh_runs()
            self._schedule_diagnostics()  # its widgets come with the diagnostics, once the tab is still

    def _add_run_widgets(self) -> None:
        """The Runs tab's entries (description, Overlay checkbox, Remove button) of kept runs that
        have none yet (called under the draw lock, from the diagnostics' thread)."""
        gui = self.client.gui
        added = []
        for kept in self.kept_runs:
            if kept.number in self.kept_widgets:
                continue
            self.no_runs.visible = False
            with self.runs_folder:
                folder = gui.add_folder(f"Run {kept.number}")
                with folder:
                    gui.add_markdown(kept.description())
                    box = gui.add_checkbox(
                        f"Overlay run {kept.number}",
                        False,
                        hint="overlay this run in the Plots tab and compare it below",
                    )
                    button = gui.add_button(f"Remove run {kept.number}", color="red")
            self.kept_widgets[kept.number] = (folder, box)
            box.on_update(lambda _: self.refresh_runs())
            button.on_click(lambda _, n=kept.number: self.remove_run(n))
            added.append(kept)
        if added:
            self.refresh_runs(redraw=False)  # a new run is not ticked: the plots stay

    def remove_run(self, number: int) -> None:
        """Forget kept run ``number`` and its widgets."""
        with self.draw_lock:
            self.kept_runs = [r for r in self.kept_runs if r.number != number]
            widgets = self.kept_widgets.pop(number, None)
            if widgets is not None:
                widgets[0].remove()
            self.no_runs.visible = not self.kept_runs
            self.refresh_runs()

    def overlay_runs(self) -> list[KeptRun]:
        """The kept runs ticked for overlay, oldest first."""
        return [
            r
            for r in self.kept_runs
            if r.number in self.kept_widgets and self.kept_widgets[r.number][1].value
        ]

    @_drawing
    def refresh_runs(self, redraw: bool = True) -> None:
        """The Runs tab's comparison (configuration differences above the results side by side)
        and (``redraw``) the Plots tab's overlay, for the runs ticked."""
        overlay = self.overlay_runs()
        if len(overlay) >= 2:
            self.diff_table.content = config_diff_markdown(
                [r.label for r in overlay], [flat_config(r.config, r.runs) for r in overlay]
            )
            self.compare_table.content = "**Results side by side**\n\n" + compare_markdown(
                [(r.label, r.results) for r in overlay]
            )
        else:
            self.diff_table.content = "Tick two or more runs to compare them." if self.kept_runs else ""
            self.compare_table.content = ""
        if redraw:
            self.refresh_plots()

    def move_cursor(self, t_s: float) -> None:
        """Move the time cursor of every plot on the page to ``t_s`` [s]: a few hundred bytes of
        script (Plotly.relayout of the cursor shape) instead of every figure again; the figures
        the server sends next carry it too (:meth:`refresh_plots`)."""
        self.cursor_t = float(t_s)
        page_scripts.run(
            self.client, page_scripts.source("time_cursor.js", t=self.cursor_t, shape=cursor_shape(0.0))
        )

    def _set_finished(self, run: export.FinishedRun | None) -> None:
        """Keep ``run``, whose final results arrived, for the Download buttons and enable them
        (None: a new run started, they are disabled until it ends)."""
        self.finished_run = run
        for button in self.download_buttons.values():
            button.disabled = run is None

    def download(self, kind: str) -> None:
        """Send the finished run as ``kind`` (app.export.FORMATS) to this tab; a notification,
        never a traceback, when there is none or it cannot be made."""
        try:
            export.send(self.client, kind, self.finished_run)
        except export.ExportError as exc:
            self.notify("Cannot download", str(exc), error=True)
        except Exception as exc:  # noqa: BLE001 - a fault of ours: said in the tab, the server keeps serving
            self.notify(
                "Cannot download",
                f"{export.FORMATS.get(kind, kind)}: {type(exc).__name__}: {exc}",
                error=True,
            )

    @_drawing
    def refresh_plots(self, only: str | None = None) -> None:
        """Redraw the workbench's plots: the error norms of the current run (or of the kept runs
        ticked for overlay), their components, NEES and innovations, each with the time cursor;
        ``only`` one group of them ("errors", "nees", "innovations": what an option changes)."""
        if only is not None:
            self.last_action_s = time.monotonic()
        results = self.results
        if not results:
            return
        if only is None or only == "errors":
            self._draw_error_plots(results)
        if only is None or only == "nees":
            block, overlay = self.nees_block.value, self.overlay_runs()
            figure = (
                overlay_figure([(r.label, nees_figure(r.results, block)) for r in overlay])
                if len(overlay) >= 2
                else nees_figure(results, block)
            )
            self.nees_plot.figure = with_cursor(figure, self.cursor_t)
        if only == "innovations":
            self._draw_innovations(results)
        if only is None:
            self._schedule_diagnostics()

    def _schedule_diagnostics(self) -> None:
        """Draw the innovations, components and ELC plots soon, one figure at a time in a thread of
        their own (called under the draw lock). They are half of a full redraw; drawn inline they
        held the draw lock, so this tab's slider and Run waited behind them (8 tabs: p95 300 ms
        in tests/server/test_load.py). They wait until the tab has been still for QUIET_S (the
        slider, a control, an option), so what the user does now is answered first. New results
        while they are drawn start them again."""
        self.diagnostics_due = True
        if getattr(self, "diagnostics_thread", None) is None:
            self.diagnostics_thread = threading.Thread(target=self._diagnostics_loop, daemon=True)
            self.diagnostics_thread.start()

    def _diagnostics_loop(self) -> None:
        while True:
            time.sleep(DIAGNOSTICS_DELAY_S)  # what the user acted on goes out first
            if time.monotonic() - getattr(self, "last_action_s", 0.0) < QUIET_S:
                continue  # still busy in this tab: wait
            with self.draw_lock:
                if not self.diagnostics_due:
                    self.diagnostics_thread = None
                    return
                self.diagnostics_due = False
                results = self.results
            for step in (
                self._draw_innovations,
                self._draw_components_and_elc,
                lambda _: self._add_run_widgets(),
            ):
                with self.draw_lock:
                    if self.diagnostics_due or not results:
                        break  # newer results: draw those instead
                    try:
                        step(results)
                    except Exception as exc:  # noqa: BLE001 - a display bug must not kill the thread silently
                        self.notify("Display error", f"{type(exc).__name__}: {exc}", error=True)
                time.sleep(0.0)

    def _draw_error_plots(self, results: dict[str, MethodResult]) -> None:
        t = self.cursor_t
        log_y = AUTO if self.log_y.value else False
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
                    else error_figure(results, q, show_sigma=self.show_sigma.value, log_y=log_y)
                )
                handle.figure = with_cursor(figure, t)

    def _draw_components_and_elc(self, results: dict[str, MethodResult]) -> None:
        t = self.cursor_t
        tv = self.truth_view
        if tv is not None:
            components = {
                m: error_components(r, tv["t_s"], tv["pos_n"], tv["C_nb"])
                for m, r in results.items()
                if len(r.t_s)
            }
            for q, handle in self.component_plots.items():
                handle.figure = with_cursor(components_figure(results, components, q), t)
        if "elc" in results:
            self.elc_plot.figure = with_cursor(elc_choice_figure(results["elc"]), t)
            self.elc_plot.visible = True
        else:
            self.elc_plot.visible = False

    def _draw_innovations(self, results: dict[str, MethodResult]) -> None:
        t = self.cursor_t
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
            panels = sum(1 for key in figure.layout.to_plotly_json() if key.startswith("yaxis"))
            # viser sizes a plot by height / width: each panel keeps its height as panels are added
            aspect = INNOVATION_PANEL_ASPECT * max(panels, 1) + 0.1
            if self.innovation_plot.aspect != aspect:
                self.innovation_plot.aspect = aspect
            self.innovation_plot.figure = with_cursor(figure, t)
            without = [m.upper() for m, r in results.items() if source not in r.updates]
            self.innovation_note.content = INNOVATION_NOTE + (
                f" No {source.upper()} updates: {', '.join(without)}." if without else ""
            )

    # ------------------------------------------------------------------ scene
    def _build_scene(self) -> None:
        scene = self.client.scene
        scene.set_up_direction("+z")
        scene.configure_environment_map(hdri=None)
        # without an environment map only viser's default lights shine, from ahead: the chase view
        # from behind showed the hull and its fins as a black silhouette
        scene.add_light_hemisphere(
            "/light/sky", sky_color=(255, 255, 255), ground_color=(150, 130, 100), intensity=1.5
        )
        d = Config()
        start_n = np.array([0.0, 0.0, d.trajectory.depth_m])
        (verts, faces), fins = auv_parts_body()
        self.auv = scene.add_mesh_simple(
            "/auv",
            verts,
            faces,
            color=(250, 200, 40),
            flat_shading=False,
            position=tuple(ned_to_view(start_n)),
            wxyz=tuple(wxyz_view(np.eye(3))),
        )
        # children of the hull's node: placed in the body frame, each turned about its hinge (show_time)
        self.fins = [
            scene.add_mesh_simple(
                f"/auv/fin{k + 1}",
                fin.verts_hinge,
                fin.faces,
                color=_hex_rgb(color),
                flat_shading=True,
                side="double",
                position=tuple(fin.hinge_b),
            )
            for k, (fin, color) in enumerate(zip(fins, FIN_COLORS))
        ]
        self.beam_nodes: list[list[Any]] | None = None  # [beam][state] under /auv (show_beams_static)
        self.beam_shown: list[str] = []
        self.terrain: Any = None  # the seabed's mesh when it is not flat (_draw_seabed)
        self.furniture: list[Any] = []  # seabed grid, surface, compass and scale (_size_scene)
        self.frame: MissionFrame | None = None
        self.truth_line = None
        self.est_lines: dict[str, Any] = {}
        self.slider_pinned = False  # the user put the time slider somewhere during the run: it stays
        self.run_time_s = 0.0  # the latest time the running run has results for [s]
        self.slider_set_s: float | None = None  # where the run last put the slider [s]
        self.slider_follow_sent = False  # the run moved the slider since the user last did
        # before a run: the default straight line's first 300 m, at the default seabed
        self._size_scene(
            mission_frame(np.array([start_n, start_n + [300.0, 0.0, 0.0]]), d.trajectory.seabed_depth_m)
        )
        self._beams_from_boxes()
        for k, p in enumerate(beam_label_positions_b(d.dvl.l_dvl_b, d.dvl.A_b), start=1):
            scene.add_label(
                f"/auv/beams/{k}/label",
                str(k),
                position=tuple(p),
                font_screen_scale=0.8,
                anchor="center-center",
            )

    @_drawing
    def _size_scene(self, frame: MissionFrame) -> None:
        """Seabed grid, sea surface, compass rose and scale bar sized to the mission ``frame``
        (app.scene.mission_frame); re-added once per run."""
        for handle in self.furniture:
            handle.remove()
        scene, self.frame = self.client.scene, frame
        (w, h), c = frame.seabed_size_m, frame.seabed_center_view
        self.seabed = scene.add_grid(
            "/seabed",
            width=w,
            height=h,
            plane="xy",
            cell_size=frame.cell_m,
            section_size=5 * frame.cell_m,
            cell_color=(150, 120, 80),
            section_color=(120, 90, 60),
            plane_color=SEABED_COLOR,
            plane_opacity=0.5,
            position=tuple(c),
            visible=self.terrain is None,
        )
        corners = np.array([[-w, -h, 0.0], [w, -h, 0.0], [w, h, 0.0], [-w, h, 0.0]]) / 2 + [c[0], c[1], 0.0]
        surface = scene.add_mesh_simple(
            "/surface",
            corners,
            np.array([[0, 1, 2], [0, 2, 3]]),
            color=(90, 170, 230),
            opacity=0.15,
            side="double",
        )
        s = frame.scale_m
        corner = np.array([frame.lo_view[0] - 0.3 * s, frame.lo_view[1] - 0.3 * s, 0.0])
        arrows, label_at = compass_view(corner, s)
        compass = scene.add_arrows(
            "/compass/arrows",
            arrows,
            (40, 40, 40),
            shaft_radius=0.015 * s,
            head_radius=0.05 * s,
            head_length=0.12 * s,
        )
        labels = [
            scene.add_label(f"/compass/{name}", name, position=tuple(p), anchor="center-center")
            for name, p in zip("NE", label_at)
        ]
        bar = scale_bar_view(corner - [0.0, 0.3 * s, 0.0], s)
        scale = scene.add_line_segments(
            "/scale/bar", bar, (40, 40, 40), thickness=3.0, thickness_units="screen"
        )
        scale_label = scene.add_label(
            "/scale/label",
            f"{s:g} m",
            position=tuple(bar[0].mean(axis=0) - [0, 0.08 * s, 0]),
            anchor="top-center",
        )
        self.furniture = [self.seabed, surface, compass, *labels, scale, scale_label]

    def _set_camera(self, position: np.ndarray, look_at: np.ndarray) -> None:
        """Position first, then look_at (viser moves look_at with the position otherwise)."""
        try:
            with self.client.atomic():
                self.client.camera.position = tuple(position)
                self.client.camera.look_at = tuple(look_at)
        except AssertionError:  # the browser has not reported its camera yet; initial_camera applies
            pass

    def fit_mission(self) -> None:
        """Frame the whole mission (the track down to the seabed) and leave the camera free."""
        if self.camera_mode.value != CAMERA_FREE:
            self.camera_mode.value = CAMERA_FREE
        if self.frame is None:
            return
        try:
            fov_v, aspect = float(self.client.camera.fov), float(self.client.camera.aspect)
        except (AssertionError, ZeroDivisionError):  # the browser has not reported its camera yet
            fov_v, aspect = np.radians(50.0), 1.0
        self._set_camera(*fit_camera_view(self.frame.lo_view, self.frame.hi_view, fov_v, aspect))

    def _camera_changed(self) -> None:
        """A chase view moves the camera to the vehicle at once (free: the camera stays)."""
        if self.camera_mode.value != CAMERA_FREE:
            self.show_time(float(self.time_slider.value))

    @_drawing
    def show_beams_static(
        self,
        config: Config,
        pos_n: np.ndarray,
        C_nb: np.ndarray,
        states: list[str] | None = None,
        range_m: np.ndarray | None = None,
    ) -> None:
        """Draw the four beams from the DVL head to the seabed, coloured by state (None: each
        enabled beam of ``config`` returning where the seabed is in range).

        ``range_m`` (4,): each beam's slant range (the truth view's, inf beyond the DVL's range:
        drawn at that range); None: traced here from ``pos_n``, ``C_nb`` to the configured
        mission's seabed (before a run, a replayed log). The beams are children of the hull's node
        in the body frame (app.scene.beam_segments_b), so hull and beams move in one message.
        Each beam has one node per state, made once and then updated in place: its points change
        and one node is shown (assigning ``colors`` to a line-segments node hid it in viser 1.1,
        and re-adding every beam at every time step blanked the beams in frames between the
        removal and the new node, and drew them from another time than the hull).
        """
        dvl = config.dvl
        if range_m is None:
            range_m = seabed_ranges_m(
                pos_n, C_nb, dvl.l_dvl_b, dvl.A_b, bathymetry(config.trajectory), dvl.max_range_m
            )
        if states is None:
            states = beam_states(dvl.beam_mask, dvl.beam_mask & np.isfinite(range_m), np.zeros(4, bool))
        full = beam_segments_b(dvl.l_dvl_b, dvl.A_b, range_m, dvl.max_range_m)
        segs = {s: beam_stub(full) if s == BEAM_SWITCHED_OFF else full for s in BEAM_THICKNESS_PX}
        order = (BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED)
        nodes = getattr(self, "beam_nodes", None)
        if nodes is None:  # the first drawing makes the nodes, each as it is to be shown
            self.beam_nodes = [
                [
                    self.client.scene.add_line_segments(
                        f"/auv/beams/{k + 1}/{j}",
                        segs[s][k : k + 1],
                        BEAM_COLORS[s],
                        thickness=BEAM_THICKNESS_PX[s],
                        thickness_units="screen",
                        visible=s == states[k],
                    )
                    for j, s in enumerate(order)
                ]
                for k in range(4)
            ]
            self.beam_shown = list(states)
            return
        for k, state in enumerate(states):
            node = nodes[k][order.index(state)]
            node.points = segs[state][k : k + 1]
            if state != self.beam_shown[k]:
                node.visible = True
                nodes[k][order.index(self.beam_shown[k])].visible = False
                self.beam_shown[k] = state

    def _beams_from_boxes(self) -> None:
        """Before a run's truth arrives the beams stand at the mission's start as the DVL beam
        boxes say: a box unticked, its beam is drawn switched off at once. A run's beams show
        what that run did."""
        if self.truth_view is not None:
            return
        config = self.config or Config()
        enabled = np.array([box.value for box in self.beam_boxes])
        pos_n, dvl = np.array([0.0, 0.0, config.trajectory.depth_m]), config.dvl
        range_m = seabed_ranges_m(
            pos_n, np.eye(3), dvl.l_dvl_b, dvl.A_b, bathymetry(config.trajectory), dvl.max_range_m
        )
        states = beam_states(enabled, enabled & np.isfinite(range_m), np.zeros(4, bool))
        self.show_beams_static(config, pos_n, np.eye(3), states, range_m)

    @_drawing
    def _clear_trajectories(self) -> None:
        for handle in self.est_lines.values():
            handle.remove()
        self.est_lines = {}
        if self.truth_line is not None:
            self.truth_line.remove()
            self.truth_line = None

    @_drawing
    def _draw_truth(self) -> None:
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        pts = ned_to_view(tv["pos_n"][decimate(len(tv["t_s"]), TRAJECTORY_POINTS)])
        self.truth_line = self.client.scene.add_line_segments(
            "/traj/truth",
            np.stack([pts[:-1], pts[1:]], axis=1),
            _hex_rgb(TRUTH_COLOR),
            thickness=3.0,
            thickness_units="screen",
        )
        self._draw_seabed(config, tv["pos_n"])
        self._size_scene(mission_frame(tv["pos_n"], config.trajectory.seabed_depth_m))
        if self.camera_mode.value == CAMERA_FREE:
            self.fit_mission()
        self.show_time(min(float(self.time_slider.value), float(tv["t_s"][-1])))

    @_drawing
    def _draw_seabed(self, config: Config, pos_n: np.ndarray) -> None:
        """A flat seabed is the grid (:meth:`_size_scene`: under the track with a margin); any other
        (terrain, the longrange trenches) a mesh of the mission's bathymetry under the track
        (app.scene.seabed_mesh_n), the grid hidden. A replayed log records no seabed: the grid at
        the configured depth."""
        if self.terrain is not None:
            self.terrain.remove()
            self.terrain = None
        seabed = bathymetry(config.trajectory)
        if seabed.is_plane or self.replaying:
            return
        verts_n, faces = seabed_mesh_n(seabed, pos_n)
        self.terrain = self.client.scene.add_mesh_simple(
            "/terrain", ned_to_view(verts_n), faces, color=SEABED_COLOR, flat_shading=False, side="double"
        )

    @_drawing
    def _draw_seabed_plot(self) -> None:
        """The Seabed tab: the altitude above the seabed of a simulated mission, otherwise a note."""
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        altitude_m = tv.get("altitude_m")
        if altitude_m is None:
            self.seabed_plot.visible = False
            self.seabed_note.content = SEABED_NOTES["log" if self.replaying else "none"]
            return
        self.seabed_plot.figure = altitude_figure(
            tv["t_s"], altitude_m, config.dvl.max_altitude_m, config.vkf.switch_altitude_m
        )
        self.seabed_plot.visible = True
        self.seabed_note.content = SEABED_NOTES["simulation"]

    @_drawing
    def _draw_vkf_plot(self, result: MethodResult | None, config: Config) -> None:
        """The Seabed tab's VKF figure: what the velocity Kalman filter learned (``result``, the
        ``vkf`` method's), or a note: the run has no VKF, or its results are still to come."""
        trace = result.vkf_trace if result is not None else None
        if trace is not None and len(trace["t_s"]):
            self.vkf_plot.figure = vkf_figure(trace)
            self.vkf_plot.visible = True
            self.vkf_note.content = VKF_NOTES["shown"]
            return
        self.vkf_plot.visible = False
        self.vkf_note.content = VKF_NOTES["running" if "vkf" in config.run.methods else "none"]

    @_drawing
    def _draw_vehicle_plot(self) -> None:
        """The Vehicle tab: fins and propeller of a dynamic truth, otherwise a note saying why none."""
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        fin_angles_rad, propeller_rpm = tv.get("fin_angles_rad"), tv.get("propeller_rpm")
        if fin_angles_rad is not None and propeller_rpm is not None:
            self.vehicle_plot.figure = actuator_figure(tv["t_s"], fin_angles_rad, propeller_rpm)
            self.vehicle_plot.visible = True
            self.vehicle_note.content = VEHICLE_NOTES["dynamic"]
            return
        self.vehicle_plot.visible = False
        self.vehicle_note.content = VEHICLE_NOTES["log" if self.replaying else config.trajectory.truth]

    @_drawing
    def _draw_estimates(self, results: dict[str, MethodResult]) -> None:
        for method, res in results.items():
            est = res.est_pos_n[decimate(len(res.t_s), TRAJECTORY_POINTS), 0]
            if len(est) < 2:
                continue
            pts = ned_to_view(est)
            segs = np.stack([pts[:-1], pts[1:]], axis=1)
            if method in self.est_lines:
                self.est_lines[method].points = segs
            else:
                self.est_lines[method] = self.client.scene.add_line_segments(
                    f"/traj/{method}",
                    segs,
                    _hex_rgb(method_color(method)),
                    thickness=2.0,
                    thickness_units="screen",
                )

    @_drawing
    def show_time(self, t_s: float) -> None:
        """Place the vehicle and colour the beams at time ``t_s`` of the current run.

        The pose is interpolated between the truth's samples (app.scene.interpolate_pose: playback
        is smooth at any speed); ranges, fins and beam states are the sample's at or before
        ``t_s``. Camera, hull, fins and beams change in one atomic batch: the page never draws a
        frame with some of them moved.
        """
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        t_s = float(np.clip(t_s, tv["t_s"][0], tv["t_s"][-1]))
        i, pos_n, C_nb = interpolate_pose(t_s, tv["t_s"], tv["pos_n"], tv["C_nb"])
        ranges = tv.get("slant_range_m")
        range_m = ranges[i] if ranges is not None else None
        states = self.beam_states_at(t_s, range_m)
        fin_angles = tv.get("fin_angles_rad")
        deflection = (
            fin_angles[i] if fin_angles is not None else np.zeros(len(self.fins))
        )  # kinematic: no fins move
        with self.client.atomic():
            if self.camera_mode.value != CAMERA_FREE:
                self._set_camera(
                    *chase_camera_view(ned_to_view(pos_n), C_nb, self.camera_mode.value, FOLLOW_DISTANCE_M)
                )
            self.auv.position = tuple(ned_to_view(pos_n))
            self.auv.wxyz = tuple(wxyz_view(C_nb))
            for fin, wxyz in zip(self.fins, fin_wxyz_body(deflection)):
                fin.wxyz = tuple(wxyz)
            self.show_beams_static(config, pos_n, C_nb, states, range_m)
        altitude = tv.get("altitude_m")
        in_range = np.isfinite(range_m) if range_m is not None else np.ones(4, dtype=bool)
        text = beam_readout(t_s, states, in_range, float(altitude[i]) if altitude is not None else None)
        if text != self.readout.content:
            self.readout.content = text

    def _slider_moved(self, event: viser.GuiEvent) -> None:
        """The time slider moved: show that time. Moved by the user's hand during a run, it stays
        there as results arrive (unless put at the latest time, where it follows the run again)."""
        t_s = float(self.time_slider.value)
        if event.client is not None:
            self.last_action_s = time.monotonic()
        if event.client is not None and self.handle is not None:
            self.slider_pinned, self.slider_set_s = t_s < self.run_time_s - 0.5, t_s
            if self.slider_follow_sent:
                self.slider_follow_sent = False
                self._echo_slider(event.client, t_s)
        self.show_time(t_s)

    def _echo_slider(self, client: viser.ClientHandle, t_s: float) -> None:
        """Send the page its own slider value back. viser echoes a value to every tab but the one
        that moved it; a value the run set (:meth:`_follow_run_time`) and sent before this tab's
        move reached the server arrives after the move and snapped the page's slider back to the
        run's latest time, while the server held the user's. Once the move is in, the run stops
        moving the slider, so one echo after it puts the page right."""
        message = viser_messages.GuiUpdateMessage(self.time_slider._impl.uuid, {"value": float(t_s)})
        client._websock_connection.queue_message(message)

    def _go_to_refused(self, text: str, message: str) -> None:
        """Refuse ``text`` of the "Go to [s]" field in a notification, if the field still holds
        it (a value typed key by key is refused once, when the typing stops)."""
        if self.go_to.value == text:
            self.notify("Go to: not moved", show(message), error=True)

    def _go_to(self, event: viser.GuiEvent) -> None:
        """The "Go to [s]" field changed (typed, or written by a click on a plot: app.plot_click):
        move the playback there, kept within what was run. During a run the slider then stays
        there, as if put there by hand."""
        if event.client is None:
            return
        self.last_action_s = time.monotonic()
        text = self.go_to.value
        try:
            t_s = plot_click.parse_go_to_s(text, float(self.time_slider.max))
        except ValueError as exc:  # said once the typing stops there, not at every key
            threading.Timer(GO_TO_REFUSAL_DELAY_S, self._go_to_refused, (text, str(exc))).start()
            return
        if t_s is None:
            return
        if self.handle is not None:
            self.slider_pinned, self.slider_set_s = t_s < self.run_time_s - 0.5, t_s
        self.time_slider.value = t_s

    def _follow_run_time(self, t_last_s: float) -> None:
        """A run's results reach ``t_last_s``: the slider moves there, unless the user put it
        elsewhere during this run or playback drives it. A slider that no longer stands where the
        run put it was moved by the user: viser runs the slider's callback in a thread pool, which
        may come after this (and read the value this would set), so the value itself decides."""
        self.run_time_s = t_last_s
        if self.playing or self.slider_pinned:
            return
        if self.slider_set_s is not None and self.time_slider.value != self.slider_set_s:
            self.slider_pinned = True
            return
        self.slider_set_s = min(t_last_s, self.time_slider.max)
        self.time_slider.value = self.slider_set_s
        self.slider_follow_sent = True

    def _span_slider(self, t_end_s: float) -> None:
        """The run ended at ``t_end_s`` (Stop, or its end): the slider spans what was run, not the
        requested duration; a value beyond it comes back to the end."""
        t_end_s = max(float(t_end_s), float(self.time_slider.step))
        # written only when out of range: min() would write back a value a tab has just moved
        if self.time_slider.value > t_end_s:  # noqa: PLR1730
            self.time_slider.value = t_end_s
        self.time_slider.max = t_end_s

    def beam_states_at(self, t_s: float, range_m: np.ndarray | None = None) -> list[str]:
        """Each beam's state at ``t_s``: the schedule's (or, once results arrive, the run's record
        of) returned beams, lost also where ``range_m`` (4,) says the seabed is beyond range (inf),
        rejected by the gate of the first of REJECT_REFERENCE that ran."""
        tv, config = self.truth_view, self.config
        assert tv is not None and config is not None
        enabled = config.dvl.beam_mask
        in_range = np.isfinite(range_m) if range_m is not None else np.ones(4, dtype=bool)
        pings = tv["ping_t_s"]
        if len(pings) == 0 or t_s < pings[0]:
            return beam_states(enabled, enabled & in_range, np.zeros(4, bool))
        p = int(np.searchsorted(pings, t_s, side="right") - 1)
        returned = tv["ping_available"][p]  # the schedule's; a run's own record also has random drop-outs
        rejected = np.zeros(4, dtype=bool)
        results = self.results or {}
        for record in (r.updates.get("dvl") for r in results.values()):
            if record is not None and p < len(record.t_s) and record.beams_available is not None:
                returned = record.beams_available[p, 0]
                break
        returned = returned & in_range
        for method in REJECT_REFERENCE:
            dvl = results[method].updates.get("dvl") if method in results else None
            if dvl is not None and p < len(dvl.t_s):
                if method == "tc":
                    rejected = dvl.rejected_rows[p, 0] & returned
                elif dvl.rejected[p, 0]:
                    rejected = returned.copy()
                break
        return beam_states(enabled, returned, rejected)

    def play(self) -> None:
        """Play the run from the slider's time (from the start if at the end) at the Speed chosen."""
        if self.truth_view is None or self.playing:
            return
        self.playing = True
        threading.Thread(target=self._play_loop, daemon=True).start()

    def _play_loop(self) -> None:
        """Move the slider at a steady PLAYBACK_FPS, to the time the wall clock and the speed give
        (app.scene.playback_time; the speed may change while playing). The slider's callback moves
        the vehicle in place (show_time). Formerly 2 s of mission every 50 ms of sleep plus drawing:
        about 35x, at the pace of each frame's cost."""
        try:
            t_end = float(self.time_slider.max)
            t0 = float(self.time_slider.value)
            if t0 >= t_end - 0.1:
                t0 = 0.0
            speed = playback_speed(self.speed.value)
            start = time.monotonic()
            frame = 0
            while self.playing:
                now = time.monotonic()
                if playback_speed(self.speed.value) != speed:  # carry on from here at the new speed
                    t0, start = playback_time(t0, speed, now - start, t_end), now
                    speed, frame = playback_speed(self.speed.value), 0
                t = playback_time(t0, speed, now - start, t_end)
                self.time_slider.value = t
                if t >= t_end:
                    break
                frame += 1
                time.sleep(max(0.0, start + frame / PLAYBACK_FPS - time.monotonic()))
        finally:
            self.playing = False

    def close(self) -> None:
        self.playing = False
        self.stop_run()


def summary_line(results: dict[str, MethodResult]) -> str:
    """One line for the completion notification: final velocity error per method."""
    parts = [f"{method.upper()} {float(rms(res.vel_err_mps[-1])):.3g} m/s" for method, res in results.items()]
    return "Final velocity error: " + ", ".join(parts)


def build_server(
    host: str = "127.0.0.1", port: int = 8080, workers: int | None = None, logs: dict[str, str] | None = None
) -> tuple[viser.ViserServer, worker.RunPool]:
    """Start the viser server with one :class:`Session` per connected tab and ``workers`` run
    processes (default :func:`app.worker.default_workers`); ``logs`` (name -> directory) are
    offered as sources to replay."""
    check_listen(host, port)
    harden_client_messages()
    pool = worker.RunPool(workers)
    try:
        server = viser.ViserServer(host=host, port=port, label="tauv", verbose=False)
    except BaseException:
        pool.shutdown()
        raise
    disable_share_tunnel(server)
    start = ned_to_view(np.array([0.0, 0.0, Config().trajectory.depth_m]))
    server.initial_camera.position = tuple(start + np.array([-0.6, -0.8, 0.6]) * FOLLOW_DISTANCE_M)
    server.initial_camera.look_at = tuple(start)
    server.gui.configure_theme(
        control_layout="fixed",
        control_width="large",
        show_share_button=False,
        show_logo=False,
        brand_color=(31, 119, 180),
    )
    sessions: dict[int, Session] = {}
    departed: set[int] = set()  # tabs that left while their Session was still being built
    lock = threading.Lock()

    @server.on_client_connect
    def _(client: viser.ClientHandle) -> None:
        session = Session(client, pool, logs)  # takes a while: the tab may close meanwhile
        with lock:
            gone = client.client_id in departed
            departed.discard(client.client_id)
            if not gone:
                sessions[client.client_id] = session
        if gone:  # its disconnect came first: without this the Session (~MBs) lived forever
            session.close()
            RECLAIM.soon()

    @server.on_client_disconnect
    def _(client: viser.ClientHandle) -> None:
        with lock:
            session = sessions.pop(client.client_id, None)
            if session is None:
                departed.add(client.client_id)
        if session is not None:
            session.close()
        RECLAIM.soon()

    return server, pool


def main(
    host: str = "127.0.0.1", port: int = 8080, workers: int | None = None, logs: dict[str, str] | None = None
) -> None:
    """Serve the dashboard until SIGTERM or SIGINT (Ctrl-C); every child process ends with it."""
    request = install_shutdown_handlers()
    bound_malloc_arenas()
    server, pool = build_server(host, port, workers, logs)
    request.serving = True
    shown = "localhost" if host in ("127.0.0.1", "0.0.0.0") else host
    print(f"tauv dashboard: http://{shown}:{server.get_port()}", flush=True)
    try:
        while request.signum is None:
            time.sleep(0.1)
        print(f"tauv dashboard: {signal.Signals(request.signum).name} received, stopping", flush=True)
    finally:
        shutdown(server, pool)


__all__ = ["Session", "build_server", "main"]
