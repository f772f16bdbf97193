"""LC aided by the DVL and a USBL (tauvcore.aiding.usbl) is consistent over a one-hour lawnmower:
30 seeded runs (random initial errors, the Table 2 IMU and DVL, a fix every 10 s with 1 s of
latency, 5 % lost, 1 % outliers), on the flat earth."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.eval.metrics import average_nees_bounds
from tauvcore.filter.layout import NEES_BLOCKS, STATE

NUM_RUNS = 30


@pytest.mark.slow
def test_lc_with_usbl_is_consistent_over_an_hour_on_the_lawnmower() -> None:
    """The run-averaged NEES of the full state in its two-sided 99 % band on average over the
    fixes and at 80 % of them or more; the position block (what the USBL measures) likewise, on
    average; the fused fixes' NIS about 1 per degree of freedom; and no run flagged by the
    divergence monitor, the 1 % outliers notwithstanding."""
    from tauvcore.engine.mission import run_streaming

    cfg = (Config().replace("trajectory", name="lawnmower", duration_s=3600.0)
           .replace("initial_error", mode="random").replace("earth", model="flat")
           .replace("run", methods=("lc",), aiding=("dvl", "usbl")))
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(2026).spawn(NUM_RUNS)]
    res = run_streaming(cfg, rngs, NUM_RUNS)["lc"]
    record = res.updates["usbl"]
    at_fix = np.isin(np.round(res.t_s * 10).astype(int), np.round(record.t_s * 10).astype(int)) & (res.t_s > 60)
    avg = res.nees[at_fix].mean(axis=1)
    lo, hi = average_nees_bounds(STATE.dim, NUM_RUNS)
    assert lo <= avg.mean() <= hi, (lo, hi, avg.mean())
    assert ((avg >= lo) & (avg <= hi)).mean() >= 0.8, ((avg >= lo) & (avg <= hi)).mean()
    pos = res.nees_block[at_fix, :, list(NEES_BLOCKS).index("pos")].mean(axis=1)
    lo3, hi3 = average_nees_bounds(3, NUM_RUNS)
    assert lo3 <= pos.mean() <= hi3, (lo3, hi3, pos.mean())
    used = record.fused & (record.t_s[:, None] > 60)  # the outliers the gate refused left out
    per_dof = record.nis[used].sum() / record.nis_dof[used].sum()
    assert 0.85 <= per_dof <= 1.3, per_dof
    # the outliers the gate refused do not make the divergence monitor cry wolf
    assert not res.diverged.any(), res.diverged_at_s[res.diverged]
