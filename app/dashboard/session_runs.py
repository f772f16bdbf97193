"""The results and kept runs of a dashboard tab: the workbench's Results tab (the summary
tables, the finished run's downloads, its configuration) and Runs tab (every finished run kept
with its configuration, ticked to overlay in the plots and compare side by side).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import viser

from app.dashboard import export
from app.dashboard.session_state import TabState, drawing
from app.reports.markdown_tables import compare_markdown, config_diff_markdown
from app.reports.settings_text import flat_config, has_smoothed, run_words
from tauvcore.config import Config
from tauvcore.engine.results import MethodResult

KEPT_RUNS_MAX = 5  # finished runs kept for comparison (memory: each holds its full results)
RUNS_NOTE = (
    f"Every finished run is kept here with its configuration until removed (at most {KEPT_RUNS_MAX}: the "
    "oldest goes when another finishes). Tick two or more to overlay them in the Plots tab (one line style per "
    "run, the method colours kept) and to compare them below. Pressing Run clears the ticks, so the plots "
    "show the new run."
)


@dataclasses.dataclass(frozen=True)
class KeptRun:
    """A finished run kept in the Runs tab for comparison."""

    number: int  # 1, 2, ... in the order the tab's runs finished
    config: Config  # what ran
    runs: int  # Monte Carlo runs
    results: dict[str, MethodResult]  # its final results
    source: str | None = None  # the replayed log's name; None for a simulated mission

    @property
    def label(self) -> str:
        return f"run {self.number}"

    def description(self) -> str:
        """What tells this run from the others: the mission or log, its length, the seed, the
        methods, then every setting that differs from the defaults (current, water-track, sources,
        outages, sensors, the smoother...: app.reports.settings_text.run_words)."""
        return ", ".join(run_words(self.config, self.runs, self.source, has_smoothed(self.results.values())))


def _compared(kept: KeptRun) -> dict[str, Any]:
    """What the Runs tab compares of ``kept``: its settings (app.reports.settings_text.flat_config),
    its runs, the log it replayed and whether it was smoothed."""
    return {
        "source": f"log {kept.source}" if kept.source is not None else "simulation",
        **flat_config(kept.config, kept.runs),
        "smoother": has_smoothed(kept.results.values()),
    }


class RunTabs:
    """The Results and Runs tabs (added to ``workbench``)."""

    def __init__(
        self,
        state: TabState,
        workbench: viser.PanelHandle,
        refresh_plots: Callable[[], None],
        schedule_diagnostics: Callable[[], None],
        notify: Callable[..., None],
    ) -> None:
        self.client = state.client
        self.draw_lock = state.draw_lock
        self.refresh_plots = refresh_plots  # redraw the plots (an overlay ticked or unticked)
        self.schedule_diagnostics = schedule_diagnostics  # a kept run's widgets come with the diagnostics
        self.notify = notify
        self.finished_run: export.FinishedRun | None = None  # what the Download buttons send
        self.kept_runs: list[KeptRun] = []
        self.kept_widgets: dict[int, Any] = {}  # run number -> its folder in the Runs tab
        self.run_number = 0
        self._clearing = False  # clear_overlay is unticking the boxes: their callbacks wait
        gui = self.client.gui
        with workbench.add_tab("Results"):
            self.table = gui.add_markdown("No run yet.")
            with gui.add_folder("Download"):
                # the finished run's results as the CLI writes them, and an offline report (app.dashboard.export)
                self.download_buttons = {
                    kind: gui.add_button(
                        label, disabled=True, icon=viser.Icon.DOWNLOAD, hint=export.FORMAT_HINTS[kind]
                    )
                    for kind, label in export.FORMATS.items()
                }
            self.run_config = gui.add_markdown("")
        with workbench.add_tab("Runs"):
            gui.add_markdown(RUNS_NOTE)
            self.runs_folder = gui.add_folder("Kept runs")
            with self.runs_folder:
                self.no_runs = gui.add_markdown("No finished run yet.")
            self.diff_table = gui.add_markdown("")
            self.compare_table = gui.add_markdown("")
        for kind, button in self.download_buttons.items():
            button.on_click(lambda _, kind=kind: self.download(kind))

    def keep_run(self, config: Config, results: dict[str, MethodResult], source: str | None = None) -> None:
        """Keep a finished run in the Runs tab (its description, an Overlay checkbox, a Remove
        button); beyond KEPT_RUNS_MAX the oldest goes, as the tab's note says (no notification:
        the run's own closing notification is the one a user waits for). ``source``: the
        replayed log's name (None: a simulated mission)."""
        with self.draw_lock:
            self.run_number += 1
            kept = KeptRun(
                self.run_number,
                config,
                int(next(iter(results.values())).vel_err_mps.shape[1]),
                results,
                source,
            )
            self.kept_runs.append(kept)
            dropped, self.kept_runs = self.kept_runs[:-KEPT_RUNS_MAX], self.kept_runs[-KEPT_RUNS_MAX:]
            overlaid = any(
                old.number in self.kept_widgets and self.kept_widgets[old.number][1].value for old in dropped
            )
            for old in dropped:
                if old.number in self.kept_widgets:
                    self.kept_widgets.pop(old.number)[0].remove()
            if overlaid:
                self.refresh_runs()
            self.schedule_diagnostics()  # its widgets come with the diagnostics, once the tab is still

    def add_run_widgets(self) -> None:
        """The Runs tab's entries (description, Overlay checkbox, Remove button) of kept runs that
        have none yet (called under the draw lock, from the diagnostics' thread)."""
        gui = self.client.gui
        added = []
        for kept in self.kept_runs:
            if kept.number in self.kept_widgets:
                continue
            self.no_runs.visible = False
            with self.runs_folder:
                folder = gui.add_folder(f"Run {kept.number}")
                with folder:
                    gui.add_markdown(kept.description())
                    box = gui.add_checkbox(
                        f"Overlay run {kept.number}",
                        False,
                        hint="overlay this run in the Plots tab and compare it below",
                    )
                    button = gui.add_button(f"Remove run {kept.number}", color="red")
            self.kept_widgets[kept.number] = (folder, box)
            box.on_update(lambda _: None if self._clearing else self.refresh_runs())
            button.on_click(lambda _, n=kept.number: self.remove_run(n))
            added.append(kept)
        if added:
            self.refresh_runs(redraw=False)  # a new run is not ticked: the plots stay

    def remove_run(self, number: int) -> None:
        """Forget kept run ``number`` and its widgets."""
        with self.draw_lock:
            self.kept_runs = [r for r in self.kept_runs if r.number != number]
            widgets = self.kept_widgets.pop(number, None)
            if widgets is not None:
                widgets[0].remove()
            self.no_runs.visible = not self.kept_runs
            self.refresh_runs()

    def overlay_runs(self) -> list[KeptRun]:
        """The kept runs ticked for overlay, oldest first."""
        return [
            r
            for r in self.kept_runs
            if r.number in self.kept_widgets and self.kept_widgets[r.number][1].value
        ]

    @drawing
    def refresh_runs(self, redraw: bool = True) -> None:
        """The Runs tab's comparison (configuration differences above the results side by side)
        and (``redraw``) the Plots tab's overlay, for the runs ticked."""
        overlay = self.overlay_runs()
        if len(overlay) >= 2:
            self.diff_table.content = config_diff_markdown(
                [r.label for r in overlay], [_compared(r) for r in overlay]
            )
            self.compare_table.content = "**Results side by side**\n\n" + compare_markdown(
                [(r.label, r.results) for r in overlay]
            )
        else:
            self.diff_table.content = "Tick two or more runs to compare them." if self.kept_runs else ""
            self.compare_table.content = ""
        if redraw:
            self.refresh_plots()

    def set_finished(self, run: export.FinishedRun | None) -> None:
        """Keep ``run``, whose final results arrived, for the Download buttons and enable them
        (None: a new run started, they are disabled until it ends, and the overlay is cleared so
        that the plots show the new run, not the kept ones)."""
        self.finished_run = run
        for button in self.download_buttons.values():
            button.disabled = run is None
        if run is None:
            self.clear_overlay()

    def clear_overlay(self) -> None:
        """Untick every kept run's Overlay box (the plots then draw the current run alone)."""
        with self.draw_lock:
            ticked = [box for _, box in self.kept_widgets.values() if box.value]
            self._clearing = True
            try:
                for box in ticked:
                    box.value = False  # viser calls the box's callback here, synchronously
            finally:
                self._clearing = False
            if ticked:
                self.refresh_runs(redraw=False)  # the new run's own drawing follows

    def download(self, kind: str) -> None:
        """Send the finished run as ``kind`` (app.dashboard.export.FORMATS) to this tab; a notification,
        never a traceback, when there is none or it cannot be made."""
        try:
            export.send(self.client, kind, self.finished_run)
        except export.ExportError as exc:
            self.notify("Cannot download", str(exc), error=True)
        except Exception as exc:  # noqa: BLE001 - a fault of ours: said in the tab, the server keeps serving
            self.notify(
                "Cannot download",
                f"{export.FORMATS.get(kind, kind)}: {type(exc).__name__}: {exc}",
                error=True,
            )
