"""The workbench's Series tab: any series a run recorded (app.figures.series_catalog: every
method's series, estimates, NEES per block, every aiding source's innovations and flags, the
sources' own states, the raw sensors, the truth) picked into a time plot or an XY plot, as in
PlotJuggler.

The picks are two lines of text the user may also type or paste (names separated by commas):
the time plot's series, and the XY plot's ``X; Y, Y...``. They stay when a new run arrives (a
name the new run lacks is said in the tab's note) and they are kept in the page's address
(app.dashboard.links: ``series`` and ``xy``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import viser

from app.dashboard.session_state import TabState, drawing
from app.figures.series_catalog import Catalog
from app.figures.series_figures import TIME_HINT, XY_HINT, series_time_figure, series_xy_figure
from app.figures.shared import SENT_CURSOR_S, placeholder_figure, with_cursor

INTRO = (
    "Any series of the run against time, or one against another: pick it in **Series** (names are "
    "`method/series`, `method/source/series`, `sensors/...`, `truth/...`, each with its unit), then "
    "**Add to time plot**, or **X axis** and **Add to Y**. The lists below can be typed or pasted too "
    "(names separated by commas; the XY plot's `X; Y, Y`). One Monte Carlo run at a time."
)
NO_RUN = "The run's series show here once a run has results."
ADD_TIME, SET_X, ADD_Y = "Add to time plot", "X axis", "Add to Y"
NO_SERIES: tuple[str, ...] = ("-",)
"""The Series choice before a run (the run's names replace it: ``str``, not the literal "-")."""
MAX_PICKS = 12
"""Series in one plot at most (more are refused, naming the plot)."""


def split_names(text: str) -> list[str]:
    """The names of a pick list: separated by commas, blanks dropped, each once, in order."""
    return list(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))


def parse_xy(text: str) -> tuple[str | None, list[str]]:
    """The XY plot's ``X; Y, Y...`` as (X or None, [Y...])."""
    x_text, _, y_text = text.partition(";")
    return (x_text.strip() or None), split_names(y_text)


def format_xy(x: str | None, ys: list[str]) -> str:
    return f"{x or ''}; {', '.join(ys)}" if x or ys else ""


class SeriesTab:
    """The Series tab's controls and two plots, drawn from ``state.results`` (and the state's
    sensor and truth views)."""

    def __init__(
        self,
        state: TabState,
        workbench: viser.PanelHandle,
        notify: Callable[..., None],
        picks_changed: Callable[[dict[str, str | None]], None] = lambda picks: None,
    ) -> None:
        self.state = state
        self.picks_changed = picks_changed  # the page's address keeps them (app.dashboard.server.Session)
        self.draw_lock = state.draw_lock
        self.notify = notify
        self.catalog: Catalog | None = None
        gui = state.client.gui
        with workbench.add_tab("Series"):
            gui.add_markdown(INTRO)
            self.pick = gui.add_dropdown(
                "Series", NO_SERIES, initial_value=NO_SERIES[0], hint="every series this run recorded"
            )
            self.add_buttons = gui.add_button_group("Pick", (ADD_TIME, SET_X, ADD_Y))
            self.time_text = gui.add_text("Time plot", "", hint="series against time, separated by commas")
            self.xy_text = gui.add_text("XY plot", "", hint="X; Y, Y...")
            self.run = gui.add_number(
                "Series of run", 1, min=1, max=1, step=1, hint="which Monte Carlo run", visible=False
            )
            self.clear_button = gui.add_button("Clear both plots")
            self.note = gui.add_markdown(NO_RUN)
            self.time_plot = gui.add_plotly(
                placeholder_figure("Series against time", TIME_HINT.replace("**", "")), aspect=0.6
            )
            self.xy_plot = gui.add_plotly(
                placeholder_figure("Series against series", XY_HINT.replace("**", "")), aspect=0.9
            )
        self.add_buttons.on_click(lambda event: self._picked(str(event.target.value)))
        self.time_text.on_update(lambda _: self._typed())
        self.xy_text.on_update(lambda _: self._typed())
        self.run.on_update(lambda _: self.draw())
        self.clear_button.on_click(lambda _: self._clear())

    def _typed(self) -> None:
        """A pick list changed: the plots, and the page's address."""
        self.draw()
        self.picks_changed(self.picks())

    def _picked(self, action: str) -> None:
        """A pick button: the dropdown's series added to the time plot, made the XY plot's X, or
        added to its Y (the text fields change; their callbacks draw)."""
        name = self.pick.value
        if self.catalog is None or name not in self.catalog.entries:
            self.notify("Series: nothing picked", "Run, then pick a series in **Series** first.", error=True)
            return
        if action == ADD_TIME:
            names = split_names(self.time_text.value)
            if name not in names:
                self.time_text.value = ", ".join([*names, name])
            return
        x, ys = parse_xy(self.xy_text.value)
        if action == SET_X:
            x = name
        elif name not in ys:
            ys.append(name)
        self.xy_text.value = format_xy(x, ys)

    def _clear(self) -> None:
        self.time_text.value = ""
        self.xy_text.value = ""

    def picks(self) -> dict[str, str | None]:
        """The picks as the page's address keeps them (app.dashboard.links.PICK_KEYS: ``series``,
        ``xy``), None where empty."""
        return {"series": self.time_text.value.strip() or None, "xy": self.xy_text.value.strip() or None}

    def apply_picks(self, view: dict[str, Any]) -> None:
        """The picks a page's address carries (``series``, ``xy``; names this run lacks are said
        when drawn)."""
        if "series" in view:
            self.time_text.value = view["series"]
        if "xy" in view:
            self.xy_text.value = view["xy"]

    @drawing
    def refresh(self) -> None:
        """A run's results arrived: the catalogue of its series, the pick list and the plots."""
        results = self.state.results
        if not results:
            return
        self.catalog = Catalog(results, self.state.sensor_view, self.state.truth_view)
        names = self.catalog.names or NO_SERIES
        if tuple(self.pick.options) != names:
            self.pick.options = names
        if self.run.max != self.catalog.runs:
            self.run.max = self.catalog.runs
            self.run.visible = self.catalog.runs > 1
        self.draw()

    @drawing
    def draw(self) -> None:
        """The two plots of the picks, and the note naming picks this run lacks or too many."""
        catalog = self.catalog
        if catalog is None:
            return
        run = min(max(int(self.run.value), 1), catalog.runs) - 1
        time_names = split_names(self.time_text.value)
        x_name, y_names = parse_xy(self.xy_text.value)
        missing = [
            n for n in (*time_names, *([x_name] if x_name else []), *y_names) if n not in catalog.entries
        ]
        notes = []
        if missing:
            notes.append(f"Not in this run: {', '.join(f'`{n}`' for n in missing)}.")
        for label, names in (("time plot", time_names), ("XY plot", y_names)):
            if len(names) > MAX_PICKS:
                notes.append(f"The {label} draws its first {MAX_PICKS} series of {len(names)}.")
        if catalog.sensor_run is not None and any(n.startswith("sensors/") for n in (*time_names, *y_names)):
            notes.append(f"`sensors/` series are of run {catalog.sensor_run + 1} (the Sensors tab's).")
        note = " ".join(notes)
        if self.note.content != note:
            self.note.content = note
        shown = [catalog.series(n, run) for n in time_names if n in catalog.entries][:MAX_PICKS]
        time_figure = series_time_figure(shown)
        height_px: Any = time_figure.layout["height"]  # plotly's stubs type an item as a figure
        aspect = round(float(height_px or 400) / 480, 2)  # viser: height = aspect x width
        if self.time_plot.aspect != aspect:
            self.time_plot.aspect = aspect
        self.time_plot.figure = with_cursor(time_figure, SENT_CURSOR_S) if shown else time_figure
        x = catalog.series(x_name, run) if x_name in catalog.entries else None
        ys = [catalog.series(n, run) for n in y_names if n in catalog.entries][:MAX_PICKS]
        self.xy_plot.figure = series_xy_figure(x, ys)
