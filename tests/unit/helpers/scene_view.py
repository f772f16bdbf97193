"""A SceneView (app.dashboard.session_scene) over a real viser server on a free local port, with
the tab's state as a namespace the test fills in (config, truth_view, results)."""

from __future__ import annotations

import contextlib
import socket
import threading
import types
from collections.abc import Iterator

import viser

from app.dashboard.session_scene import SceneView
from app.figures.scene import CAMERA_FREE


@contextlib.contextmanager
def scene_view() -> Iterator[tuple[SceneView, types.SimpleNamespace]]:
    """The view and its state (nothing run yet, four beams ticked, the camera free); the server
    stops on leaving."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = viser.ViserServer(host="127.0.0.1", port=port, verbose=False)
    try:
        client = types.SimpleNamespace(scene=server.scene, atomic=server.atomic,
                                       camera=types.SimpleNamespace(fov=0.9, aspect=1.5))
        state = types.SimpleNamespace(client=client, draw_lock=threading.RLock(), truth_view=None, config=None,
                                      results=None, replaying=False, events_shown=True)
        view = SceneView(state, [types.SimpleNamespace(value=True)] * 4, types.SimpleNamespace(value=0.0),
                         types.SimpleNamespace(value=CAMERA_FREE), types.SimpleNamespace(content=""))
        yield view, state
    finally:
        server.stop()
