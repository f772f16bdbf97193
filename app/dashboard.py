"""The tauv dashboard: a viser server in which a navigation engineer flies a mission, switches
DVL beams off, picks fusion methods and watches the navigation errors live.

    tauv serve [--host 127.0.0.1] [--port 8080]

Every browser tab is a :class:`Session` with its own controls, scene, run and results; a run
goes in its own process (app.worker) so the server and the other tabs stay responsive.
viser's share button (an external relay service) is off; nothing is fetched from the internet.
"""

from __future__ import annotations

import queue as queue_mod
import socket
import threading
import time
from typing import Any

import numpy as np
import plotly.graph_objects as go
import viser

from app import worker
from app.figures import (
    METHOD_COLORS,
    TRUTH_COLOR,
    decimate,
    elc_choice_figure,
    error_figure,
    summary_markdown,
)
from app.scene import (
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    M_VIEW_FROM_NED,
    auv_mesh_view_body,
    beam_segments_n,
    beam_states,
    ned_to_view,
    wxyz_view,
)
from tauvcore.config import METHODS, Config, to_dict
from tauvcore.eval.metrics import rms
from tauvcore.eval.runner import MethodResult
from tauvcore.sensors.dvl import Outage
from tauvcore.truth import TRAJECTORIES
from tauvcore.validation import ConfigError

DEFAULT_METHODS = ("ins", "lc", "tc", "nsv", "elc")
GUI_REFRESH_S = 1.5          # at most this often the plots are redrawn during a run (wall time)
FOLLOW_DISTANCE_M = 22.0     # chase-camera distance: the 3 m hull and its beams fill the view
TRAJECTORY_POINTS = 600      # points per drawn trajectory (a 250 s run has 2501 epochs)
REJECT_REFERENCE = ("tc", "elc", "nsv", "vb", "vhv", "plcf", "lc")  # whose gate decides the red beams
DVL_METHODS = tuple(m for m in METHODS if m != "ins")


def _hex_rgb(color: str) -> tuple[int, int, int]:
    return tuple(int(color[i:i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


class InputError(Exception):
    """A control holds a value the run cannot use; the message names it and the value."""


class Session:
    """One browser tab: its controls, 3-D scene, background run and results."""

    def __init__(self, client: viser.ClientHandle, pool: worker.RunPool) -> None:
        self.client = client
        self.pool = pool
        self.lock = threading.Lock()
        self.handle: worker.RunHandle | None = None
        self.config: Config | None = None
        self.truth_view: dict[str, np.ndarray] | None = None
        self.results: dict[str, MethodResult] | None = None
        self.playing = False
        self._build_gui()
        self._build_scene()

    # ------------------------------------------------------------------ GUI
    def _build_gui(self) -> None:
        gui = self.client.gui
        d = Config()
        tabs = gui.add_tab_group()
        with tabs.add_tab("Mission"):
            self.trajectory = gui.add_dropdown("Trajectory", TRAJECTORIES, initial_value=d.trajectory.name)
            self.duration = gui.add_number("Duration [s]", d.trajectory.duration_s, step=1.0)
            with gui.add_folder("Methods"):
                self.method_boxes = {m: gui.add_checkbox(m.upper(), m in DEFAULT_METHODS) for m in METHODS}
            with gui.add_folder("DVL beams"):
                self.beam_boxes = [gui.add_checkbox(f"Beam {k}", True) for k in range(1, 5)]
                self.dropout = gui.add_number("Dropout probability", d.dvl.dropout_probability, step=0.01,
                                              hint="chance that each beam misses each ping")
            with gui.add_folder("Outages [s] (start = end: none)", expand_by_default=False):
                self.outage = [(gui.add_number(f"Beam {k} outage start", 0.0, step=1.0),
                                gui.add_number(f"Beam {k} outage end", 0.0, step=1.0)) for k in range(1, 5)]
            with gui.add_folder("Aiding", expand_by_default=False):
                self.aid_depth = gui.add_checkbox("Depth (pressure)", False)
                self.aid_mag = gui.add_checkbox("Magnetometer", False)
            with gui.add_folder("Sensors (Table 2)", expand_by_default=False):
                self.accel_bias = gui.add_number("Accel bias [mg]", d.imu.accel_bias_mg, step=0.1)
                self.gyro_bias = gui.add_number("Gyro bias [deg/h]", d.imu.gyro_bias_deg_per_h, step=0.5)
                self.accel_noise = gui.add_number("Accel noise [m/s/sqrt(h)]", d.imu.accel_noise_mps_per_sqrt_h,
                                                  step=0.001)
                self.gyro_noise = gui.add_number("Gyro noise [deg/sqrt(h)]", d.imu.gyro_noise_deg_per_sqrt_h, step=0.01)
                self.dvl_noise = gui.add_number("DVL noise [m/s]", d.dvl.noise_mps, step=0.001)
                self.dvl_bias = gui.add_number("DVL bias [m/s]", d.dvl.bias_mps, step=0.001)
                self.dvl_sf = gui.add_number("DVL scale factor [%]", d.dvl.scale_factor_pct, step=0.1)
            self.seed = gui.add_number("Seed", d.run.seed, step=1)
            self.runs = gui.add_number("Runs", 1, step=1, hint="Monte Carlo runs; > 1 plots RMS curves")
            self.run_button = gui.add_button("Run", color="green")
            self.stop_button = gui.add_button("Stop", color="red", disabled=True)
            self.progress = gui.add_progress_bar(0.0, animated=False)
            self.status = gui.add_markdown("Ready. Choose a mission and press **Run**.")
            with gui.add_folder("Playback"):
                self.time_slider = gui.add_slider("Time [s]", 0.0, d.trajectory.duration_s, 0.1, 0.0)
                self.follow = gui.add_checkbox("Follow vehicle", True, hint="keep the camera on the AUV")
                self.play_button = gui.add_button("Play")
                self.pause_button = gui.add_button("Pause")
            self.legend = gui.add_html(self._legend_html(DEFAULT_METHODS))
        with tabs.add_tab("Plots"):
            self.show_sigma = gui.add_checkbox("Show 1-sigma", False)
            self.log_y = gui.add_checkbox("Log scale", True)
            self.plots = {q: gui.add_plotly(go.Figure(), aspect=1.4) for q in ("vel", "att", "pos")}
            self.elc_plot = gui.add_plotly(go.Figure(), aspect=2.2, visible=False)
        with tabs.add_tab("Results"):
            self.table = gui.add_markdown("No run yet.")

        self.run_button.on_click(lambda _: self.start_run())
        self.stop_button.on_click(lambda _: self.stop_run())
        self.show_sigma.on_update(lambda _: self.refresh_plots())
        self.log_y.on_update(lambda _: self.refresh_plots())
        self.time_slider.on_update(lambda _: self.show_time(self.time_slider.value))
        self.play_button.on_click(lambda _: self.play())
        self.pause_button.on_click(lambda _: setattr(self, "playing", False))

    @staticmethod
    def _legend_html(methods: tuple[str, ...]) -> str:
        items = [f'<span style="color:{TRUTH_COLOR}">&#9632;</span> truth']
        items += [f'<span style="color:{METHOD_COLORS[m]}">&#9632;</span> {m.upper()}' for m in methods]
        beams = [f'<span style="color:rgb{BEAM_COLORS[s]}">&#9646;</span> {s}'
                 for s in (BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED)]
        return ('<div style="font-size:0.8em;line-height:1.6">Trajectories: ' + " &nbsp; ".join(items)
                + "<br>Beams: " + " &nbsp; ".join(beams) + "</div>")

    def notify(self, title: str, body: str, error: bool = False) -> None:
        self.client.add_notification(title, body, auto_close_seconds=None if error else 6.0,
                                     color="red" if error else "green")

    # ------------------------------------------------------------------ inputs
    def selected_methods(self) -> tuple[str, ...]:
        return tuple(m for m in METHODS if self.method_boxes[m].value)

    def read_config(self) -> tuple[Config, int]:
        """The configuration the controls describe; InputError/ConfigError name the bad field."""
        methods = self.selected_methods()
        if not methods:
            raise InputError("Methods: select at least one method")
        runs = self.runs.value
        if not float(runs).is_integer() or runs < 1:
            raise InputError(f"Runs must be a whole number >= 1, got {runs!r}")
        seed = self.seed.value
        if not float(seed).is_integer() or seed < 0:
            raise InputError(f"Seed must be a whole number >= 0, got {seed!r}")
        beams = tuple(k for k in range(1, 5) if self.beam_boxes[k - 1].value)
        dvl_methods = [m for m in methods if m in DVL_METHODS]
        if dvl_methods and not beams:
            raise InputError("DVL beams: all four are off, so no DVL method can aid; switch a beam on or select INS only")
        if dvl_methods == ["lc"] and len(beams) < 3:
            raise InputError(f"LC needs three or more beams, but only {len(beams)} "
                             f"({', '.join(map(str, beams)) or 'none'}) are on; add TC or an ELC method")
        outages = []
        for k, (start, end) in enumerate(self.outage, start=1):
            if start.value == end.value == 0.0:
                continue
            if end.value <= start.value:
                raise InputError(f"Beam {k} outage ends ({end.value:g} s) before it starts ({start.value:g} s)")
            outages.append(Outage(beams=(k,), start_s=float(start.value), end_s=float(end.value)))
        aiding = ("dvl",) + (("depth",) if self.aid_depth.value else ()) + (("mag",) if self.aid_mag.value else ())
        config = (Config()
                  .replace("trajectory", name=self.trajectory.value, duration_s=float(self.duration.value))
                  .replace("imu", accel_bias_mg=float(self.accel_bias.value), gyro_bias_deg_per_h=float(self.gyro_bias.value),
                           accel_noise_mps_per_sqrt_h=float(self.accel_noise.value),
                           gyro_noise_deg_per_sqrt_h=float(self.gyro_noise.value))
                  .replace("dvl", noise_mps=float(self.dvl_noise.value), bias_mps=float(self.dvl_bias.value),
                           scale_factor_pct=float(self.dvl_sf.value), beams=beams,
                           dropout_probability=float(self.dropout.value))
                  .replace("run", methods=methods, aiding=aiding, seed=int(seed)))
        config = config.replace("dvl", outages=tuple(outages))
        return config, int(runs)

    # ------------------------------------------------------------------ runs
    def start_run(self) -> None:
        with self.lock:
            if self.handle is not None:
                self.notify("Already running", "Press Stop first, or wait for the run to finish.", error=True)
                return
            try:
                config, runs = self.read_config()
            except (InputError, ConfigError) as exc:
                self.notify("Cannot run", str(exc), error=True)
                return
            self.config, self.results, self.truth_view = config, None, None
            self.handle = handle = self.pool.start(to_dict(config), runs)
        self.run_button.disabled, self.stop_button.disabled = True, False
        self.progress.value = 0.0
        self.status.content = f"Running {config.trajectory.name}, {config.trajectory.duration_s:g} s, " \
                              f"{runs} run(s): {', '.join(m.upper() for m in config.run.methods)}"
        self.legend.content = self._legend_html(config.run.methods)
        self.time_slider.max = config.trajectory.duration_s
        self._clear_trajectories()
        threading.Thread(target=self._pump, args=(handle, config), daemon=True).start()

    def stop_run(self) -> None:
        with self.lock:
            handle = self.handle
        if handle is not None:
            handle.stop()

    def _pump(self, handle: worker.RunHandle, config: Config) -> None:
        """Read the worker's messages and update this tab (runs in a thread of this session)."""
        last_draw = 0.0
        pending: dict[str, MethodResult] | None = None
        finished = False
        try:
            while not finished:
                try:
                    msg = handle.queue.get(timeout=0.1)
                except queue_mod.Empty:
                    if handle.finished() and handle.queue.empty():
                        if pending is not None:
                            self._show_results(pending, config)
                        self.status.content = "Run stopped."
                        self.notify("Run stopped", "The run ended before completion.")
                        break
                    if pending is not None and time.monotonic() - last_draw > GUI_REFRESH_S:
                        self._show_results(pending, config)
                        pending, last_draw = None, time.monotonic()
                    continue
                kind = msg[0]
                if kind == "truth":
                    self.truth_view = msg[1]
                    self._draw_truth()
                elif kind == "progress":
                    pending = msg[2]
                    self.progress.value = 100.0 * msg[1] / config.trajectory.duration_s
                    if time.monotonic() - last_draw > GUI_REFRESH_S:
                        self._show_results(pending, config)
                        pending, last_draw = None, time.monotonic()
                elif kind == "done":
                    results, stopped = msg[1], msg[2]
                    self._show_results(results, config)
                    t_end = float(next(iter(results.values())).t_s[-1])
                    if stopped:
                        self.status.content = f"Stopped at {t_end:.1f} s."
                        self.notify("Run stopped", f"Stopped at t = {t_end:.1f} s.")
                    else:
                        self.progress.value = 100.0
                        self.status.content = f"Run complete: {config.trajectory.name}, {t_end:g} s."
                        self.notify("Run complete", summary_line(results))
                    finished = True
                elif kind == "error":
                    self.status.content = "Run failed."
                    self.notify("Run failed", msg[1], error=True)
                    finished = True
        except Exception as exc:  # a display bug must not leave the tab stuck in "running"
            self.status.content = "Display error."
            self.notify("Display error", f"{type(exc).__name__}: {exc}", error=True)
        finally:
            with self.lock:
                self.handle = None
            self.run_button.disabled, self.stop_button.disabled = False, True

    # ------------------------------------------------------------------ results
    def _show_results(self, results: dict[str, MethodResult], config: Config) -> None:
        self.results = results
        self.refresh_plots()
        self.table.content = summary_markdown(results)
        self._draw_estimates(results)
        t_last = float(next(iter(results.values())).t_s[-1])
        if not self.playing:
            self.time_slider.value = min(t_last, self.time_slider.max)

    def refresh_plots(self) -> None:
        results = self.results
        if not results:
            return
        for q, handle in self.plots.items():
            handle.figure = error_figure(results, q, show_sigma=self.show_sigma.value, log_y=self.log_y.value)
        if "elc" in results:
            self.elc_plot.figure = elc_choice_figure(results["elc"])
            self.elc_plot.visible = True
        else:
            self.elc_plot.visible = False

    # ------------------------------------------------------------------ scene
    def _build_scene(self) -> None:
        scene = self.client.scene
        scene.set_up_direction("+z")
        scene.configure_environment_map(hdri=None)
        d = Config()
        self.seabed = scene.add_grid("/seabed", width=600.0, height=600.0, plane="xy", cell_size=10.0,
                                     section_size=50.0, cell_color=(150, 120, 80), section_color=(120, 90, 60),
                                     plane_color=(194, 170, 120), plane_opacity=0.5,
                                     position=(0.0, 150.0, -d.trajectory.seabed_depth_m))
        surface_v = np.array([[-300, -150, 0], [300, -150, 0], [300, 450, 0], [-300, 450, 0]], dtype=float)
        scene.add_mesh_simple("/surface", surface_v, np.array([[0, 1, 2], [0, 2, 3]]), color=(90, 170, 230),
                              opacity=0.15, side="double")
        verts, faces = auv_mesh_view_body()
        self.auv = scene.add_mesh_simple("/auv", verts, faces, color=(250, 200, 40), flat_shading=False,
                                         position=tuple(ned_to_view(np.array([0.0, 0.0, d.trajectory.depth_m]))))
        self.beams: list[Any] = []
        self.truth_line = None
        self.est_lines: dict[str, Any] = {}
        self.show_beams_static(d, np.array([0.0, 0.0, d.trajectory.depth_m]), np.eye(3))

    def _aim_camera(self, center_n: np.ndarray, distance_m: float) -> None:
        center = ned_to_view(center_n)
        self._set_camera(center + np.array([-0.6, -0.8, 0.6]) * distance_m, center)

    def _set_camera(self, position: np.ndarray, look_at: np.ndarray) -> None:
        """Position first, then look_at (viser moves look_at with the position otherwise)."""
        try:
            with self.client.atomic():
                self.client.camera.position = tuple(position)
                self.client.camera.look_at = tuple(look_at)
        except AssertionError:  # the browser has not reported its camera yet; initial_camera applies
            pass

    def show_beams_static(self, config: Config, pos_n: np.ndarray, C_nb: np.ndarray,
                          states: list[str] | None = None) -> None:
        """Draw the four beams from the DVL head to the seabed, coloured by state.

        Each beam is re-added under its name rather than recoloured: assigning ``colors`` to an
        existing line-segments node hides it in viser 1.1 (seen in headless Chromium).
        """
        segs = ned_to_view(beam_segments_n(pos_n, C_nb, config.dvl.l_dvl_b, config.dvl.A_b,
                                           config.trajectory.seabed_depth_m))
        states = states or [BEAM_RETURNING] * 4
        self.beams = [self.client.scene.add_line_segments(
            f"/beams/{k + 1}", segs[k:k + 1], BEAM_COLORS[state], thickness=2.5, thickness_units="screen")
            for k, state in enumerate(states)]

    def _clear_trajectories(self) -> None:
        for handle in self.est_lines.values():
            handle.remove()
        self.est_lines = {}
        if self.truth_line is not None:
            self.truth_line.remove()
            self.truth_line = None

    def _draw_truth(self) -> None:
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        pts = ned_to_view(tv["pos_n"][decimate(len(tv["t_s"]), TRAJECTORY_POINTS)])
        self.truth_line = self.client.scene.add_line_segments(
            "/traj/truth", np.stack([pts[:-1], pts[1:]], axis=1), _hex_rgb(TRUTH_COLOR), thickness=3.0,
            thickness_units="screen")
        lo, hi = tv["pos_n"].min(axis=0), tv["pos_n"].max(axis=0)
        center = 0.5 * (lo + hi)
        self.seabed.position = (float(ned_to_view(center)[0]), float(ned_to_view(center)[1]),
                                -config.trajectory.seabed_depth_m)
        if self.follow.value:
            self._aim_camera(tv["pos_n"][0], 25.0)
        else:
            self._aim_camera(center, max(60.0, 0.8 * float(np.max(hi[:2] - lo[:2]))))
        self.show_time(0.0)

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
                    f"/traj/{method}", segs, _hex_rgb(METHOD_COLORS[method]), thickness=2.0,
                    thickness_units="screen")

    def show_time(self, t_s: float) -> None:
        """Place the vehicle and colour the beams at time ``t_s`` of the current run."""
        tv, config = self.truth_view, self.config
        if tv is None or config is None:
            return
        i = int(np.clip(np.searchsorted(tv["t_s"], t_s), 0, len(tv["t_s"]) - 1))
        pos_n, C_nb = tv["pos_n"][i], tv["C_nb"][i]
        if self.follow.value:
            # chase view: behind and above the vehicle's track; untick "Follow vehicle" to orbit freely
            target = ned_to_view(pos_n)
            heading_view = M_VIEW_FROM_NED @ C_nb[:, 0]
            back = -heading_view / max(np.linalg.norm(heading_view[:2]), 1e-6)
            offset = FOLLOW_DISTANCE_M * (0.7 * np.array([back[0], back[1], 0.0]) + np.array([0.0, 0.0, 0.7]))
            self._set_camera(target + offset, target)
        self.auv.position = tuple(ned_to_view(pos_n))
        self.auv.wxyz = tuple(wxyz_view(C_nb))
        self.show_beams_static(config, pos_n, C_nb, self.beam_states_at(t_s))

    def beam_states_at(self, t_s: float) -> list[str]:
        tv, config = self.truth_view, self.config
        assert tv is not None and config is not None
        enabled = config.dvl.beam_mask
        pings = tv["ping_t_s"]
        if len(pings) == 0 or t_s < pings[0]:
            return beam_states(enabled, enabled, np.zeros(4, bool))
        p = int(np.searchsorted(pings, t_s, side="right") - 1)
        returned = tv["ping_available"][p]
        rejected = np.zeros(4, dtype=bool)
        results = self.results or {}
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
        if self.truth_view is None or self.playing:
            return
        self.playing = True

        def loop() -> None:
            t = float(self.time_slider.value)
            t_end = float(self.time_slider.max)
            if t >= t_end - 0.1:
                t = 0.0
            while self.playing and t <= t_end:
                self.time_slider.value = t       # on_update moves the vehicle
                t += 2.0
                time.sleep(0.05)
            self.playing = False
        threading.Thread(target=loop, daemon=True).start()

    def close(self) -> None:
        self.playing = False
        self.stop_run()


def summary_line(results: dict[str, MethodResult]) -> str:
    """One line for the completion notification: final velocity error per method."""
    parts = [f"{method.upper()} {float(rms(res.vel_err_mps[-1])):.3g} m/s" for method, res in results.items()]
    return "Final velocity error: " + ", ".join(parts)


def check_listen(host: str, port: int) -> None:
    """Raise OSError if ``host:port`` cannot be bound: viser would silently move to another
    port, and a user (or a Docker port mapping) would look for the dashboard in the wrong place."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((host, port))


def build_server(host: str = "127.0.0.1", port: int = 8080) -> tuple[viser.ViserServer, worker.RunPool]:
    """Start the viser server with one :class:`Session` per connected tab."""
    check_listen(host, port)
    pool = worker.RunPool()
    server = viser.ViserServer(host=host, port=port, label="tauv", verbose=False)
    start = ned_to_view(np.array([0.0, 0.0, Config().trajectory.depth_m]))
    server.initial_camera.position = tuple(start + np.array([-0.6, -0.8, 0.6]) * FOLLOW_DISTANCE_M)
    server.initial_camera.look_at = tuple(start)
    server.gui.configure_theme(control_layout="fixed", control_width="large", show_share_button=False,
                               show_logo=False, brand_color=(31, 119, 180))
    sessions: dict[int, Session] = {}

    @server.on_client_connect
    def _(client: viser.ClientHandle) -> None:
        sessions[client.client_id] = Session(client, pool)

    @server.on_client_disconnect
    def _(client: viser.ClientHandle) -> None:
        session = sessions.pop(client.client_id, None)
        if session is not None:
            session.close()

    return server, pool


def main(host: str = "127.0.0.1", port: int = 8080) -> None:
    """Serve the dashboard until interrupted."""
    server, pool = build_server(host, port)
    shown = "localhost" if host in ("127.0.0.1", "0.0.0.0") else host
    print(f"tauv dashboard: http://{shown}:{server.get_port()}", flush=True)
    try:
        while True:
            time.sleep(3600.0)
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
        pool.shutdown()


__all__ = ["Session", "build_server", "main"]
