"""Field checks for the frozen config dataclasses: one clear message naming field and value."""

from __future__ import annotations

import math
from typing import Any


class ConfigError(ValueError):
    """A configuration value is invalid. The message names the field and the offending value."""


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def require_finite(field: str, value: Any) -> None:
    if not _is_number(value) or not math.isfinite(value):
        raise ConfigError(f"{field} must be a finite number, got {value!r}")


def require_nonnegative(field: str, value: Any) -> None:
    require_finite(field, value)
    if value < 0:
        raise ConfigError(f"{field} must be >= 0, got {value!r}")


def require_positive(field: str, value: Any) -> None:
    require_finite(field, value)
    if value <= 0:
        raise ConfigError(f"{field} must be > 0, got {value!r}")


def require_range(field: str, value: Any, low: float, high: float) -> None:
    require_finite(field, value)
    if not low <= value <= high:
        raise ConfigError(f"{field} must be within [{low}, {high}], got {value!r}")


def require_choice(field: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ConfigError(f"{field} must be one of {', '.join(choices)}, got {value!r}")


def require_vector3(field: str, value: Any) -> None:
    if not isinstance(value, (tuple, list)) or len(value) != 3:
        raise ConfigError(f"{field} must be a list of 3 numbers, got {value!r}")
    for i, v in enumerate(value):
        require_finite(f"{field}[{i}]", v)
