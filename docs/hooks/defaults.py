"""An MkDocs hook (mkdocs.yml ``hooks:``): every default a page quotes, written from the code at
build time, so that a page cannot say 256 where the code says 64.

A page writes ``{{ default("KEY") }}`` (optionally ``{{ default("KEY", "FORMAT") }}``) where the
value goes; KEY is one of

- ``config:SECTION.FIELD``: the field of the default configuration (``config:partial.vb_nf``,
  ``config:run.methods``), or ``config:METHOD()`` a method of it
  (``config:nsv_epsilon_value_m2_per_s2()``);
- ``imu:profile``: the name of the IMU profile the default configuration holds
  (tauvcore.sensors.imu.IMU_PROFILES);
- ``MODULE.NAME``: a constant of the code (``tauvcore.engine.smooth_defaults.DEFAULT_BUDGET_MB``).

A KEY in capitals alone (``{{ default("KEY") }}``) is a placeholder, as a page explaining the
macro writes it, and is left as it is. FORMAT is a format spec for a number (``.2f``), or ``MiB`` (bytes shown in mebibytes). Without
it a float is written ``:g``, a tuple comma-separated, anything else as ``str`` gives it.
tests/release/test_docs_defaults.py checks that no page quotes a default any other way.
"""

from __future__ import annotations

import importlib
import re
from typing import Any

MACRO = re.compile(r"""\{\{\s*default\(\s*"([^"]+)"\s*(?:,\s*"([^"]*)"\s*)?\)\s*\}\}""")


def lookup(key: str) -> Any:
    """The value KEY names (see the module's docstring); ValueError naming KEY if it names nothing."""
    from tauvcore.config import Config

    try:
        if key.startswith("config:"):
            value: Any = Config()
            for part in key.removeprefix("config:").split("."):
                value = getattr(value, part.removesuffix("()"))
                if part.endswith("()"):
                    value = value()
            return value
        if key == "imu:profile":
            from tauvcore.sensors.imu import IMU_PROFILES

            return next(name for name, imu in IMU_PROFILES.items() if imu == Config().imu)
        module, _, name = key.rpartition(".")
        return getattr(importlib.import_module(module), name)
    except (AttributeError, ImportError, StopIteration, ValueError) as exc:
        raise ValueError(f"{{{{ default({key!r}) }}}}: names nothing in the code ({exc})") from None


def show(value: Any, spec: str | None = None) -> str:
    """``value`` as a page writes it (see the module's docstring for ``spec``)."""
    if spec == "MiB":
        return f"{value / 2**20:g}"
    if spec:
        return format(value, spec)
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return ",".join(show(v) for v in value)
    return str(value)


def placeholder(key: str) -> bool:
    """Whether KEY is a placeholder (capitals alone, ``KEY``), left as written."""
    return re.fullmatch(r"[A-Z_]+", key) is not None


def render(markdown: str) -> str:
    """``markdown`` with every ``{{ default(...) }}`` replaced by the code's value."""
    return MACRO.sub(
        lambda m: m.group(0) if placeholder(m.group(1)) else show(lookup(m.group(1)), m.group(2)), markdown
    )


def on_page_markdown(markdown: str, page: Any, **kwargs: Any) -> str:
    return render(markdown)
