"""The 3-D scene of a dashboard tab: the AUV (hull, fins, the DVL's four beams), the current's
arrow over it, the truth's and each method's trajectory, the seabed and its furniture (grid or
terrain, sea surface, compass, scale bar), and the camera (a chase view or free; "Fit mission"
frames the whole track).

:meth:`SceneView.show_time` draws the vehicle as it was at a time of the run (app.dashboard.session_playback
decides the time); the run's truth and results arrive through the tab's
:class:`~app.dashboard.session_state.TabState`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import viser

from app.dashboard.session_state import TabState, drawing
from app.figures.event_traces import EVENT_COLORS, track_marks
from app.figures.scene import (
    BEAM_COLORS,
    BEAM_OUTAGE,
    BEAM_REJECTED,
    BEAM_RETURNING,
    BEAM_SWITCHED_OFF,
    BEAM_THICKNESS_PX,
    BEAM_WATER,
    CAMERA_FREE,
    CURRENT_ARROW_ABOVE_M,
    CURRENT_ARROW_HEAD_M,
    CURRENT_ARROW_SHAFT_M,
    CURRENT_COLOR,
    CURRENT_LABEL_ABOVE_M,
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
    current_arrow_view,
    current_head_m,
    current_label,
    fin_wxyz_body,
    fit_camera_view,
    interpolate_pose,
    mission_frame,
    ned_to_view,
    scale_bar_view,
    seabed_mesh_n,
    seabed_ranges_m,
    water_beside,
    water_ranges_m,
    water_tracking,
    wxyz_view,
)
from app.figures.shared import TRUTH_COLOR, decimate, method_color
from app.figures.vehicle_figures import FIN_COLORS
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult, UpdateRecord
from tauvcore.eval.envelope import DecimatedUpdates
from tauvcore.eval.events import Event, run_events
from tauvcore.truth.kinematic import bathymetry

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


def hex_rgb(color: str) -> tuple[int, int, int]:
    """``"#rrggbb"`` as an RGB triple."""
    return tuple(int(color[i : i + 2], 16) for i in (1, 3, 5))  # type: ignore[return-value]


class SceneView:
    """The tab's 3-D scene, built at once (before a run: the default mission's start)."""

    def __init__(
        self,
        state: TabState,
        beam_boxes: list[viser.GuiCheckboxHandle],
        time_slider: viser.GuiSliderHandle[float],
        camera_mode: viser.GuiDropdownHandle[Any],
        readout: viser.GuiMarkdownHandle,
    ) -> None:
        self.state = state
        self.client = state.client
        self.draw_lock = state.draw_lock
        self.beam_boxes = beam_boxes  # the DVL beam boxes of the control panel
        self.time_slider = time_slider  # the playback's (its time when the camera or truth changes)
        self.camera_mode = camera_mode
        self.readout = readout  # the beams' state at the shown time, under the playback controls
        self.event_marks: list[Any] = []  # the events drawn on the truth's track (draw_events)
        self.events_drawn: list[Event] | None = None
        self._build_scene()

    def _build_scene(self) -> None:
        scene = self.client.scene
        scene.set_up_direction("+z")
        scene.configure_environment_map(hdri=None)
        scene.configure_default_lights(enabled=True, cast_shadow=False)
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
                color=hex_rgb(color),
                flat_shading=True,
                side="double",
                position=tuple(fin.hinge_b),
            )
            for k, (fin, color) in enumerate(zip(fins, FIN_COLORS))
        ]
        # the current: an arrow and its label over the vehicle, in the view's axes (not the hull's),
        # shown for a mission in a current (show_time)
        self.current_node = scene.add_frame("/current", show_axes=False, visible=False)
        self.current_arrow = scene.add_arrows(
            "/current/arrow",
            current_arrow_view(np.array([0.1, 0.0, 0.0])),
            CURRENT_COLOR,
            shaft_radius=CURRENT_ARROW_SHAFT_M,
            head_radius=2.5 * CURRENT_ARROW_SHAFT_M,
            head_length=CURRENT_ARROW_HEAD_M,
        )
        self.current_text = scene.add_label(
            "/current/label", "", font_screen_scale=0.8, anchor="bottom-center"
        )
        self.current_shown: np.ndarray | None = None  # the current the arrow shows [m/s] (None: hidden)
        self.beam_nodes: list[list[Any]] | None = None  # [beam][state] under /auv (show_beams_static)
        self.beam_visible: list[list[bool]] = []  # per beam, which of its state nodes show
        self.terrain: Any = None  # the seabed's mesh when it is not flat (_draw_seabed)
        self.furniture: list[Any] = []  # seabed grid, surface, compass and scale (_size_scene)
        self.frame: MissionFrame | None = None
        self.keep_camera = False  # a camera from the page's address: the next truth does not move it
        self.truth_line = None
        self.est_lines: dict[str, Any] = {}
        # before a run: the default straight line's first 300 m, at the default seabed
        self._size_scene(
            mission_frame(np.array([start_n, start_n + [300.0, 0.0, 0.0]]), d.trajectory.seabed_depth_m)
        )
        self.beams_from_boxes()
        # the beams' numbers stand in the view's frame, not under the hull: viser places a label
        # from its parent's world matrix of the frame before, so a label under the moving hull
        # trailed its beam by a frame's travel during Play; placed here with the hull (show_time),
        # in the same message batch, each stands on its beam in every frame
        self.beam_labels = [
            scene.add_label(
                f"/beam_labels/{k}",
                str(k),
                position=tuple(p),
                font_screen_scale=0.8,
                anchor="center-center",
            )
            for k, p in enumerate(beam_label_positions_view(d, start_n, np.eye(3)), start=1)
        ]

    @drawing
    def _size_scene(self, frame: MissionFrame) -> None:
        """Seabed grid, sea surface, compass rose and scale bar sized to the mission ``frame``
        (app.figures.scene.mission_frame); re-added once per run."""
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

    def restore_camera(self, position: tuple[float, ...], look_at: tuple[float, ...]) -> None:
        """Put the camera at ``position`` looking at ``look_at`` (view frame [m], from the page's
        address: app.dashboard.links) and leave it free: the next run's truth keeps it there."""
        self.keep_camera = True
        if self.camera_mode.value != CAMERA_FREE:
            self.camera_mode.value = CAMERA_FREE
        self._set_camera(np.asarray(position, float), np.asarray(look_at, float))

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

    def camera_changed(self) -> None:
        """A chase view moves the camera to the vehicle at once (free: the camera stays)."""
        if self.camera_mode.value != CAMERA_FREE:
            self.show_time(float(self.time_slider.value))

    @drawing
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
        in the body frame (app.figures.scene.beam_segments_b), so hull and beams move in one message.
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
            bottom, water = water_tracking(dvl.water_track, dvl.beam_mask, np.isfinite(range_m))
            states = beam_states(dvl.beam_mask, bottom, np.zeros(4, bool), water)
        full = beam_segments_b(dvl.l_dvl_b, dvl.A_b, range_m, dvl.max_range_m)
        segs = {s: beam_stub(full) if s == BEAM_SWITCHED_OFF else full for s in BEAM_THICKNESS_PX}
        layer = water_ranges_m(C_nb, dvl.A_b, dvl.water_layer_m)
        # a water-tracking beam ends at its layer; with water-track "both" it is drawn beside its
        # bottom-track too (lime over the blue beam, down to the layer)
        beside = water_beside(dvl.water_track, states, layer, range_m)
        if BEAM_WATER in states or beside.any():
            segs[BEAM_WATER] = beam_segments_b(dvl.l_dvl_b, dvl.A_b, layer, dvl.max_range_m)
        order = (BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_OUTAGE, BEAM_REJECTED, BEAM_WATER)
        shown = [[s == states[k] or (s == BEAM_WATER and bool(beside[k])) for s in order] for k in range(4)]
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
                        visible=shown[k][j],
                    )
                    for j, s in enumerate(order)
                ]
                for k in range(4)
            ]
            self.beam_visible = shown
            return
        for k in range(4):
            for j, s in enumerate(order):
                if shown[k][j]:
                    nodes[k][j].points = segs[s][k : k + 1]
                if shown[k][j] != self.beam_visible[k][j]:
                    nodes[k][j].visible = shown[k][j]
        self.beam_visible = shown

    def beams_from_boxes(self) -> None:
        """Before a run's truth arrives the beams stand at the mission's start as the DVL beam
        boxes say: a box unticked, its beam is drawn switched off at once. A run's beams show
        what that run did."""
        if self.state.truth_view is not None:
            return
        config = self.state.config or Config()
        enabled = np.array([box.value for box in self.beam_boxes])
        pos_n, dvl = np.array([0.0, 0.0, config.trajectory.depth_m]), config.dvl
        range_m = seabed_ranges_m(
            pos_n, np.eye(3), dvl.l_dvl_b, dvl.A_b, bathymetry(config.trajectory), dvl.max_range_m
        )
        bottom, water = water_tracking(dvl.water_track, enabled, np.isfinite(range_m))
        states = beam_states(enabled, bottom, np.zeros(4, bool), water)
        self.show_beams_static(config, pos_n, np.eye(3), states, range_m)

    @drawing
    def clear_trajectories(self) -> None:
        for handle in self.est_lines.values():
            handle.remove()
        self.est_lines = {}
        if self.truth_line is not None:
            self.truth_line.remove()
            self.truth_line = None

    @drawing
    def draw_truth(self) -> None:
        tv, config = self.state.truth_view, self.state.config
        if tv is None or config is None:
            return
        pts = ned_to_view(tv["pos_n"][decimate(len(tv["t_s"]), TRAJECTORY_POINTS)])
        self.truth_line = self.client.scene.add_line_segments(
            "/traj/truth",
            np.stack([pts[:-1], pts[1:]], axis=1),
            hex_rgb(TRUTH_COLOR),
            thickness=3.0,
            thickness_units="screen",
        )
        self._draw_seabed(config, tv["pos_n"])
        self._size_scene(mission_frame(tv["pos_n"], config.trajectory.seabed_depth_m))
        if self.camera_mode.value == CAMERA_FREE and not self.keep_camera:
            self.fit_mission()
        self.keep_camera = False
        self.draw_events()
        self.show_time(min(float(self.time_slider.value), float(tv["t_s"][-1])))

    @drawing
    def _draw_seabed(self, config: Config, pos_n: np.ndarray) -> None:
        """A flat seabed is the grid (:meth:`_size_scene`: under the track with a margin); any other
        (terrain, the longrange trenches) a mesh of the mission's bathymetry under the track
        (app.figures.scene.seabed_mesh_n), the grid hidden. A replayed log records no seabed: the grid at
        the configured depth."""
        if self.terrain is not None:
            self.terrain.remove()
            self.terrain = None
        seabed = bathymetry(config.trajectory)
        if seabed.is_plane or self.state.replaying:
            return
        verts_n, faces = seabed_mesh_n(seabed, pos_n)
        self.terrain = self.client.scene.add_mesh_simple(
            "/terrain", ned_to_view(verts_n), faces, color=SEABED_COLOR, flat_shading=False, side="double"
        )

    @drawing
    def draw_estimates(self, results: dict[str, MethodResult]) -> None:
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
                    hex_rgb(method_color(method)),
                    thickness=2.0,
                    thickness_units="screen",
                )
        self.draw_events()

    @drawing
    def draw_events(self) -> None:
        """The run's events on the truth's track (app.figures.event_traces.track_marks), in their
        kinds' colours: each span a thick stretch of the track, each instant (gate rejections,
        lock-out resets, divergence flags) a dot, with labels naming the outages, dropouts and
        divergence flags and each other kind's count; none with the Events box off. Drawn again only
        when the events change."""
        tv, config = self.state.truth_view, self.state.config
        if tv is None or config is None:
            return
        events = run_events(self.state.results or {}, config) if self.state.events_shown else []
        if events == self.events_drawn:
            return
        for handle in self.event_marks:
            handle.remove()
        self.event_marks = []
        self.events_drawn = events
        spans, instants, labels = track_marks(events, tv["t_s"], tv["pos_n"])
        scene = self.client.scene
        for k, (event, pos_n) in enumerate(spans):
            pts = ned_to_view(pos_n)
            self.event_marks.append(
                scene.add_line_segments(
                    f"/events/span_{k}",
                    np.stack([pts[:-1], pts[1:]], axis=1),
                    hex_rgb(EVENT_COLORS[event.kind]),
                    thickness=7.0 if event.method is None else 5.0,
                    thickness_units="screen",
                )
            )
        for kind, pos_n in instants.items():
            self.event_marks.append(
                scene.add_point_cloud(
                    f"/events/{kind}",
                    ned_to_view(pos_n),
                    hex_rgb(EVENT_COLORS[kind]),
                    point_size=1.2,
                    point_shape="circle",
                )
            )
        for k, (text, pos_n) in enumerate(labels):
            position = ned_to_view(pos_n[None])[0] + [0.0, 0.0, 2.0]
            self.event_marks.append(
                scene.add_label(f"/events/label_{k}", text, position=tuple(position), anchor="bottom-center")
            )

    @drawing
    def show_time(self, t_s: float) -> None:
        """Place the vehicle and colour the beams at time ``t_s`` of the current run.

        The pose is interpolated between the truth's samples (app.figures.scene.interpolate_pose: playback
        is smooth at any speed); ranges, fins and beam states are the sample's at or before
        ``t_s``. Camera, hull, fins and beams change in one atomic batch: the page never draws a
        frame with some of them moved.
        """
        tv, config = self.state.truth_view, self.state.config
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
            for label, p_view in zip(self.beam_labels, beam_label_positions_view(config, pos_n, C_nb)):
                label.position = tuple(p_view)
            current = tv.get("current_n_mps")
            self._show_current(pos_n, current[i] if current is not None else None)
        altitude = tv.get("altitude_m")
        in_range = np.isfinite(range_m) if range_m is not None else np.ones(4, dtype=bool)
        text = beam_readout(t_s, states, in_range, float(altitude[i]) if altitude is not None else None)
        if text != self.readout.content:
            self.readout.content = text

    def _show_current(self, pos_n: np.ndarray, current_n_mps: np.ndarray | None) -> None:
        """The current's arrow over the vehicle at ``pos_n`` (3,) NED [m], pointing where the water
        ``current_n_mps`` (3,) NED [m/s] flows (None: still water, hidden). Arrow and label are sent
        again only when the current has changed by a millimetre per second (a constant current
        moves, it does not redraw)."""
        shown = self.current_shown
        if current_n_mps is None:
            if shown is not None:
                self.current_node.visible = False
                self.current_shown = None
            return
        self.current_node.position = tuple(ned_to_view(pos_n) + [0.0, 0.0, CURRENT_ARROW_ABOVE_M])
        if shown is not None and np.max(np.abs(current_n_mps - shown)) < 1e-3:
            return
        moving = bool(np.linalg.norm(current_n_mps) >= 1e-3)
        arrow = current_arrow_view(current_n_mps)
        if moving:  # a still current has no direction: its label alone
            self.current_arrow.points = arrow
            self.current_arrow.head_length = current_head_m(current_n_mps)
        self.current_text.position = tuple(arrow[0, 1] + [0.0, 0.0, CURRENT_LABEL_ABOVE_M])
        if shown is None or self.current_arrow.visible != moving:
            self.current_arrow.visible = moving
        self.current_text.text = current_label(current_n_mps)
        if shown is None:
            self.current_node.visible = True
        self.current_shown = np.array(current_n_mps, float)

    def beam_states_at(self, t_s: float, range_m: np.ndarray | None = None) -> list[str]:
        """Each beam's state at ``t_s``: the schedule's (or, once results arrive, the run's record
        of) returned beams, lost also where ``range_m`` (4,) says the seabed is beyond range (inf),
        rejected by the gate of the first of REJECT_REFERENCE that ran; water-tracking where the
        DVL water-tracks instead (app.figures.scene.water_tracking)."""
        tv, config = self.state.truth_view, self.state.config
        assert tv is not None and config is not None
        enabled, mode = config.dvl.beam_mask, config.dvl.water_track
        in_range = np.isfinite(range_m) if range_m is not None else np.ones(4, dtype=bool)
        pings = tv["ping_t_s"]
        if len(pings) == 0 or t_s < pings[0]:
            bottom, water = water_tracking(mode, enabled, in_range)
            return beam_states(enabled, bottom, np.zeros(4, bool), water)
        p = int(np.searchsorted(pings, t_s, side="right") - 1)
        scheduled = tv["ping_available"][p]
        returned, water = water_tracking(mode, scheduled, in_range)  # a run's own record also has drop-outs
        rejected = np.zeros(4, dtype=bool)
        results = self.state.results or {}
        for record in (r.updates.get("dvl") for r in results.values()):
            q = _record_row(record, p, t_s)
            if record is not None and q is not None and record.beams_available is not None:
                returned = record.beams_available[q, 0]
                break
        returned = returned & in_range & (mode != "always")
        for method in REJECT_REFERENCE:
            dvl = results[method].updates.get("dvl") if method in results else None
            q = _record_row(dvl, p, t_s)
            if dvl is not None and q is not None:
                if method == "tc":
                    rejected = dvl.rejected_rows[q, 0] & returned
                elif dvl.rejected[q, 0]:
                    rejected = returned.copy()
                break
        return beam_states(enabled, returned, rejected, water)


def _record_row(record: UpdateRecord | None, ping: int, t_s: float) -> int | None:
    """The row of a DVL ``record`` that holds ping ``ping`` (the ping at or before ``t_s``), None if
    it has none yet; a long run's record reduced to time bins (tauvcore.eval.envelope) holds the
    last ping of each bin: its row is the latest at or before ``t_s``."""
    if record is None:
        return None
    if isinstance(record, DecimatedUpdates):
        q = int(np.searchsorted(record.t_s, t_s, side="right") - 1)
        return q if q >= 0 else None
    return ping if ping < len(record.t_s) else None


def beam_label_positions_view(config: Config, pos_n: np.ndarray, C_nb: np.ndarray) -> np.ndarray:
    """(4, 3) where beams 1-4 carry their numbers in the view's frame, for the vehicle at ``pos_n``
    (3,) NED [m] turned by ``C_nb`` (3, 3) (app.figures.scene.beam_label_positions_b, body frame)."""
    p_b = beam_label_positions_b(config.dvl.l_dvl_b, config.dvl.A_b)
    return ned_to_view(np.asarray(pos_n) + p_b @ np.asarray(C_nb).T)
