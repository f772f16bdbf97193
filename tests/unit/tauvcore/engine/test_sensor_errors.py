"""The sensor-error records (``run(..., sensor_errors=True)``: MethodResult.sensor_est,
sensor_sigma, sensor_true): asking for them changes no other number; the truth is the
simulation's own; the estimate and sigma are the filter's (a known answer for the standalone INS,
the bank's own P at the last epoch, the sensor NEES rebuilt from them); and they follow the
chunking, stops, progress and hand-outs as every other per-epoch record does."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine import filter_bank, yoo_bank
from tauvcore.engine.mission import Banks, Sinks, Watch, run, run_streaming
from tauvcore.engine.results import (
    SENSOR_COLUMNS,
    SENSOR_FIELDS,
    SENSOR_STATES,
    MethodResult,
    sensor_states,
)
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.engine.start import initial_covariance
from tauvcore.filter.layout import NEES_BLOCKS, NOISE, STATE
from tauvcore.ins.error_model import noise_psd
from tests.unit.tauvcore.engine.yoo_reference import use_numpy_bank

METHODS = ("ins", "lc", "tc", "ins-dvl", "vkf")
SENSOR_BLOCK = list(NEES_BLOCKS).index("sensor")  # the sensor NEES's column of nees_block (both banks)


def _config(duration_s: float = 20.0, methods: tuple[str, ...] = METHODS) -> Config:
    config = Config().replace("trajectory", name="figure8", duration_s=duration_s)
    return config.replace("initial_error", mode="random").replace("run", methods=methods, aiding=("dvl", "depth"))


def _same(a: object, b: object, where: str) -> None:
    """Every array of ``a`` exactly ``b``'s (NaN where NaN), recursively through dataclasses and dicts."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for key in a:
            _same(a[key], b[key], f"{where}.{key}")
    elif dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.shape == b.shape and a.dtype == b.dtype, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), where
    else:
        assert a == b, where


def _assert_only_sensor_fields_differ(off: dict[str, MethodResult], on: dict[str, MethodResult]) -> None:
    assert off.keys() == on.keys()
    for method in off:
        for name in SENSOR_FIELDS:
            assert getattr(off[method], name) is None, (method, name)
        T, R = on[method].t_s.size, on[method].nees.shape[1]
        S = len(sensor_states(method))
        for name in SENSOR_FIELDS:
            assert getattr(on[method], name).shape == (T, R, S), (method, name)
        _same(off[method], dataclasses.replace(on[method], **dict.fromkeys(SENSOR_FIELDS)), method)


def _latest_ping(ping_k: np.ndarray, out_k: np.ndarray) -> np.ndarray:
    """Row of the latest ping at or before each output sample (the first ping's before it)."""
    return np.maximum(np.searchsorted(ping_k, out_k, side="right") - 1, 0)


def test_the_columns_are_the_sensor_blocks_of_the_state_in_its_order() -> None:
    """The 20-state filter's 11 columns are the NEES sensor block's states in order (the NEES
    tests below rest on it); Yoo 2014's 6 are its bias states, named as the first six."""
    assert filter_bank.SENSOR_INDEX.tolist() == list(NEES_BLOCKS["sensor"])
    assert [c.name for c in SENSOR_STATES] == ["ba_x", "ba_y", "ba_z", "bg_x", "bg_y", "bg_z", "b_dvl_1",
                                               "b_dvl_2", "b_dvl_3", "b_dvl_4", "sf_dvl"]
    assert [c.unit for c in SENSOR_STATES] == ["m/s^2"] * 3 + ["rad/s"] * 3 + ["m/s"] * 4 + ["-"]
    assert SENSOR_COLUMNS["yoo"] == SENSOR_STATES[:6]
    assert yoo_bank.SENSOR_INDEX.tolist() == np.flatnonzero(yoo_bank.BLOCK_OF_STATE == SENSOR_BLOCK).tolist()
    assert sensor_states("vkf") is SENSOR_COLUMNS["yoo"] and sensor_states("tc") is SENSOR_STATES
    assert len(SENSOR_STATES) == len(NEES_BLOCKS["sensor"]) and len(SENSOR_COLUMNS["yoo"]) == 6


def test_streaming_asking_for_the_sensor_errors_changes_no_other_number() -> None:
    """Two runs, the INS, LC, TC and both Yoo methods: off, the three fields are None; on, they
    are (T, R, S) and every other field of every method (series, updates, the VKF's trace) is
    exactly the run without them."""
    config = _config()
    off = run_streaming(config, np.random.default_rng(1), num_runs=2)
    on = run_streaming(config, np.random.default_rng(1), num_runs=2, sensor_errors=True)
    _assert_only_sensor_fields_differ(off, on)
    assert on["vkf"].vkf_trace is not None


def test_a_whole_simulation_with_its_truth() -> None:
    """mission.run on a simulate()d mission: no other number changes, and sensor_true is the
    simulation's truth at the output samples: the IMU's true biases at the sample, the DVL's true
    beam biases and scale factor of the latest ping (the first ping's before it)."""
    config = _config(15.0)
    results = {}
    for flag in (False, True):
        rng = np.random.default_rng(2)
        sim = simulate(config, rng, 2)
        results[flag] = run(config, sim, rng, sensor_errors=flag)
    _assert_only_sensor_fields_differ(results[False], results[True])
    out_k = np.searchsorted(sim.truth.t_s, results[True]["lc"].t_s)
    np.testing.assert_array_equal(sim.truth.t_s[out_k], results[True]["lc"].t_s)
    ping = _latest_ping(sim.dvl.index, out_k)
    imu_true = np.concatenate([sim.imu.accel_bias[out_k], sim.imu.gyro_bias[out_k]], axis=-1)
    dvl_true = np.concatenate([sim.dvl.bias_mps[ping], sim.dvl.scale_factor[ping][..., None]], axis=-1)
    for method, r in results[True].items():
        expected = imu_true if method in ("ins-dvl", "vkf") else np.concatenate([imu_true, dvl_true], axis=-1)
        np.testing.assert_array_equal(r.sensor_true, expected, err_msg=method)


def test_sensor_true_is_what_the_streamed_simulation_drew() -> None:
    """The chunks run_streaming simulated (on_sim_chunk), pieced together: the IMU biases (a walk,
    different at every sample) at the output samples, the DVL's per-ping beam biases and scale
    factor (walks too) of the latest ping, for every run and every method."""
    config = _config()
    chunks: list[SimChunk] = []
    results = run_streaming(config, np.random.default_rng(3), num_runs=2, chunk_s=4.0, sensor_errors=True, sinks=Sinks(on_sim_chunk=chunks.append))
    assert len(chunks) > 3
    t_s = np.concatenate([c.truth.t_s for c in chunks])
    ba = np.concatenate([c.imu.accel_bias for c in chunks])
    bg = np.concatenate([c.imu.gyro_bias for c in chunks])
    ping_k = np.concatenate([c.dvl.index for c in chunks])
    ping_bias = np.concatenate([c.dvl.bias_mps for c in chunks])
    ping_sf = np.concatenate([c.dvl.scale_factor for c in chunks])
    assert np.ptp(ba[:, 0, 0]) > 0 and np.ptp(ping_bias[:, 0, 0]) > 0 and np.ptp(ping_sf[:, 0]) > 0
    for method, r in results.items():
        out_k = np.searchsorted(t_s, r.t_s)
        np.testing.assert_array_equal(t_s[out_k], r.t_s)
        ping = _latest_ping(ping_k, out_k)
        true = {c.name: None for c in sensor_states(method)}
        for j, axis in enumerate("xyz"):
            true[f"ba_{axis}"], true[f"bg_{axis}"] = ba[out_k, :, j], bg[out_k, :, j]
        if "sf_dvl" in true:
            for j in range(4):
                true[f"b_dvl_{j + 1}"] = ping_bias[ping, :, j]
            true["sf_dvl"] = ping_sf[ping]
        np.testing.assert_array_equal(r.sensor_true, np.stack(list(true.values()), axis=-1), err_msg=method)


def test_the_standalone_ins_keeps_its_estimate_and_its_sigma_grows_as_the_random_walk() -> None:
    """Without aiding nothing corrects the sensor errors: their estimate stays at the start
    value (zero) and, as nothing else drives them (F has zero rows for them), each variance is
    its prior plus the walk's PSD times the time: ``sigma^2 = P0_ii + q_i t``."""
    config = _config(20.0, ("ins",))
    r = run_streaming(config, np.random.default_rng(4), num_runs=2, sensor_errors=True)["ins"]
    assert np.all(r.sensor_est == 0.0)
    P0 = np.diag(initial_covariance(config, np.zeros(3)))
    q = noise_psd(config.imu, config.dvl)
    var0 = np.array([P0[getattr(STATE, c.block).start + c.component] for c in SENSOR_STATES])
    rate = np.array([q[getattr(NOISE, c.block).start + c.component] for c in SENSOR_STATES])
    expected = np.sqrt(var0 + rate * r.t_s[:, None, None])
    np.testing.assert_allclose(r.sensor_sigma, np.broadcast_to(expected, r.sensor_sigma.shape), rtol=1e-9, atol=0)
    assert np.all(r.sensor_sigma[-1] > r.sensor_sigma[0])  # every walk is on


def test_the_last_epoch_is_the_banks_state_and_rebuilds_the_sensor_nees() -> None:
    """At the last sample (an output epoch) the records are the banks' own state after the run:
    the estimate is their ba, bg (and DVL states), the sigma the square root of their P's diagonal;
    with the sensor block of that P, ``(true - est)^T P_ss^-1 (true - est)`` is the sensor NEES the
    results carry, so ``sensor_true - sensor_est`` is the error the NEES is of."""
    config = _config(15.0, ("ins", "lc", "tc", "ins-dvl"))
    rng = np.random.default_rng(5)
    sim = simulate(config, rng, 2)
    banks = Banks(config, 2, sim.truth.num_samples, sim.truth.dt_s, rng, sensor_errors=True)
    banks.feed(SimChunk.whole(sim))
    results = banks.results()
    first, yoo = banks.banks
    assert isinstance(first, filter_bank.FilterBank) and isinstance(yoo, yoo_bank.YooBank)
    for bank, index in ((first, filter_bank.SENSOR_INDEX), (yoo, yoo_bank.SENSOR_INDEX)):
        for m, method in enumerate(bank.methods):
            r = results[method]
            assert r.t_s[-1] == sim.truth.t_s[-1]
            P_ss = bank.P[m][:, index][:, :, index]  # (R, S, S)
            est = [bank.ba[m], bank.bg[m]]
            if bank is first:
                est += [first.bdvl[m], first.sf[m][:, None]]
            np.testing.assert_array_equal(r.sensor_est[-1], np.concatenate(est, axis=-1), err_msg=method)
            np.testing.assert_array_equal(r.sensor_sigma[-1], np.sqrt(np.diagonal(P_ss, axis1=1, axis2=2)),
                                          err_msg=method)
            e = r.sensor_true[-1] - r.sensor_est[-1]
            nees = np.einsum("ri,ri->r", e, np.linalg.solve(P_ss, e[..., None])[..., 0])
            np.testing.assert_allclose(nees, r.nees_block[-1, :, SENSOR_BLOCK], rtol=1e-9, err_msg=method)
            if method != "ins":
                assert np.any(r.sensor_est[-1] != 0.0), method  # the aided methods did estimate


@pytest.mark.parametrize("methods", [("lc", "tc", "ins-dvl", "vkf")])
def test_the_sensor_records_do_not_depend_on_the_chunk_size(methods: tuple[str, ...]) -> None:
    config = _config(12.0, methods)
    a = run_streaming(config, np.random.default_rng(6), num_runs=2, chunk_s=2.0, sensor_errors=True)
    b = run_streaming(config, np.random.default_rng(6), num_runs=2, chunk_s=10.0, sensor_errors=True)
    for method in methods:
        for name in SENSOR_FIELDS:
            x, y = getattr(a[method], name), getattr(b[method], name)
            np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12 * np.max(np.abs(y)), err_msg=f"{method} {name}")


def test_stop_progress_and_hand_outs_cut_the_sensor_records_with_the_epochs() -> None:
    """A stop request ends the sensor records at the stop's epoch, as t_s, in both banks; each
    progress call's partial results carry them up to its time; results handed out chunk by
    chunk (keep=False) carry each chunk's rows and add up to the whole run's."""
    config = _config(12.0, ("lc", "vkf"))
    whole = run_streaming(config, np.random.default_rng(7), num_runs=2, sensor_errors=True)
    polls = iter(range(10_000))
    stopped = run_streaming(config, np.random.default_rng(7), num_runs=2, sensor_errors=True, watch=Watch(should_stop=lambda: next(polls) >= 50))
    seen: list[dict[str, MethodResult]] = []
    run_streaming(config, np.random.default_rng(7), num_runs=2, sensor_errors=True, watch=Watch(interval_s=2.0, progress=lambda t, r: seen.append(r)))
    handed: list[dict[str, MethodResult]] = []
    run_streaming(config, np.random.default_rng(7), num_runs=2, sensor_errors=True, keep=False, chunk_s=3.0, sinks=Sinks(on_chunk=handed.append))
    assert len(seen) >= 4 and len(handed) >= 4
    for method in ("lc", "vkf"):
        T = stopped[method].t_s.size
        assert 10 < T < whole[method].t_s.size
        for name in SENSOR_FIELDS:
            full = getattr(whole[method], name)
            assert getattr(stopped[method], name).shape[0] == T
            np.testing.assert_array_equal(getattr(stopped[method], name), full[:T])
            for partial in seen:
                part = getattr(partial[method], name)
                assert part.shape[0] == partial[method].t_s.size
                np.testing.assert_array_equal(part, full[: part.shape[0]])
            pieces = [getattr(h[method], name) for h in handed]
            assert [p.shape[0] for p in pieces] == [h[method].t_s.size for h in handed]
            np.testing.assert_array_equal(np.concatenate(pieces), full)


def test_off_the_banks_store_no_rows_for_them() -> None:
    """Without the flag the stores' sensor arrays have no rows: nothing of the mission's length."""
    config = _config(4.0, ("lc", "vkf"))
    rng = np.random.default_rng(8)
    sim = simulate(config, rng, 2)
    banks = Banks(config, 2, sim.truth.num_samples, sim.truth.dt_s, rng)
    banks.feed(SimChunk.whole(sim))
    for bank, S in zip(banks.banks, (len(SENSOR_STATES), len(SENSOR_COLUMNS["yoo"])), strict=True):
        assert bank is not None and bank.chunks
        for store in bank.chunks:
            assert store["t_s"].size > 0
            for name in SENSOR_FIELDS:
                assert store[name].shape == (0, 1, 2, S), name


def test_without_dvl_pings_the_dvl_truth_is_unknown() -> None:
    """A mission without a DVL (a log without one): the DVL columns of sensor_true are NaN (the
    NEES keeps its zero for them), the IMU's are the truth; no other number changes."""
    config = _config(6.0, ("ins", "lc"))
    results = {}
    for flag in (False, True):
        rng = np.random.default_rng(9)
        sim = simulate(config, rng, 2)
        sim = dataclasses.replace(sim, sources={k: v for k, v in sim.sources.items() if k != "dvl"})
        results[flag] = run(config, sim, rng, sensor_errors=flag)
    _assert_only_sensor_fields_differ(results[False], results[True])
    dvl = np.array([c.block in ("b_dvl", "sf_dvl") for c in SENSOR_STATES])
    for r in results[True].values():
        assert np.isnan(r.sensor_true[..., dvl]).all() and np.isfinite(r.sensor_true[..., ~dvl]).all()


def test_the_compiled_yoo_records_equal_the_numpy_reference(monkeypatch: pytest.MonkeyPatch) -> None:
    """Yoo 2014's compiled record (tauvcore.engine.yoo_records.record) and the numpy one
    (tests/unit/tauvcore/engine/yoo_reference.py) write the same sensor records, to 1e-9 relative."""
    config = _config(12.0, ("ins-dvl", "vkf")).replace("run", aiding=("dvl", "mag"))
    fast = run_streaming(config, np.random.default_rng(10), num_runs=2, sensor_errors=True)

    use_numpy_bank(monkeypatch)
    slow = run_streaming(config, np.random.default_rng(10), num_runs=2, sensor_errors=True)
    for method in fast:
        for name in SENSOR_FIELDS:
            x, y = getattr(fast[method], name), getattr(slow[method], name)
            np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-9 * np.max(np.abs(y)), err_msg=f"{method} {name}")
