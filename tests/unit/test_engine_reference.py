"""The compiled filter bank equals the numpy engine it replaced (issue 9), to 1e-9.

The reference (``tests/fixtures/engine_reference.npz``) holds the results of the numpy engine of
commit 9235ddc, written by ``scripts/make_engine_reference.py`` from the same seeded
simulations: three trajectories, all eight methods, DVL, depth and magnetometer aiding, random
initial errors over two runs, and four, two and three DVL beams in turn.
"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

from tauvcore.eval.runner import run, simulate

ROOT = pathlib.Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("make_engine_reference", ROOT / "scripts" / "make_engine_reference.py")
ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ref)

REFERENCE = np.load(ROOT / "tests" / "fixtures" / "engine_reference.npz")


@pytest.mark.parametrize("trajectory", ref.TRAJECTORIES)
def test_compiled_engine_equals_numpy_reference(trajectory: str) -> None:
    config = ref.reference_config(trajectory)
    rng = np.random.default_rng(config.run.seed)
    results = run(config, simulate(config, rng, ref.NUM_RUNS), rng)
    checked = 0
    for method, res in results.items():
        for name in ref.SERIES:
            expected = REFERENCE[f"{trajectory}/{method}/{name}"]
            np.testing.assert_allclose(getattr(res, name)[::ref.EVERY], expected, rtol=1e-9, atol=1e-9,
                                       err_msg=f"{trajectory} {method} {name}")
            checked += 1
        for src, rec in res.updates.items():
            for name in ref.UPDATE_SERIES:
                expected = REFERENCE[f"{trajectory}/{method}/{src}/{name}"]
                np.testing.assert_allclose(getattr(rec, name), expected, rtol=1e-9, atol=1e-9,
                                           err_msg=f"{trajectory} {method} {src} {name}")
                checked += 1
    expected_keys = [k for k in REFERENCE.files if k.startswith(f"{trajectory}/")]
    assert checked == len(expected_keys) == 146
