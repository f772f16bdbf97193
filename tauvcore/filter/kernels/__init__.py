"""The compiled filter's kernels (numba): the one implementation of the hot formulas.

Why numba: the filter bank's work is many small (3x3 to 20x20) operations per IMU sample and per
covariance step, for every method and Monte Carlo run; numpy's per-call overhead (microseconds)
dominated them. numba compiles plain loops over the batch to machine code, keeps the formulas
readable, and with its cache the compilation is paid once per install
(:func:`tauvcore.filter.kernels.common.jit`; ``python -m tauvcore.engine.warmup`` pays it).

These kernels ARE the formulas: :class:`tauvcore.ins.strapdown.Strapdown` (:mod:`.strapdown`),
:func:`tauvcore.ins.error_model.F_matrix` / :func:`~tauvcore.ins.error_model.G_matrix` /
:func:`~tauvcore.ins.error_model.discretise` and :func:`tauvcore.filter.eskf.propagate`
(:mod:`.error_model`), :func:`tauvcore.filter.eskf.correct` / ``inject`` / ``difference``
(:mod:`.correction`), :func:`tauvcore.filter.statistics.nees` /
:func:`~tauvcore.filter.statistics.block_nees` (:mod:`.nees`) and the DVL models of
tauvcore.aiding (:mod:`.dvl`, :mod:`.two_beam`) call them for their batched numpy callers, so the
tests that check those functions (finite differences, known answers) check these kernels; the
engine's compiled loops (tauvcore.engine.loop, tauvcore.engine.yoo_loop) call them directly on
their (methods, runs) batch.

The modules, each importing the kernels it calls from the one that defines them:
:mod:`.common` (the decorator, the state layout by number, the compiled earth functions),
:mod:`.rotations`, :mod:`.strapdown`, :mod:`.error_model`, :mod:`.nees`, :mod:`.correction`,
:mod:`.two_beam`, :mod:`.dvl`.
"""
