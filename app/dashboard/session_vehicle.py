"""The Mission tab's "Your vehicle" folder: Calibrate and Tune on the chosen log, run by a worker
(app.dashboard.vehicle_tasks) with the progress bar and Stop of a run, the command's own report shown, and
Apply laying what was found over the log's own configuration (the controls it has filled in, the
rest applied at Run: app.dashboard.session_controls.ControlPanel.vehicle_sections)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import viser

from tauvcore.config import merge

INTRO = (
    "On a replayed log with a reference. **Calibrate** estimates the DVL's mounting misalignment "
    "and scale factor and the IMU-to-reference boresight (`tauv calibrate`); **Tune** finds the "
    "noise of the first ticked DVL method (LC when none) by the likelihood of its innovations "
    "(`tauv tune`). Both run on a worker; **Stop** ends them. **Apply** lays the result over the "
    "log's own configuration for the next Run."
)
"""What the folder says before anything was found."""


def result_markdown(kind: str, source: str, report: str, stopped: bool) -> str:
    """The task's report as the folder shows it: a heading naming what was done on which log, the
    command's own table in a code block (its columns aligned), and a word when Stop ended it."""
    what = "Calibration" if kind == "calibrate" else "Tuning"
    note = "\n\n*Stopped: the best point so far.*" if stopped else ""
    return f"**{what} of {source}**{note}\n\n```\n{report.rstrip()}\n```"


class VehiclePanel:
    """The folder's controls; what they start is the session's (``start``: kind -> None)."""

    def __init__(self, gui: viser.GuiApi, start: Callable[[str], None], apply: Callable[[], None]) -> None:
        with gui.add_folder("Your vehicle: calibrate and tune", expand_by_default=False):
            gui.add_markdown(INTRO)
            self.calibrate_button = gui.add_button("Calibrate", hint="tauv calibrate on the chosen log")
            self.tune_button = gui.add_button("Tune", hint="tauv tune on the chosen log")
            self.result = gui.add_markdown("")
            self.apply_button = gui.add_button("Apply", disabled=True, hint="use the result at the next Run")
        self.calibrate_button.on_click(lambda _: start("calibrate"))
        self.tune_button.on_click(lambda _: start("tune"))
        self.apply_button.on_click(lambda _: apply())
        self.found: tuple[str, dict[str, Any]] | None = None  # (log, sections) Apply would apply

    def busy(self, running: bool) -> None:
        """Calibrate and Tune disabled while anything runs in this tab."""
        self.calibrate_button.disabled = self.tune_button.disabled = running

    def show(self, kind: str, source: str, report: str, sections: dict[str, Any], stopped: bool) -> None:
        """Show a finished task's report and offer its sections to Apply."""
        self.result.content = result_markdown(kind, source, report, stopped)
        self.found = (source, sections) if sections else None
        self.apply_button.disabled = self.found is None


def applied(previous: dict[str, Any], sections: dict[str, Any]) -> dict[str, Any]:
    """The sections a log runs with after Apply: those applied before with the new ones over them
    (a calibration, then a tuning: both stand)."""
    return merge(previous, sections)
