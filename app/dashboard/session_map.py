"""The workbench's Map tab: the north-east map of the truth and every method's track with their
position ellipses (app.figures.map_figures), following the time cursor.

The map is drawn with the deferred plots (app.dashboard.session_plots.PLOT_GROUPS) and when its
options change. When the time slider moves only the cursor's traces move: the server reckons
their points at the new time and the page restyles those traces alone (``map_cursor.js``), a few
kilobytes instead of the whole figure.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import viser

from app.dashboard import page_scripts
from app.dashboard.session_state import TabState, drawing
from app.figures.map_figures import COLOUR_BY, MapTrack, cursor_traces, map_figure, map_tracks
from app.figures.shared import placeholder_figure
from tauvcore.engine.results import MethodResult
from tauvcore.eval.events import run_events

MAP_ASPECT = 1.1  # the map's height / width (viser), room for the legend below a square map
MAP_NOTE = (
    "Seen from above, north up: the truth (dotted) and each method's track, with its filter's 1-sigma "
    "(solid) and 3-sigma (dashed) horizontal position ellipses at the time cursor and, paler, every "
    "{every:g} s along the track. A consistent filter keeps the truth's cross inside its 3-sigma ellipse "
    "about 99 % of the time. Methods without a position state (VKF, INS-DVL) have no ellipse. "
    "The run's events lie on the truth's track (the Plots tab's Events box). The view fits the truth and "
    "the aided tracks; the autoscale button shows all. Click a track or an event to go to that time."
)
EVERY_CHOICES = ("10", "20", "50", "0")
"""The seconds between two ellipse pairs along a track the tab offers (0: none)."""
_KEYS = itertools.count(1)  # names each map figure drawn, so the page's cursor moves only its own


def _truth(state: TabState) -> tuple[np.ndarray, np.ndarray]:
    """The truth's epochs (N,) [s] and north-east positions (N, 2) [m] of the tab's run (empty: none)."""
    tv = state.truth_view
    if tv is None or len(tv["t_s"]) == 0:
        return np.zeros(0), np.zeros((0, 2))
    return np.asarray(tv["t_s"], dtype=float), np.asarray(tv["pos_n"], dtype=float)[:, :2]


class MapRoom:
    """The Map tab (added to ``workbench``): its options, the map and the cursor's moves."""

    def __init__(self, state: TabState, workbench: viser.PanelHandle) -> None:
        self.state = state
        self.draw_lock = state.draw_lock
        gui = state.client.gui
        with workbench.add_tab("Map"):
            self.colour_by = gui.add_dropdown(
                "Colour by",
                COLOUR_BY,
                initial_value=COLOUR_BY[0],
                hint="each track in its method's colour, or marked by its horizontal error against the "
                "truth, or by how many DVL beams returned at the latest ping",
            )
            self.every_s = gui.add_dropdown(
                "Ellipses every [s]", EVERY_CHOICES, initial_value="20", hint="along the track; 0: none"
            )
            self.run = gui.add_number(
                "Run", 1, min=1, max=1, step=1, hint="which Monte Carlo run", visible=False
            )
            self.smoothed = gui.add_checkbox(
                "Smoothed",
                False,
                disabled=True,
                hint="the smoother's tracks and ellipses (a run with the smoother)",
            )
            self.note = gui.add_markdown(MAP_NOTE.format(every=20.0))
            self.plot = gui.add_plotly(placeholder_figure("Map"), aspect=MAP_ASPECT)
        self.tracks: list[MapTrack] = []
        self.truth = _truth(state)
        self.key = ""
        self.first_cursor = 0
        for handle in (self.colour_by, self.every_s, self.run, self.smoothed):
            handle.on_update(lambda _: self.redraw())

    @drawing
    def redraw(self) -> None:
        """Draw the map of the tab's results again (an option changed)."""
        if self.state.results:
            self.draw(self.state.results)

    def draw(self, results: dict[str, MethodResult]) -> None:
        """Draw the map of ``results`` at the tab's cursor (called under the draw lock)."""
        runs = max((r.est_pos_n.shape[1] for r in results.values() if len(r.t_s)), default=1)
        if self.run.max != runs:
            self.run.max = runs
            self.run.visible = runs > 1
        smoothed = any(r.smoothed is not None for r in results.values())
        if self.smoothed.disabled == smoothed:
            self.smoothed.disabled = not smoothed
        run = min(max(int(self.run.value), 1), runs) - 1
        self.tracks = map_tracks(results, run=run, smoothed=smoothed and self.smoothed.value)
        self.truth = _truth(self.state)
        self.key = f"map {next(_KEYS)}"
        every = float(self.every_s.value)
        config = self.state.config
        events = run_events(results, config, run) if self.state.events_shown and config is not None else None
        figure = map_figure(
            self.tracks,
            *self.truth,
            t=self.state.cursor_t or 0.0,
            colour_by=self.colour_by.value,
            every_s=every,
            key=self.key,
            events=events,
        )
        meta: Any = figure.layout["meta"]  # plotly's stubs type an item as a figure
        self.first_cursor = int(meta["cursor"])
        note = MAP_NOTE.format(every=every) + (f" Run {run + 1} of {runs}." if runs > 1 else "")
        if self.note.content != note:
            self.note.content = note
        self.plot.figure = figure

    def move_cursor(self, t_s: float) -> None:
        """Move the map's cursor traces to ``t_s`` [s] in the page (only those traces)."""
        if not self.tracks:
            return
        points = cursor_traces(self.tracks, *self.truth, t_s)
        script = page_scripts.source(
            "map_cursor.js",
            key=self.key,
            first=self.first_cursor,
            x=[x for x, _ in points],
            y=[y for _, y in points],
        )
        page_scripts.run(self.state.client, script)


__all__ = ["MAP_ASPECT", "MapRoom"]
