"""Aiding sources added as one plug-in each: the registry the configuration, the engine and the
log reader and writer read.

The sensors aboard every vehicle of the lab, the DVL, the depth, the magnetometer, the echo sounder
and the propeller's RPM, are sources like any other (:attr:`~tauvcore.aiding.source.AidingSource.aboard`);
the last two are data for Yoo 2014's methods, not measurements of their own
(:attr:`~tauvcore.aiding.source.AidingSource.fused`). Adding a source
(docs/adding_a_sensor.md walks through :mod:`tauvcore.aiding.usbl`): write
``tauvcore/aiding/<name>.py`` with a subclass of :class:`tauvcore.aiding.source.AidingSource` and a
``SOURCE = <Class>()``, then add ``"<name>"`` to :data:`MODULES` below (one line). ``run.aiding``
and ``--aiding`` then take it, ``[<name>]`` configures it (a TOML file, ``tauv config``), a log's
``<name>.csv`` or ``.parquet`` table feeds it in a replay, ``tauv run --save-log`` writes it, and
every method of the 20-state bank that takes aiding fuses it, with a record of every update in the
results, tables, studies and consistency summaries.
"""

from __future__ import annotations

import dataclasses
import importlib

from tauvcore.aiding.source import AidingSource, settings
from tauvcore.filter.layout import STATE

MODULES: tuple[str, ...] = (
    "dvl_beams",  # tauvcore/aiding/dvl_beams.py: the Janus DVL's beams (the methods fuse them)
    "depth",  # tauvcore/aiding/depth.py: depth from the pressure sensor aboard
    "attitude_mag",  # tauvcore/aiding/attitude_mag.py: the magnetometer's attitude
    "echo_altitude",  # tauvcore/aiding/echo_altitude.py: the echo sounder's altitude (Yoo's switch)
    "propeller_rpm",  # tauvcore/aiding/propeller_rpm.py: the propeller's RPM (Yoo's velocity filter)
    "usbl",  # tauvcore/aiding/usbl.py: a ship's USBL position fix (docs/adding_a_sensor.md's example)
)
"""The modules of tauvcore.aiding that define a plug-in source (each its ``SOURCE``), one line each."""

BUILT_IN = ("cv", "imu", "reference")
"""Names a source, its section or its table may not take: the constant-velocity model (a method's
measurement without data) and the log's own tables."""


def load(modules: tuple[str, ...]) -> dict[str, AidingSource]:
    """Each module's ``SOURCE`` by name, checked.

    Parameters
    ----------
    modules : tuple[str, ...]
        Module names within ``tauvcore.aiding`` (e.g. ``"usbl"``), each defining ``SOURCE``, in
        registry order (:data:`MODULES`).

    Returns
    -------
    dict[str, AidingSource]
        Every module's source by its :attr:`~tauvcore.aiding.source.AidingSource.name`, in the
        order of ``modules``.

    Raises
    ------
    TypeError
        A module that does not define ``SOURCE = <AidingSource>()``.
    ValueError
        A source whose name is not a lower-case identifier or is taken (by another source or
        :data:`BUILT_IN`); whose ``section_name`` or ``table`` is taken or no name; whose columns
        are not distinct names other than ``t_s``; whose truth columns are not distinct names other
        than ``t_s`` and the columns; with ``methods_fuse`` on a source the engine fuses; fused
        without its ``observes`` naming error-state blocks, its ``model()`` or its ``row_labels``;
        without a label; whose ``bag_messages`` fill columns not its own; or with a field of its ``config_type`` that declares no ``Setting``.
    """
    out: dict[str, AidingSource] = {}
    for module_name in modules:
        source = getattr(importlib.import_module(f"tauvcore.aiding.{module_name}"), "SOURCE", None)
        if not isinstance(source, AidingSource):
            raise TypeError(
                f"tauvcore.aiding.{module_name} must define SOURCE = <AidingSource>(), got {source!r}"
            )
        name = source.name
        if not isinstance(name, str) or not name or name != name.strip().lower() or not name.isidentifier():
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.name must be a lower-case identifier, got {name!r}"
            )
        if name in BUILT_IN or name in out:
            raise ValueError(f"tauvcore.aiding.{module_name}: source name {name!r} is taken")
        for what, value, others in (
            ("section_name", source.section_name, {s.section_name for s in out.values()}),
            ("table", source.table, {s.table for s in out.values()}),
        ):
            if not isinstance(value, str) or not value.isidentifier() or value in BUILT_IN or value in others:
                raise ValueError(
                    f"tauvcore.aiding.{module_name}: SOURCE.{what} {value!r} is taken or no name"
                )
        columns = [c.name for c in source.columns]
        if "t_s" in columns or len(set(columns)) != len(columns) or not columns:
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.columns must be distinct names other than t_s, got {columns}"
            )
        truth = [c.name for c in source.truth_columns]
        if "t_s" in truth or len(set(columns + truth)) != len(columns) + len(truth):
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.truth_columns must be distinct names other than t_s "
                f"and the columns, got {truth}"
            )
        filled = [c for m in source.bag_messages for f in m.fields for c in f.columns]
        if not set(filled) <= set(columns):
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.bag_messages fill columns that are not its own: "
                f"{sorted(set(filled) - set(columns))}"
            )
        if source.methods_fuse and source.fused:
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.methods_fuse is for a source the engine does not "
                "fuse (fused = False)"
            )
        if source.fused and not (source.observes and set(source.observes) <= set(STATE.names)):
            raise ValueError(
                f"tauvcore.aiding.{module_name}: a fused SOURCE.observes must name the error-state blocks its "
                f"H weighs (of {', '.join(STATE.names)}), got {source.observes!r}"
            )
        if source.fused and (type(source).model is AidingSource.model or not source.row_labels):
            raise ValueError(
                f"tauvcore.aiding.{module_name}: a fused SOURCE needs its model() and its row_labels "
                "(or fused = False: data a method reads)"
            )
        label = getattr(source, "label", None)
        if not isinstance(label, str) or not label.strip():
            raise ValueError(
                f"tauvcore.aiding.{module_name}: SOURCE.label must be a few words, got {label!r}"
            )
        bare = [f.name for f in dataclasses.fields(source.config_type)]
        declared = {key for key, _, _ in settings(source.config_type)}
        if [f for f in bare if f not in declared]:
            raise ValueError(
                f"tauvcore.aiding.{module_name}: every field of {source.config_type.__name__} must declare "
                f"its Setting (tauvcore.aiding.source.setting); {', '.join(f for f in bare if f not in declared)} do not"
            )
        out[name] = source
    return out


SOURCES: dict[str, AidingSource] = load(MODULES)
"""Every plug-in source by name, in :data:`MODULES` order."""
FUSED: dict[str, AidingSource] = {name: s for name, s in SOURCES.items() if s.fused}
"""The sources with a measurement the engine fuses, in registry order."""
AIDING: tuple[str, ...] = tuple(name for name, s in SOURCES.items() if s.fused or s.methods_fuse)
"""The sources ``run.aiding`` may name (``--aiding``): the DVL, whose beams the methods fuse, and
those of :data:`FUSED`, in registry order."""
