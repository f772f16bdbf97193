"""A Monte Carlo's batches joined (tauvcore.engine.run_joining) are the batch of all its runs:

- every field of every method (series, estimates, sensor errors, the current's states, update
  records, the velocity Kalman filter's trace, the smoother's results and cuts) of runs
  [0, 2) and [2, 5) joined equals runs [0, 5) computed at once, to 1e-9;
- batches stopped at different epochs, cut to the epochs both reached, are the whole batch cut
  there: series, update records, the trace, and a divergence flagged later forgotten;
- batches that cannot be one are refused with the reason named.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import run_streaming
from tauvcore.engine.run_joining import joined_runs, until
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.study import run_rng
from tests.unit.helpers.same_results import assert_same_results

SEED = 21
CONFIG = (Config().replace("trajectory", name="lawnmower", duration_s=12.0, current_n_mps=(0.2, -0.25, 0.0))
          .replace("dvl", beams=(1, 2, 3), current_states="random-walk", water_track="always")
          .replace("initial_error", mode="random")
          .replace("run", methods=("ins", "lc", "tc", "nsv", "vkf"), aiding=("dvl", "depth", "mag"), seed=SEED))


def _batch(first: int, count: int, smooth: bool = True) -> dict:
    rngs = [run_rng(SEED, i) for i in range(first, first + count)]
    return run_streaming(CONFIG, rngs, num_runs=count, sensor_errors=True,
                         smooth=SmoothOptions() if smooth else None)


@pytest.fixture(scope="module")
def batches() -> tuple[dict, dict, dict]:
    return _batch(0, 5), _batch(0, 2), _batch(2, 3)


def test_batches_joined_are_the_runs_computed_at_once(batches) -> None:
    whole, a, b = batches
    assert all(r.smoothed is not None for r in whole.values())  # what the comparison covers is there
    assert whole["lc"].smoothed.smoother_cuts is not None and set(whole["lc"].updates) >= {"dvl", "water", "depth"}
    assert whole["vkf"].vkf_trace is not None and whole["lc"].sensor_est is not None
    assert whole["lc"].state_labels == ("current_north_mps", "current_east_mps")
    joined = joined_runs([a, b])
    assert joined["lc"].vel_err_mps.shape == whole["lc"].vel_err_mps.shape == (len(whole["lc"].t_s), 5)
    assert_same_results(joined, whole)


def test_batches_cut_to_the_epochs_both_reached_are_the_whole_cut_there(batches) -> None:
    whole, a, b = batches
    T = len(whole["tc"].t_s)
    short = until(b, T // 2)  # the second batch stopped half way
    assert len(short["tc"].t_s) == T // 2
    t_end = whole["tc"].t_s[T // 2 - 1]
    for method, r in short.items():
        for name, rec in r.updates.items():
            assert rec.t_s.size and rec.t_s[-1] <= t_end < whole[method].updates[name].t_s[-1], (method, name)
    assert short["vkf"].vkf_trace is not None and short["vkf"].vkf_trace["t_s"][-1] <= t_end
    joined = joined_runs([until(a, T // 2), short])
    assert_same_results(joined, until(whole, T // 2))
    assert until(whole, T) is not whole and until(whole, T)["lc"] is whole["lc"]  # nothing to cut


def test_a_divergence_after_the_cut_is_forgotten(batches) -> None:
    whole = batches[0]
    r = whole["lc"]
    flagged = dataclasses.replace(r, diverged_at_s=np.r_[r.t_s[3], r.t_s[-1], np.full(3, np.nan)],
                                  diverged=np.r_[True, True, False, False, False])
    cut = until({"lc": flagged}, 6)["lc"]
    np.testing.assert_array_equal(cut.diverged, [True, False, False, False, False])
    assert cut.diverged_at_s[0] == r.t_s[3] and np.isnan(cut.diverged_at_s[1:]).all()


def test_batches_that_cannot_be_one_are_refused(batches) -> None:
    whole, a, b = batches
    with pytest.raises(ValueError, match="no batch"):
        joined_runs([])
    with pytest.raises(ValueError, match="different methods"):
        joined_runs([a, {m: b[m] for m in ("lc", "ins")}])
    with pytest.raises(ValueError, match="t_s differ"):
        joined_runs([a, until(b, 3)])
    unsmoothed = {m: dataclasses.replace(r, smoothed=None, smoother_cuts=None) for m, r in b.items()}
    with pytest.raises(ValueError, match="smoothed is recorded in some batches only"):
        joined_runs([a, unsmoothed])
