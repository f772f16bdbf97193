"""The chunk driver both banks are (tauvcore.engine.chunk_driver): polling for progress and stop
requests changes no number, results handed out chunk by chunk add up to the whole for the Yoo
bank as for the 20-state one, and chunks out of order are refused."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import Sinks, Watch, run_streaming
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.engine.yoo_bank import YooBank

METHODS = ("lc", "tc", "ins-dvl", "vkf")
FIELDS = ("pos_err_m", "vel_err_mps", "att_err_deg", "nees", "nees_block", "est_pos_n", "est_vel_n")


def _config() -> Config:
    config = Config().replace("trajectory", name="figure8", duration_s=30.0)
    return (config.replace("initial_error", mode="random")
            .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"), seed=2))


def _assert_equal(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for m in a:
        np.testing.assert_array_equal(a[m].t_s, b[m].t_s, err_msg=m)
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(a[m], name), getattr(b[m], name), err_msg=f"{m} {name}")
        assert a[m].updates.keys() == b[m].updates.keys()
        for src, rec in a[m].updates.items():
            np.testing.assert_array_equal(rec.nis, b[m].updates[src].nis, err_msg=f"{m} {src}")
            np.testing.assert_array_equal(rec.fused, b[m].updates[src].fused, err_msg=f"{m} {src}")


def test_polling_for_progress_and_stop_changes_no_number() -> None:
    """Coming back to Python at every output epoch (a stop request polled) or every 2 s (progress)
    leaves every result of both banks as the run that never comes back gives."""
    config = _config()
    plain = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=3.7)
    seen: list[float] = []
    polls = {"n": 0}

    def never() -> bool:
        polls["n"] += 1
        return False
    polled = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=3.7, watch=Watch(progress=lambda t, r: seen.append(t), interval_s=2.0, should_stop=never))
    _assert_equal(plain, polled)
    assert polls["n"] == plain["lc"].t_s.size - 1          # every output epoch but the first
    # every 20 output epochs recorded (epoch 0 the first of them), the last not before the end
    np.testing.assert_allclose(seen, np.arange(1.9, 30.0, 2.0))


def test_a_wall_time_floor_calls_progress_less_often_and_changes_no_number(monkeypatch) -> None:
    """With progress_min_wall_s, progress is called only when that much wall time has passed
    since the last call (a clock here that advances 1 s per reading: every other interval at
    a 1.5 s floor), and every result equals the run without it."""
    import tauvcore.engine.chunk_driver as driver

    config = _config()
    plain = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=3.7)
    clock = {"t": 0.0}

    def tick() -> float:
        clock["t"] += 1.0
        return clock["t"]

    monkeypatch.setattr(driver.time, "monotonic", tick)
    seen: list[float] = []
    floored = run_streaming(config, np.random.default_rng(4), num_runs=2, chunk_s=3.7, watch=Watch(progress=lambda t, r: seen.append(t), interval_s=2.0, min_wall_s=1.5))
    _assert_equal(plain, floored)
    every = np.arange(1.9, 30.0, 2.0)
    assert 0 < len(seen) < len(every) and set(np.round(seen, 6)) <= set(np.round(every, 6))


@pytest.mark.parametrize("keep", [True, False])
def test_taken_chunks_add_up_to_the_whole_for_both_banks(keep: bool) -> None:
    config = _config()
    whole = run_streaming(config, np.random.default_rng(6), num_runs=2)
    parts: list[dict] = []
    run_streaming(config, np.random.default_rng(6), num_runs=2, chunk_s=4.0, keep=keep, sinks=Sinks(on_chunk=parts.append))
    assert len(parts) == 8
    for m in METHODS:
        for name in FIELDS:
            np.testing.assert_array_equal(np.concatenate([getattr(p[m], name) for p in parts]),
                                          getattr(whole[m], name), err_msg=f"{m} {name} keep={keep}")
        np.testing.assert_array_equal(np.concatenate([p[m].updates["dvl"].nis for p in parts]),
                                      whole[m].updates["dvl"].nis, err_msg=m)
    trace = np.concatenate([p["vkf"].vkf_trace["x"] for p in parts])
    np.testing.assert_array_equal(trace, whole["vkf"].vkf_trace["x"])


def test_a_stop_cuts_both_banks_at_the_same_epoch_whatever_the_chunking() -> None:
    config = _config()
    ends = []
    for chunk_s in (1.3, 10.0):
        calls = iter(range(10_000))
        out = run_streaming(config, np.random.default_rng(1), chunk_s=chunk_s, watch=Watch(should_stop=lambda: next(calls) >= 77))
        assert [r.t_s[-1] for r in out.values()] == [pytest.approx(7.8)] * len(METHODS)  # the 78th poll: epoch 78
        ends.append(out)
    _assert_equal(*ends)


def test_chunks_must_come_in_order_and_the_yoo_bank_started_first() -> None:
    config = _config().replace("run", methods=("ins-dvl",))
    sim = simulate(config, np.random.default_rng(0))
    whole = SimChunk.whole(sim)
    bank = YooBank(config, 1, sim.truth.num_samples, sim.truth.dt_s)
    with pytest.raises(ValueError, match="first chunk must start at sample 0, got 5"):
        bank.feed(dataclasses.replace(whole, k0=5))
    with pytest.raises(ValueError, match="YooBank.start"):
        bank.feed(whole)
