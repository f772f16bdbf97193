"""A study with the smoother: every run smoothed inside its chunk, wherever the chunk is computed,
the smoothed series summed beside the filtered."""

import numpy as np
import pytest

from tauvcore.config import Config, to_dict
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.study import compute_chunk, iterate_chunks, run_chunk, run_study, study_config

CONFIG = Config().replace("trajectory", name="figure8", duration_s=20.0).replace("run", methods=("lc", "vkf"))


def test_a_smoothed_study_is_the_same_on_worker_processes_and_leaves_no_tape(tmp_path) -> None:
    """Four runs in chunks of two, smoothed with every tape spilled to ``tmp_path``: in this
    process and on two worker processes the summaries are identical, the smoothed series are
    run_chunk's ``.smoothed`` (Yoo 2014's method's too), and nothing is left in ``tmp_path``."""
    spill = SmoothOptions(budget_mb=0.0, directory=str(tmp_path))
    seeded = CONFIG.replace("run", seed=3)
    here = run_study(seeded, 4, workers=1, chunk_runs=2, smooth=spill).summary()
    there = run_study(seeded, 4, workers=2, chunk_runs=2, smooth=spill).summary()
    assert list(tmp_path.iterdir()) == []
    assert here["methods"]["vkf"]["smoothed"] is not None
    for key in ("rms", "mean_nees"):
        for name, values in here["methods"]["lc"]["smoothed"][key].items():
            np.testing.assert_array_equal(there["methods"]["lc"]["smoothed"][key][name], values, err_msg=name)
    assert here["methods"]["lc"]["smoothed"]["consistency"] == there["methods"]["lc"]["smoothed"]["consistency"]
    chunk = compute_chunk(to_dict(CONFIG), 3, 2, 2, SmoothOptions())
    direct = run_chunk(CONFIG, 3, 2, 2, SmoothOptions())["lc"].smoothed
    np.testing.assert_array_equal(chunk.smoothed["lc"]["vel_err_mps"], direct.vel_err_mps)
    assert set(chunk.smoothed) == {"lc", "vkf"} and study_config(CONFIG).initial_error.mode == "random"
    filtered = np.asarray(here["methods"]["lc"]["rms"]["vel_err_mps"])
    smoothed = np.asarray(here["methods"]["lc"]["smoothed"]["rms"]["vel_err_mps"])
    assert np.sqrt(np.mean(smoothed**2)) < np.sqrt(np.mean(filtered**2))


@pytest.mark.slow
def test_a_dask_cluster_smooths_to_the_local_numbers(tmp_path) -> None:
    """The smoother's options travel with the chunks to Dask workers: their smoothed series are
    the local ones bit for bit, and the tapes spilled on the workers are removed."""
    distributed = pytest.importorskip("distributed")
    spill = SmoothOptions(budget_mb=0.0, directory=str(tmp_path))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  host="127.0.0.1") as cluster:
        remote = list(iterate_chunks(CONFIG, 4, 3, dask_address=cluster.scheduler_address, chunk_runs=2, smooth=spill))
    local = list(iterate_chunks(CONFIG, 4, 3, workers=1, chunk_runs=2, smooth=SmoothOptions()))
    assert list(tmp_path.iterdir()) == []
    for a, b in zip(local, remote, strict=True):
        assert set(a.smoothed) == set(b.smoothed) == {"lc", "vkf"}
        for method in ("lc", "vkf"):
            for name, values in a.smoothed[method].items():
                np.testing.assert_array_equal(b.smoothed[method][name], values, err_msg=f"{method} {name}")
