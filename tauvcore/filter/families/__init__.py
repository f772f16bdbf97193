"""Filter families: the registry the configuration, the engine, the results and the app read.

A family is one kind of filter: its error state (by named blocks), the methods it runs, the NEES
blocks its results carry and the sensor errors it estimates. The 20-state error-state EKF of the
first paper (:mod:`tauvcore.filter.families.eskf`, with the right-invariant EKF as one of its
methods) and Yoo 2014's 12-state filter (:mod:`tauvcore.filter.families.yoo`) are the families.
Each lives in its own folder, whose ``__init__`` defines ``FAMILY = Family(...)``, and is registered
by one line of :data:`MODULES` (:class:`~tauvcore.filter.families.spec.Family`).

Everything that asks "which filter is this method?" asks :func:`family_of`: the engine builds one
bank per family with methods in ``run.methods`` (tauvcore.engine.mission.Banks), the results take
their NEES dimensions and sensor-error columns from it (tauvcore.engine.results), the tables group
their columns by it (app.reports.tables).
"""

from __future__ import annotations

import importlib

from tauvcore.filter.families.spec import Family

MODULES = (
    "eskf",  # the first paper's 20-state error-state EKF (Tal, Klein & Katz 2017) and its IEKF variant
    "yoo",  # Yoo 2014's 12-state indirect feedback filter, aided by the DVL or the RPM's VKF
    "ukf",  # the unscented error-state filter on the 20 states, the worked example of docs/adding_a_filter.md
)
"""The folders of tauvcore.filter.families, each defining ``FAMILY``, one line each, in the order the
engine builds their banks (the first family draws the initial errors every family starts from)."""


def _load(modules: tuple[str, ...]) -> dict[str, Family]:
    out: dict[str, Family] = {}
    for module_name in modules:
        family = getattr(importlib.import_module(f"tauvcore.filter.families.{module_name}"), "FAMILY", None)
        if not isinstance(family, Family) or family.name != module_name:
            raise TypeError(
                f"tauvcore.filter.families.{module_name} must define FAMILY = Family(name={module_name!r}, "
                f"...), got {family!r}"
            )
        taken = {m for f in out.values() for m in f.methods}
        if taken & set(family.methods):
            raise ValueError(
                f"tauvcore.filter.families.{module_name}: method(s) {sorted(taken & set(family.methods))} "
                "of another family"
            )
        out[family.name] = family
    return out


FAMILIES: dict[str, Family] = _load(MODULES)
"""Every family by name, in :data:`MODULES` order."""

FIRST = FAMILIES[MODULES[0]]
"""The first family: the 20-state filter, which also runs the methods registered in
tauvcore.aiding.registry (one file each, fused by its bank)."""

PAPERS = ("eskf", "yoo")
"""The families of the two papers the lab is built on; every other is added in its own folder."""

ADDED = (
    "; ".join(
        f"`{', '.join(family.methods)}` {family.title}"
        for name, family in FAMILIES.items()
        if name not in PAPERS
    )
    or "none yet"
)
"""The methods of the families added beside the papers', with each family's title, as the docs name
them (docs/cli.md renders it: docs/hooks/defaults.py)."""


def family_of(method: str) -> Family:
    """The family that runs ``method``.

    Parameters
    ----------
    method : str
        A method's name (a key of ``run.methods``).

    Returns
    -------
    Family
        The family whose ``methods`` name it; :data:`FIRST` for any other name (the methods
        registered in tauvcore.aiding.registry run on its bank).
    """
    for family in FAMILIES.values():
        if method in family.methods:
            return family
    return FIRST
