"""Yoo 2014's methods (``ins-dvl``, ``vkf``) on a replayed log: judged by the monitor on what a log
gives (no true IMU biases), and equal to the run the log was written from."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from tauvcore.config import YOO_METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.replay import replay
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log

SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "tilt_err_deg", "heading_err_deg", "vel_sigma_mps",
          "att_sigma_deg", "est_pos_n", "est_vel_n")


def test_yoo_methods_replay_unflagged_and_equal_to_their_run(tmp_path: Path) -> None:
    """A simulated log replayed with ``ins-dvl,vkf`` and the run's initial errors: no method flagged
    (a log's unknown IMU biases leave the NEES unknown, not the filter diverged), every series and
    every DVL decision the run's to 1e-9."""
    config = (Config().replace("trajectory", name="figure8", duration_s=40.0)
              .replace("run", methods=YOO_METHODS, aiding=("dvl",)))
    rng = np.random.default_rng(3)
    sim = simulate(config, rng)
    ours = run(config, sim, rng)
    write_log(tmp_path, simulation_tables([SimChunk.whole(sim)]), "csv")
    _, back = replay(config.replace("replay", initial_errors=True), read_log(tmp_path), np.random.default_rng(3))
    for method in YOO_METHODS:
        assert not ours[method].diverged.any(), method
        assert not back[method].diverged.any(), f"{method} flagged at {back[method].diverged_at_s} s"
        assert np.isnan(back[method].diverged_at_s).all(), method
        assert np.isnan(back[method].nees).all()                   # the true IMU biases are unknown
        for name in SERIES:
            a, b = getattr(ours[method], name), getattr(back[method], name)
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * max(np.abs(a).max(), 1e-9), err_msg=f"{method} {name}")
        for src, rec in ours[method].updates.items():
            np.testing.assert_array_equal(back[method].updates[src].fused, rec.fused, err_msg=f"{method} {src}")


def test_tauv_replay_of_a_longrange_log_flags_no_yoo_method(tmp_path: Path) -> None:
    """End to end: ``tauv run --trajectory longrange --save-log`` then ``tauv replay --method
    ins-dvl,vkf``: exit 0, no method flagged, its velocity error the run's within a factor of 2
    (the replay starts on the reference; the run off it)."""
    def cli(*argv: str) -> tuple[str, dict]:
        out = tmp_path / f"{argv[0]}.json"
        proc = subprocess.run([sys.executable, "-m", "app.cli", *argv, "--json", str(out)], check=False,
                              capture_output=True, text=True, timeout=120)
        assert proc.returncode == 0, proc.stderr
        return proc.stdout, json.loads(out.read_text())["results"]

    _, ran = cli("run", "--trajectory", "longrange", "--duration", "60", "--method", "ins-dvl,vkf", "--seed", "1",
                 "--save-log", str(tmp_path / "log"))
    shown, replayed = cli("replay", str(tmp_path / "log"), "--method", "ins-dvl,vkf")
    assert "diverged" not in shown
    for method in YOO_METHODS:
        assert replayed[method]["diverged"] is False and replayed[method]["diverged_at_s"] is None, method
        rms = [float(np.sqrt(np.mean(np.square(np.array(r[method]["vel_err_mps"], dtype=float)))))
               for r in (ran, replayed)]
        assert 0.5 * rms[0] < rms[1] < 2.0 * rms[0], f"{method} velocity RMS run {rms[0]} replay {rms[1]}"
