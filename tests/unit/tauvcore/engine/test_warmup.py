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
    """The bar's total is every kernel's source lines; a kernel compiled (a numba:compile event,
    or a helper's line naming it) adds its lines once, whatever its signatures; a kernel made
    elsewhere adds none; the bar ends full. Off the terminal (``show`` False) there is no bar."""
    import numba

    def twice(x):
        return 2 * x

    def other(x):
        return x + 1

    weights = warmup.kernel_weights()
    assert len(weights) > 100 and "tauvcore.engine.loop.run_stops" in weights  # the modules' kernels, by name
    counted, stranger = numba.njit(twice), numba.njit(other)   # no cache: compiled here
    key = warmup.kernel_key(counted)
    monkeypatch.setattr(warmup, "kernel_weights", lambda: {key: 7, "helper.kernel": 3, "never.compiled": 5})
    with warmup.compile_progress(True) as progress:
        assert progress is not None and progress.bar.total == 15 and progress.bar.n == 0
        counted(1)
        counted(1.5)   # a second signature: compiled again, not counted again
        stranger(1)
        assert progress.bar.n == 7
        progress.mark("helper.kernel")   # the helper process's line
        progress.mark("helper.kernel")
        progress.mark("a.stranger")
        assert progress.bar.n == 10
    assert progress.bar.n == 15
    assert "tauv: compiling kernels" in capsys.readouterr().err
    with warmup.compile_progress(False) as nothing:
        assert nothing is None


def test_the_helper_reports_each_kernel_it_compiles_on_stdout(monkeypatch, capsys) -> None:
    """``--part others`` runs that half of the mission and prints one line per kernel compiled."""
    import numba

    def thrice(x):
        return 3 * x

    kernel = numba.njit(thrice)
    ran = []
    monkeypatch.setattr(warmup, "warm_up", lambda part=None: ran.append(part) or kernel(1) or 0.0)
    warmup.main(["--part", "others"])
    assert ran == ["others"]
    assert capsys.readouterr().out.splitlines() == [warmup.COMPILED + warmup.kernel_key(kernel)]


def test_the_halves_together_take_every_method_once() -> None:
    import pytest

    from tauvcore.config import ALL_METHODS

    eskf, others = warmup.part_methods("eskf"), warmup.part_methods("others")
    assert sorted(eskf + others) == sorted(ALL_METHODS) and not set(eskf) & set(others)
    assert "lc" in eskf and {"vkf", "ukf"} <= set(others) and warmup.part_methods(None) == ALL_METHODS
    with pytest.raises(ValueError, match="part must be one of"):
        warmup.part_methods("half")
