"""The tauv dashboard: a viser server in which a navigation engineer flies a mission, switches
DVL beams off, picks fusion methods (and sets the partial-beam methods' assumptions) and watches
the navigation errors live, and whether each method knows its error (NEES against its 99 % band).

    tauv serve [--host 127.0.0.1] [--port 8080] [--workers N]

Every browser tab is a :class:`Session` with its own controls, scene, run and results; a run
goes in its own process (app.dashboard.worker) so the server and the other tabs stay responsive. A Session
is built of rooms, each in a module of its own around the tab's shared state
(app.dashboard.session_state.TabState): the control panel (app.dashboard.session_controls), the 3-D scene
(app.dashboard.session_scene), the playback (app.dashboard.session_playback), the plot tabs (app.dashboard.session_plots) and
the results and kept runs (app.dashboard.session_runs); the Session builds them, wires what one asks of
another, and runs the tab's run.
viser's share tunnel (an external relay service) cannot be started: its button is off and its
message handlers are removed (app.dashboard.hardening.disable_share_tunnel); nothing is fetched from the internet.
"""

from __future__ import annotations

import queue as queue_mod
import signal
import threading
import time
from typing import Any

import numpy as np
import viser

from app.dashboard import export, inputs, page_scripts, plot_click, worker
from app.dashboard.control_table import DEFAULT_METHODS
from app.dashboard.hardening import (
    RECLAIM,
    bound_malloc_arenas,
    check_listen,
    disable_share_tunnel,
    display_error,
    harden_client_messages,
    install_shutdown_handlers,
    shutdown,
)
from app.dashboard.inputs import Controls, InputError, config_markdown
from app.dashboard.session_controls import ControlPanel, replay_settings_note
from app.dashboard.session_playback import Playback
from app.dashboard.session_plots import VKF_NOTES, PlotTabs
from app.dashboard.session_runs import RunTabs
from app.dashboard.session_scene import FOLLOW_DISTANCE_M, SceneView
from app.dashboard.session_series import SeriesTab
from app.dashboard.session_state import TabState, clear_notices, notify
from app.dashboard.session_vehicle import VehiclePanel, applied
from app.dashboard.split_run import SplitRun, splits
from app.figures.scene import (
    BEAM_COLOR_NAMES,
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    BEAM_WATER,
    ned_to_view,
)
from app.figures.shared import TRUTH_COLOR, method_color
from app.reports.markdown_tables import rms_markdown, smoothed_markdown, summary_markdown
from tauvcore.config import Config, from_dict, to_dict
from tauvcore.engine.results import MethodResult
from tauvcore.eval.metrics import rms
from tauvcore.validation import ConfigError

LEGEND_WIDTH_PX, LEGEND_HEIGHT_PX = 420, 118  # the floating legend over the 3-D view (up to six methods)
LEGEND_LINE_PX = 21  # one more line of the legend (every further six methods)
WORKBENCH_WIDTH_PX = 500  # the plot panel docked left of the 3-D view (the user can resize or minimise it)
GUI_REFRESH_S = 1.5  # at most this often the plots are redrawn during a run (wall time)
CHECKING_STATUS = "Checking the controls the page shows..."
CAMERA_ADDRESS_S = 1.0  # the page's address follows the camera at most this often (wall time)


class Session:
    """One browser tab: its rooms (controls, 3-D scene, playback, plots, results and kept runs)
    and its background run."""

    def __init__(
        self, client: viser.ClientHandle, pool: worker.RunPool, logs: dict[str, str] | None = None
    ) -> None:
        self.client = client
        self.pool = pool
        self.state = TabState(client)
        self.draw_lock = self.state.draw_lock
        self.lock = threading.Lock()
        self.handle: worker.RunHandle | SplitRun | None = None
        self.run_log: str | None = None  # the log the current run replays (its name), None: a simulation
        self.run_note = (
            ""  # what the status adds of a replay's settings (session_controls.replay_settings_note)
        )
        self.run_source: dict[str, Any] | None = (
            None  # that log as app.dashboard.worker.replay_source describes it
        )
        gui = client.gui
        # the colours' legend floats over the 3-D view's bottom-left corner, in its own small panel:
        # in view whatever the control panel or the workbench scrolls to (the user may move it)
        self.legend_panel = gui.add_panel()
        with self.legend_panel.add_tab("Legend"):
            self.legend = gui.add_html(self._legend_html(DEFAULT_METHODS))
        self.legend_panel.float(x=12, y=-12, width=LEGEND_WIDTH_PX, height=LEGEND_HEIGHT_PX)
        tabs = gui.add_tab_group()
        with tabs.add_tab("Mission"):
            self.panel = ControlPanel(self.state, dict(logs or {}), self.notify)
            self.vehicle = (
                VehiclePanel(gui, self.start_vehicle, self.apply_vehicle)
                if self.panel.source is not None
                else None
            )
            self.playback = Playback(
                self.state,
                show_time=lambda t_s: self.scene.show_time(t_s),
                running=lambda: self.handle is not None,
                notify=self.notify,
            )
        # the workbench: plots, diagnostics, results and kept runs in a panel of their
        # own docked left of the 3-D view, several plots in view at once (viser: height = aspect x width)
        self.workbench = gui.add_panel()
        self.workbench.dock_left()
        self.workbench.set_width(WORKBENCH_WIDTH_PX)
        self.plot_tabs = PlotTabs(
            self.state,
            self.workbench,
            tabs,
            overlay_runs=lambda: self.run_tabs.overlay_runs(),
            add_run_widgets=lambda: self.run_tabs.add_run_widgets(),
            notify=self.notify,
        )
        self.series_tab = SeriesTab(
            self.state, self.workbench, notify=self.notify, picks_changed=self._picks_changed
        )
        self.run_tabs = RunTabs(
            self.state,
            self.workbench,
            refresh_plots=self.plot_tabs.refresh_plots,
            schedule_diagnostics=self.plot_tabs.schedule_diagnostics,
            notify=self.notify,
        )
        playback = self.playback
        self.scene = SceneView(
            self.state, self.panel.beam_boxes, playback.time_slider, playback.camera_mode, playback.readout
        )
        self.camera_timer: threading.Timer | None = None
        self.camera_lock = threading.Lock()  # not the run's lock: a Run waiting for the page holds that
        self._wire(playback)

    def _wire(self, playback: Playback) -> None:
        """What the rooms' controls and the page start: Run and Stop, the slider's map cursor, the
        camera, the page's scripts (one time axis, plot clicks, labels) and the link's view."""
        # what the run writes as it goes
        self.status, self.progress = self.panel.status, self.panel.progress
        self.run_button, self.stop_button = self.panel.run_button, self.panel.stop_button
        self.run_button.on_click(lambda _: self.start_run())
        self.stop_button.on_click(lambda _: self.stop_run())
        playback.time_slider.on_update(lambda _: self.plot_tabs.map.move_cursor(playback.time_slider.value))
        # the Events box: PlotTabs redraws its plots and the map (its own callback), the scene its
        # track here (viser runs the two callbacks on its threads, in no set order: each reads the box)
        self.plot_tabs.show_events.on_update(lambda _: self._events_box())
        playback.camera_mode.on_update(lambda _: self.scene.camera_changed())
        playback.fit_button.on_click(lambda _: self.scene.fit_mission())
        for box in self.panel.beam_boxes:  # before a run the 3-D beams show the boxes at once
            box.on_update(lambda _: self.scene.beams_from_boxes())
        # one time axis for the page's plots (cursor, zoom), kept across tabs (app/assets/view_sync.js)
        page_scripts.run(self.client, page_scripts.view_sync())
        # the view in the page's address (app.dashboard.links.VIEW_KEYS): a link's shown, the camera kept
        self.panel.apply_view = self.apply_view
        self.client.camera.on_update(lambda _: self._camera_moved())
        plot_click.install(self.client)  # a click on any plot moves the playback (app.dashboard.plot_click)
        page_scripts.run(self.client, page_scripts.label_inputs())  # each input named by its label
        threading.Thread(target=self.panel.read_link, daemon=True).start()

    def _events_box(self) -> None:
        self.state.events_shown = bool(self.plot_tabs.show_events.value)
        self.scene.draw_events()

    @staticmethod
    def _legend_height_px(methods: tuple[str, ...]) -> int:
        """The legend's height for ``methods``: a line more for every six methods beyond the first six
        (with eight methods the last line was cut off)."""
        return LEGEND_HEIGHT_PX + LEGEND_LINE_PX * max(0, -(-(len(methods) - 6) // 6))

    @staticmethod
    def _legend_html(methods: tuple[str, ...]) -> str:
        items = [f'<span style="color:{TRUTH_COLOR}">&#9632;</span> truth']
        items += [f'<span style="color:{method_color(m)}">&#9632;</span> {m.upper()}' for m in methods]
        beams = [
            f'<span style="color:rgb{BEAM_COLORS[s]}">&#9646;</span> {s} ({BEAM_COLOR_NAMES[s]})'
            for s in (BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_WATER)
        ]
        return (
            '<div id="tauv-legend" style="font-size:0.8em;line-height:1.6">Trajectories: '
            + " &nbsp; ".join(items)
            + "<br>Beams (numbered 1-4 in the view): "
            + " &nbsp; ".join(beams)
            + "</div>"
        )

    def notify(self, title: str, body: str, error: bool = False) -> None:
        notify(self.client, title, body, error, self.state.notices)

    # ------------------------------------------------------------------ the rooms' main calls
    def controls(self) -> Controls:
        """What the controls hold (app.dashboard.session_controls.ControlPanel.controls)."""
        return self.panel.controls()

    def set_controls(self, c: Controls) -> None:
        """Set every control to what ``c`` holds."""
        self.panel.set_controls(c)

    def refresh_plots(self, only: str | None = None) -> None:
        """Redraw the plot tabs (app.dashboard.session_plots.PlotTabs.refresh_plots)."""
        self.plot_tabs.refresh_plots(only)

    def show_time(self, t_s: float) -> None:
        """Draw the vehicle and its beams at time ``t_s`` [s] of the current run."""
        self.scene.show_time(t_s)

    def play(self) -> None:
        """Play the run from the slider's time at the Speed chosen."""
        self.playback.play()

    def apply_view(self, view: dict[str, Any]) -> None:
        """Show the view a link carries (app.dashboard.links.parse_view's values by key): every time
        plot's zoomed range, the slider's time, the camera."""
        if "x" in view:
            page_scripts.run(self.client, page_scripts.set_range(view["x"]))
        if "t" in view:
            self.playback.restore_time(view["t"])
        if "cam" in view:
            self.scene.restore_camera(*view["cam"])
        self.series_tab.apply_picks(view)

    def _picks_changed(self, picks: dict[str, Any]) -> None:
        """The Series tab's picks changed: the page's address keeps them."""
        self.panel.view.update(picks)
        self.panel.update_address(action=False)

    def _camera_moved(self) -> None:
        """The page's camera moved: its address follows, at most once every CAMERA_ADDRESS_S."""
        with self.camera_lock:
            if self.camera_timer is not None:
                return
            self.camera_timer = threading.Timer(CAMERA_ADDRESS_S, self._write_camera)
            self.camera_timer.daemon = True
            self.camera_timer.start()

    def _write_camera(self) -> None:
        with self.camera_lock:
            self.camera_timer = None
        try:
            camera = self.client.camera
            position, look_at = tuple(map(float, camera.position)), tuple(map(float, camera.look_at))
        except AssertionError:  # not reported yet
            return
        self.panel.view["cam"] = (position, look_at)
        self.panel.update_address(action=False)

    # ------------------------------------------------------------------ runs
    def start_run(self) -> None:
        panel = self.panel
        with self.lock:
            if self.handle is not None:
                self.notify("Already running", "Press Stop first, or wait for the run to finish.", error=True)
                return
            # shown at once (a GUI-only message); the page's answer waits for one 3-D frame of it
            previous, self.status.content = self.status.content, CHECKING_STATUS
            try:
                panel.confirm_page_state()
                config, runs = panel.read_config()
                smooth_mb = panel.smoother_budget_mb()
            except (InputError, ConfigError) as exc:
                self.status.content = previous
                self.notify("Cannot run", str(exc), error=True)
                return
            except RuntimeError:  # the tab closed while it was asked for its controls
                return
            source = panel.source.value if panel.source is not None else inputs.SIMULATION
            log_dir = panel.logs.get(source)
            state = self.state
            state.config, state.results, state.truth_view, state.sensor_view = config, None, None, None
            state.replaying = log_dir is not None
            self.run_log = source if log_dir is not None else None
            self.run_source = None  # the worker describes a replayed log with its configuration
            self.handle = handle = (
                SplitRun(self.pool, to_dict(config), runs, smooth_mb=smooth_mb)
                if splits(config, runs, log_dir, self.pool)
                else self.pool.start(to_dict(config), runs, log_dir=log_dir, smooth_mb=smooth_mb)
            )
        self.run_button.disabled, self.stop_button.disabled = True, False
        self.run_tabs.set_finished(None)
        self.progress.value = 0.0
        what = (
            f"log {source}"
            if log_dir is not None
            else f"{config.trajectory.name}, {config.trajectory.duration_s:g} s, {runs} run(s)"
        )
        # a replay names what the controls carry into it beyond the log (outages, sensors...)
        self.run_note = replay_settings_note(config, source) if log_dir is not None else ""
        self.status.content = (
            f"Running {what}: {', '.join(m.upper() for m in config.run.methods)}{self.run_note}"
        )
        self.run_tabs.run_config.content = config_markdown(config, runs)
        self.legend.content = self._legend_html(config.run.methods)
        self.legend_panel.float(
            x=12, y=-12, width=LEGEND_WIDTH_PX, height=self._legend_height_px(config.run.methods)
        )
        self.playback.new_run(config.trajectory.duration_s)
        self.scene.clear_trajectories()
        self.plot_tabs.draw_vkf_plot(None, config)
        self.plot_tabs.run_started()
        threading.Thread(target=self._pump, args=(handle, config), daemon=True).start()

    def start_vehicle(self, kind: str) -> None:
        """Calibrate or Tune (``kind``, app.dashboard.vehicle_tasks) on the log the Source names, under the
        configuration the controls make of it, on a worker: the progress bar, the status and Stop
        as a run's; the report in the "Your vehicle" folder when it ends."""
        panel, vehicle = self.panel, self.vehicle
        assert vehicle is not None
        with self.lock:
            if self.handle is not None:
                self.notify("Already running", "Press Stop first, or wait for the run to finish.", error=True)
                return
            source = panel.source.value if panel.source is not None else inputs.SIMULATION
            log_dir = panel.logs.get(source)
            what = "Calibrate" if kind == "calibrate" else "Tune"
            if log_dir is None:
                self.notify(
                    f"Cannot {what.lower()}",
                    f"{inputs.SOURCE} is {source}: choose a log to {what.lower()} on.",
                    error=True,
                )
                return
            previous, self.status.content = self.status.content, CHECKING_STATUS
            try:
                panel.confirm_page_state()
                config, _ = panel.read_config()
            except (InputError, ConfigError) as exc:
                self.status.content = previous
                self.notify(f"Cannot {what.lower()}", str(exc), error=True)
                return
            except RuntimeError:  # the tab closed while it was asked for its controls
                return
            self.handle = handle = self.pool.start_vehicle(kind, to_dict(config), log_dir)
        self.run_button.disabled, self.stop_button.disabled = True, False
        vehicle.busy(True)
        self.progress.value = 0.0
        self.status.content = f"{what}: log {source}"
        threading.Thread(target=self._pump_vehicle, args=(handle, source), daemon=True).start()

    def _pump_vehicle(self, handle: worker.RunHandle, source: str) -> None:
        """Read a calibration's or tuning's messages (app.dashboard.vehicle_tasks) and show them."""
        vehicle = self.vehicle
        assert vehicle is not None
        note: tuple[str, str, bool] | None = None
        try:
            while True:
                try:
                    msg = handle.queue.get(timeout=0.1)
                except queue_mod.Empty:
                    if handle.finished() and handle.queue.empty():
                        self.status.content = "Stopped."
                        note = ("Stopped", "The task ended before it found anything.", False)
                        break
                    continue
                if msg[0] == "vehicle-progress":
                    self.progress.value = 100.0 * float(msg[1])
                    self.status.content = str(msg[2])
                elif msg[0] == "vehicle-done":
                    _, kind, report, sections, stopped = msg
                    vehicle.show(kind, source, report, sections, stopped)
                    self.progress.value = 100.0
                    what = "Calibration" if kind == "calibrate" else "Tuning"
                    self.status.content = f"{what} of {source} {'stopped' if stopped else 'complete'}."
                    note = (
                        f"{what} of {source}",
                        "Its report is in the Your vehicle folder; Apply uses it at the next Run.",
                        False,
                    )
                    break
                elif msg[0] == "error":
                    self.status.content = "Failed."
                    note = ("Calibrate or Tune failed", msg[1], True)
                    break
        except Exception as exc:  # noqa: BLE001 - a display bug must not leave the tab stuck in "running"
            self.status.content = "Display error."
            note = display_error(exc)
        finally:
            with self.lock:
                self.handle = None
            self.run_button.disabled, self.stop_button.disabled = False, True
            vehicle.busy(False)
        if note is not None:
            self.notify(*note)

    def apply_vehicle(self) -> None:
        """Lay what Calibrate or Tune found over its log's own configuration for the next Run:
        the controls it names filled in, the rest (the calibration) applied at Run."""
        vehicle = self.vehicle
        if vehicle is None or vehicle.found is None:
            return
        source, sections = vehicle.found
        panel = self.panel
        panel.vehicle_sections[source] = applied(panel.vehicle_sections.get(source, {}), sections)
        if panel.source is not None and panel.source.value != source:
            panel.source.value = source
        try:
            filled, hidden = panel.fill_fields(sections)
        except ConfigError as exc:
            self.notify("Not applied", str(exc), error=True)
            return
        parts = ([f"{', '.join(filled)} filled in"] if filled else []) + (
            [f"{', '.join(hidden)} apply at Run"] if hidden else []
        )
        self.notify(f"Applied to log {source}", "; ".join(parts) + ".")
        panel.update_address()

    def stop_run(self) -> None:
        with self.lock:
            handle = self.handle
        if handle is not None:
            handle.stop()

    def _pump(self, handle: worker.RunHandle | SplitRun, config: Config) -> None:
        """Read the worker's messages and update this tab (runs in a thread of this session).

        While every worker is busy the run waits in line, and the status says its place; a
        worker that dies ends the run with an "error" message (app.dashboard.worker), shown as a
        notification like any failed run. The run's closing notification is sent only after the
        tab is ready for the next run (Run enabled, no run held): a Run pressed as soon as "Run
        complete" shows must start, not meet "Already running".

        Live results are drawn at most every GUI_REFRESH_S, and not when the run's final results
        are due sooner than that (:func:`seconds_left`): a short Monte Carlo draws its first
        results and its last, not a third set the page would render while the final one arrives.
        """
        pump = _RunPump(self, config)
        try:
            while not pump.finished:
                try:
                    msg = handle.queue.get(timeout=0.1)
                except queue_mod.Empty:
                    pump.idle(handle)
                    continue
                pump.show(msg)
        except Exception as exc:  # noqa: BLE001 - a display bug must not leave the tab stuck in "running"
            self.status.content = "Display error."
            pump.note = display_error(exc)
        finally:
            with self.lock:
                self.handle = None
            self.run_button.disabled, self.stop_button.disabled = False, True
        if pump.note is not None:
            self.notify(*pump.note)

    def _show_results(self, results: dict[str, MethodResult], config: Config, live: bool = False) -> None:
        """Draw ``results``: a run's final ones, or (``live``) those so far, whose diagnostics
        (app.dashboard.session_plots.PlotTabs.refresh_plots) are drawn less often. The slider (and
        so every plot's cursor in the page) moves first: the figures sent next are drawn at its time."""
        self.state.results = results
        self.playback.follow_run_time(float(next(iter(results.values())).t_s[-1]))
        self.plot_tabs.refresh_plots(live=live)
        smoothed = smoothed_markdown(results)
        self.run_tabs.table.content = (
            summary_markdown(results)
            + "\n\n"
            + rms_markdown(results)
            + (f"\n\n{smoothed}" if smoothed else "")
        )
        self.scene.draw_estimates(results)
        if "vkf" in results:  # the VKF's learned scale factor and bias, as far as the run got
            self.plot_tabs.draw_vkf_plot(results["vkf"], config)
        if not live:  # any series picked: drawn from the run's final results
            self.series_tab.refresh()

    def _keep_finished(self, results: dict[str, MethodResult], config: Config, stopped: bool) -> None:
        """The run's final results arrived (``stopped``: Stop ended it): offer them for download,
        and let the time slider span what was run."""
        self.run_tabs.set_finished(
            export.finished_run(config, results, self.run_log, stopped, self.run_source)
        )
        if results:
            self.run_tabs.keep_run(config, results, self.run_log)  # the Runs tab keeps it for comparison
        if results:
            self.playback.span_slider(float(next(iter(results.values())).t_s[-1]))

    def close(self) -> None:
        self.playback.playing = False
        self.stop_run()


class _RunPump:
    """What :meth:`Session._pump` keeps of a run between the worker's messages, and how it shows
    each of them in the tab (``session``)."""

    def __init__(self, session: Session, config: Config) -> None:
        self.session = session
        self.config = config  # the run's (a replayed log's as the log made it, once it comes)
        self.draw_after = 0.0  # time.monotonic() before which live results are held
        self.computing_since: float | None = None  # when the worker began (its truth arrived)
        self.pending: dict[str, MethodResult] | None = None  # live results held, not drawn yet
        self.running_status = session.status.content
        self.place = 0  # the run's place in line for a free worker (0: computing)
        self.note: tuple[str, str, bool] | None = None  # the closing notification
        self.finished = False

    def idle(self, handle: worker.RunHandle | SplitRun) -> None:
        """No message came: the status names the run's place in line, a run whose worker ended
        without a last message is stopped, and live results held are drawn once due."""
        s, config = self.session, self.config
        now_place = handle.position()
        if now_place != self.place:
            self.place = now_place
            s.status.content = (
                self.running_status
                if self.place == 0
                else f"Waiting for a free worker: {self.place - 1} run(s) ahead "
                f"({s.pool.workers} compute at once)."
            )
        if handle.finished() and handle.queue.empty():
            if self.pending is not None:
                s._show_results(self.pending, config)
            s.status.content = "Run stopped."
            shown = s.state.results
            if shown:  # the slider spans what was run
                s.playback.span_slider(float(next(iter(shown.values())).t_s[-1]))
            if "vkf" in config.run.methods and not (shown and "vkf" in shown):
                s.plot_tabs.vkf_note.content = VKF_NOTES["stopped"]  # killed before its first progress
            self.note = ("Run stopped", "The run ended before completion.", False)
            self.finished = True
            return
        if self.pending is not None and time.monotonic() >= self.draw_after:
            s._show_results(self.pending, config, live=True)
            self.pending, self.draw_after = None, time.monotonic() + GUI_REFRESH_S

    def show(self, msg: tuple[Any, ...]) -> None:
        """Show one of the worker's messages (app.dashboard.worker) in the tab."""
        s, kind = self.session, msg[0]
        if kind == "config":  # a replayed log: its own length, rate, origin and start
            self.config, s.run_source = from_dict(msg[1]), msg[2]
            with s.lock:
                s.state.config = self.config
            s.playback.time_slider.max = self.config.trajectory.duration_s
            s.panel.show_log_facts(self.config)
            s.run_tabs.run_config.content = config_markdown(self.config, 1, s.run_source)
        elif kind == "truth":
            self.computing_since = time.monotonic()
            s.state.truth_view = msg[1]
            s.scene.draw_truth()
            s.plot_tabs.draw_vehicle_plot()
            s.plot_tabs.draw_seabed_plot()
        elif kind == "sensors":  # drawn with the next results
            s.state.sensor_view = msg[1]
        elif kind == "progress":
            self._progress(msg[1], msg[2])
        elif kind == "smoothing":
            s.status.content = "Smoothing: the fixed-interval smoother over the run so far."
        elif kind == "done":
            self._done(msg[1], msg[2])
        elif kind == "error":
            s.status.content = "Run failed."
            self.note = ("Run failed", msg[1], True)
            self.finished = True

    def _progress(self, t_s: float, latest: dict[str, MethodResult]) -> None:
        """The results so far, at ``t_s`` of the mission: drawn at most every GUI_REFRESH_S, and
        not when the final results are due sooner (:func:`seconds_left`)."""
        duration_s = self.config.trajectory.duration_s
        self.pending = latest
        self.session.progress.value = 100.0 * t_s / duration_s
        now = time.monotonic()
        left_s = seconds_left(
            t_s, duration_s, now - (now if self.computing_since is None else self.computing_since)
        )
        if now >= self.draw_after and left_s < GUI_REFRESH_S:
            self.draw_after = now + left_s + GUI_REFRESH_S  # the final results should come first
        elif now >= self.draw_after:
            self.session._show_results(latest, self.config, live=True)
            self.pending, self.draw_after = None, time.monotonic() + GUI_REFRESH_S

    def _done(self, results: dict[str, MethodResult], stopped: bool) -> None:
        """The run's final results (or, after Stop, those so far): drawn and kept."""
        s, config = self.session, self.config
        s._show_results(results, config)
        s._keep_finished(results, config, stopped)
        t_end = float(next(iter(results.values())).t_s[-1])
        if stopped:
            s.status.content = f"Stopped at {t_end:.1f} s."
            self.note = ("Run stopped", f"Stopped at t = {t_end:.1f} s.", False)
        else:
            s.progress.value = 100.0
            what = f"log {s.run_log}" if s.run_log is not None else config.trajectory.name
            s.status.content = f"Run complete: {what}, {t_end:g} s{s.run_note}."
            self.note = ("Run complete", summary_line(results), False)
            clear_notices(s.state.notices)  # what a red notice refused or reported is behind us
        self.finished = True


def seconds_left(t_s: float, duration_s: float, elapsed_s: float) -> float:
    """Wall time [s] a run needs to finish at the pace it kept: ``elapsed_s`` of wall time for the
    first ``t_s`` of its ``duration_s`` [s] of mission (inf before any progress)."""
    if t_s <= 0.0 or elapsed_s <= 0.0:
        return float("inf")
    return elapsed_s * max(duration_s - t_s, 0.0) / t_s


def summary_line(results: dict[str, MethodResult]) -> str:
    """One line for the completion notification: final velocity error per method."""
    parts = [f"{method.upper()} {float(rms(res.vel_err_mps[-1])):.3g} m/s" for method, res in results.items()]
    return "Final velocity error: " + ", ".join(parts)


def build_server(
    host: str = "127.0.0.1", port: int = 8080, workers: int | None = None, logs: dict[str, str] | None = None
) -> tuple[viser.ViserServer, worker.RunPool]:
    """Start the viser server with one :class:`Session` per connected tab and ``workers`` run
    processes (default :func:`app.dashboard.worker.default_workers`); ``logs`` (name -> directory) are
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
    server.gui.main_panel.dock_right()  # the control panel docked at the right edge, beside the 3-D view
    server.gui.configure_theme(
        control_width="medium",
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
