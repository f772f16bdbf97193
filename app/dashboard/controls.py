"""The plug-in aiding sources' controls, described from the registry (tauvcore.aiding.sources).

Every source with a measurement of its own (:data:`~tauvcore.aiding.sources.FUSED`) gets, in the
Mission tab's Aiding folder, a checkbox (its ``label``, its ``summary`` as the hint) and a folder of its section's
controls, one per field of its ``config_type``, each described by the field's
:class:`~tauvcore.aiding.source.Setting` (label, unit, range, hint): a float is a text field read
as the other numeric controls are (app.dashboard.inputs.parse_float), a 3-vector one text field of three
comma-separated numbers, a bool a checkbox. Each control's key, ``<source>.<field>``, is the
configuration field the section's messages name, the control's address key (app.dashboard.links) and its
entry in :attr:`app.dashboard.inputs.Controls.source_fields`. Nothing here names a source: a new plug-in
shows up in the dashboard with its registry line. The sources that are data for Yoo 2014's
methods (the echo sounder, the RPM) are nothing to tick: the mission's "Seabed and RPM" folder
(app.dashboard.control_table) holds what a user of those methods tunes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import viser

from tauvcore.aiding.source import AidingSource, Setting, settings
from tauvcore.aiding.sources import FUSED

KINDS = ("number", "vector", "flag")
"""How a field's control holds its value: a float as typed, three floats as typed, a bool."""


@dataclass(frozen=True)
class FieldControl:
    """One field of a plug-in source's section as the dashboard shows it."""

    key: str  # "<section>.<field>": the configuration field, the address key, the Controls entry
    source: str  # the plug-in's name
    section: str  # its configuration section
    field: str  # the field of its config_type
    label: str  # the control's label, e.g. "USBL fix interval [s]"
    kind: str  # one of KINDS
    hint: str  # what it is and its range
    default: str | bool  # what the control holds for the section's default

    def shown(self, value: Any) -> str | bool:
        """A value of the field as this control holds it."""
        return shown(self.kind, value)


def shown(kind: str, value: Any) -> str | bool:
    """A field's value as a control of ``kind`` holds it (a float to twelve significant digits,
    a vector's components separated by commas)."""
    if kind == "flag":
        return bool(value)
    if kind == "vector":
        return ",".join(f"{float(v):.12g}" for v in value)
    return f"{float(value):.12g}"


@dataclass(frozen=True)
class SourceControl:
    """A plug-in source as the dashboard shows it: its checkbox and its section's controls."""

    name: str  # the source's name: in run.aiding, its address key ("usbl=1")
    label: str  # its checkbox
    hint: str  # its summary
    fields: tuple[FieldControl, ...]

    @property
    def folder(self) -> str:
        """The title of the folder that holds its controls."""
        return f"{self.label} settings"


def _kind(default: Any) -> str:
    if isinstance(default, bool):
        return "flag"
    return "vector" if isinstance(default, tuple) else "number"


def _hint(kind: str, s: Setting) -> str:
    unit = f" {s.unit}" if s.unit else ""
    if kind == "flag":
        return s.hint
    if kind == "vector":
        bound = f", each within +-{s.bound:g}{unit}" if s.bound is not None else ""
        return f"{s.hint}; three numbers separated by commas{bound}"
    span = f"; [{s.low:g}, {s.high:g}]{unit}" if s.low is not None and s.high is not None else ""
    return f"{s.hint}{span}"


def describe(source: AidingSource) -> SourceControl:
    """The controls of plug-in ``source``, from its section's Settings."""
    fields = []
    for name, default, s in settings(source.config_type):
        kind = _kind(default)
        label = f"{source.label} {s.label}" + (f" [{s.unit}]" if s.unit else "")
        key = f"{source.section_name}.{name}"
        fields.append(
            FieldControl(
                key, source.name, source.section_name, name, label, kind, _hint(kind, s), shown(kind, default)
            )
        )
    return SourceControl(source.name, source.label, source.summary, tuple(fields))


PLUGIN_SOURCES: tuple[SourceControl, ...] = tuple(describe(s) for s in FUSED.values())
"""Every fused source's controls, in the registry's order."""
PLUGIN_FIELDS: dict[str, FieldControl] = {f.key: f for s in PLUGIN_SOURCES for f in s.fields}
"""Every plug-in field's control by its key."""
DEFAULT_SOURCE_FIELDS: tuple[tuple[str, str | bool], ...] = tuple(
    (f.key, f.default) for f in PLUGIN_FIELDS.values()
)
"""What the plug-in fields' controls hold on a new page (app.dashboard.inputs.Controls.source_fields)."""


def add_source_controls(
    gui: viser.GuiApi,
) -> tuple[dict[str, viser.GuiCheckboxHandle], dict[str, Any]]:
    """Add every plug-in source's checkbox (off) and the folder of its section's controls (closed)
    where ``gui`` adds controls now; return the checkboxes by source name and the field controls
    by key."""
    boxes: dict[str, viser.GuiCheckboxHandle] = {}
    handles: dict[str, Any] = {}
    for s in PLUGIN_SOURCES:
        boxes[s.name] = gui.add_checkbox(s.label, False, hint=s.hint)
        with gui.add_folder(s.folder, expand_by_default=False):
            for f in s.fields:
                handles[f.key] = (
                    gui.add_checkbox(f.label, bool(f.default), hint=f.hint)
                    if f.kind == "flag"
                    else gui.add_text(f.label, str(f.default), hint=f.hint)
                )
    return boxes, handles
