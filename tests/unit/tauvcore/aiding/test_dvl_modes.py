"""What every method does with a partial DVL, as the runner records it (short runs, all methods).

Given the beams that return (a fixed set, a scheduled outage, or random dropout), when every
method of tauvcore.config.METHODS runs on the same simulation, then each DVL epoch's record says
which beams returned and what the method did: coast (0), loosely coupled (1), partial (2) or
tightly coupled (3), which body axes it fused and, for the selector, which method each axis took.
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.aiding import elc_nsv, elc_plcf, elc_vb, elc_vhv
from tauvcore.aiding.dvl_extended import (
    ELC_METHODS,
    MODE_COAST,
    MODE_LC,
    MODE_PARTIAL,
    MODE_TC,
)
from tauvcore.aiding.elc_select import CANDIDATES
from tauvcore.config import METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.simulation import simulate
from tauvcore.sensors.dvl import Outage

DVL_METHODS = tuple(m for m in METHODS if m != "ins")
SERIES = ("vel_err_mps", "att_err_deg", "pos_err_m", "vel_sigma_mps", "att_sigma_deg", "pos_sigma_m", "nees")
PARTIAL_AXES_12 = {                        # beams 1, 2 (u, v, w)
    "vb": [True, True, True],
    "nsv": [True, True, True],             # sway is the assumption v = 0
    "plcf": [True, False, False],
    "vhv": [True, True, False],
    "elc": [True, True, True],
}


def _run(seed: int = 0, num_runs: int = 1, duration_s: float = 20.0, **dvl_changes):
    config = (Config().replace("trajectory", duration_s=duration_s).replace("dvl", **dvl_changes)
              .replace("run", methods=METHODS))
    rng = np.random.default_rng(seed)
    sim = simulate(config, rng, num_runs=num_runs)
    return config, run(config, sim, rng)


@pytest.fixture(scope="module")
def beams_12():
    return _run(seed=11, beams=(1, 2))[1]


@pytest.fixture(scope="module")
def beams_1():
    return _run(seed=12, beams=(1,))[1]


@pytest.fixture(scope="module")
def beams_14():
    return _run(seed=13, beams=(1, 4))[1]


def _assert_same_state(a, b, label: str) -> None:
    """Two methods that fused nothing carry the same state (up to the round-off of a zero injection)."""
    for name in SERIES:
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-9, atol=1e-9, err_msg=f"{label} {name}")


# ------------------------------------------------------------------------------------------ beams 1, 2

def test_beams_12_every_dvl_epoch_records_the_two_beams(beams_12):
    assert "dvl" not in beams_12["ins"].updates
    for method in DVL_METHODS:
        rec = beams_12[method].updates["dvl"]
        assert rec.t_s.size == 20, method                      # one record per 1 Hz ping
        np.testing.assert_array_equal(rec.beams_available,
                                      np.broadcast_to([True, True, False, False], rec.beams_available.shape))


def test_beams_12_lc_coasts_and_keeps_the_ins_state(beams_12):
    rec = beams_12["lc"].updates["dvl"]
    np.testing.assert_array_equal(rec.mode, MODE_COAST)
    assert not rec.valid.any() and not rec.fused.any() and not rec.measured_axes.any()
    _assert_same_state(beams_12["lc"], beams_12["ins"], "lc vs ins")


def test_beams_12_tc_fuses_the_two_beams(beams_12):
    rec = beams_12["tc"].updates["dvl"]
    np.testing.assert_array_equal(rec.mode, MODE_TC)
    assert rec.fused.all()
    assert not rec.fused_rows[..., 2:].any()                   # beams 3, 4 never fused
    np.testing.assert_array_equal(rec.elc_choice, -1)


@pytest.mark.parametrize("method", ELC_METHODS)
def test_beams_12_elc_methods_are_partial_on_their_axes(beams_12, method):
    rec = beams_12[method].updates["dvl"]
    np.testing.assert_array_equal(rec.mode, MODE_PARTIAL)
    np.testing.assert_array_equal(rec.measured_axes, np.broadcast_to(PARTIAL_AXES_12[method], rec.measured_axes.shape))
    assert rec.valid.all()
    # the rows it did not measure are never fused
    assert not np.any(rec.fused_rows & ~rec.measured_axes)
    assert rec.fused.any()
    if method != "elc":
        np.testing.assert_array_equal(rec.elc_choice, -1)


def test_beams_12_selector_choices(beams_12):
    choice = beams_12["elc"].updates["dvl"].elc_choice
    assert choice.min() >= -1 and choice.max() <= len(CANDIDATES) - 1
    assert np.all(choice >= 0)                                 # every axis measured by someone (VB at least)
    np.testing.assert_array_equal(choice[..., 1], CANDIDATES.index("nsv"))   # epsilon is the smallest sway variance


def test_beams_12_partial_methods_change_the_state(beams_12):
    """Aiding with two beams is not a no-op: every ELC method ends away from the free INS."""
    ins = beams_12["ins"].vel_err_mps
    for method in ELC_METHODS:
        assert not np.allclose(beams_12[method].vel_err_mps, ins, rtol=1e-6, atol=1e-6), method


# ------------------------------------------------------------------------------------------ outage

def test_outage_of_beams_3_4_switches_lc_to_partial_and_back():
    _, results = _run(seed=14, duration_s=30.0, outages=(Outage((3, 4), 10.0, 20.0),))
    t = results["lc"].updates["dvl"].t_s
    inside = (t >= 10.0) & (t < 20.0)
    assert inside.sum() == 10 and (~inside).sum() == 20
    for method in ELC_METHODS:
        rec = results[method].updates["dvl"]
        np.testing.assert_array_equal(rec.t_s, t)
        np.testing.assert_array_equal(rec.mode[:, 0], np.where(inside, MODE_PARTIAL, MODE_LC), err_msg=method)
        np.testing.assert_array_equal(rec.beams_available[inside, 0], np.broadcast_to([1, 1, 0, 0], (10, 4)))
        np.testing.assert_array_equal(rec.beams_available[~inside, 0], True)
        np.testing.assert_array_equal(rec.measured_axes[~inside], True)      # LC: full velocity
        if method == "elc":
            np.testing.assert_array_equal(rec.elc_choice[~inside], -1)    # no selection outside
            assert np.all(rec.elc_choice[inside] >= 0)
    np.testing.assert_array_equal(results["lc"].updates["dvl"].mode[:, 0], np.where(inside, MODE_COAST, MODE_LC))
    np.testing.assert_array_equal(results["tc"].updates["dvl"].mode, MODE_TC)


# ------------------------------------------------------------------------------------------ one beam, beams 1, 4

def test_one_beam_only_tc_aids(beams_1):
    rec = beams_1["tc"].updates["dvl"]
    np.testing.assert_array_equal(rec.mode, MODE_TC)
    assert rec.fused.all() and not rec.fused_rows[..., 1:].any()
    for method in ("lc",) + ELC_METHODS:
        rec = beams_1[method].updates["dvl"]
        np.testing.assert_array_equal(rec.beams_available,
                                      np.broadcast_to([True, False, False, False], rec.beams_available.shape))
        np.testing.assert_array_equal(rec.mode, MODE_COAST, err_msg=method)
        assert not rec.fused.any() and not rec.measured_axes.any(), method
        _assert_same_state(beams_1[method], beams_1["ins"], f"{method} vs ins")


def test_beams_14_nsv_coasts_but_vb_plcf_vhv_and_elc_aid(beams_14):
    nsv = beams_14["nsv"].updates["dvl"]
    np.testing.assert_array_equal(nsv.mode, MODE_COAST)
    assert not nsv.fused.any()
    _assert_same_state(beams_14["nsv"], beams_14["ins"], "nsv vs ins")
    expected_axes = {"vb": [True, True, True], "plcf": [False, True, False], "vhv": [True, True, False],
                     "elc": [True, True, True]}
    for method, axes in expected_axes.items():
        rec = beams_14[method].updates["dvl"]
        np.testing.assert_array_equal(rec.mode, MODE_PARTIAL, err_msg=method)
        np.testing.assert_array_equal(rec.measured_axes, np.broadcast_to(axes, rec.measured_axes.shape))
        assert rec.fused.any(), method
    assert not np.any(beams_14["elc"].updates["dvl"].elc_choice == CANDIDATES.index("nsv"))


# ------------------------------------------------------------------------------------------ random dropout

def _expected(method: str, available: np.ndarray) -> tuple[int, np.ndarray]:
    """Mode and measured axes a method must record for one epoch's beams (Figure 7 of the paper)."""
    n = int(available.sum())
    pattern = tuple(bool(b) for b in available)
    none = np.zeros(3, dtype=bool)
    if method in ("tc", "iekf"):                 # the invariant EKF fuses the beams as TC does
        return (MODE_TC if n >= 1 else MODE_COAST), none
    if n >= 3:
        return MODE_LC, np.ones(3, dtype=bool)
    if method == "lc" or n < 2:
        return MODE_COAST, none
    pitch = np.radians(20.0)
    sol = {"vb": lambda: elc_vb.solve(pitch, pattern, 2.0), "nsv": lambda: elc_nsv.solve(pitch, pattern, 1e-4),
           "plcf": lambda: elc_plcf.solve(pitch, pattern), "vhv": lambda: elc_vhv.solve(pitch, pattern, 2.0),
           "elc": lambda: elc_vb.solve(pitch, pattern, 2.0)}[method]()     # elc: VB covers every axis
    return (MODE_PARTIAL, sol.measured) if sol.ok else (MODE_COAST, none)


def test_random_dropout_every_epoch_records_the_mode_its_beams_allow():
    _, results = _run(seed=15, num_runs=3, duration_s=30.0, dropout_probability=0.4)
    counts = np.zeros(5, dtype=int)
    for method in DVL_METHODS:
        rec = results[method].updates["dvl"]
        U, R = rec.mode.shape
        for u in range(U):
            for r in range(R):
                mode, axes = _expected(method, rec.beams_available[u, r])
                assert rec.mode[u, r] == mode, (method, u, r, rec.beams_available[u, r])
                np.testing.assert_array_equal(rec.measured_axes[u, r], axes, err_msg=f"{method} {u} {r}")
                if method == "lc":
                    counts[int(rec.beams_available[u, r].sum())] += 1
    # the draw exercised partial epochs of every kind: 0-1, 2 and 3-4 beams
    assert counts[:2].sum() > 0 and counts[2] > 5 and counts[3:].sum() > 5
    beams = results["lc"].updates["dvl"].beams_available
    pairs = {tuple(np.flatnonzero(b)) for b in beams.reshape(-1, 4) if b.sum() == 2}
    assert len(pairs) >= 4                                     # several different pairs, not only 1-2
