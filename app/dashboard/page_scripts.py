"""The scripts the server runs in a tab's page, kept as files of app/assets (package data).

viser 1.1 runs any script the server sends in its ``RunJavascriptMessage`` (it loads plotly.js
that way) and has no other way to read the page: so the dashboard asks the page, through a
script, to write what the server needs (the address's query, the controls as the page shows
them) to the tab's localStorage, and reads it back with viser's ``local_storage.get_item``
(app.dashboard.links.read_address, app.dashboard.server.Session.confirm_page_state; one script,
``report_to_storage.js``, for both). The other scripts: ``view_sync.js`` gives the page one time
axis (:func:`view_sync`: every time plot's cursor and zoomed range, kept when a tab is hidden and
applied whenever a plot is drawn; the busy sign; the time and range in the address), ``plot_click.js`` (app.dashboard.plot_click) turns a click on a plot into a playback time,
``mark_fields.js`` marks the controls that cannot run (app.dashboard.control_checks), ``label_inputs.js`` ties
each label to its input, ``scroll_to_plot.js`` brings a plot a checkbox added into view. A
script's ``__NAME__`` placeholders are filled with JSON values (:func:`source`).
"""

from __future__ import annotations

import functools
import json
from importlib.resources import files
from typing import Any

import viser
from viser import _messages as viser_messages

from app.figures.shared import CURSOR_NAME

VISER_STORAGE_PREFIX = "viser-user:"  # viser's client prefixes local_storage keys (MessageHandler.tsx)


@functools.cache
def _text(name: str) -> str:
    return (files("app") / "assets" / name).read_text(encoding="utf-8")


def source(name: str, **values: Any) -> str:
    """The script ``app/assets/<name>`` with each ``__KEY__`` placeholder replaced by the JSON of
    ``values[KEY.lower()]`` (``ids=[...]`` fills ``__IDS__``)."""
    text = _text(name)
    for key, value in values.items():
        placeholder = f"__{key.upper()}__"
        if placeholder not in text:
            raise KeyError(f"app/assets/{name} has no placeholder {placeholder}")
        text = text.replace(placeholder, json.dumps(value))
    return text


def report(ids: list[str], prefix: str, key: str) -> str:
    """The script that writes the page's query and the controls ``ids`` as the page shows them to
    its localStorage under ``key`` (dropping answers older than a minute under ``prefix``), for
    ``client.local_storage.get_item(key)``: ``{"t": ms, "search": "?...", "values": {id: value}}``."""
    return source(
        "report_to_storage.js",
        ids=ids,
        prefix=VISER_STORAGE_PREFIX + prefix,
        key=VISER_STORAGE_PREFIX + key,
    )


def mark(bad: dict[str, str], scroll: bool = False) -> str:
    """The script that marks the controls of ``bad`` (viser id -> message: a red outline,
    ``aria-invalid``, the message as the tooltip), clears every other mark, and with ``scroll``
    scrolls the first marked control into view."""
    return source("mark_fields.js", bad=bad, scroll=scroll)


def label_inputs() -> str:
    """The script that gives every control's input its label's text as ``aria-label``, now and
    for controls added later (viser labels the input's row, not the input)."""
    return source("label_inputs.js")


BUSY_DELAY_S = 0.3  # what the user started shows a busy sign once it has taken this long


def view_sync() -> str:
    """The script that installs the page's time axis, once per page (it guards itself):
    ``window.__tauv`` = {t_s, x_range} applied to every plot tagged a time plot
    (app.figures.shared.TIME_META) whenever it is drawn, a zoom, pan or reset of one fanned out to
    all, a hidden tab's plots kept as drawn; :func:`set_time`, :func:`set_range`, :func:`busy`
    and app.dashboard.links.show_address call into it."""
    return source("view_sync.js", cursor_name=CURSOR_NAME, busy_delay_ms=round(BUSY_DELAY_S * 1000))


def set_time(t_s: float) -> str:
    """The script that moves every time plot's cursor to ``t_s`` [s] (only the cursor shape's
    x0/x1 are edited)."""
    return f"window.__tauv && window.__tauv.setTime({float(t_s)!r});"


def set_range(x_range_s: tuple[float, float] | None) -> str:
    """The script that shows ``x_range_s`` ([s], None: each plot's whole time) on every time plot."""
    value = "null" if x_range_s is None else json.dumps([float(x_range_s[0]), float(x_range_s[1])])
    return f"window.__tauv && window.__tauv.setRange({value});"


def busy(on: bool) -> str:
    """The script that shows (after BUSY_DELAY_S) or hides the page's busy sign."""
    return f"window.__tauv && window.__tauv.busy({'true' if on else 'false'});"


SCROLL_WAIT_MS = 10000  # how long the page looks for a plot to scroll to (it is drawn after the script lands)


def scroll_to_plot(title: str) -> str:
    """The script that scrolls the plot whose title starts with ``title`` into view as soon as
    the page has drawn it (a plot a checkbox adds below the others would appear off-screen)."""
    return source("scroll_to_plot.js", title=title, wait_ms=SCROLL_WAIT_MS)


def run(client: viser.ClientHandle, script: str) -> None:
    """Run ``script`` in ``client``'s page."""
    client._websock_connection.queue_message(viser_messages.RunJavascriptMessage(source=script))


__all__ = [
    "BUSY_DELAY_S",
    "VISER_STORAGE_PREFIX",
    "busy",
    "label_inputs",
    "mark",
    "report",
    "run",
    "scroll_to_plot",
    "set_range",
    "set_time",
    "source",
    "view_sync",
]
