"""Clicking a plot moves the playback: one timeline for the plots and the scene.

viser 1.1 draws plotly figures but tells the server nothing of a click on them (no plotly event
reaches Python). The page does run the scripts the server sends (app.dashboard.links explains the channel),
so at connect a script (app/assets/plot_click.js) listens for plotly's ``plotly_click`` on every figure of
the page, the ones drawn later too, and writes the clicked point's time into the Playback folder's
"Go to [s]" field, as if typed: viser then sends the field's new value, and the dashboard moves the
time slider there (app.dashboard.server.Session.go_to). The field is an ordinary control too: a time typed
into it moves the playback the same way.

Every plot of the workbench has the mission time in seconds on its x axis (app.figures.shared), so the
clicked point's ``x`` is the time to show. A click between points takes the nearest point in x
(plotly's ``hovermode`` "x unified"), so any click inside a plot's area moves the playback.
"""

from __future__ import annotations

import math

import viser

from app.dashboard import page_scripts

GO_TO_LABEL = "Go to [s]"
GO_TO_HINT = "type a mission time, or click any plot: the playback moves there"
# viser's label[for] names the row, not the Mantine input: the input follows the label's row
_FIELD_XPATH = (
    '//label[normalize-space()="{label}"]/../../following-sibling::*[1]//input[not(@type="hidden")]'
)


def script() -> str:
    """The page script, with the field's locator filled in."""
    return page_scripts.source("plot_click.js", xpath=_FIELD_XPATH.format(label=GO_TO_LABEL))


def install(client: viser.ClientHandle) -> None:
    """Send app/assets/plot_click.js to ``client``'s page (once per page: the script guards itself)."""
    page_scripts.run(client, script())


def parse_go_to_s(text: str, t_max_s: float) -> float | None:
    """The time the "Go to [s]" field asks for, within [0, ``t_max_s``]; None for an empty field.
    Raises ValueError naming the field and the value for anything but a finite number."""
    stripped = text.strip()
    if stripped == "":
        return None
    try:
        t_s = float(stripped)
    except ValueError:
        raise ValueError(f"{GO_TO_LABEL}: {stripped!r} is not a number of seconds") from None
    if not math.isfinite(t_s):
        raise ValueError(f"{GO_TO_LABEL}: {stripped!r} is not a finite time")
    return min(max(t_s, 0.0), float(t_max_s))


__all__ = ["GO_TO_HINT", "GO_TO_LABEL", "install", "parse_go_to_s", "script"]
