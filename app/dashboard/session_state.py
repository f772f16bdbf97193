"""What the rooms of a dashboard tab share (app.dashboard.server.Session builds them around one
:class:`TabState`): the tab's client, the lock its drawing takes, and the run being shown.

The rooms: the control panel (app.dashboard.session_controls), the 3-D scene (app.dashboard.session_scene), the
playback (app.dashboard.session_playback), the plot tabs (app.dashboard.session_plots) and the results and kept runs
(app.dashboard.session_runs). Each holds this state and the handles it needs; what one room asks of another
is a callable the Session hands it when it builds them.
"""

from __future__ import annotations

import dataclasses
import functools
import threading
import warnings
from collections.abc import Callable
from typing import Any

import viser

from app.dashboard.truth_view import TruthView
from app.figures.sensor_view import SensorView
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult


@dataclasses.dataclass(eq=False)
class TabState:
    """The run a tab shows, read by every room and written by the Session's run."""

    client: viser.ClientHandle
    # the run's message thread, the slider's callback and the playback thread all redraw the
    # scene and plots: one at a time (a beam re-added by one while another assigns to it
    # raised "Cannot assign to 'visible' on a removed LineSegmentsHandle")
    draw_lock: threading.RLock = dataclasses.field(default_factory=threading.RLock)
    config: Config | None = None  # what the current run runs (a replayed log: its own, once known)
    truth_view: TruthView | None = None  # its truth, as the worker sends it
    results: dict[str, MethodResult] | None = None  # its latest results
    sensor_view: SensorView | None = None  # one run's raw measurements, as the worker sends them
    replaying: bool = False  # the current run replays a log (tauv serve --logs)
    cursor_t: float | None = None  # the plots' time cursor [s] (None: none drawn)
    events_shown: bool = True  # the Events box: events on the time plots, the 3-D track and the map
    last_action_s: float = 0.0  # time.monotonic() of the user's latest action in this tab
    # the red notices still up (:func:`notify`): the next successful run removes them (:func:`clear_notices`)
    notices: list[viser.NotificationHandle] = dataclasses.field(default_factory=list)


def drawing(method: Callable[..., None]) -> Callable[..., None]:
    """Run a room's method that changes the scene or plots under the tab's draw lock
    (``self.draw_lock``: every room holds the state's one lock)."""

    @functools.wraps(method)
    def locked(self: Any, *args: Any, **kwargs: Any) -> None:
        with self.draw_lock:
            method(self, *args, **kwargs)

    return locked


def notify(
    client: viser.ClientHandle,
    title: str,
    body: str,
    error: bool = False,
    notices: list[viser.NotificationHandle] | None = None,
) -> None:
    """A notification in the tab: green, closing after 6 s; red (``error``), staying until closed
    or until :func:`clear_notices` removes it (kept in ``notices``, a :attr:`TabState.notices`)."""
    handle = client.add_notification(
        title, body, auto_close_seconds=None if error else 6.0, color="red" if error else "green"
    )
    if error and notices is not None:
        notices.append(handle)


def clear_notices(notices: list[viser.NotificationHandle]) -> None:
    """Remove the red notices ``notices`` still up (one the user closed is removed again harmlessly:
    the page has none of that id) and forget them."""
    kept, notices[:] = list(notices), []
    for handle in kept:
        with warnings.catch_warnings():  # removed twice: viser warns, nothing else happens
            warnings.simplefilter("ignore")
            handle.remove()
