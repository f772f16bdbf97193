"""The warm-up mission the README's commands run after installing takes every kernel of the engine."""

from __future__ import annotations

from tauvcore.engine import loop, smoothing, warmup, yoo_loop
from tauvcore.filter.kernels import correction, smoother
from tauvcore.filter.kernels import dvl_kernels as dvl
from tauvcore.filter.kernels import invariant_kernels as invariant
from tauvcore.filter.kernels import strapdown_kernels as strapdown
from tauvcore.truth import dynamic

# the engine's entry points from Python (propagate_bank runs inside run_stops), by their modules
ENGINE_KERNELS = (
    (loop, ("run_stops", "record_bank", "positive_definite_bank", "flag_implausible_bank")),
    (yoo_loop, ("run_stops",)),
    (strapdown, ("advance",)),
    (correction, ("correct_batch", "inject_batch")),
    (dvl, ("dvl_measure_bank",)),
    (invariant, ("retract_batch",)),
    (smoother, ("smooth_backward",)),
    (smoothing, ("smoothed_series_into",)),
)


def test_the_warm_up_compiles_every_kernel_the_engine_calls() -> None:
    assert warmup.warm_up() > 0.0
    for module, names in ENGINE_KERNELS:
        for name in names:
            assert getattr(module, name).signatures, f"{module.__name__}.{name} was not compiled by the warm-up"
    assert dynamic.simulate_knots.signatures, "the dynamic truth was not compiled by the warm-up"
