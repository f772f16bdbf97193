"""The scene and plots of a tab are changed by one thread at a time.

The run's message thread redraws the plots, trajectories and vehicle while the time slider's
callback (or playback) moves the vehicle and re-adds the beams; interleaved, one thread
assigned to a beam the other had just replaced ("Cannot assign to 'visible' on a removed
LineSegmentsHandle", seen in the 8-client load test). Every drawing method of a Session's rooms
(app.dashboard.session_scene, app.dashboard.session_plots, app.dashboard.session_runs) takes the tab's one draw lock.
"""

from __future__ import annotations

import threading
import types

import numpy as np
import pytest

from app.dashboard.server import Session
from app.dashboard.session_playback import Playback
from app.dashboard.session_plots import PlotTabs
from app.dashboard.session_runs import RunTabs
from app.dashboard.session_scene import SceneView
from tauvcore.config import Config


def _idle_session() -> types.SimpleNamespace:
    """The state a Session's drawing methods read, with nothing to draw (each returns at once)."""
    scene = types.SimpleNamespace(add_line_segments=lambda *args, **kwargs: object())
    state = types.SimpleNamespace(truth_view=None, config=None, results=None, cursor_t=None, last_action_s=0.0)
    return types.SimpleNamespace(draw_lock=threading.RLock(), state=state,
                                 est_lines={}, truth_line=None, client=types.SimpleNamespace(scene=scene),
                                 vkf_plot=types.SimpleNamespace(figure=None, visible=False),
                                 vkf_note=types.SimpleNamespace(content=""), kept_runs=[], kept_widgets={},
                                 diff_table=types.SimpleNamespace(content=""),
                                 compare_table=types.SimpleNamespace(content=""),
                                 overlay_runs=lambda: [], refresh_plots=lambda: None, draw_events=lambda: None,
                                 _with_events=lambda figure, run=0: figure)


@pytest.mark.parametrize("call", [
    lambda s: SceneView.show_time(s, 1.0),
    lambda s: SceneView.draw_truth(s),
    lambda s: SceneView.draw_estimates(s, {}),
    lambda s: SceneView.clear_trajectories(s),
    lambda s: PlotTabs.refresh_plots(s),
    lambda s: SceneView.show_beams_static(s, Config(), np.zeros(3), np.eye(3)),
    lambda s: PlotTabs.draw_vkf_plot(s, None, Config()),
    lambda s: RunTabs.refresh_runs(s),
], ids=["show_time", "draw_truth", "draw_estimates", "clear_trajectories", "refresh_plots", "show_beams_static",
        "draw_vkf_plot", "refresh_runs"])
def test_drawing_waits_for_the_draw_lock(call) -> None:
    session = _idle_session()
    done = threading.Event()
    session.draw_lock.acquire()
    try:
        worker = threading.Thread(target=lambda: (call(session), done.set()), daemon=True)
        worker.start()
        assert not done.wait(0.3), "drew while another thread held the draw lock"
    finally:
        session.draw_lock.release()
    assert done.wait(5.0), "never drew after the lock was released"




@pytest.mark.parametrize("messages, title", [
    ([("done", {}, False)], "Run complete"),
    ([("done", {}, True)], "Run stopped"),
    ([("error", "boom")], "Run failed"),
], ids=["complete", "stopped", "failed"])
def test_the_run_s_closing_notification_finds_the_tab_ready_for_the_next_run(messages, title) -> None:
    """Seen in the 8-client load test: a Run pressed as soon as "Run complete" showed met
    "Already running" when the notification went out before the tab let go of its run."""
    import queue

    handle = types.SimpleNamespace(queue=queue.Queue(), finished=lambda: True, position=lambda: 0)
    for msg in messages:
        handle.queue.put(msg)
    seen = []
    session = types.SimpleNamespace(
        lock=threading.Lock(), handle=handle, status=types.SimpleNamespace(content=""),
        progress=types.SimpleNamespace(value=0.0), pool=types.SimpleNamespace(workers=2),
        run_button=types.SimpleNamespace(disabled=True), stop_button=types.SimpleNamespace(disabled=False),
        _show_results=lambda results, config: None, _keep_finished=lambda results, config, stopped: None,
        run_log=None, run_note="", state=types.SimpleNamespace(notices=[]))
    session.notify = lambda t, body, error=False: seen.append(
        (t, session.handle is None, session.run_button.disabled, session.stop_button.disabled))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("app.dashboard.server.summary_line", lambda results: "")
        # a "done" message's results name their last epoch
        if messages[0][0] == "done":
            result = types.SimpleNamespace(t_s=np.array([0.0, 20.0]))
            handle.queue.queue[0] = ("done", {"lc": result}, messages[0][2])
        Session._pump(session, handle, Config())
    assert seen == [(title, True, False, True)]


def test_the_vkf_figure_shows_for_a_vkf_run_and_a_note_otherwise() -> None:
    """The Seabed tab: the VKF's figure once its results arrive (with the run's progress); before
    that a note that they will, and without VKF a note how to get it."""
    from app.dashboard.server import VKF_NOTES
    from app.figures.vehicle_figures import VKF_SF_NAME
    session = _idle_session()
    with_vkf = Config().replace("run", methods=("lc", "vkf"))
    PlotTabs.draw_vkf_plot(session, None, with_vkf)
    assert not session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["running"]
    PlotTabs.draw_vkf_plot(session, None, Config())
    assert not session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["none"]
    U = 5
    trace = {"t_s": np.arange(U, dtype=float), "x": np.full((U, 1, 3), 0.1), "sigma": np.full((U, 1, 3), 0.01),
             "sf_true": np.full((U, 1), np.nan), "b_true": np.full((U, 1), np.nan),
             "rpm_in_use": np.zeros((U, 1), bool), "altitude_m": np.full((U, 1), 50.0)}
    PlotTabs.draw_vkf_plot(session, types.SimpleNamespace(vkf_trace=trace), with_vkf)
    assert session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["shown"]
    assert VKF_SF_NAME in [t.name for t in session.vkf_plot.figure.data]


def _slider_session(value: float, max_s: float) -> types.SimpleNamespace:
    """What the time slider's methods read: a slider, a run in progress, nothing to draw."""
    slider = types.SimpleNamespace(value=value, max=max_s, step=0.1)
    session = types.SimpleNamespace(time_slider=slider, running=lambda: True, playing=False, slider_pinned=False,
                                    run_time_s=0.0, slider_set_s=None, slider_follow_sent=False, shown=[],
                                    echoed=[], state=types.SimpleNamespace(last_action_s=0.0))
    session.show_time = lambda t: session.shown.append(t)
    session._echo_slider = lambda client, t: session.echoed.append(t)
    return session


def test_the_slider_stays_where_the_user_put_it_while_the_run_goes_on() -> None:
    """Issue 13: the slider snapped back to the latest time at every results update."""
    session = _slider_session(0.0, 250.0)
    Playback.follow_run_time(session, 40.0)
    assert session.time_slider.value == 40.0                    # untouched: it follows the run
    session.time_slider.value = 12.0                            # the user's hand
    Playback._slider_moved(session, types.SimpleNamespace(client=object()))
    assert session.slider_pinned and session.shown == [12.0]
    Playback.follow_run_time(session, 80.0)
    assert session.time_slider.value == 12.0
    session.time_slider.value = 80.0                            # put back at the latest time: follows again
    Playback._slider_moved(session, types.SimpleNamespace(client=object()))
    Playback.follow_run_time(session, 120.0)
    assert session.time_slider.value == 120.0
    # the user's move seen before its callback ran (viser runs it in a thread pool): it stays
    session.time_slider.value = 7.0
    Playback.follow_run_time(session, 130.0)
    assert session.time_slider.value == 7.0 and session.slider_pinned


def test_a_move_that_raced_a_follow_set_is_echoed_to_its_page_once() -> None:
    """viser echoes a slider's value to every tab but the one that moved it: a value the run set
    just before the user's move reached the server arrived at the page after the move and snapped
    the page's slider back, while the server held the user's. The page gets its own value back
    once, after a follow-set; moves without one in between (dragging) get none."""
    session = _slider_session(0.0, 250.0)
    Playback.follow_run_time(session, 40.0)                     # sent to the page
    session.time_slider.value = 12.0
    Playback._slider_moved(session, types.SimpleNamespace(client=object()))
    assert session.echoed == [12.0]
    for t in (11.0, 10.0):                                      # the user drags on: the run is pinned
        session.time_slider.value = t
        Playback._slider_moved(session, types.SimpleNamespace(client=object()))
    Playback.follow_run_time(session, 80.0)
    assert session.echoed == [12.0] and session.time_slider.value == 10.0


def test_after_a_stop_the_slider_spans_what_was_run() -> None:
    session = _slider_session(200.0, 1200.0)
    Playback.span_slider(session, 150.0)
    assert session.time_slider.max == 150.0 and session.time_slider.value == 150.0
    session = _slider_session(30.0, 1200.0)
    session.run_tabs = types.SimpleNamespace(set_finished=lambda *args: None,   # the downloads' and runs' part
                                             keep_run=lambda *args: None)
    session.playback = types.SimpleNamespace(span_slider=lambda t: Playback.span_slider(session, t))
    session.run_log = session.run_source = None
    result = types.SimpleNamespace(t_s=np.array([0.0, 41.5]))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("app.dashboard.server.export.finished_run", lambda *args: None)
        Session._keep_finished(session, {"lc": result}, Config(), True)
    assert session.time_slider.max == 41.5 and session.time_slider.value == 30.0


class _Node:
    def __init__(self, points, visible) -> None:
        self.points, self.visible = points, visible


def test_beams_are_updated_in_place_not_re_added() -> None:
    """Beams vanished in 4 of 14 frames during a run: each was removed and re-added at every time
    step. Now one node per beam and state is made once; later drawings move points and switch
    which node shows, under the hull's node."""
    from app.figures.scene import BEAM_OUTAGE, BEAM_RETURNING, BEAM_SWITCHED_OFF
    added = []

    def add(name, points, colors, **kwargs):
        added.append(name)
        return _Node(points, kwargs.get("visible", True))
    session = types.SimpleNamespace(draw_lock=threading.RLock(),
                                    client=types.SimpleNamespace(scene=types.SimpleNamespace(add_line_segments=add)))
    states = [BEAM_RETURNING, BEAM_SWITCHED_OFF, BEAM_RETURNING, BEAM_RETURNING]
    SceneView.show_beams_static(session, Config(), np.array([0.0, 0.0, 20.0]), np.eye(3), states)
    assert len(added) == 20 and all(name.startswith("/auv/beams/") for name in added)
    shown = [[n.visible for n in beam] for beam in session.beam_nodes]
    assert [row.index(True) for row in shown] == [0, 1, 0, 0] and all(sum(row) == 1 for row in shown)
    states2 = [BEAM_OUTAGE, BEAM_SWITCHED_OFF, BEAM_RETURNING, BEAM_RETURNING]
    ranges = np.array([np.inf, 50.0, 45.0, 40.0])
    SceneView.show_beams_static(session, Config(), np.array([0.0, 0.0, 20.0]), np.eye(3), states2, ranges)
    assert len(added) == 20                                       # nothing re-added
    assert [[n.visible for n in beam].index(True) for beam in session.beam_nodes] == [2, 1, 0, 0]
    assert session.beam_nodes[2][0].points[0, 1] == pytest.approx(
        Config().dvl.l_dvl_b + Config().dvl.A_b[2] * 45.0)       # body frame, to the range


def test_seconds_left_is_the_run_s_own_pace() -> None:
    from app.dashboard.server import seconds_left
    assert seconds_left(50.0, 250.0, 2.0) == pytest.approx(8.0)     # a fifth in 2 s: four fifths in 8 s
    assert seconds_left(250.0, 250.0, 3.0) == 0.0
    assert seconds_left(0.0, 250.0, 1.0) == float("inf")           # no progress yet: no estimate


@pytest.mark.parametrize("second_t_s, draws", [(95.0, ["live", "final"]), (10.0, ["live", "live", "final"])],
                         ids=["ending-soon", "far-from-the-end"])
def test_live_results_are_not_drawn_when_the_final_ones_are_due_first(second_t_s, draws) -> None:
    """Given a clock that advances 2 s per reading, a run of 100 s whose first progress is at 1 s
    is drawn; a second progress at 95 s (the final results due in well under GUI_REFRESH_S) is
    held for the final results, one at 10 s (ninety seconds to go at that pace) is drawn."""
    import queue

    handle = types.SimpleNamespace(queue=queue.Queue(), finished=lambda: True, position=lambda: 0)
    result = types.SimpleNamespace(t_s=np.array([0.0, 100.0]))
    for msg in [("truth", {}), ("progress", 1.0, {"lc": result}), ("progress", second_t_s, {"lc": result}),
                ("done", {"lc": result}, False)]:
        handle.queue.put(msg)
    shown = []
    session = types.SimpleNamespace(
        lock=threading.Lock(), handle=handle, status=types.SimpleNamespace(content=""),
        progress=types.SimpleNamespace(value=0.0), pool=types.SimpleNamespace(workers=2),
        run_button=types.SimpleNamespace(disabled=True), stop_button=types.SimpleNamespace(disabled=False),
        state=types.SimpleNamespace(truth_view=None), run_log=None,
        scene=types.SimpleNamespace(draw_truth=lambda: None),
        plot_tabs=types.SimpleNamespace(draw_vehicle_plot=lambda: None, draw_seabed_plot=lambda: None),
        _show_results=lambda results, config, live=False: shown.append("live" if live else "final"),
        _keep_finished=lambda results, config, stopped: None, notify=lambda *args, **kwargs: None)
    clock = iter(range(0, 2000, 2))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("app.dashboard.server.summary_line", lambda results: "")
        mp.setattr("app.dashboard.server.time.monotonic", lambda: float(next(clock)))
        Session._pump(session, handle, Config().replace("trajectory", duration_s=100.0))
    assert shown == draws
