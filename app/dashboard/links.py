"""The dashboard's controls in the page's address: a link reproduces a setup, a reload keeps it.

    http://localhost:8080/?traj=figure8&truth=kinematic&dur=60&m=lc,tc,nsv&nf=20&eps=auto&b=1,2&...&seed=3&runs=1

Every control of app.dashboard.inputs.Controls has a short key (:data:`KEYS`, in the order of the page, made
of the control table app.dashboard.control_table.CONTROLS); the
address carries them all, so a link opened by a later version with other defaults still
reproduces the setup. A link written by hand may name only some: the others keep what the page
holds (a new page: the defaults), and a trajectory whose preset the link does not cover in full
gets its preset first, as if picked in the dropdown (app.dashboard.inputs.preset_controls).

Values, as the controls hold them: a choice by its name (``traj=longrange``, ``truth=dynamic``,
``wt=always``, ``cst=random-walk``, ``src=<log>``), checkboxes as ``1`` or ``0``, methods and beams
as comma lists (``m=ins,lc``, ``b=1,2``; empty: none ticked), a beam's outage as ``start:end`` in
seconds (``o3=50:200``), the numeric fields as typed. A plug-in aiding source (app.dashboard.controls, from
the registry) is keyed by its name (``usbl=1``) and each field of its section by
``<source>.<field>`` (``usbl.interval_s=5``, a 3-vector as a comma list:
``usbl.lever_arm_b_m=0,0,-0.3``). Parsing is as strict as the controls' (app.dashboard.inputs.parse_float,
parse_int, parse_float_or_auto; ranges are checked at Run, as for a typed value): an unknown key, a
repeated key or a bad value is refused with one line naming the key and the value
(:attr:`Link.problems`), and the rest still applies.

What viser 1.1 allows. The server learns nothing of the page's address from viser: the page
opens its websocket at the address without its query (client/src/App.tsx,
``getDefaultServerFromUrl``), no message carries it, and there is no public call that runs a
script in the page or sets its address. The page does run any script the server sends in
viser's ``RunJavascriptMessage`` (viser loads plotly.js that way; the dashboard reads the page's
controls that way, app.dashboard.session_controls.ControlPanel.confirm_page_state). So at connect a script writes
``location.search`` to the tab's localStorage and the server reads it back (viser's
``local_storage.get_item``, :func:`read_address`), and on each change the server sends a script
calling ``history.replaceState`` (:func:`show_address`). viser's own client rewrites the query on
connect, percent-decoded and written back without escapes
(client/src/SearchParamsUtils.ts, ``syncSearchParamServer``): so the values written here keep to
characters a query needs no escape for (letters, digits, ``. , : _ -``), a number's ``+`` is
dropped (``1e+3`` is written ``1e3``), and a space read in a number is taken for the ``+`` that
rewrite turned into one. viser's own parameters (``darkMode``, ``initialCameraPosition``, ...) are
left in the address as they were, and are not this module's to refuse.

The address also keeps what the page shows (:data:`VIEW_KEYS`, not controls): the time ``t``
(seconds), the plots' zoomed time range ``x`` (``start:end`` in seconds) and the 3-D camera
``cam`` (its position and the point it looks at, six numbers in the view's frame, metres:
``cam=10,-20,5,0,0,-30``). Opened, a link puts the slider, every time plot and the camera there
(:attr:`Link.view`); bad values are refused as a control's are. The page writes ``t`` and ``x``
itself as they change (app/assets/view_sync.js), the server ``cam``.
"""

from __future__ import annotations

import dataclasses
import json
import re
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any
from urllib.parse import quote, unquote

import viser

from app.dashboard import inputs, page_scripts
from app.dashboard.control_table import CONTROLS, Control
from app.dashboard.controls import PLUGIN_FIELDS, PLUGIN_SOURCES
from app.dashboard.inputs import Controls, InputError
from tauvcore.config import RUN_METHODS
from tauvcore.validation import show


@dataclass(frozen=True)
class Key:
    """One control in the address."""

    key: str  # the query's key
    field: str  # the app.dashboard.inputs.Controls field it sets
    label: str  # the control's label, for messages
    kind: str  # how its value is written: one of KINDS


KINDS = ("choice", "number", "integer", "number_or_auto", "vector", "flag", "methods", "beams", "outage")
PER_KEY_FIELDS = ("aid_sources", "source_fields")
"""Controls fields that several keys set, one entry each (a plug-in source, a field of its section)."""
OUTAGES = next(c for c in CONTROLS if c.widget == "outages")
OUTAGE_KEYS = tuple(f"{OUTAGES.key}{k}" for k in range(1, 5))


def _keys(c: Control) -> tuple[Key, ...]:
    """The address keys of control table entry ``c``."""
    if c.widget == "outages":
        return tuple(
            Key(key, c.field, f"Beam {k} outage", c.kind) for k, key in enumerate(OUTAGE_KEYS, start=1)
        )
    if c.widget == "plugins":
        return tuple(Key(p.name, c.field, p.label, c.kind) for p in PLUGIN_SOURCES)
    if c.widget == "plugin_fields":
        return tuple(Key(f.key, c.field, f.label, f.kind) for f in PLUGIN_FIELDS.values())
    return (Key(c.key, c.field, c.label, c.kind),)


KEYS = tuple(key for c in CONTROLS for key in _keys(c))
"""Every control of app.dashboard.inputs.Controls, in the page's order (app.dashboard.control_table.CONTROLS: the four
outages one key per beam, each plug-in source and each field of its section one key:
app.dashboard.controls)."""
BY_KEY = {k.key: k for k in KEYS}
CHOICES = {c.field: c.options for c in CONTROLS if c.widget == "dropdown"}
"""A dropdown's choices by its Controls field (trajectory, truth, the DVL's water-track and current
states); the Source's are the server's logs."""
ALIASES = {"dep": "depth"}
"""Other keys read as a control's own: ``dep``, a short key of the depth's checkbox that saved
addresses hold (the page writes ``depth``, its source's name)."""
VISER_PARAMS = (
    "websocket",
    "playbackPath",
    "darkMode",
    "showStats",
    "fixedDpr",
    "logCamera",
    "hideViserLogo",
    "forceOrbitOriginTool",
    "initialCameraPosition",
    "initialCameraLookAt",
    "initialCameraUp",
    "initialCameraFov",
    "initialCameraNear",
    "initialCameraFar",
    "dummyWindowDimensions",
    "dummyWindowTitle",
)
"""The query parameters viser's page reads itself (client/src: App.tsx, DevSettingsStore.ts, ...)."""
MAX_QUERY_CHARS = 4000
"""Longest query read (every control at its longest is about 1,500 characters)."""
SAFE = "-._~,:"
"""Characters written unescaped besides letters and digits (none has a meaning inside a query value)."""
_NUMERIC = ("number", "integer", "number_or_auto")
_PARSERS: dict[str, Callable[[str, str], Any]] = {
    "number": inputs.parse_float,
    "integer": inputs.parse_int,
    "number_or_auto": inputs.parse_float_or_auto,
    "vector": inputs.parse_vector,
}
_SIGNED = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")


VIEW_KEYS = {"t": "Time [s]", "x": "Time range [s]", "cam": "Camera", "series": "Time plot", "xy": "XY plot"}
"""The page's view in the address, by key: its label in messages (not controls: nothing is run by them)."""
VIEW_PAGE_KEYS = ("t", "x")
"""The view keys the page itself writes (app/assets/view_sync.js)."""


def _view_numbers(label: str, text: str, sep: str, count: int) -> tuple[float, ...]:
    parts = text.split(sep)
    if len(parts) != count:
        raise InputError(f"{label}: expected {count} numbers separated by {show(sep)}")
    return tuple(inputs.parse_float(label, part.replace(" ", "+")) for part in parts)


PICK_KEYS = ("series", "xy")
"""The view keys of the Series tab's picks (app.dashboard.session_series): its two lists as typed."""
PICK_CHARACTERS = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-./,; ")
"""What the picks are written with: series names (app.figures.series_catalog), commas and the XY's ``;``."""


def parse_view(key: str, text: str) -> Any:
    """The value of view key ``key`` (:data:`VIEW_KEYS`) that ``text`` spells: ``t`` a time >= 0 [s],
    ``x`` (start, end) [s] with start < end, ``cam`` ((position), (look_at)) [m], ``series`` and
    ``xy`` the Series tab's picks as typed (names the run lacks are said there), or InputError
    naming the value's label and ``text``."""
    label = VIEW_KEYS[key]
    if key in PICK_KEYS:
        text = text.replace("+", " ")  # a space the page's address wrote as a plus: no name holds one
        bad = sorted(set(text) - PICK_CHARACTERS)
        if bad:
            raise InputError(f"{label}: {show(text)} holds {show(''.join(bad))}, which no series name has")
        return text
    if key == "t":
        (t_s,) = _view_numbers(label, text, ",", 1)
        if t_s < 0.0:
            raise InputError(f"{label}: {show(text)} is before the start (0 s)")
        return t_s
    if key == "x":
        start, end = _view_numbers(label, text, ":", 2)
        if not start < end:
            raise InputError(f"{label}: {show(text)} does not end after it starts")
        return (start, end)
    p = _view_numbers(label, text, ",", 6)
    if p[:3] == p[3:]:
        raise InputError(f"{label}: {show(text)} looks at its own position")
    return (p[:3], p[3:])


def encode_view(view: dict[str, Any]) -> list[str]:
    """The address's parts for the view keys of ``view`` (key -> value as :func:`parse_view` gives)."""
    parts = []
    for key in VIEW_KEYS:
        value = view.get(key)
        if value is None:
            continue
        if key in PICK_KEYS:
            parts.append(f"{key}={quote(str(value), safe=SAFE + '/;')}")
            continue
        if key == "t":
            text = f"{float(value):.2f}"
        elif key == "x":
            text = f"{float(value[0]):.3f}:{float(value[1]):.3f}"
        else:
            text = ",".join(f"{float(v):.2f}" for v in (*value[0], *value[1]))
        parts.append(f"{key}={quote(_text(text), safe=SAFE)}")
    return parts


@dataclass(frozen=True)
class Link:
    """What a page's query says: the values it sets well, what it got wrong, and viser's own part."""

    values: dict[str, Any]  # Controls field -> value (outages: beam 1..4 -> (start, end) texts;
    # aid_sources: source -> on; source_fields: key -> value)
    keys: tuple[str, ...]  # the keys applied, in the query's order
    problems: tuple[str, ...]  # one line per refused key: the key, its value as given, why
    viser_params: tuple[str, ...] = ()  # viser's own "key=value" parts, as they were (kept in the address)
    view: dict[str, Any] = dataclasses.field(default_factory=dict)  # VIEW_KEYS key -> parse_view's value

    def labels(self) -> set[str]:
        """The labels of the controls the link sets (for app.dashboard.inputs.preset_controls' labels)."""
        out = {BY_KEY[k].label for k in self.keys if BY_KEY[k].kind != "outage"}
        for k in self.keys:
            if BY_KEY[k].kind == "outage":
                out.update(inputs.outage_labels(OUTAGE_KEYS.index(k) + 1))
        return out


# ---------------------------------------------------------------------------------------- write
def _text(value: str) -> str:
    """A typed numeric text for the address: stripped, a number's redundant ``+`` dropped."""
    s = value.strip()
    return s.replace("+", "") if _SIGNED.fullmatch(s) else s


def _value(key: Key, c: Controls) -> str:
    if key.kind == "outage":
        start, end = c.outages[OUTAGE_KEYS.index(key.key)]
        return f"{_text(start)}:{_text(end)}"
    if key.field == "aid_sources":
        value: Any = key.key in c.aid_sources
    elif key.field == "source_fields":
        value = dict(c.source_fields)[key.key]
    else:
        value = getattr(c, key.field)
    if key.kind == "vector":
        return ",".join(_text(part) for part in value.split(","))
    if key.kind == "flag":
        return "1" if value else "0"
    if key.kind == "methods":
        return ",".join(m for m in RUN_METHODS if m in value)
    if key.kind == "beams":
        return ",".join(str(b) for b in sorted(value))
    return _text(value) if key.kind in _NUMERIC else str(value)


def encode(c: Controls) -> str:
    """The query (without ``?``) that sets every control to what ``c`` holds; the source only
    when it is a log (the Source control exists only then)."""
    parts = [
        f"{k.key}={quote(_value(k, c), safe=SAFE)}"
        for k in KEYS
        if not (k.field == "source" and c.source == inputs.SIMULATION)
    ]
    return "&".join(parts)


def address(c: Controls, viser_params: Sequence[str] = (), view: dict[str, Any] | None = None) -> str:
    """The page's new query, ``?`` and viser's own parameters first, then :func:`encode`, then the
    view's keys (:func:`encode_view`)."""
    return "?" + "&".join([*viser_params, encode(c), *encode_view(view or {})])


# ---------------------------------------------------------------------------------------- read
def _list(text: str, allowed: Sequence[str], what: str) -> tuple[str, ...]:
    items = tuple(text.split(",")) if text else ()
    for item in items:
        if item not in allowed:
            raise InputError(f"{show(item)} is not {what} ({', '.join(allowed)})")
    if len(set(items)) != len(items):
        raise InputError("a repeated entry")
    return items


def _number_text(key: Key, text: str) -> str:
    """``text`` if the control ``key`` would read it (a space taken for the ``+`` that viser's
    page turned into one), else InputError naming the control and the text."""
    try:
        _PARSERS[key.kind](key.label, text)
        return text
    except InputError:
        plus = text.replace(" ", "+")
        if plus != text:
            try:
                _PARSERS[key.kind](key.label, plus)
                return plus
            except InputError:
                pass
        raise


def _parse_value(key: Key, text: str, sources: Sequence[str]) -> Any:
    """The Controls value ``text`` spells for ``key``, or InputError saying why not."""
    if key.kind == "choice":
        options = tuple(sources) if key.field == "source" else CHOICES[key.field]
        if text not in options:
            raise InputError(f"{key.label}: choose from {', '.join(options)}")
        return text
    if key.kind == "flag":
        if text not in ("0", "1"):
            raise InputError("expected 1 (on) or 0 (off)")
        return text == "1"
    if key.kind == "methods":
        return _list(text, RUN_METHODS, "a method")
    if key.kind == "beams":
        return tuple(int(b) for b in _list(text, ("1", "2", "3", "4"), "a beam"))
    if key.kind == "outage":
        start, sep, end = text.partition(":")
        if not sep:
            raise InputError("expected start:end in seconds, e.g. 50:200")
        start_label, end_label = inputs.outage_labels(OUTAGE_KEYS.index(key.key) + 1)
        return (
            _number_text(Key(key.key, key.field, start_label, "number"), start),
            _number_text(Key(key.key, key.field, end_label, "number"), end),
        )
    return _number_text(key, text)


def parse(query: str, sources: Sequence[str] = (inputs.SIMULATION,)) -> Link:
    """Read a page's ``location.search`` (with or without ``?``, percent-escaped as the browser
    holds it; ``+`` is a plus, not a space). ``sources``: the Source control's choices (without
    logs, only "simulation"). Never raises: what cannot be applied is in ``problems``."""
    query = query.removeprefix("?")
    if len(query) > MAX_QUERY_CHARS:
        return Link(
            {},
            (),
            (
                (
                    f"the address's query is {len(query)} characters long; at most {MAX_QUERY_CHARS} "
                    "are read, so none of it was applied"
                ),
            ),
        )
    values: dict[str, Any] = {}
    view: dict[str, Any] = {}
    keys: list[str] = []
    problems: list[str] = []
    kept: list[str] = []
    outages: dict[int, tuple[str, str]] = {}
    for part in query.split("&"):
        if not part:
            continue
        raw_key, _, raw_value = part.partition("=")
        name, text = unquote(raw_key), unquote(raw_value)
        name = ALIASES.get(name, name)
        if name in VISER_PARAMS:
            kept.append(part)
            continue
        if name in VIEW_KEYS:
            if name in view:
                problems.append(f"{name}={show(text)}: {name} is given twice; the first one applies")
                continue
            try:
                view[name] = parse_view(name, text)
            except InputError as exc:
                problems.append(f"{name}={show(text)}: {exc}")
            continue
        key = BY_KEY.get(name)
        if key is None:
            known = ", ".join([*BY_KEY, *VIEW_KEYS])
            problems.append(f"{show(name)}={show(text)}: unknown key (the keys are {known})")
            continue
        if name in keys:
            problems.append(f"{name}={show(text)}: {name} is given twice; the first one applies")
            continue
        try:
            value = _parse_value(key, text, sources)
        except InputError as exc:
            problems.append(f"{name}={show(text)}: {exc}")
            continue
        keys.append(name)
        if key.kind == "outage":
            outages[OUTAGE_KEYS.index(name) + 1] = value
        elif key.field in PER_KEY_FIELDS:
            values.setdefault(key.field, {})[name] = value
        else:
            values[key.field] = value
    if outages:
        values["outages"] = outages
    return Link(values, tuple(keys), tuple(problems), tuple(kept), view)


def apply(c: Controls, link: Link) -> Controls:
    """``c`` with the values ``link`` sets (each outage beam apart)."""
    changes = dict(link.values)
    if "outages" in changes:
        outages = list(c.outages)
        for beam, pair in changes["outages"].items():
            outages[beam - 1] = pair
        changes["outages"] = tuple(outages)
    if "aid_sources" in changes:
        on = {name for name in c.aid_sources if changes["aid_sources"].get(name, True)}
        on |= {name for name, ticked in changes["aid_sources"].items() if ticked}
        changes["aid_sources"] = tuple(p.name for p in PLUGIN_SOURCES if p.name in on)
    if "source_fields" in changes:
        changes["source_fields"] = tuple(
            (key, changes["source_fields"].get(key, value)) for key, value in c.source_fields
        )
    return dataclasses.replace(c, **changes)


# ---------------------------------------------------------------------------------------- page
ADDRESS_KEY_PREFIX = "tauv-address-"  # + a fresh id per read: tabs of one browser share localStorage
READ_TIMEOUT_S = 30.0  # a page loading under software WebGL answers late


def read_address(client: viser.ClientHandle, timeout_s: float = READ_TIMEOUT_S) -> str | None:
    """The query of ``client``'s page (``location.search``, "" without one); None if no page ran
    the script (a scripted client). Raises TimeoutError, or RuntimeError if the tab closed or its
    storage is blocked (viser's ``local_storage.get_item``)."""
    key = f"{ADDRESS_KEY_PREFIX}{uuid.uuid4().hex}"
    page_scripts.run(client, page_scripts.report([], ADDRESS_KEY_PREFIX, key))
    raw = client.local_storage.get_item(key, timeout=timeout_s)
    if raw is None:
        return None
    try:
        search = json.loads(raw).get("search")
    except (ValueError, AttributeError):
        search = None
    return search if isinstance(search, str) else ""


def show_address(client: viser.ClientHandle, query: str) -> None:
    """Make ``query`` (from :func:`address`) the page's query, in place: no reload, no new entry
    in the browser's history. The page writes its own view keys (VIEW_PAGE_KEYS) into it as it
    shows them (app/assets/view_sync.js)."""
    q = json.dumps(query)
    page_scripts.run(
        client,
        f"if (window.__tauv && window.__tauv.setAddress) window.__tauv.setAddress({q}); "
        f"else history.replaceState(history.state, '', {q} + window.location.hash);",
    )


__all__ = [
    "KEYS",
    "VIEW_KEYS",
    "Key",
    "Link",
    "address",
    "apply",
    "encode",
    "encode_view",
    "parse",
    "parse_view",
    "read_address",
    "show_address",
]
