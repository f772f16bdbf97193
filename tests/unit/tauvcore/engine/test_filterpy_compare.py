"""Our filter equals the plain per-step filterpy ``KalmanFilter`` loop, to 1e-9.

The loop is ``benchmarks/filterpy_compare.py``'s: ``lc`` written the plain way, one filterpy
filter per run stepped per IMU sample, on the same simulation and initial errors as
``tauvcore.engine.mission.run``. A short mission (30 s, 2 runs) here; the benchmark runs 250 s and
times both. No timing in this test.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import pathlib

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[4]
_spec = importlib.util.spec_from_file_location("filterpy_compare", ROOT / "benchmarks" / "filterpy_compare.py")
fc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fc)

NUM_RUNS = 2


@pytest.fixture(scope="module", params=[("fixed", 3.0, 10.0), ("random", 1.0, 7.0)],
                ids=["fixed-gate3-cov10Hz", "random-gate1-cov7Hz"])
def results(request: pytest.FixtureRequest) -> tuple:
    """Ours, the loop and the gate on one 30 s figure-eight simulation. The second case stresses
    what the defaults leave unexercised: a 1-sigma gate rejects some pings (both branches of the
    gate compared), and a 7 Hz covariance step (21 IMU samples) falls between the 10 Hz output
    epochs (15 samples), so run()'s extra propagations at the epochs are compared too."""
    mode, gate, cov_rate_hz = request.param
    config = (fc.lc_config("figure8", 30.0, mode)
              .replace("filter", gate_sigma=gate, covariance_rate_hz=cov_rate_hz))
    ours, loop = fc.prepare(config, NUM_RUNS)
    return ours(), loop(), gate


def test_filterpy_loop_equals_ours_to_1e9(results: tuple) -> None:
    ours, theirs, _ = results
    diffs = fc.check(ours, theirs)       # raises beyond 1e-9, on any differing gate decision, on a P repair
    assert set(diffs) == set(fc.COMPARED) | {"innovation", "gate"}
    assert all(rel <= 1e-9 for _, rel in diffs.values())
    assert diffs["gate"] == (0.0, 0.0)
    # the comparison is not empty: every epoch of both runs, positive finite NEES
    assert ours.nees.shape == theirs.nees.shape == (301, NUM_RUNS)
    assert np.isfinite(theirs.nees).all() and (theirs.nees > 0).all()


def test_gate_decides_every_ping_alike(results: tuple) -> None:
    ours, theirs, gate = results
    dvl = ours.updates["dvl"]
    assert dvl.valid.all()                              # four beams: every ping gives a velocity
    assert np.array_equal(dvl.fused, theirs.fused)
    assert np.array_equal(dvl.rejected, dvl.valid & ~theirs.fused)
    assert theirs.fused.any()
    if gate == 1.0:                                     # the tight gate exercised the rejection branch
        assert dvl.rejected.any()


@pytest.mark.parametrize("name, change", [
    ("nees", lambda a: a * (1.0 + 1e-8)),
    ("est_pos_n", lambda a: a + 1e-8),
    ("vel_err_mps", lambda a: a + np.where(np.arange(a.shape[0])[:, None] == 7, 2e-9, 0.0)),
    ("fused", lambda a: np.where(np.arange(a.shape[0])[:, None] == 3, ~a, a)),
])
def test_check_catches_a_difference_just_above_tolerance(results: tuple, name: str, change) -> None:
    ours, theirs, _ = results
    wrong = dataclasses.replace(theirs, **{name: change(getattr(theirs, name))})
    with pytest.raises(AssertionError, match="differ beyond"):
        fc.check(ours, wrong)


def test_different_initial_errors_are_caught() -> None:
    """The loop started from another generator state (other initial errors) is not 'equal'."""
    config = fc.lc_config("figure8", 10.0, "random")
    ours, _ = fc.prepare(config, 1)
    rng = np.random.default_rng(config.run.seed)
    sim = fc.simulate(config, rng, 1)
    theirs = fc.filterpy_loop(config, sim, np.random.default_rng(12345))
    with pytest.raises(AssertionError, match="differ beyond"):
        fc.check(ours(), theirs)


@pytest.mark.parametrize("section, change", [("run", {"methods": ("lc", "tc")}), ("run", {"aiding": ("dvl", "depth")})])
def test_loop_refuses_what_it_does_not_implement(section: str, change: dict) -> None:
    config = fc.lc_config("figure8", 2.0, "fixed").replace(section, **change)
    rng = np.random.default_rng(0)
    sim = fc.simulate(config, rng, 1)
    with pytest.raises(ValueError, match="lc with DVL aiding only"):
        fc.filterpy_loop(config, sim, rng)
