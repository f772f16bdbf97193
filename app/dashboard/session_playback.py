"""The playback of a dashboard tab: the Mission tab's Playback folder (the time slider, "Go to
[s]", Play and Pause at a Speed, the Camera and "Fit mission", the beams' readout), the plots'
time cursor, and the slider following a run as its results arrive.

The time chosen here is drawn by the scene (app.dashboard.session_scene.SceneView.show_time, the
``show_time`` this room is given); the camera controls are the scene's, wired by app.dashboard.server.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import viser
from viser import _messages as viser_messages

from app.dashboard import page_scripts, plot_click
from app.dashboard.session_state import TabState
from app.figures.scene import (
    CAMERA_MODES,
    CAMERA_SIDE,
    PLAYBACK_DEFAULT_SPEED,
    PLAYBACK_FPS,
    PLAYBACK_SPEEDS,
    playback_speed,
    playback_time,
)
from tauvcore.config import Config
from tauvcore.validation import show

GO_TO_REFUSAL_DELAY_S = 0.8  # a bad "Go to [s]" is refused once it has stood this long (typing stopped)


class Playback:
    """The Playback folder (added where ``gui`` adds controls now) and the time it shows."""

    def __init__(
        self,
        state: TabState,
        show_time: Callable[[float], None],
        running: Callable[[], bool],
        notify: Callable[..., None],
    ) -> None:
        self.state = state
        self.client = state.client
        self.show_time = show_time  # draw the scene at a time of the run
        self.running = running  # whether a run is going on (the slider then follows it)
        self.notify = notify
        self.playing = False
        self.slider_pinned = False  # the user put the time slider somewhere during the run: it stays
        self.run_time_s = 0.0  # the latest time the running run has results for [s]
        self.slider_set_s: float | None = None  # where the run last put the slider [s]
        self.slider_follow_sent = False  # the run moved the slider since the user last did
        self.restored_s: float | None = None  # a time from the page's address, kept by the next run
        gui = self.client.gui
        d = Config()
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
        self.time_slider.on_update(lambda _: self.move_cursor(self.time_slider.value))
        self.time_slider.on_update(self._slider_moved)
        self.go_to.on_update(self._go_to)
        self.play_button.on_click(lambda _: self.play())
        self.pause_button.on_click(lambda _: setattr(self, "playing", False))

    def new_run(self, duration_s: float) -> None:
        """A run of ``duration_s`` [s] starts: the slider spans it and follows it until the user
        moves it (a time from the page's address: it stays there, :meth:`restore_time`)."""
        self.slider_pinned, self.slider_set_s, self.slider_follow_sent = False, None, False
        if self.restored_s is not None:
            self.slider_pinned, self.slider_set_s = True, self.restored_s
            self.restored_s = None
        self.time_slider.max = duration_s

    def restore_time(self, t_s: float) -> None:
        """Put the slider (and every plot's cursor) at ``t_s`` [s] from the page's address: kept
        through the next run as if put there by hand (within what is run)."""
        self.time_slider.max = max(self.time_slider.max, t_s)
        self.restored_s = float(t_s)
        self.time_slider.value = float(t_s)

    def move_cursor(self, t_s: float) -> None:
        """Move the time cursor of every time plot on the page to ``t_s`` [s]: a few bytes of
        script (app.dashboard.page_scripts.set_time edits each cursor shape's x0/x1 in place), never
        a figure; a plot drawn later (a tab shown, a figure sent) takes the page's time as drawn."""
        self.state.cursor_t = float(t_s)
        page_scripts.run(self.client, page_scripts.set_time(self.state.cursor_t))

    def _slider_moved(self, event: viser.GuiEvent) -> None:
        """The time slider moved: show that time. Moved by the user's hand during a run, it stays
        there as results arrive (unless put at the latest time, where it follows the run again)."""
        t_s = float(self.time_slider.value)
        if event.client is not None:
            self.state.last_action_s = time.monotonic()
        if event.client is not None and self.running():
            self.slider_pinned, self.slider_set_s = t_s < self.run_time_s - 0.5, t_s
            if self.slider_follow_sent:
                self.slider_follow_sent = False
                self._echo_slider(event.client, t_s)
        self.show_time(t_s)

    def _echo_slider(self, client: viser.ClientHandle, t_s: float) -> None:
        """Send the page its own slider value back. viser echoes a value to every tab but the one
        that moved it; a value the run set (:meth:`follow_run_time`) and sent before this tab's
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
        """The "Go to [s]" field changed (typed, or written by a click on a plot: app.dashboard.plot_click):
        move the playback there, kept within what was run. During a run the slider then stays
        there, as if put there by hand."""
        if event.client is None:
            return
        self.state.last_action_s = time.monotonic()
        text = self.go_to.value
        try:
            t_s = plot_click.parse_go_to_s(text, float(self.time_slider.max))
        except ValueError as exc:  # said once the typing stops there, not at every key
            threading.Timer(GO_TO_REFUSAL_DELAY_S, self._go_to_refused, (text, str(exc))).start()
            return
        if t_s is None:
            return
        if self.running():
            self.slider_pinned, self.slider_set_s = t_s < self.run_time_s - 0.5, t_s
        page_scripts.run(self.client, page_scripts.busy(True))
        try:
            self.time_slider.value = t_s
        finally:
            page_scripts.run(self.client, page_scripts.busy(False))

    def follow_run_time(self, t_last_s: float) -> None:
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

    def span_slider(self, t_end_s: float) -> None:
        """The run ended at ``t_end_s`` (Stop, or its end): the slider spans what was run, not the
        requested duration; a value beyond it comes back to the end."""
        t_end_s = max(float(t_end_s), float(self.time_slider.step))
        # written only when out of range: min() would write back a value a tab has just moved
        if self.time_slider.value > t_end_s:  # noqa: PLR1730
            self.time_slider.value = t_end_s
        self.time_slider.max = t_end_s

    def play(self) -> None:
        """Play the run from the slider's time (from the start if at the end) at the Speed chosen."""
        if self.state.truth_view is None or self.playing:
            return
        self.playing = True
        threading.Thread(target=self._play_loop, daemon=True).start()

    def _play_loop(self) -> None:
        """Move the slider at a steady PLAYBACK_FPS, to the time the wall clock and the speed give
        (app.figures.scene.playback_time; the speed may change while playing). The slider's callback moves
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
