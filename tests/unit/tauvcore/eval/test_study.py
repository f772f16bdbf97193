"""Monte Carlo studies: seeded runs as independent units, any chunking, any workers.

- a run's numbers do not depend on which runs share its chunk (to 1e-9; the batched products
  may differ in the last bits), and with the study's fixed chunking they are bit-identical
  whatever the number of local workers;
- the accumulator's RMS, mean NEES and consistency equal those computed from all runs at once,
  and its final statistics (RMS, median, 95th percentile, with and without the runs the monitor
  flagged) those of the per-run values;
- a Dask LocalCluster with two workers gives the local numbers bit for bit (slow).
"""

from __future__ import annotations

import numpy as np
import pytest

from tauvcore.config import Config, to_dict
from tauvcore.eval.consistency import nees_series, summarise_nees
from tauvcore.eval.study import (
    ERROR_SERIES,
    RUN_SERIES,
    ChunkSeries,
    StudyAccumulator,
    chunks,
    compute_chunk,
    final_statistics,
    iterate_chunks,
    local_pool,
    run_chunk,
    run_rng,
    run_study,
    submit_chunks,
)

CONFIG = (Config().replace("trajectory", name="figure8", duration_s=15.0).replace("dvl", beams=(1, 2))
          .replace("run", methods=("ins", "tc", "nsv", "elc"), seed=11))


def test_chunks_cover_the_runs_in_order():
    assert chunks(7, 3) == [(0, 3), (3, 3), (6, 1)]
    assert chunks(1, 10) == [(0, 1)]
    with pytest.raises(ValueError):
        chunks(0, 3)


def test_each_run_has_its_own_stream():
    a, b = run_rng(5, 0).standard_normal(4), run_rng(5, 1).standard_normal(4)
    assert not np.allclose(a, b)
    np.testing.assert_array_equal(a, run_rng(5, 0).standard_normal(4))
    assert not np.allclose(a, run_rng(6, 0).standard_normal(4))


def test_a_run_does_not_depend_on_the_runs_beside_it():
    whole = run_chunk(CONFIG, 11, 0, 5)
    parts = [run_chunk(CONFIG, 11, 0, 2), run_chunk(CONFIG, 11, 2, 1), run_chunk(CONFIG, 11, 3, 2)]
    for method, r in whole.items():
        for name in ("vel_err_mps", "pos_err_m", "tilt_err_deg", "heading_err_deg", "nees", "nees_block"):
            joined = np.concatenate([getattr(p[method], name) for p in parts], axis=1)
            np.testing.assert_allclose(joined, getattr(r, name), rtol=1e-9, atol=1e-12, err_msg=f"{method} {name}")
        np.testing.assert_array_equal(np.concatenate([p[method].diverged for p in parts]), r.diverged)
    # runs differ from each other: each drew its own noise, biases and initial errors
    assert np.ptp(whole["tc"].vel_err_mps[-1]) > 1e-4


def _all_series(chunk_list):
    return {m: {n: np.concatenate([c.series[m][n] for c in chunk_list], axis=1) for n in RUN_SERIES}
            for m in chunk_list[0].series}


def test_local_workers_give_bit_identical_numbers():
    one = list(iterate_chunks(CONFIG, 6, 11, workers=1, chunk_runs=3))
    two = list(iterate_chunks(CONFIG, 6, 11, workers=2, chunk_runs=3))
    with local_pool(2) as pool:       # one pool shared by two studies (tauv reproduce)
        other = list(iterate_chunks(CONFIG.replace("run", methods=("lc",)), 2, 11, chunk_runs=3, pool=pool))
        shared = list(iterate_chunks(CONFIG, 6, 11, chunk_runs=3, pool=pool))
    assert [c.first for c in two] == [0, 3] and [c.first for c in shared] == [0, 3]
    assert list(other[0].series) == ["lc"]
    a, b, c = _all_series(one), _all_series(two), _all_series(shared)
    for m in a:
        for n in RUN_SERIES:
            np.testing.assert_array_equal(a[m][n], b[m][n], err_msg=f"{m} {n}")
            np.testing.assert_array_equal(a[m][n], c[m][n], err_msg=f"{m} {n}")


def test_queued_studies_give_the_same_numbers_and_an_error_cancels_what_is_queued(tmp_path):
    """tauv reproduce queues every study's chunks at once (submit_chunks); they come back as
    files in the pool's directory, equal to the chunks computed in this process, and the files are
    gone afterwards. An error (or Ctrl-C) while they are queued cancels the chunks not started
    instead of computing them all first."""
    import os

    here = list(iterate_chunks(CONFIG, 6, 11, workers=1, chunk_runs=3))
    with local_pool(2) as pool:
        queued = [submit_chunks(CONFIG, 6, 11, pool, 3), submit_chunks(CONFIG.replace("run", methods=("lc",)), 4, 11,
                                                                       pool, 2)]
        first = list(iterate_chunks(CONFIG, 6, 11, chunk_runs=3, pool=pool, submitted=queued[0]))
        second = list(iterate_chunks(CONFIG, 4, 11, chunk_runs=2, pool=pool, submitted=queued[1]))
        chunk_dir = pool.chunk_dir
        assert os.listdir(chunk_dir) == []
    assert not os.path.exists(chunk_dir)
    assert [c.first for c in second] == [0, 2] and list(second[0].series) == ["lc"]
    a, b = _all_series(here), _all_series(first)
    for m in a:
        for n in RUN_SERIES:
            np.testing.assert_array_equal(a[m][n], b[m][n], err_msg=f"{m} {n}")
    long = CONFIG.replace("trajectory", duration_s=60.0)
    with pytest.raises(RuntimeError, match="stop"):
        with local_pool(2) as pool:
            queued = submit_chunks(long, 40, 11, pool, 2)          # 20 chunks
            next(iterate_chunks(long, 40, 11, chunk_runs=2, pool=pool, submitted=queued))
            raise RuntimeError("stop")
    assert sum(f.cancelled() for f in queued) >= 10


def test_the_accumulator_equals_the_whole_study_at_once():
    chunk_list = [compute_chunk(to_dict(CONFIG), 11, f, c) for f, c in chunks(5, 2)]
    acc = StudyAccumulator(CONFIG.run.methods)
    for c in reversed(chunk_list):                 # any order
        acc.add(c)
    whole = run_chunk(CONFIG, 11, 0, 5)
    summary = acc.summary()
    assert summary["num_runs"] == 5
    for m, r in whole.items():
        for n in ERROR_SERIES:
            np.testing.assert_allclose(acc.rms(m, n), np.sqrt(np.mean(getattr(r, n) ** 2, axis=1)), rtol=1e-9)
            np.testing.assert_allclose(summary["methods"][m]["final_per_run"][n], getattr(r, n)[-1], rtol=1e-9)
        np.testing.assert_allclose(acc.mean_nees(m, "nees"), r.nees.mean(axis=1), rtol=1e-9)
        for block in ("full", "vel", "heading"):
            direct = summarise_nees(nees_series(r, block), {"full": 20, "vel": 3, "heading": 1}[block])
            got = acc.consistency(m, block)
            assert got["per_dim"] == pytest.approx(direct.per_dim, rel=1e-9)
            assert got["in_band"] == pytest.approx(direct.in_band, abs=1e-12)


def test_final_statistics_with_and_without_the_flagged_runs():
    values = np.array([0.05, 0.04, 9.9, 0.06, np.nan, 0.03])
    flagged = np.array([False, False, True, False, False, False])
    got = final_statistics(values, flagged)
    finite = values[np.isfinite(values)]
    assert got["rms"] == pytest.approx(np.sqrt(np.mean(finite**2)), rel=1e-12)     # the locked-out run carries it
    assert got["median"] == pytest.approx(0.05) and got["runs"] == 5
    assert got["p95"] == pytest.approx(np.percentile(finite, 95.0), rel=1e-12)
    kept = np.array([0.05, 0.04, 0.06, 0.03])
    assert got["rms_unflagged"] == pytest.approx(np.sqrt(np.mean(kept**2)), rel=1e-12)
    assert got["median_unflagged"] == pytest.approx(0.045) and got["runs_unflagged"] == 4
    assert got["p95_unflagged"] == pytest.approx(np.percentile(kept, 95.0), rel=1e-12)
    with pytest.raises(ValueError, match="one entry per run"):
        final_statistics(values, flagged[:3])


def test_the_summary_names_the_flagged_runs_and_leaves_them_out_on_request():
    """Two chunks added out of order, run 3 flagged for LC: its number is reported, the RMS over
    all runs equals final_rms, and the unflagged statistics are those of the other runs."""
    t = np.array([0.0, 1.0])

    def chunk(first, finals, flags):
        series = {n: np.vstack([np.zeros_like(finals), finals]) for n in RUN_SERIES}
        return ChunkSeries(first=first, count=len(finals), t_s=t, series={"lc": series},
                           diverged={"lc": np.array(flags)})

    acc = StudyAccumulator(("lc",))
    acc.add(chunk(2, np.array([0.2, 7.0]), [False, True]))
    acc.add(chunk(0, np.array([0.1, 0.3]), [False, False]))
    m = acc.summary()["methods"]["lc"]
    assert m["flagged_runs"] == [3] and m["runs_flagged_by_monitor"] == 1
    stats = m["final_stats"]["vel_err_mps"]
    assert stats["rms"] == pytest.approx(m["final_rms"]["vel_err_mps"], rel=1e-12)
    assert stats["median_unflagged"] == pytest.approx(0.2) and stats["runs_unflagged"] == 3
    assert stats["rms_unflagged"] == pytest.approx(np.sqrt((0.01 + 0.09 + 0.04) / 3), rel=1e-12)


def test_run_study_reports_progress_and_hands_chunks_over_in_order():
    seen, progress = [], []
    run_study(CONFIG.replace("run", seed=11), 5, on_chunk=lambda c: seen.append(c.first),
              progress=lambda d, t: progress.append((d, t)), chunk_runs=2)
    assert seen == [0, 2, 4] and progress == [(2, 5), (4, 5), (5, 5)]


@pytest.mark.slow
def test_a_dask_cluster_gives_the_local_numbers():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  host="127.0.0.1") as cluster:
        remote = list(iterate_chunks(CONFIG, 6, 11, dask_address=cluster.scheduler_address, chunk_runs=3))
    local = list(iterate_chunks(CONFIG, 6, 11, workers=1, chunk_runs=3))
    a, b = _all_series(local), _all_series(remote)
    for m in a:
        for n in RUN_SERIES:
            np.testing.assert_array_equal(a[m][n], b[m][n], err_msg=f"{m} {n}")
