"""The divergence monitor's innovation test read as the record grows (InnovationTest) gives, at
every call, exactly what the whole-record test (innovation_divergence_s) gives for the record so
far: records with consistent and inflated stretches, missing and invalid updates, lock-outs,
resets (explaining the rejections before them, and repeated), grown in chunks of any size."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.engine.monitor import InnovationTest, innovation_divergence_s


def _record(rng: np.random.Generator, U: int, R: int) -> dict[str, np.ndarray]:
    """One record of U updates and R runs, each run drawn with its own troubles."""
    t = np.cumsum(rng.uniform(0.5, 1.5, U))
    dof = rng.choice([0, 1, 3], size=(U, R), p=[0.05, 0.25, 0.7])
    nis = rng.chisquare(np.maximum(dof, 1)).astype(float)
    scale = np.ones((U, R))
    fused = np.ones((U, R), bool)
    reset = np.zeros((U, R), bool)
    for r in range(R):
        for _ in range(rng.integers(0, 4)):  # inflated stretches: a window flags
            a = rng.integers(0, U)
            scale[a : a + rng.integers(3, 40), r] = rng.uniform(2.0, 30.0)
        for _ in range(rng.integers(0, 4)):  # rejected stretches: lock-outs, some ending in a reset
            a = rng.integers(0, U)
            n = rng.integers(2, 12)
            fused[a : a + n, r] = False
            if rng.random() < 0.6 and a + n < U:
                reset[a + n, r] = True
    nis *= scale
    nis[rng.random((U, R)) < 0.03] = np.nan
    valid = rng.random((U, R)) > 0.1
    return {"t_s": t, "nis": nis, "nis_dof": dof, "fused": fused, "valid": valid, "reset": reset}


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("with_reset", [True, False])
def test_every_call_equals_the_whole_record_s_test(seed, with_reset):
    rng = np.random.default_rng([2026, seed])
    U, R = 600, 6
    rec = _record(rng, U, R)
    window, lockout = int(rng.integers(2, 12)), int(rng.integers(2, 8))
    test = InnovationTest(R, window=window, false_alarm=1e-3, lockout=lockout)
    ends = np.unique(np.append(rng.integers(1, U, 40), U))
    flagged = 0
    for n in ends:
        cols = {k: v[:n] for k, v in rec.items()}
        reset = cols.pop("reset") if with_reset else None
        cols.pop("reset", None)
        want = innovation_divergence_s(**cols, window=window, false_alarm=1e-3, lockout=lockout, reset=reset)
        got = test(**cols, reset=reset)
        np.testing.assert_array_equal(got, want, err_msg=f"after {n} updates")
        np.testing.assert_array_equal(test(**cols, reset=reset), want)  # no new update: the same
        flagged += int(np.isfinite(want).sum())
    assert flagged > 0  # the records do flag: the equality is not between two NaN arrays


def test_a_run_is_scanned_from_its_last_window_not_from_the_start():
    """Over consistent updates the scan's start follows the end of the record."""
    rng = np.random.default_rng(7)
    U = 2000
    t = np.arange(1.0, U + 1)
    nis = rng.chisquare(3, (U, 1))
    ones = np.ones((U, 1), bool)
    test = InnovationTest(1, window=30, lockout=10)
    for n in range(100, U + 1, 100):
        assert np.isnan(test(t[:n], nis[:n], np.full((n, 1), 3), ones[:n], ones[:n]))[0]
        assert test.start[0] == n - 29
