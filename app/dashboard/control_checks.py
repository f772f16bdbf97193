"""Every bad control of the Mission tab at once, not the first one a run meets.

:func:`problems` checks each typed control (the text fields, each beam's outage, each plug-in
source's field) on its own: the controls as they are, with every other typed field at its value
on a new page (app.dashboard.control_table's ``initial``), through the same
:func:`app.dashboard.inputs.config_from_controls` a run uses, so a field is named for its own fault and
never for another's. A fault that needs two controls together (an outage ending before it
starts is one control; LC with two beams, or Runs of a log, are the choices) is found by the
whole set, checked last. The current's four controls are one vector of the configuration and
are checked together (:data:`CURRENT_FIELDS`). The dashboard checks as you type (after a pause),
marks the fields and names them all in one notification when Run is pressed.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from app.dashboard import control_table
from app.dashboard.controls import PLUGIN_FIELDS
from app.dashboard.inputs import Controls, InputError, config_from_controls, outage_labels, parse_float
from tauvcore.config import Config

TYPED_WIDGETS = ("text",)
CURRENT_FIELDS = ("current_speed", "current_toward", "current_shear", "current_variation")
"""The current's controls (app.dashboard.inputs.current_fields), checked together: one vector of the
configuration."""


def initial_controls() -> dict[str, Any]:
    """Each Controls field's value on a new page (the fields with no ``initial`` are left out)."""
    defaults = Config()
    out: dict[str, Any] = {}
    for c in control_table.CONTROLS:
        value = c.initial(defaults)
        if value is not None:
            out[c.field] = value
    return out


def _baseline(c: Controls, initial: dict[str, Any]) -> Controls:
    """``c`` with every typed field (text, outages, plug-in fields) at its new-page value; the
    choices and check boxes (trajectory, source, methods, beams, sources ticked) kept."""
    typed = {e.field for e in control_table.CONTROLS if e.widget in TYPED_WIDGETS}
    changes = {f: initial[f] for f in typed if f in initial}
    changes["outages"] = (("0", "0"),) * len(c.outages)
    changes["source_fields"] = Controls.__dataclass_fields__["source_fields"].default
    return dataclasses.replace(c, **changes)


def _error(c: Controls, log_config: dict[str, Any] | None) -> str | None:
    try:
        config_from_controls(c, log_config)
    except InputError as exc:
        return str(exc)
    return None


def problems(c: Controls, log_config: dict[str, Any] | None = None) -> dict[str, str]:
    """Every bad control of ``c``: its label -> the one-line message a run would give for it.

    Parameters
    ----------
    c : Controls
        What the page's controls hold.
    log_config : dict[str, Any] or None
        The chosen log's own configuration (raw tables), as :func:`app.dashboard.inputs.config_from_controls`
        takes it; None for a simulated mission.

    Returns
    -------
    dict[str, str]
        Label -> message, in the page's order; empty when the controls describe a run. A fault of
        the controls together (no field of its own) is keyed by the label its message starts with
        ("Methods", "DVL beams", ...).
    """
    initial = initial_controls()
    base = _baseline(c, initial)
    shared = _error(base, log_config)  # a fault of the choices: every trial below would meet it
    found: dict[str, str] = {}

    def trial(label: str, changed: Controls) -> None:
        message = _error(changed, log_config)
        if message is not None and message != shared:
            found[label] = message

    for entry in control_table.CONTROLS:
        if entry.field in CURRENT_FIELDS:
            if entry.field == CURRENT_FIELDS[0]:
                _check_current(c, base, log_config, shared, found)
        elif entry.widget in TYPED_WIDGETS and getattr(c, entry.field) != getattr(base, entry.field):
            trial(entry.label, dataclasses.replace(base, **{entry.field: getattr(c, entry.field)}))
    for k, pair in enumerate(c.outages, start=1):
        if pair != base.outages[k - 1]:
            outages = tuple(pair if j == k else b for j, b in enumerate(base.outages, start=1))
            trial(outage_labels(k)[0], dataclasses.replace(base, outages=outages))
    defaults = dict(base.source_fields)
    for key, value in c.source_fields:
        if defaults.get(key) != value:
            fields = tuple((k, value if k == key else v) for k, v in base.source_fields)
            trial(_plugin_label(key), dataclasses.replace(base, source_fields=fields))
    if not found:
        message = _error(c, log_config)
        if message is not None:
            found[message.split(":", 1)[0]] = message
    return found


def _check_current(
    c: Controls, base: Controls, log_config: dict[str, Any] | None, shared: str | None, found: dict[str, str]
) -> None:
    """The current's controls: each one that is not a number on its own, then (all numbers) the
    four together, since speed and direction make one vector the configuration judges whole (a
    speed checked at another control's default direction could be refused for a crab it does not
    need). A fault of the four is keyed by the control its message names."""
    changed = {f: getattr(c, f) for f in CURRENT_FIELDS if getattr(c, f) != getattr(base, f)}
    if not changed:
        return
    labels = {e.field: e.label for e in control_table.CONTROLS if e.field in CURRENT_FIELDS}
    for field, text in changed.items():
        try:
            parse_float(labels[field], text)
        except InputError as exc:
            found[labels[field]] = str(exc)
    if any(labels[f] in found for f in changed):
        return
    message = _error(dataclasses.replace(base, **changed), log_config)
    if message is not None and message != shared:
        found[message.split(":", 1)[0]] = message


def _plugin_label(key: str) -> str:
    field = PLUGIN_FIELDS.get(key)
    return field.label if field is not None else key


def notification(found: dict[str, str]) -> str:
    """One line naming every bad control: its message alone for one, "3 controls to fix: Seed:
    ...; Dropout: ...; ..." for several."""
    if len(found) == 1:
        return next(iter(found.values()))
    return f"{len(found)} controls to fix: " + "; ".join(found.values())


def without_problems(c: Controls, found: dict[str, str]) -> Controls:
    """``c`` with each control of ``found`` back at its value on a new page: what the page's
    address may carry (a bad value never enters it)."""
    if not found:
        return c
    initial = initial_controls()
    base = _baseline(c, initial)
    changes: dict[str, Any] = {}
    for entry in control_table.CONTROLS:
        if entry.widget in TYPED_WIDGETS and entry.label in found:
            changes[entry.field] = getattr(base, entry.field)
    outages = tuple(
        base.outages[k - 1] if outage_labels(k)[0] in found else pair
        for k, pair in enumerate(c.outages, start=1)
    )
    fields = tuple(
        (key, dict(base.source_fields).get(key, value) if _plugin_label(key) in found else value)
        for key, value in c.source_fields
    )
    return dataclasses.replace(c, outages=outages, source_fields=fields, **changes)


def labels_to_ids(found: dict[str, str], ids_by_label: dict[str, list[str]]) -> dict[str, str]:
    """The page ids of the controls ``found`` names (``ids_by_label``: label -> the viser ids of
    its inputs), each with its message; a fault of the controls together marks nothing."""
    return {uid: message for label, message in found.items() for uid in ids_by_label.get(label, ())}
