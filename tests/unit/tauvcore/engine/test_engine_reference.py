"""The compiled filter bank equals the numpy engine it replaced, to 1e-9.

The reference (``tests/fixtures/engine_reference.npz``) holds the results of the numpy engine of
commit 9235ddc (plus the second-order rotation term of the velocity increment), written
by ``scripts/make_engine_reference.py`` from the same seeded
simulations: three trajectories, all eight methods, DVL, depth and magnetometer aiding, random
initial errors over two runs, and four, two and three DVL beams in turn.

What "equal" can mean here. The two engines add and multiply in different orders (BLAS with
fused multiply-adds in the numpy engine; plain loops in the compiled one), so each IMU step
differs in the last bit, and the INS integrates those bits: a heading difference of 1e-13 rad
becomes 1e-10 m of position after 100 s at 1 m/s. The floor is measured, not assumed: changing
one product's association in the numpy engine itself (``C_earth @ (C @ exp(phi))`` instead of
``(C_earth @ C) @ exp(phi)``, commit ee59289) moves its positions by 6e-10 m and its heading
NEES by 1e-8 relative. So every series is compared at 1e-9 of its own scale (the largest value
of the reference series; for positions and position errors the largest position, the magnitude
whose round-off they carry), and the NEES and NIS, which divide error components as small as
1e-5 rad by their own sigma and so magnify that floor, at 1e-7 of theirs. A wrong formula, a
missing term or a changed schedule moves these series by 1e-4 or more.
"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate

ROOT = pathlib.Path(__file__).resolve().parents[4]
_spec = importlib.util.spec_from_file_location("make_engine_reference", ROOT / "scripts" / "make_engine_reference.py")
ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ref)

REFERENCE = np.load(ROOT / "tests" / "fixtures" / "engine_reference.npz")


@pytest.mark.parametrize("trajectory", ref.TRAJECTORIES)
def test_compiled_engine_equals_numpy_reference(trajectory: str) -> None:
    # the reference's EKF takes the scale factor's column of H at the current estimate, its two-beam
    # rows are the paper's (tests/unit/tauvcore/filter/kernels/test_partial_sensor_columns.py holds the
    # lab's), and it has the methods of its commit (the invariant EKF came after it:
    # tests/unit/tauvcore/filter/test_invariant.py)
    config = ref.reference_config(trajectory).replace("filter", scale_factor_velocity_tau_s=0.0)
    config = config.replace("partial", sensor_columns=False)
    config = config.replace("run", methods=tuple(m for m in config.run.methods if m != "iekf"))
    rng = np.random.default_rng(config.run.seed)
    results = run(config, simulate(config, rng, ref.NUM_RUNS), rng)
    checked = 0
    for method, res in results.items():
        position_scale = np.abs(REFERENCE[f"{trajectory}/{method}/est_pos_n"]).max()
        for name in ref.SERIES:
            expected = REFERENCE[f"{trajectory}/{method}/{name}"]
            scale = position_scale if name in ("pos_err_m", "est_pos_n") else np.nanmax(np.abs(expected))
            tolerance = (1e-7 if name.startswith("nees") else 1e-9) * scale
            np.testing.assert_allclose(getattr(res, name)[::ref.EVERY], expected, rtol=0.0, atol=tolerance,
                                       err_msg=f"{trajectory} {method} {name}")
            checked += 1
        for src, rec in res.updates.items():
            for name in ref.UPDATE_SERIES:
                expected = REFERENCE[f"{trajectory}/{method}/{src}/{name}"]
                actual = getattr(rec, name)
                if expected.dtype == bool:       # the gate decided the same everywhere
                    np.testing.assert_array_equal(actual, expected, err_msg=f"{trajectory} {method} {src} {name}")
                else:
                    np.testing.assert_allclose(actual, expected, rtol=0.0, atol=1e-7 * np.nanmax(np.abs(expected)),
                                               err_msg=f"{trajectory} {method} {src} {name}")
                checked += 1
    expected_keys = [k for k in REFERENCE.files if k.startswith(f"{trajectory}/")]
    assert checked == len(expected_keys) == 146


def test_both_banks_record_the_series_in_the_order_the_results_unpack_them() -> None:
    """tauvcore.engine.results.method_result unpacks the rows of both banks' series by SERIES_FIELDS:
    the 20-state kernels' rows and the Yoo kernels' must be the same names in the same order."""
    from tauvcore.engine import loop, yoo_bank, yoo_loop
    from tauvcore.engine.results import SERIES_FIELDS

    assert tuple(SERIES_FIELDS) == loop.SERIES_NAMES == yoo_bank.SERIES
    assert yoo_loop.NUM_SERIES == len(SERIES_FIELDS)
