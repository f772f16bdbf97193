"""The filter bank fed chunk by chunk: the same numbers whatever the chunk,
the same as one whole chunk, and results handed out chunk by chunk add up to the whole."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import METHODS, Config
from tauvcore.engine.filter_bank import FilterBank
from tauvcore.engine.mission import Sinks, Watch, run_streaming
from tauvcore.engine.simulation import SimChunk
from tauvcore.engine.source_streams import SourceStream
from tauvcore.sensors.dvl import Outage
from tauvcore.sensors.stream import SensorStream, SensorStreams
from tauvcore.truth import generate

SERIES = ("pos_err_m", "vel_err_mps", "att_err_deg", "nees", "nees_block", "est_pos_n", "pos_sigma_m")


def _config(trajectory: str = "figure8") -> Config:
    config = Config().replace("trajectory", name=trajectory, duration_s=40.0)
    config = config.replace("dvl", outages=(Outage(beams=(3, 4), start_s=10.0, end_s=25.0),
                                            Outage(beams=(1,), start_s=30.0, end_s=35.0)))
    return (config.replace("initial_error", mode="random")
            .replace("run", methods=METHODS, aiding=("dvl", "depth", "mag"), seed=3))


def _assert_same(a: dict, b: dict, atol: float = 0.0) -> None:
    assert a.keys() == b.keys()
    for m in a:
        for name in SERIES:
            np.testing.assert_allclose(getattr(a[m], name), getattr(b[m], name), rtol=0, atol=atol, err_msg=f"{m} {name}")
        assert a[m].updates.keys() == b[m].updates.keys()
        for src in a[m].updates:
            for f in ("nis", "innovation", "fused", "rejected", "valid"):
                np.testing.assert_allclose(getattr(a[m].updates[src], f), getattr(b[m].updates[src], f), rtol=0,
                                           atol=atol, err_msg=f"{m} {src} {f}")
        np.testing.assert_array_equal(a[m].diverged, b[m].diverged)


@pytest.mark.parametrize("trajectory", ["figure8", "lawnmower"])
def test_results_do_not_depend_on_the_chunk_size(trajectory: str) -> None:
    config = _config(trajectory)
    ten = run_streaming(config, np.random.default_rng(5), num_runs=2)
    odd = run_streaming(config, np.random.default_rng(5), num_runs=2, chunk_s=1.37)   # chunks end mid-interval
    whole = run_streaming(config, np.random.default_rng(5), num_runs=2, chunk_s=1000.0)
    _assert_same(ten, odd)
    _assert_same(ten, whole)
    assert ten["lc"].t_s.size == 401 and ten["lc"].pos_err_m.shape == (401, 2)


def test_chunks_equal_the_bank_fed_the_whole_simulation_at_once() -> None:
    """The carried state (IMU increments, gyro sum, latest ping) is exact: the same streams as one
    whole-mission chunk give the streaming run's numbers."""
    config = _config()
    streamed = run_streaming(config, np.random.default_rng(8), num_runs=2, chunk_s=2.0)
    rng = np.random.default_rng(8)
    streams = SensorStreams.spawned(rng)
    truth = generate(config.trajectory, config.earth, config.imu.rate_hz)
    sensors = SensorStream(config.imu, streams, 2, truth.num_samples, truth.dt_s)
    sources = SourceStream(config, rng, 2, truth.num_samples, truth.dt_s, streams)
    bank = FilterBank(config, 2, truth.num_samples, truth.dt_s, streams.initial)
    bank.feed(SimChunk(0, truth, sensors.next_chunk(0, truth), sources=sources.next_chunk(0, truth)))
    _assert_same(streamed, bank.results())


def test_results_handed_out_chunk_by_chunk_add_up_to_the_whole() -> None:
    config = _config()
    whole = run_streaming(config, [np.random.default_rng(i) for i in range(3)], num_runs=3)
    for keep in (True, False):
        parts: list[dict] = []
        last = run_streaming(config, [np.random.default_rng(i) for i in range(3)], num_runs=3, chunk_s=7.0,
                             keep=keep, sinks=Sinks(on_chunk=parts.append))
        assert len(parts) == 6                                    # 40 s in 7 s chunks
        for m in METHODS:
            for name in SERIES:
                np.testing.assert_array_equal(np.concatenate([getattr(p[m], name) for p in parts]),
                                              getattr(whole[m], name), err_msg=f"{m} {name} keep={keep}")
            for src, rec in whole[m].updates.items():
                np.testing.assert_array_equal(np.concatenate([p[m].updates[src].nis for p in parts
                                                              if src in p[m].updates]), rec.nis)
            np.testing.assert_array_equal(parts[-1][m].diverged, whole[m].diverged)
        if not keep:
            assert last["lc"].t_s.size == parts[-1]["lc"].t_s.size < whole["lc"].t_s.size


def test_per_run_generators_give_each_run_its_own_numbers() -> None:
    """Run r of a batch equals run r alone (a study's runs are independent of their chunking)."""
    config = _config().replace("run", methods=("lc", "vb"))
    batch = run_streaming(config, [np.random.default_rng(10 + i) for i in range(3)], num_runs=3)
    alone = run_streaming(config, [np.random.default_rng(11)], num_runs=1)
    for m in ("lc", "vb"):
        np.testing.assert_allclose(batch[m].pos_err_m[:, 1], alone[m].pos_err_m[:, 0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch[m].nees[:, 1], alone[m].nees[:, 0], rtol=1e-12)


def test_should_stop_ends_the_stream_at_an_output_epoch() -> None:
    config = _config().replace("run", methods=("lc",))
    calls = {"n": 0}

    def stop() -> bool:
        calls["n"] += 1
        return calls["n"] >= 123
    out = run_streaming(config, np.random.default_rng(0), chunk_s=3.0, watch=Watch(should_stop=stop))
    assert out["lc"].t_s.size == 124       # epoch 0, then 123 polled epochs
    assert out["lc"].t_s[-1] == pytest.approx(12.3)
