"""The smoother on the 20-state filter bank (tauvcore.engine.smoothing): it leaves the filter's
numbers alone, ends on them, bridges a DVL outage, is consistent, and its tape written to files
gives the numbers it gives in memory."""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.mission import Banks, Sinks, Watch, run, run_streaming
from tauvcore.engine.simulation import chunks_of, simulate
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.engine.tape import SmoothingError
from tauvcore.sensors.dvl import Outage

DIMS = np.array([3, 3, 2, 1, 11])  # NEES blocks: pos, vel, tilt, heading, sensor
FIELDS = ("pos_err_m", "vel_err_mps", "att_err_deg", "nees", "nees_block", "est_pos_n", "est_vel_n",
          "est_euler_rad", "pos_sigma_m", "heading_sigma_deg")


def _config(duration_s: float = 200.0, trajectory: str = "figure8", methods=("ins", "lc", "tc", "nsv", "iekf")):
    config = Config().replace("trajectory", name=trajectory, duration_s=duration_s)
    if duration_s > 140.0:
        config = config.replace("dvl", outages=(Outage(beams=(1, 2, 3, 4), start_s=80.0, end_s=140.0),))
    return config.replace("initial_error", mode="random").replace(
        "run", methods=methods, aiding=("dvl", "depth", "mag"), seed=3
    )


@pytest.fixture(scope="module")
def outage_runs():
    config = _config()
    sim = simulate(config, np.random.default_rng(1), 12)
    return (
        run(config, sim, np.random.default_rng(2)),
        run(config, sim, np.random.default_rng(2), smooth=SmoothOptions(), sensor_errors=True),
    )


def test_the_filter_s_numbers_are_unchanged(outage_runs):
    """With the smoother the filtered results are those of the run without it, bit for bit."""
    plain, smoothed = outage_runs
    for method, result in plain.items():
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(smoothed[method], name), getattr(result, name), err_msg=name)


def test_last_epoch_is_the_filter_s_and_ins_is_unchanged(outage_runs):
    """At the last epoch the smoothed estimate is the filtered one exactly; the standalone INS,
    which corrects nothing, is its own smoothed estimate throughout."""
    _, results = outage_runs
    for method, result in results.items():
        s = result.smoothed
        assert s is not None and s.t_s.shape == result.t_s.shape
        np.testing.assert_array_equal(s.t_s, result.t_s)
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(s, name)[-1], getattr(result, name)[-1], err_msg=f"{method} {name}")
        np.testing.assert_array_equal(s.sensor_est[-1], result.sensor_est[-1])
        assert not s.smoother_cuts.any()
    ins = results["ins"]
    for name in FIELDS:
        np.testing.assert_allclose(getattr(ins.smoothed, name), getattr(ins, name), rtol=0, atol=1e-9, err_msg=name)


def test_outage_is_bridged_and_everything_improves(outage_runs):
    """The smoothed position error during the 60 s four-beam outage is at most the filtered error
    at its ends (RMS over runs), and the smoothed RMS is below the filtered one for every aided
    method, block and stretch of the mission."""
    _, results = outage_runs

    def rms(a):
        return float(np.sqrt(np.mean(a**2)))

    for method in ("lc", "tc", "nsv", "iekf"):
        f, s = results[method], results[method].smoothed
        t = f.t_s
        inside = (t > 80.0) & (t < 140.0)
        ends = max(rms(f.pos_err_m[np.argmin(abs(t - 80.0))]), rms(f.pos_err_m[np.argmin(abs(t - 140.0))]))
        assert rms(s.pos_err_m[inside]) <= ends, method
        for lo, hi in ((0.0, 80.0), (80.0, 140.0), (140.0, 200.0)):
            w = (t >= lo) & (t < hi)
            for name in ("vel_err_mps", "tilt_err_deg", "heading_err_deg"):
                assert rms(getattr(s, name)[w]) < rms(getattr(f, name)[w]), (method, name, lo)
            assert rms(s.pos_err_m[w]) <= rms(f.pos_err_m[w]) + 1e-9, (method, lo)


def test_smoothed_nees_per_block(outage_runs):
    """Smoothed NEES/dim of every block in [0.5, 2] (12 runs: a coarse check; the slow test below
    holds 30 runs to it on the three missions)."""
    _, results = outage_runs
    for method in ("lc", "tc", "nsv", "iekf"):
        per_dim = np.nanmean(results[method].smoothed.nees_block, axis=(0, 1)) / DIMS
        assert np.all((per_dim > 0.5) & (per_dim < 2.0)), (method, per_dim)


def test_tape_in_files_equals_tape_in_memory(tmp_path):
    """A budget of nothing writes every segment to a temporary directory (removed after): the
    smoothed numbers are those of the tape held in memory, bit for bit."""
    config = _config(60.0, methods=("lc", "tc"))
    sim = simulate(config, np.random.default_rng(4), 2)
    held = run(config, sim, np.random.default_rng(5), smooth=SmoothOptions())
    spilled = run(config, sim, np.random.default_rng(5), smooth=SmoothOptions(budget_mb=0.0, directory=str(tmp_path)))
    for method in held:
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(spilled[method].smoothed, name), getattr(held[method].smoothed, name))
    assert list(tmp_path.iterdir()) == []


def test_unwritable_directory_is_one_line(tmp_path):
    """A tape that cannot be written: one SmoothingError naming the directory."""
    config = _config(30.0, methods=("lc",))
    sim = simulate(config, np.random.default_rng(4), 1)
    missing = tmp_path / "missing"
    with pytest.raises(SmoothingError, match="missing") as info:
        run(config, sim, np.random.default_rng(5), smooth=SmoothOptions(budget_mb=0.0, directory=str(missing)))
    assert "\n" not in str(info.value)


def test_a_stopped_run_smooths_what_was_run():
    """A run stopped early smooths its epochs up to the stop; its last smoothed epoch is the
    filtered one."""
    config = _config(60.0, methods=("lc",))
    sim = simulate(config, np.random.default_rng(4), 1)
    calls = []

    def stop() -> bool:
        calls.append(1)
        return len(calls) > 250

    results = run(config, sim, np.random.default_rng(5), Watch(should_stop=stop), smooth=SmoothOptions())
    lc = results["lc"]
    assert lc.t_s[-1] < 30.0 and lc.smoothed.t_s.shape == lc.t_s.shape
    np.testing.assert_array_equal(lc.smoothed.pos_err_m[-1], lc.pos_err_m[-1])
    assert np.abs(lc.smoothed.vel_err_mps[:-50] - lc.vel_err_mps[:-50]).max() > 0.0


def test_chunks_of_any_size_smooth_alike():
    """The tape cut at other chunk boundaries (the banks fed 7 s at a time) smooths to the same
    numbers to 1e-9."""
    config = _config(50.0, methods=("lc", "tc"))
    sim = simulate(config, np.random.default_rng(6), 2)
    whole = run(config, sim, np.random.default_rng(7), smooth=SmoothOptions())
    banks = Banks(config, 2, sim.truth.num_samples, sim.truth.dt_s, np.random.default_rng(7), smooth=SmoothOptions())
    for chunk in chunks_of(sim, round(7.0 / sim.truth.dt_s)):
        banks.feed(chunk)
    other = banks.with_smoothed(banks.results())
    for method in whole:
        for name in FIELDS:
            np.testing.assert_allclose(getattr(other[method].smoothed, name), getattr(whole[method].smoothed, name),
                                       rtol=0, atol=1e-9, err_msg=name)


@pytest.mark.slow
@pytest.mark.parametrize("trajectory", ["straight", "figure8", "lawnmower"])
def test_smoothed_nees_over_30_runs(trajectory):
    """LC, TC and NSV on the three missions, 30 seeded runs: smoothed NEES/dim of every block in
    [0.5, 2], and the smoothed RMS of position, velocity, tilt and heading below the filtered."""
    config = _config(250.0, trajectory, ("lc", "tc", "nsv")).replace("dvl", outages=())
    sim = simulate(config, np.random.default_rng(8), 30)
    results = run(config, sim, np.random.default_rng(9), smooth=SmoothOptions())
    for method, f in results.items():
        s = f.smoothed
        per_dim = np.nanmean(s.nees_block, axis=(0, 1)) / DIMS
        assert np.all((per_dim > 0.5) & (per_dim < 2.0)), (trajectory, method, per_dim)
        for name in ("vel_err_mps", "tilt_err_deg", "heading_err_deg"):
            assert np.mean(getattr(s, name) ** 2) < np.mean(getattr(f, name) ** 2), (trajectory, method, name)
        # horizontal position is unobservable with the DVL, depth and magnetometer: the smoother's
        # own sigma sees no gain there, and its error matches the filter's within the runs' spread
        assert np.all(s.pos_sigma_m <= f.pos_sigma_m + 1e-9)
        assert np.mean(s.pos_err_m**2) <= 1.05 * np.mean(f.pos_err_m**2), (trajectory, method)


def test_streamed_smoothed_chunks_add_up_to_the_kept_results():
    """run_streaming hands the smoothed results out chunk by chunk, in the mission's order, after
    the filtered ones: together they are the smoothed results it keeps, bit for bit."""
    config = _config(45.0, methods=("lc", "ins"))
    kept = run_streaming(config, np.random.default_rng(3), num_runs=2, smooth=SmoothOptions())
    order, parts = [], []

    def filtered(results):
        order.append("filtered")

    def smoothed(results):
        order.append("smoothed")
        parts.append(results)

    run_streaming(config, np.random.default_rng(3), num_runs=2, keep=False,
                  smooth=SmoothOptions(budget_mb=0.0), sinks=Sinks(on_chunk=filtered, on_smoothed_chunk=smoothed))
    assert order == ["filtered"] * len(parts) + ["smoothed"] * len(parts) and len(parts) > 2
    for method in kept:
        for name in FIELDS:
            np.testing.assert_array_equal(np.concatenate([getattr(p[method], name) for p in parts]),
                                          getattr(kept[method].smoothed, name), err_msg=name)


def test_yoo_methods_are_smoothed():
    """Yoo 2014's filters (ins-dvl, vkf; their 12 states and the DVL's consider states): with
    the smoother their filtered numbers are those without it (the bank's numpy methods, equal to
    its compiled loop to 1e-9), the last epoch is the filter's, the velocity, tilt and heading
    improve, and the smoothed NEES/dim of each block is in [0.5, 2] over 12 runs."""
    config = _config(120.0, methods=("ins-dvl", "vkf"))
    sim = simulate(config, np.random.default_rng(1), 12)
    plain = run(config, sim, np.random.default_rng(2))
    results = run(config, sim, np.random.default_rng(2), smooth=SmoothOptions(budget_mb=0.0))
    dims = np.array([3, 2, 1, 6])  # velocity, tilt, heading, sensors (no position state)
    for method, f in results.items():
        for name in FIELDS:
            np.testing.assert_allclose(getattr(f, name), getattr(plain[method], name), rtol=0, atol=1e-9,
                                       err_msg=name)
        s = f.smoothed
        for name in FIELDS:
            np.testing.assert_array_equal(getattr(s, name)[-1], getattr(f, name)[-1], err_msg=name)
        np.testing.assert_array_equal(s.pos_err_m, f.pos_err_m)  # no position state: the strapdown's
        for name in ("vel_err_mps", "tilt_err_deg", "heading_err_deg"):
            assert np.mean(getattr(s, name) ** 2) < 0.8 * np.mean(getattr(f, name) ** 2), (method, name)
        per_dim = np.nanmean(s.nees_block[..., 1:], axis=(0, 1)) / dims
        assert np.all((per_dim > 0.5) & (per_dim < 2.0)), (method, per_dim)
        assert not s.smoother_cuts.any()


def test_the_tape_keeps_covariances_as_their_upper_triangles(tmp_path):
    """A segment's covariances go on the tape as their upper triangles (in memory and on disk)
    and come back as the symmetric matrices they were, bit for bit; the other arrays as they are."""
    from tauvcore.engine.tape import Tape

    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 2, 1, 20, 20))
    P = A @ np.swapaxes(A, -1, -2)
    segment = {"tape_P": P, "ev_Pm": P[:2], "tape_X": rng.normal(size=(3, 2, 1, 9, 15))}
    for budget in (10**9, 0):
        tape = Tape(budget, str(tmp_path))
        tape.add(segment)
        assert tape.held_bytes + tape.spilled_bytes < sum(a.nbytes for a in segment.values())
        back = tape.segment(0)
        for name, a in segment.items():
            np.testing.assert_array_equal(back[name], a)
        tape.close()
    assert list(tmp_path.iterdir()) == []
