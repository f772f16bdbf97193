"""Calibration's known answer over seeds: simulated logs of a DVL head mounted (0.3, -0.5, 1.0) deg off
with a 0.5 % scale factor offset (half of them with the reference turned by a boresight) give back
their misalignment, scale factor and boresight within 3 sigma, with sigmas that are neither too
small (RMS of the normalised errors near 1) nor absurdly large; and the calibration applied to a
misaligned log's replay brings it to the aligned log's."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore import units
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.calibration import calibrate
from tauvcore.eval.consistency import method_consistency
from tauvcore.eval.replay import replay
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tests.unit.tauvcore.eval.calibration.test_calibration import (
    BORESIGHT_DEG,
    MISALIGNMENT_DEG,
    OFFSET_PCT,
    _rotated_reference,
)

pytestmark = pytest.mark.slow

SEEDS = range(100, 120)
TRAJECTORY = {"name": "figure8", "duration_s": 400.0, "dive_rate_mps": 0.5, "turn_sideslip_deg": 10.0,
              "seabed_depth_m": 250.0}
"""Velocity along every body axis (a 0.5 m/s dive, 10 deg of sideslip in the turns), so that all four
DVL unknowns are observable; the DVL's range reaches the seabed from the start."""
BASE = Config().replace("trajectory", **TRAJECTORY).replace("dvl", max_altitude_m=300.0)
MISALIGNED = BASE.replace("dvl", misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT)


def _log(tmp_path, config: Config, seed: int, boresight_deg=None):
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(seed)))])
    if boresight_deg is not None:
        tables = _rotated_reference(tables, C_nb_from_euler(np.asarray(boresight_deg) * units.DEG))
    write_log(tmp_path / str(seed), tables, "parquet")
    return read_log(tmp_path / str(seed))


def test_twenty_seeds_give_back_the_mounting_within_three_sigma(tmp_path) -> None:
    z, sigma = [], []
    for i, seed in enumerate(SEEDS):
        boresight = BORESIGHT_DEG if i % 2 else (0.0, 0.0, 0.0)
        log = _log(tmp_path, MISALIGNED, seed, boresight if i % 2 else None)
        result = calibrate([(str(seed), log, MISALIGNED)])
        # the true scale factor: the configured offset plus the one drawn at turn-on (and its walk)
        sf_pct = float(np.mean(log.dvl_truth["true_scale_factor"])) / units.PERCENT
        truth = np.array([*MISALIGNMENT_DEG, sf_pct, *boresight])
        value = np.concatenate([result.dvl.value, result.boresight.value])
        s = np.concatenate([result.dvl.sigma, result.boresight.sigma])
        z.append((value - truth) / s)
        sigma.append(s)
    z, sigma = np.array(z), np.array(sigma)
    assert np.abs(z).max() < 3.0, np.abs(z).max(axis=0)
    rms = np.sqrt(np.mean(z**2, axis=0))
    assert np.all((rms > 0.5) & (rms < 1.5)), rms  # the sigmas are the errors' size: not too small, nor too large
    # not absurdly large: a tenth of the misalignment's size or so for the angles, and the scale factor
    # as well known as the beams' biases allow at 2 m/s (0.5 %: docs/calibration.md)
    assert np.all(sigma[:, :3] < 0.4) and np.all(sigma[:, 3] < 0.7), sigma.max(axis=0)
    assert np.all(sigma[:, 4:] < 0.1), sigma[:, 4:].max(axis=0)


def test_the_calibration_applied_makes_a_misaligned_log_s_replay_the_aligned_one_s(tmp_path) -> None:
    """LC and TC on the same seed: aligned, misaligned, and misaligned with its own calibration
    applied. The filters' bias and scale factor states hide the misalignment from the NIS (within a
    few per cent either way) but not from the position, 2.5 times the aligned log's error without
    the calibration and back to it with it."""
    config = BASE.replace("run", methods=("lc", "tc"))
    aligned, misaligned = _log(tmp_path / "a", BASE, 7), _log(tmp_path / "m", MISALIGNED, 7)
    result = calibrate([("m", misaligned, MISALIGNED)])
    calibrated = config.replace(
        "calibration",
        dvl_misalignment_deg=result.config.dvl_misalignment_deg,
        dvl_scale_factor_pct=result.config.dvl_scale_factor_pct,
        imu_boresight_deg=result.config.imu_boresight_deg,
    )
    runs = {
        name: replay(cfg, log, np.random.default_rng(0))[1]
        for name, cfg, log in (("aligned", config, aligned), ("misaligned", config, misaligned),
                               ("calibrated", calibrated, misaligned))
    }
    for method in ("lc", "tc"):
        nis = {name: method_consistency(r[method]).nis["dvl"].per_dof for name, r in runs.items()}
        end = {name: float(np.linalg.norm(r[method].pos_err_m[-1])) for name, r in runs.items()}
        assert abs(nis["calibrated"] / nis["aligned"] - 1.0) < 0.1, nis
        assert end["misaligned"] > 2.0 * end["aligned"], end
        assert end["calibrated"] < 1.25 * end["aligned"], end
