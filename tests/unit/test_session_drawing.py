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
                                 est_lines={}, truth_line=None, client=types.SimpleNamespace(scene=scene))


@pytest.mark.parametrize("call", [
    lambda s: Session.show_time(s, 1.0),
    lambda s: Session._draw_truth(s),
    lambda s: Session._draw_estimates(s, {}),
    lambda s: Session._clear_trajectories(s),
    lambda s: Session.refresh_plots(s),
    lambda s: Session.show_beams_static(s, Config(), np.zeros(3), np.eye(3)),
], ids=["show_time", "_draw_truth", "_draw_estimates", "_clear_trajectories", "refresh_plots", "show_beams_static"])
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


