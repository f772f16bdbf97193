"""A simulated log replays as its run: ``tauv run --save-log`` then ``tauv replay --initial-errors``
with the run's seed gives the run's errors and consistency to 1e-9, on every trajectory and
truth and for both filter banks (the 20-state methods and Yoo 2014's 12-state ``ins-dvl`` and
``vkf``): the log carries the run's configuration (``log.toml``) and the replay draws the
filters' initial errors as the run did."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tauvcore.truth import TRAJECTORIES, TRUTH_SOURCES

METHODS = "ins,lc,tc,ins-dvl,vkf"
SERIES = ("pos_err_m", "vel_err_mps", "tilt_err_deg", "heading_err_deg", "vel_sigma_mps", "pos_sigma_m",
          "nees_pos", "nees_vel", "nees_tilt", "nees_heading")
"""What a log can judge: its reference gives the navigation errors; it holds no truth of the sensor
errors (biases, scale factor), so the full and the sensor block's NEES are unknown on a replay."""


def _json(out: Path, *argv: str) -> dict:
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", *argv, "--json", str(out)],
        check=False,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(out.read_text())


@pytest.mark.parametrize("truth", TRUTH_SOURCES)
@pytest.mark.parametrize("trajectory", TRAJECTORIES)
def test_replay_of_a_simulated_log_equals_its_run(trajectory: str, truth: str, tmp_path: Path) -> None:
    seed = str(5 + TRAJECTORIES.index(trajectory))
    ran = _json(tmp_path / "run.json", "run", "--trajectory", trajectory, "--truth", truth, "--duration", "60",
                "--method", METHODS, "--seed", seed, "--save-log", str(tmp_path / "log"))
    replayed = _json(tmp_path / "replay.json", "replay", str(tmp_path / "log"), "--method", METHODS,
                     "--initial-errors", "--seed", seed)
    assert set(replayed["results"]) == set(ran["results"]) == set(METHODS.split(","))
    compared = 0
    for method, series in ran["results"].items():
        for name in SERIES:
            if name not in series:
                continue
            a = np.array(series[name], dtype=float)
            b = np.array(replayed["results"][method][name], dtype=float)
            assert a.shape == b.shape, f"{method} {name}"
            assert np.array_equal(np.isnan(a), np.isnan(b)), f"{method} {name}: NaN at other epochs"
            if np.isnan(a).all():
                continue
            scale = max(1.0, float(np.nanmax(np.abs(a))))
            np.testing.assert_allclose(b, a, rtol=0.0, atol=1e-9 * scale, err_msg=f"{method} {name}")
            compared += 1
        assert ran["results"][method]["diverged_at_s"] == replayed["results"][method]["diverged_at_s"]
        for name in ("nees", "nees_sensor"):
            assert np.isnan(np.array(replayed["results"][method][name], dtype=float)).all(), f"{method} {name}"
    assert compared >= 30
