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


def test_the_progress_counts_each_kernel_compiled_once_by_its_lines(monkeypatch, capsys) -> None:
    """The bar's total is every kernel's source lines; a kernel compiled (a numba:compile event)
    adds its lines once, whatever its signatures; a kernel made elsewhere adds none; the bar
    ends full. Off the terminal (``show`` False) there is no bar."""
    import numba

    def twice(x):
        return 2 * x

    def other(x):
        return x + 1

    assert len(warmup.kernel_weights()) > 100   # the tauvcore modules' kernels, found
    counted, stranger = numba.njit(twice), numba.njit(other)   # no cache: compiled here
    monkeypatch.setattr(warmup, "kernel_weights", lambda: {id(counted): 7, id(stranger) + 1: 5})
    with warmup.compile_progress(True) as bar:
        assert bar.total == 12 and bar.n == 0
        counted(1)
        counted(1.5)   # a second signature: compiled again, not counted again
        stranger(1)
        assert bar.n == 7
    assert bar.n == 12
    assert "tauv: compiling kernels" in capsys.readouterr().err
    with warmup.compile_progress(False) as nothing:
        assert nothing is None
