"""The warm-up mission the README's commands run after installing takes every kernel of the engine."""

from __future__ import annotations

from tauvcore.engine import warmup
from tauvcore.filter import kernels
from tauvcore.truth import dynamic

# the engine's entry points from Python (propagate_bank runs inside run_stops)
ENGINE_KERNELS = ("run_stops", "advance", "record_bank", "correct_batch", "inject_batch",
                  "positive_definite_bank", "dvl_measure_bank")


def test_the_warm_up_compiles_every_kernel_the_engine_calls() -> None:
    assert warmup.warm_up() > 0.0
    for name in ENGINE_KERNELS:
        assert getattr(kernels, name).signatures, f"{name} was not compiled by the warm-up"
    assert dynamic.simulate_knots.signatures, "the dynamic truth was not compiled by the warm-up"
