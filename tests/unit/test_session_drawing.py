"""The scene and plots of a tab are changed by one thread at a time.

The run's message thread redraws the plots, trajectories and vehicle while the time slider's
callback (or playback) moves the vehicle and re-adds the beams; interleaved, one thread
assigned to a beam the other had just replaced ("Cannot assign to 'visible' on a removed
LineSegmentsHandle", seen in the 8-client load test). Every drawing method of Session takes the
session's draw lock.
"""

from __future__ import annotations

import threading
import types

import numpy as np
import pytest

from app.dashboard import Session
from tauvcore.config import Config


def _idle_session() -> types.SimpleNamespace:
    """The state a Session's drawing methods read, with nothing to draw (each returns at once)."""
    scene = types.SimpleNamespace(add_line_segments=lambda *args, **kwargs: object())
    return types.SimpleNamespace(draw_lock=threading.RLock(), truth_view=None, config=None, results=None,
                                 est_lines={}, truth_line=None, client=types.SimpleNamespace(scene=scene),
                                 vkf_plot=types.SimpleNamespace(figure=None, visible=False),
                                 vkf_note=types.SimpleNamespace(content=""))


@pytest.mark.parametrize("call", [
    lambda s: Session.show_time(s, 1.0),
    lambda s: Session._draw_truth(s),
    lambda s: Session._draw_estimates(s, {}),
    lambda s: Session._clear_trajectories(s),
    lambda s: Session.refresh_plots(s),
    lambda s: Session.show_beams_static(s, Config(), np.zeros(3), np.eye(3)),
    lambda s: Session._draw_vkf_plot(s, None, Config()),
], ids=["show_time", "_draw_truth", "_draw_estimates", "_clear_trajectories", "refresh_plots", "show_beams_static",
        "_draw_vkf_plot"])
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
        _show_results=lambda results, config: None, _keep_finished=lambda results, config, stopped: None)
    session.notify = lambda t, body, error=False: seen.append(
        (t, session.handle is None, session.run_button.disabled, session.stop_button.disabled))
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("app.dashboard.summary_line", lambda results: "")
        # a "done" message's results name their last epoch
        if messages[0][0] == "done":
            result = types.SimpleNamespace(t_s=np.array([0.0, 20.0]))
            handle.queue.queue[0] = ("done", {"lc": result}, messages[0][2])
        Session._pump(session, handle, Config())
    assert seen == [(title, True, False, True)]


def test_the_vkf_figure_shows_for_a_vkf_run_and_a_note_otherwise() -> None:
    """The Seabed tab: the VKF's figure once its results arrive (with the run's progress); before
    that a note that they will, and without VKF a note how to get it."""
    from app.dashboard import VKF_NOTES
    from app.figures import VKF_SF_NAME
    session = _idle_session()
    with_vkf = Config().replace("run", methods=("lc", "vkf"))
    Session._draw_vkf_plot(session, None, with_vkf)
    assert not session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["running"]
    Session._draw_vkf_plot(session, None, Config())
    assert not session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["none"]
    U = 5
    trace = {"t_s": np.arange(U, dtype=float), "x": np.full((U, 1, 3), 0.1), "sigma": np.full((U, 1, 3), 0.01),
             "sf_true": np.full((U, 1), np.nan), "b_true": np.full((U, 1), np.nan),
             "rpm_in_use": np.zeros((U, 1), bool), "altitude_m": np.full((U, 1), 50.0)}
    Session._draw_vkf_plot(session, types.SimpleNamespace(vkf_trace=trace), with_vkf)
    assert session.vkf_plot.visible and session.vkf_note.content == VKF_NOTES["shown"]
    assert VKF_SF_NAME in [t.name for t in session.vkf_plot.figure.data]
