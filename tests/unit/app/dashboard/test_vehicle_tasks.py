"""The dashboard's Calibrate and Tune as a worker runs them (app.dashboard.vehicle_tasks): the messages, the
report the command line prints, the sections Apply lays over the log's own configuration, Stop,
and a failure left to the worker to turn into one line."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from app.dashboard.session_vehicle import applied, result_markdown
from app.dashboard.vehicle_tasks import run_vehicle_task, tuned_method
from app.reports.vehicle_reports import calibration_sections, calibration_table
from tauvcore.config import Config, from_dict, to_dict
from tauvcore.eval.calibration import calibrate
from tauvcore.logs import CONFIG_FILE, read_log


class ListQueue:
    def __init__(self) -> None:
        self.messages: list[tuple] = []

    def put(self, message: tuple) -> None:
        self.messages.append(message)


class StopAfter:
    """Stop pressed once ``n`` progress messages have arrived on ``queue``."""

    def __init__(self, queue: ListQueue, n: int | None) -> None:
        self.queue, self.n = queue, n

    def is_set(self) -> bool:
        progress = sum(m[0] == "vehicle-progress" for m in self.queue.messages)
        return self.n is not None and progress >= self.n


@pytest.fixture(scope="module")
def misaligned_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A figure eight's log whose DVL head is mounted 1 deg off in yaw (the filters do not know)."""
    tmp = tmp_path_factory.mktemp("vehicle")
    config = tmp / "c.toml"
    config.write_text('[dvl]\nmisalignment_deg = [0.0, 0.0, 1.0]\n', encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--trajectory", "figure8", "--duration", "200", "--method", "lc",
         "--seed", "2", "--config", str(config), "--save-log", str(tmp / "log")],
        check=False, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return tmp / "log"


def _config(log: Path) -> dict:
    raw = tomllib.loads((log / CONFIG_FILE).read_text(encoding="utf-8"))
    return to_dict(from_dict(raw).replace("run", methods=("ins", "tc")))


def test_calibrate_task_reports_as_the_command_and_offers_its_section(misaligned_log: Path) -> None:
    queue = ListQueue()
    run_vehicle_task("calibrate", _config(misaligned_log), str(misaligned_log), queue, StopAfter(queue, None))
    kinds = [m[0] for m in queue.messages]
    assert kinds[0] == "vehicle-progress" and kinds[-1] == "vehicle-done" and "error" not in kinds
    _, kind, report, sections, stopped = queue.messages[-1]
    config = from_dict(tomllib.loads((misaligned_log / CONFIG_FILE).read_text(encoding="utf-8")))
    expected = calibrate([("log", read_log(misaligned_log), config)])
    assert kind == "calibrate" and not stopped
    assert report == calibration_table(expected)
    assert sections == calibration_sections(expected)
    yaw = sections["calibration"]["dvl_misalignment_deg"][2]
    assert abs(yaw - 1.0) < 3 * expected.dvl.sigma[2]
    # Apply: over the log's own file, then a later tuning's sections over both
    laid = applied(sections, {"dvl": {"noise_mps": 0.03}})
    assert laid["calibration"] == sections["calibration"] and laid["dvl"] == {"noise_mps": 0.03}
    assert from_dict(laid).calibration.dvl_misalignment_deg[2] == pytest.approx(yaw)
    shown = result_markdown(kind, "log", report, stopped)
    assert shown.startswith("**Calibration of log**") and report.splitlines()[0] in shown


def test_tune_task_stops_at_its_best_point_so_far(misaligned_log: Path) -> None:
    """Stop after three evaluations: the task ends with the best point so far, marked stopped, and
    its sections are the tuned keys of the method Tune picked (TC: the first ticked DVL method)."""
    queue = ListQueue()
    run_vehicle_task("tune", _config(misaligned_log), str(misaligned_log), queue, StopAfter(queue, 4))
    assert queue.messages[-1][0] == "vehicle-done", queue.messages[-1]
    _, kind, report, sections, stopped = queue.messages[-1]
    assert kind == "tune" and stopped
    assert "TC" in report or "tc" in report
    assert set(sections) <= {"imu", "dvl"} and sections
    tuned = from_dict(sections)
    assert tuned.dvl.noise_mps > 0.0


def test_a_task_failure_is_raised_for_the_worker(tmp_path: Path) -> None:
    queue = ListQueue()
    with pytest.raises(Exception):  # noqa: B017, PT011 - whatever the reader raises, the worker words it
        run_vehicle_task("calibrate", to_dict(Config()), str(tmp_path / "missing"), queue, StopAfter(queue, None))
    with pytest.raises(ValueError, match="unknown task"):
        run_vehicle_task("guess", to_dict(Config()), str(tmp_path), queue, StopAfter(queue, None))


def test_tuned_method_is_the_first_ticked_dvl_method() -> None:
    assert tuned_method(("ins", "tc", "lc")) == "tc"
    assert tuned_method(("ins", "ins-dvl")) == "lc"
    assert tuned_method(()) == "lc"
