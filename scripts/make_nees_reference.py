"""Write the NEES of a few seeded runs as they are when the reference is exact, the fixture that
``tests/unit/tauvcore/filter/kernels/test_reference_sigma.py`` holds the engine to bit for bit.

    python scripts/make_nees_reference.py tests/fixtures/nees_reference.npz

Written with the engine before ``[reference]`` (the reference's own 1-sigma) existed, so that
its default, 0 (exact), is shown to leave every NEES as it was: both banks (the 20-state
methods and Yoo 2014's), their smoothers, on a simulation and on the replay of a simulated log.
The cases (:func:`cases`) are rebuilt by the test from the same seeds.
"""

from __future__ import annotations

import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from tauvcore.config import ALL_METHODS, Config
from tauvcore.engine.mission import run
from tauvcore.engine.results import MethodResult
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.engine.smoothing import SmoothOptions
from tauvcore.eval.replay import replay
from tauvcore.filter.families import PAPERS, family_of
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log

EVERY = 5  # every 5th output epoch (2 Hz): a small file, a strict check
PAPER_METHODS = tuple(m for m in ALL_METHODS if family_of(m).name in PAPERS)
"""The papers' filters' methods (tauvcore.filter.families.PAPERS), which the fixture holds."""
NAMES = ("nees", "nees_block")


def simulation_config() -> Config:
    """Both papers' methods on 30 s of the figure eight, DVL, depth and magnetometer aiding, random
    initial errors."""
    return (
        Config()
        .replace("trajectory", name="figure8", duration_s=30.0)
        .replace("initial_error", mode="random")
        .replace("run", methods=PAPER_METHODS, aiding=("dvl", "depth", "mag"), seed=11)
    )


def replay_config() -> Config:
    """A 30 s simulated log of both banks' DVL methods, replayed off its reference by the initial errors."""
    return (
        Config()
        .replace("trajectory", name="figure8", duration_s=30.0)
        .replace("run", methods=("lc", "tc", "ins-dvl", "vkf"), seed=12)
        .replace("replay", initial_errors=True)
    )


def cases() -> Iterator[tuple[str, dict[str, MethodResult]]]:
    """Each case's name and results: a simulation (two runs), the smoothers on one run of it, and
    the replay of a simulated log."""
    config = simulation_config()
    rng = np.random.default_rng(config.run.seed)
    yield "simulation", run(config, simulate(config, rng, 2), rng)
    smoothed = config.replace("run", methods=("lc", "ins-dvl"))
    rng = np.random.default_rng(config.run.seed)
    results = run(smoothed, simulate(smoothed, rng), rng, smooth=SmoothOptions())
    yield "smoothed", {m: r.smoothed for m, r in results.items() if r.smoothed is not None}
    config = replay_config()
    rng = np.random.default_rng(config.run.seed)
    sim = simulate(config, rng)
    with tempfile.TemporaryDirectory() as tmp:
        write_log(Path(tmp) / "log", simulation_tables([SimChunk.whole(sim)]), "csv")
        _, results = replay(config, read_log(Path(tmp) / "log"), np.random.default_rng(config.run.seed))
    yield "replay", results


def arrays() -> dict[str, np.ndarray]:
    """``case/method/name`` -> every :data:`EVERY`-th epoch of that NEES series."""
    return {
        f"{case}/{method}/{name}": np.asarray(getattr(result, name))[::EVERY]
        for case, results in cases()
        for method, result in results.items()
        for name in NAMES
    }


def main() -> None:
    if len(sys.argv) != 2:
        raise SystemExit("usage: python scripts/make_nees_reference.py OUT.npz")
    np.savez_compressed(sys.argv[1], **arrays())


if __name__ == "__main__":
    main()
