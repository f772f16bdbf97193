"""The workbench's Spread tab: how a Monte Carlo's runs spread around the curves the other tabs
draw (the RMS of the errors, the mean NEES over the runs).

For the chosen method its runs' velocity and position errors against time, the median and the
5-95 % band over the runs; every method's final errors as histograms; every NEES block's mean
over the runs against its 95 % and 99 % bands for that many runs (app.figures.spread_figures).
Drawn once a Monte Carlo's results are final (:meth:`SpreadTab.show` with ``live`` False), not at
every live update; a single run shows a hint instead of plots of one line each.
"""

from __future__ import annotations

import plotly.graph_objects as go
import viser

from app.dashboard.session_state import TabState
from app.figures.shared import SENT_CURSOR_S, with_cursor
from app.figures.spread_figures import (
    MAX_RUNS_DRAWN,
    final_errors_figure,
    nees_blocks_figure,
    runs_figure,
)
from tauvcore.engine.results import MethodResult

SINGLE_RUN_HINT = (
    "Run a Monte Carlo (Runs > 1) to see the spread: each run's errors, their median and "
    "5-95 % band over time, histograms of the final errors and the NEES of every block against its "
    "bands. **Runs** is in the Mission tab's Run folder."
)
INITIAL_METHODS: tuple[str, ...] = ("lc",)
"""The method choices before a Monte Carlo (its own replace them): any method name, so ``str``."""
RUNNING_NOTE = "The spread of the {runs} runs is drawn when the Monte Carlo ends."
SPREAD_NOTE = (
    "How the {runs} runs spread. Top: the chosen method's velocity and position errors, a pale line per "
    "run (at most {most} drawn), their median (black) and the band from the 5th to the 95th percentile "
    "over all the runs at each epoch. Middle: every method's errors at the last epoch, one count per run. "
    "Bottom: each NEES block's mean over the runs divided by its dimension (1 = consistent), against the "
    "95 % and 99 % bands of a consistent filter's mean of {runs} runs: outside them most of the time, "
    "the filter's covariance does not describe its errors."
)
PLOT_WIDTH_PX = 480  # the workbench's plot width a figure's height is reckoned against (viser: aspect)


def num_runs(results: dict[str, MethodResult]) -> int:
    """The runs R of ``results`` (the most of any method's series; 1 for none)."""
    return max((r.vel_err_mps.shape[1] for r in results.values()), default=1)


class SpreadTab:
    """The Spread tab of the workbench (``workbench``): a note, the method whose runs are drawn,
    and three plots, hidden until a Monte Carlo's results are final."""

    def __init__(self, state: TabState, workbench: viser.PanelHandle) -> None:
        self.state = state
        gui = state.client.gui
        with workbench.add_tab("Spread"):
            self.note = gui.add_markdown(SINGLE_RUN_HINT)
            self.method = gui.add_dropdown(
                "Spread of",
                INITIAL_METHODS,
                initial_value=INITIAL_METHODS[0],
                hint="the method whose runs are drawn",
                visible=False,
            )
            self.runs_plot = gui.add_plotly(go.Figure(), aspect=0.9, visible=False)
            self.final_plot = gui.add_plotly(go.Figure(), aspect=0.9, visible=False)
            self.nees_plot = gui.add_plotly(go.Figure(), aspect=1.5, visible=False)
        self.plots = (self.runs_plot, self.final_plot, self.nees_plot)
        self.drawn: dict[str, MethodResult] | None = None  # the results the plots show
        self.choosing = False  # show() sets the dropdown's choices (its callback draws nothing)
        self.chosen: str | None = None  # the method the user picked, kept across runs that have it
        self.method.on_update(lambda _: self._method_chosen())

    def show(self, results: dict[str, MethodResult], live: bool) -> None:
        """The tab for ``results`` (called under the tab's draw lock): the hint for a single run, a
        note while a Monte Carlo runs (``live``), its spread once its results are final; the same
        results drawn once."""
        if results is self.drawn:
            return
        runs = num_runs(results)
        methods = tuple(m for m, r in results.items() if len(r.t_s))
        if runs < 2 or not methods or live:
            self.drawn = None
            self._set_note(SINGLE_RUN_HINT if runs < 2 or not methods else RUNNING_NOTE.format(runs=runs))
            self._set_visible(False)
            return
        self.drawn = results
        self.choosing = True  # the choices change: drawn below, not by the dropdown's callback
        try:
            if tuple(self.method.options) != methods:
                self.method.options = methods
            # the user's pick if this run has it, else the first aided method (INS's spread dwarfs theirs)
            wanted = (
                self.chosen
                if self.chosen in methods
                else next((m for m in methods if m != "ins"), methods[0])
            )
            if self.method.value != wanted:
                self.method.value = wanted
        finally:
            self.choosing = False
        self._draw_runs()
        t = SENT_CURSOR_S
        self._place(self.final_plot, final_errors_figure(results))
        self._place(self.nees_plot, with_cursor(nees_blocks_figure(results), t))
        self._set_note(SPREAD_NOTE.format(runs=runs, most=MAX_RUNS_DRAWN))
        self._set_visible(True)

    def _method_chosen(self) -> None:
        with self.state.draw_lock:
            if self.drawn is not None and not self.choosing:
                self.chosen = self.method.value
                self._draw_runs()

    def _draw_runs(self) -> None:
        results = self.drawn
        if results is None or self.method.value not in results:
            return
        method = self.method.value
        self._place(self.runs_plot, with_cursor(runs_figure(method, results[method]), SENT_CURSOR_S))

    @staticmethod
    def _place(handle: viser.GuiPlotlyHandle, figure: go.Figure) -> None:
        """``figure`` into ``handle``, sized for its height (viser sets a plot's height as aspect x width)."""
        height_px: object = figure.layout["height"]
        aspect = round(float(height_px) / PLOT_WIDTH_PX, 2) if isinstance(height_px, (int, float)) else 0.9
        if handle.aspect != aspect:
            handle.aspect = aspect
        handle.figure = figure

    def _set_note(self, text: str) -> None:
        if self.note.content != text:
            self.note.content = text

    def _set_visible(self, shown: bool) -> None:
        for handle in (self.method, *self.plots):
            if handle.visible != shown:
                handle.visible = shown
