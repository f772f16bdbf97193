"""A replay's NEES only where its reference was measured (tauvcore.eval.judging): between the
samples of a slow reference the interpolated reference is not the truth, and a NEES there would
judge the interpolation, not the filter."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval.consistency import nees_series
from tauvcore.eval.judging import JUDGED_SERIES, judged, output_interval_s, reference_epochs
from tauvcore.eval.replay import replay
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log


def test_reference_epochs_known_answers() -> None:
    t = np.round(np.arange(0.0, 3.0, 0.1), 12)  # 10 Hz output epochs
    whole = reference_epochs(np.arange(0.0, 3.0, 1.0), t, 0.1)
    np.testing.assert_array_equal(np.flatnonzero(whole), [0, 10, 20])
    # a reference half-way between two epochs: both are within half an interval
    between = reference_epochs(np.array([1.05]), t, 0.1)
    np.testing.assert_array_equal(np.flatnonzero(between), [10, 11])
    # a reference denser than the output: every epoch
    assert reference_epochs(np.arange(0.0, 3.0, 0.01), t, 0.1).all()
    # one sample, and none
    np.testing.assert_array_equal(np.flatnonzero(reference_epochs(np.array([2.02]), t, 0.1)), [20])
    assert not reference_epochs(np.zeros(0), t, 0.1).any()


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A 60 s figure eight (turns all the way) written twice: its reference at the IMU's rate and
    the same reference kept only at every whole second (a 1 Hz post-processed solution)."""
    root = tmp_path_factory.mktemp("judging")
    config = Config().replace("trajectory", name="figure8", duration_s=60.0)
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(4)))])
    write_log(root / "full", tables, "csv")
    ref = tables["reference"]
    whole_s = np.abs(ref["t_s"] - np.round(ref["t_s"])) < 1e-9
    assert whole_s.sum() == 61
    write_log(root / "sparse", {**tables, "reference": {k: v[whole_s] for k, v in ref.items()}}, "csv")
    return root / "full", root / "sparse"


def _replayed(directory: Path) -> dict:
    config = Config().replace("run", methods=("lc", "ins-dvl"), seed=3).replace("replay", initial_errors=True)
    config = config.replace("initial_error", mode="random")
    _, results = replay(config, read_log(directory), np.random.default_rng(3))
    return results


def test_a_slow_reference_judges_nees_at_its_own_epochs_only(logs: tuple[Path, Path]) -> None:
    """Given the same mission replayed against its reference at the IMU's rate and against the same
    reference at 1 Hz, then with the 1 Hz reference the NEES is finite exactly at the whole
    seconds and there equals the full reference's to 1e-9 (both are the truth there); the errors
    stay at every epoch (the plots' interpolated reference); the consistency over the finite NEES
    is the full replay's at those epochs, and unlike the mean over every epoch of the
    interpolated comparison it stays near the full reference's."""
    full_dir, sparse_dir = logs
    full, sparse = _replayed(full_dir), _replayed(sparse_dir)
    for m in ("lc", "ins-dvl"):
        f, s = full[m], sparse[m]
        at = np.abs(s.t_s - np.round(s.t_s)) < 1e-9
        assert at.sum() == 61
        known = np.isfinite(f.nees_block).all(axis=(0, 1))  # the blocks a replay knows (not the sensors')
        assert known.sum() >= 3
        fb, sb = f.nees_block[..., known], s.nees_block[..., known]
        assert np.isfinite(sb[at]).all() and np.isnan(s.nees_block[~at]).all()
        np.testing.assert_allclose(sb[at], fb[at], rtol=1e-9, atol=1e-12)
        assert np.isfinite(s.tilt_err_deg).all() and np.isfinite(s.vel_err_mps).all()
        np.testing.assert_allclose(s.tilt_err_deg[at], f.tilt_err_deg[at], rtol=1e-9, atol=1e-12)
    # what the mask removes: the 1 Hz reference interpolated through the turns is off by more than
    # the filter's tilt sigma between its samples
    lc_full, lc_sparse = full["lc"], sparse["lc"]
    assert np.nanmax(np.abs(lc_sparse.tilt_err_deg - lc_full.tilt_err_deg)) > 0.0
    tilt = nees_series(lc_sparse, "tilt")[:, 0]
    np.testing.assert_allclose(np.nanmean(tilt), np.mean(nees_series(lc_full, "tilt")[np.isfinite(tilt), 0]), rtol=1e-9)


def test_a_simulated_log_is_judged_unchanged_and_a_log_without_reference_not_at_all(logs: tuple[Path, Path]) -> None:
    """The full-rate reference has a sample at every output epoch: judged returns every array as
    it was. The same results judged for a log without a reference: every judged series NaN,
    the smoothed ones too."""
    full_dir, _ = logs
    log = read_log(full_dir)
    config = Config().replace("run", methods=("lc",), seed=1)
    config, results = replay(config, log, np.random.default_rng(1))
    again = judged(log, results, config.filter.output_rate_hz)
    for name in JUDGED_SERIES:
        np.testing.assert_array_equal(getattr(again["lc"], name), getattr(results["lc"], name))
    bare = dataclasses_replace_no_reference(log)
    blind = judged(bare, results, config.filter.output_rate_hz)
    for name in JUDGED_SERIES:
        assert np.isnan(getattr(blind["lc"], name)).all()
    assert output_interval_s(log, config.filter.output_rate_hz) == pytest.approx(0.1, rel=1e-9)


def dataclasses_replace_no_reference(log):
    import dataclasses

    return dataclasses.replace(log, ref_t_s=None, ref_position=None, ref_euler=None, ref_vel_n=None)


def test_the_smoothed_results_are_judged_as_the_filter_s(logs: tuple[Path, Path]) -> None:
    """With the smoother, the smoothed NEES of a 1 Hz reference is finite at the same epochs."""
    from tauvcore.engine import mission
    from tauvcore.engine.smoothing import SmoothOptions
    from tauvcore.eval.replay import prepare

    _, sparse_dir = logs
    log = read_log(sparse_dir)
    rng = np.random.default_rng(1)
    config, sim = prepare(Config().replace("run", methods=("lc",), seed=1), log, rng)
    results = judged(log, mission.run(config, sim, rng, smooth=SmoothOptions()), config.filter.output_rate_hz)
    r = results["lc"]
    assert r.smoothed is not None
    vel, smoothed_vel = nees_series(r, "vel")[:, 0], nees_series(r.smoothed, "vel")[:, 0]
    np.testing.assert_array_equal(np.isfinite(smoothed_vel), np.isfinite(vel))
    assert np.isfinite(vel).sum() == 61 and len(r.t_s) == 601


def test_the_nees_plot_joins_a_slow_reference_s_epochs(logs: tuple[Path, Path]) -> None:
    """The dashboard's NEES figure of the 1 Hz replay draws a line through its 61 known epochs
    (plotly's connectgaps), not 601 points of which 540 are gaps."""
    from app.figures.error_figures import nees_figure

    _, sparse_dir = logs
    results = _replayed(sparse_dir)
    figure = nees_figure({"lc": results["lc"]}, "tilt", max_points=None)
    (lc,) = [t for t in figure.data if t.name == "LC"]
    assert lc.connectgaps is True
    assert np.isfinite(np.array(lc.y, dtype=float)).sum() == 61
