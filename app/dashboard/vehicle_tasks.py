"""The dashboard's Calibrate and Tune on a replayed log, as a worker computes them (app.dashboard.worker):
the same estimates, tables and sections as ``tauv calibrate`` and ``tauv tune`` give on the
command line (app.commands.calibrate, app.commands.tune), with progress and Stop.

Messages put on the queue (after the worker's own ``("end",)`` protocol, app.dashboard.worker):

- ``("vehicle-progress", fraction, text)``: how far the task is (0 to 1) and what it does;
- ``("vehicle-done", kind, report, sections, stopped)``: the printed report (the command's own
  table), the configuration sections it found (section -> key -> value, what ``--out`` would
  hold) and whether Stop ended it early (a tuning's best point so far);
- ``("error", message)``: one line, as a failed run's.
"""

from __future__ import annotations

import os
import time
from typing import Any

from tauvcore.config import METHODS, from_dict

TASKS = ("calibrate", "tune")
"""What the dashboard's "Your vehicle" folder asks a worker to do with the chosen log."""

TUNED_BY_DEFAULT = "lc"
"""The method tuned when none of the ticked methods fuses an aiding source in the 20-state filter."""


def tuned_method(methods: tuple[str, ...]) -> str:
    """The method the dashboard tunes: the first ticked method of the 20-state filter that fuses an
    aiding source (not the standalone INS, not Yoo 2014's 12-state filter, which keeps no
    log det S), else :data:`TUNED_BY_DEFAULT`.

    Parameters
    ----------
    methods : tuple[str, ...]
        The ticked methods, in the dashboard's order.

    Returns
    -------
    str
        A method name of tauvcore.config.METHODS.
    """
    return next((m for m in methods if m in METHODS and m != "ins"), TUNED_BY_DEFAULT)


def run_vehicle_task(
    kind: str, config_dict: dict[str, Any], log_dir: str, queue: Any, stop_event: Any
) -> None:
    """Calibrate (``kind`` ``"calibrate"``) or tune (``"tune"``) on the log ``log_dir`` under the
    configuration the dashboard's controls make of it (the log's own file beneath them), putting
    the messages of the module docstring on ``queue``; Stop (``stop_event.is_set()``) ends a
    tuning at its best point so far. A failure raises: the worker makes it one ``("error",
    line)`` (app.dashboard.worker), the server keeps serving."""
    if kind not in TASKS:
        raise ValueError(f"unknown task {kind!r} (choose from {', '.join(TASKS)})")
    config = from_dict(config_dict)
    from tauvcore.logs.bags import read_recording

    queue.put(("vehicle-progress", 0.0, f"Reading {os.path.basename(os.path.normpath(log_dir))}"))
    log = read_recording(log_dir, config.dvl.A_b)
    name = os.path.basename(os.path.normpath(log_dir))
    if kind == "calibrate":
        report, sections, stopped = _calibrate(name, log, config, queue)
    else:
        report, sections, stopped = _tune(name, log, config, queue, stop_event)
    queue.put(("vehicle-done", kind, report, sections, stopped))


def _calibrate(name: str, log: Any, config: Any, queue: Any) -> tuple[str, dict[str, dict[str, Any]], bool]:
    from app.reports.vehicle_reports import calibration_sections, calibration_table
    from tauvcore.eval.calibration import calibrate

    queue.put(("vehicle-progress", 0.2, "Calibrating: the DVL's alignment and the IMU's boresight"))
    result = calibrate([(name, log, config)])
    return calibration_table(result), calibration_sections(result), False


def _tune(
    name: str, log: Any, config: Any, queue: Any, stop_event: Any
) -> tuple[str, dict[str, dict[str, Any]], bool]:
    from app.reports.vehicle_reports import report
    from tauvcore.eval import tuning

    method = tuned_method(config.run.methods)
    case = tuning.TuningLog(name, log, config.replace("run", methods=(method,)))
    names = tuning.DEFAULT_PARAMETERS
    started = time.perf_counter()
    queue.put(("vehicle-progress", 0.0, f"Tuning {method.upper()}: reading the log"))
    prepared = tuning.PreparedLog(case)
    start = tuning.start_values([case], names)
    # the search's evaluations and the curvature's (2 n^2 + 1 at most) make the whole
    expected = tuning.MAX_EVALUATIONS + 2 * len(names) ** 2 + 1

    def progress(ev: Any) -> None:
        queue.put(
            (
                "vehicle-progress",
                min(0.99, ev.count / expected),
                (
                    f"Tuning {method.upper()}: evaluation {ev.count} ({ev.phase}), "
                    f"-log likelihood {ev.best_nll:,.1f}"
                ),
            )
        )

    result = tuning.tune([prepared], names, start=start, progress=progress, should_stop=stop_event.is_set)
    before_values = tuning.parameter_values(case.config, names)
    before = prepared.results(before_values, tuning=False)[method]
    after = prepared.results(result.tuned, tuning=False)[method]
    text = report(
        result,
        before_values,
        [(case, before, after)],
        start.still is not None,
        time.perf_counter() - started,
        False,
    )
    return text, tuning.tuned_sections(result), bool(result.stopped)
