"""Fusion methods added as one file each: the registry the configuration and the engine read.

The first paper's methods (``lc``, ``tc``, the extended ones) are compiled into the DVL kernel
(tauvcore.filter.kernels.dvl_kernels.dvl_measure_bank, dispatched by tauvcore.engine.dvl_fusion.DVL_FUSION) and
Yoo 2014's into its own bank. A method registered here needs neither: it is a filter of the
20-state bank (tauvcore.engine.filter_bank.FilterBank) that fuses its own measurement model every
``1 / rate_hz`` seconds (on the nearest IMU sample), besides the depth and the magnetometer when
``run.aiding`` has them; it takes no DVL. The model says "how" (small and pure: ``measure(nom) ->
Measurement``, with ``predict`` and ``jacobian`` for the finite-difference test); the bank says
"when" and leaves a record of every update (``MethodResult.updates[source]``), so the method
appears in every table, study, consistency summary and figure like the others.

Adding a method (docs/adding_a_method.md walks through :mod:`tauvcore.aiding.cv`): write
``tauvcore/aiding/<name>.py`` with the model and a ``METHOD = FusionMethod(...)``
(:class:`tauvcore.aiding.fusion_method.FusionMethod`), then add ``"<name>"`` to :data:`MODULES`
below (one line). ``run.methods`` then takes it (tauvcore.config.RUN_METHODS: a TOML file, the
library), the CLI's ``--method`` offers it, and the dashboard shows a checkbox for it (its hint:
the method's ``summary``) and a colour of its own (app.figures.shared.REGISTERED_COLORS, in MODULES order).
"""

from __future__ import annotations

import importlib

from tauvcore.aiding.fusion_method import FusionMethod
from tauvcore.aiding.sources import SOURCES

MODULES = (
    "cv",  # tauvcore/aiding/cv.py: constant body velocity, the worked example of docs/adding_a_method.md
)
"""The modules of tauvcore.aiding that define a registered method (each its ``METHOD``), one line each."""


def _load(modules: tuple[str, ...]) -> dict[str, FusionMethod]:
    out: dict[str, FusionMethod] = {}
    for module_name in modules:
        method = getattr(importlib.import_module(f"tauvcore.aiding.{module_name}"), "METHOD", None)
        if not isinstance(method, FusionMethod):
            raise TypeError(
                f"tauvcore.aiding.{module_name} must define METHOD = FusionMethod(...), got {method!r}"
            )
        taken = {name for name in SOURCES} | {s.table for s in SOURCES.values()}
        if method.name in taken or method.source in taken:
            raise ValueError(
                f"tauvcore.aiding.{module_name}: method or source {method.name!r} / {method.source!r} is an "
                "aiding source's name (tauvcore.aiding.sources)"
            )
        if method.name in out or method.source in {m.source for m in out.values()}:
            raise ValueError(
                f"tauvcore.aiding.{module_name}: method or source {method.name!r} registered twice"
            )
        out[method.name] = method
    return out


REGISTRY: dict[str, FusionMethod] = _load(MODULES)
"""Every registered method by name, in :data:`MODULES` order."""
