"""Field checks for the frozen config dataclasses: one clear message naming field and value.

A section's field may declare what it is once, as a :class:`Setting` in its metadata
(:func:`setting`): its label, unit and range, which :func:`check_settings` enforces and the
dashboard shows.

Every message that echoes a value goes through :func:`show`, so a 500 kB string or a
100,000-entry list is quoted as its first characters and its size, never whole.
"""

from __future__ import annotations

import math
import reprlib
from dataclasses import dataclass, field, fields
from typing import Any

SHOW_CHARS = 60
"""Characters of a value quoted in a message before it is cut."""

_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxtuple, _REPR.maxdict = 3, 8, 8, 4
_REPR.maxstring = _REPR.maxother = SHOW_CHARS


class ConfigError(ValueError):
    """A configuration value is invalid. The message names the field and the offending value."""


class OutputDirError(ValueError):
    """A directory a writer was given cannot be written (tauvcore.logs.writer.output_dir): the
    message names the flag or argument, the directory and why."""


class LogError(ValueError):
    """A recorded log that cannot be used as it is (tauvcore.logs): the message names the file,
    column, row and value."""


def shorten(text: str) -> str:
    """``text`` itself when short, else its first :data:`SHOW_CHARS` characters and its length
    (for names echoed without quotes: keys, sections, file names)."""
    if len(text) <= SHOW_CHARS:
        return text
    return f"{text[:SHOW_CHARS]}... ({len(text)} characters)"


def show_path(path: str) -> str:
    """A file name for a message: quoted, and when long its last :data:`SHOW_CHARS` characters
    (the end names the file) and its length."""
    if len(path) <= SHOW_CHARS:
        return repr(path)
    return f"{'...' + path[-SHOW_CHARS:]!r} ({len(path)} characters)"


MESSAGE_CHARS = 400
"""Longest message line; every value in it is already shortened, this is the last guard."""


def one_line(text: str, limit: int = MESSAGE_CHARS) -> str:
    """``text`` as one printable line: control characters (newlines, ...) escaped, and at most
    ``limit`` characters in all."""
    if not text.isprintable():
        text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def show(value: Any) -> str:
    """``repr(value)`` for a message, shortened when long.

    A string longer than :data:`SHOW_CHARS` becomes its first 60 characters then
    ``... (N characters)``; a list or table is quoted up to 60 characters then ``... (N items)``;
    an integer too long to print is named by its number of digits. Cost is bounded by the cut,
    not by the size of the value.
    """
    if isinstance(value, str):
        if len(value) <= SHOW_CHARS:
            return repr(value)
        return f"{value[:SHOW_CHARS]!r}... ({len(value)} characters)"
    if isinstance(value, int) and not isinstance(value, bool):
        if value.bit_length() > 3 * SHOW_CHARS:  # more digits than a message should hold
            digits = int(value.bit_length() * math.log10(2)) + 1
            return f"<{'a negative' if value < 0 else 'an'} integer of about {digits} digits>"
        return repr(value)
    text = _REPR.repr(value)
    if isinstance(value, (list, tuple, dict, set, frozenset)):
        if len(text) > SHOW_CHARS or "..." in text:  # cut here or by reprlib
            return f"{text[:SHOW_CHARS]}... ({len(value)} item{'' if len(value) == 1 else 's'})"
        return text
    if len(text) > SHOW_CHARS:
        return f"{text[:SHOW_CHARS]}... ({len(text)} characters)"
    return text


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _is_finite(value: Any) -> bool:
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer beyond the float range (TOML allows 10**400)
        return False


def require_finite(field: str, value: Any) -> None:
    if not _is_number(value) or not _is_finite(value):
        raise ConfigError(f"{field} must be a finite number, got {show(value)}")


def require_nonnegative(field: str, value: Any) -> None:
    require_finite(field, value)
    if value < 0:
        raise ConfigError(f"{field} must be >= 0, got {show(value)}")


def require_positive(field: str, value: Any) -> None:
    require_finite(field, value)
    if value <= 0:
        raise ConfigError(f"{field} must be > 0, got {show(value)}")


def require_range(field: str, value: Any, low: float, high: float, *, low_open: bool = False) -> None:
    """``low <= value <= high`` (``low < value`` if ``low_open``)."""
    require_finite(field, value)
    if not (low < value if low_open else low <= value) or not value <= high:
        raise ConfigError(
            f"{field} must be within {'(' if low_open else '['}{low:g}, {high:g}], got {show(value)}"
        )


def require_choice(field: str, value: Any, choices: tuple[str, ...]) -> None:
    if not isinstance(value, str) or value not in choices:
        raise ConfigError(f"{field} must be one of {', '.join(choices)}, got {show(value)}")


def require_choices(field: str, values: Any, choices: tuple[str, ...], allow_empty: bool = False) -> None:
    """A list of distinct names from ``choices``.

    The length is checked before any element, so a 100,000-entry list costs nothing.
    """
    if not isinstance(values, (tuple, list)):
        raise ConfigError(f"{field} must be a list, got {show(values)}")
    if len(values) > len(choices):
        raise ConfigError(f"{field} must list each of {', '.join(choices)} at most once, got {show(values)}")
    for v in values:
        require_choice(field, v, choices)
    if len(set(values)) != len(values):
        raise ConfigError(f"{field} names an entry twice, got {show(values)}")
    if not values and not allow_empty:
        raise ConfigError(f"{field} must name at least one of {', '.join(choices)}, got []")


def require_vector3(field: str, value: Any, bound: float | None = None) -> None:
    """Three finite numbers, each within ``[-bound, bound]`` if a bound is given."""
    if not isinstance(value, (tuple, list)) or len(value) != 3:
        raise ConfigError(f"{field} must be a list of 3 numbers, got {show(value)}")
    for i, v in enumerate(value):
        if bound is None:
            require_finite(f"{field}[{i}]", v)
        else:
            require_range(f"{field}[{i}]", v, -bound, bound)


SETTING = "tauv.setting"
"""The metadata key of a section field's :class:`Setting`."""


@dataclass(frozen=True)
class Setting:
    """What one field of a source's section is, for its check and for the dashboard's control.

    A float field is within ``[low, high]``; a bool field is true or false; a 3-vector field
    (a tuple of three floats) has each component within ``[-bound, bound]``. A range of its own on
    one component (a depth under the surface), and the check of a field of another kind (a list of
    beams, a choice of words: a Setting without a range or a bound), is the section's
    ``__post_init__``'s to add."""

    label: str  # the control's words after the source's label, e.g. "fix interval"
    unit: str = ""  # e.g. "s", "m"; "" for a dimensionless number or a switch
    low: float | None = None  # a float's range
    high: float | None = None
    bound: float | None = None  # a 3-vector's bound on each component
    hint: str = ""  # one line: what it is (the range is added where it is shown)
    low_open: bool = False  # the float's range excludes low: (low, high]


def setting(
    default: Any,
    label: str,
    unit: str = "",
    low: float | None = None,
    high: float | None = None,
    *,
    bound: float | None = None,
    hint: str = "",
    low_open: bool = False,
) -> Any:
    """A section field with its default and its :class:`Setting` (``dataclasses.field``)."""
    return field(default=default, metadata={SETTING: Setting(label, unit, low, high, bound, hint, low_open)})


def settings(section_type: type) -> tuple[tuple[str, Any, Setting], ...]:
    """(field name, default, setting) of every field of ``section_type`` that declares one, in order."""
    return tuple(
        (f.name, f.default, f.metadata[SETTING]) for f in fields(section_type) if SETTING in f.metadata
    )


def check_settings(name: str, section: Any) -> None:
    """Every declared field of ``section`` (the section of source ``name``) within its
    :class:`Setting`; ConfigError naming ``<name>.<field>`` and the value."""
    for key, default, s in settings(type(section)):
        value, where = getattr(section, key), f"{name}.{key}"
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise ConfigError(f"{where} must be true or false, got {show(value)}")
        elif isinstance(default, tuple) and s.bound is not None:
            require_vector3(where, value, bound=s.bound)
        elif s.low is not None and s.high is not None:
            require_range(where, value, s.low, s.high, low_open=s.low_open)
