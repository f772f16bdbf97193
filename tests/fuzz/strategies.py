"""Hypothesis strategies for hostile ``tauv`` input: flag values, TOML documents, file bytes."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import tomli_w
from hypothesis import strategies as st

from tauvcore.aiding import AIDING_SOURCES
from tauvcore.config import METHODS, Config
from tauvcore.truth import TRAJECTORIES

MAX_RUN_S = 4.0
"""Longest simulated run a fuzz case may start (~0.1-0.5 s of wall time in-process)."""

# --- text that any flag might receive -------------------------------------------------------------

SPECIAL_TEXT = [
    "", " ", "nan", "NaN", "-nan", "inf", "-inf", "+inf", "Infinity", "1e308", "1e309", "-1e309", "1e-320", "5e-324",
    "0", "-0", "0.0", "-1", "-1e5", "1e300", "-1e300", "1e5", "0x10", "1_000", "\u0661\u0662", "None", "true",
    "--", "-", "--json", "--config", "-h", "--ideal", "-x", "--dur", "--meth", "=", "a\nb", "\x00", "\t3",
    "\u00fc", "\U0001f600", "1,2,3,4", "1,,2", ",", "all", "all,lc", "3,4@1:2", "@:", "1@2:1", "9" * 400,
    "-" + "9" * 400, "\ud800", "1e3", "2.5", "18446744073709551616", "-9223372036854775809",
]


def long_text() -> st.SearchStrategy[str]:
    """Strings of 61 to 200,000 characters (built cheaply: one character repeated)."""
    return st.builds(lambda c, n: c * n, st.sampled_from(["x", "9", "-", "\u00e9", ",", "1,"]),
                     st.integers(61, 200_000))


def hostile_text() -> st.SearchStrategy[str]:
    return st.one_of(
        st.sampled_from(SPECIAL_TEXT),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers(-(10**30), 10**30).map(str),
        st.text(max_size=24),
        long_text(),
    )


def finite_float_text(low: float, high: float) -> st.SearchStrategy[str]:
    return st.floats(low, high, allow_nan=False, allow_infinity=False).map(lambda x: f"{x:.6g}")


VALID_FLAG_VALUES: dict[str, st.SearchStrategy[str]] = {
    "--trajectory": st.sampled_from(TRAJECTORIES),
    "--method": st.one_of(st.just("all"), st.lists(st.sampled_from(METHODS), min_size=1, max_size=3, unique=True)
                          .map(",".join)),
    "--duration": finite_float_text(1.0, MAX_RUN_S),
    "--seed": st.integers(0, 2**63 - 1).map(str),
    "--aiding": st.lists(st.sampled_from(AIDING_SOURCES), min_size=1, max_size=3, unique=True).map(",".join),
    "--beams": st.lists(st.sampled_from("1234"), min_size=1, max_size=4, unique=True).map(",".join),
    "--outage": st.builds(lambda beams, a, w: f"{beams}@{a:.2f}:{a + w:.2f}",
                          st.lists(st.sampled_from("1234"), min_size=1, max_size=2, unique=True).map(",".join),
                          st.floats(0.0, 2.0), st.floats(0.1, 1.5)),
    "--dropout": finite_float_text(0.0, 1.0),
    "--vb-nf": finite_float_text(1.0, 100.0),
    "--nsv-epsilon": st.one_of(st.just("auto"), finite_float_text(1e-3, 100.0)),
}
"""Values each flag accepts (so that a good share of the cases really runs)."""


def is_long_duration(text: str) -> bool:
    """True if ``text`` is a legal run length longer than MAX_RUN_S (it would run for seconds)."""
    try:
        value = float(text.partition("=")[2] if text.startswith("--duration=") else text)
    except ValueError:
        return False
    return math.isfinite(value) and MAX_RUN_S < value <= 36000.0


# --- TOML documents ------------------------------------------------------------------------------

def _fields() -> list[tuple[str, str, Any]]:
    config = Config()
    return [(name, f.name, getattr(section, f.name))
            for name, section in config.sections().items() for f in dataclasses.fields(section)]


FIELDS = _fields()
"""Every (section, key, default) of the configuration."""


def _any_scalar() -> st.SearchStrategy[Any]:
    return st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.integers(-(10**400), 10**400),
        st.sampled_from([0, 0.0, -0.0, 1e300, -1e300, 5e-324, 2**63, 2**64, -(2**63) - 1, 10**400]),
        st.booleans(),
        st.text(max_size=12),
        long_text(),
    )


def _huge_list(item: Any) -> st.SearchStrategy[list]:
    return st.integers(5, 60_000).map(lambda n: [item] * n)


def field_value(key: str, default: Any) -> st.SearchStrategy[Any]:
    """A value for one field: mostly plausible (in or near range), often hostile."""
    if isinstance(default, bool):
        plausible = st.booleans()
    elif isinstance(default, int):
        plausible = st.integers(0, 2**64)
    elif isinstance(default, float):
        scale = abs(default) or 1.0
        plausible = st.one_of(st.just(0.0), st.floats(-scale, 10 * scale), st.floats(0.0, 1000 * scale),
                              st.just(default))
    elif isinstance(default, str):
        plausible = st.sampled_from({"name": TRAJECTORIES, "mode": ("fixed", "random")}.get(key, (default,)))
    elif key == "methods":
        plausible = st.lists(st.sampled_from(METHODS), min_size=0, max_size=10)
    elif key == "aiding":
        plausible = st.lists(st.sampled_from(AIDING_SOURCES), min_size=0, max_size=5)
    elif key == "beams":
        plausible = st.lists(st.integers(-1, 6), min_size=0, max_size=6)
    elif key == "outages":
        window = st.fixed_dictionaries({"beams": st.lists(st.integers(0, 5), max_size=4),
                                        "start_s": st.floats(-1.0, 5.0), "end_s": st.floats(-1.0, 6.0)})
        plausible = st.one_of(st.lists(window, max_size=4), _huge_list({"beams": [1], "start_s": 0.0, "end_s": 1.0}),
                              st.lists(st.dictionaries(st.text(max_size=6), _any_scalar(), max_size=3), max_size=2))
    else:  # 3-vectors
        plausible = st.lists(st.one_of(st.floats(-20.0, 20.0), _any_scalar()), min_size=0, max_size=5)
    hostile = st.one_of(
        _any_scalar(),
        st.lists(_any_scalar(), max_size=4),
        _huge_list(1.0),
        _huge_list("lc"),
        st.dictionaries(st.text(max_size=6), st.integers(), max_size=2),
    )
    return st.one_of(plausible, plausible, hostile)


@st.composite
def toml_document(draw: st.DrawFn) -> tuple[dict[str, Any], list[str]]:
    """A configuration table with one to three fields changed, and the names a message may give."""
    doc: dict[str, Any] = {"trajectory": {"duration_s": draw(st.floats(1.0, MAX_RUN_S))}}
    names = ["--config"]
    for _ in range(draw(st.integers(1, 3))):
        section, key, default = draw(st.sampled_from(FIELDS))
        value = draw(field_value(key, default))
        doc.setdefault(section, {})[key] = value
        names += [f"{section}.{key}", f"[{section}]"]
    structure = draw(st.sampled_from(["none"] * 6 + ["unknown key", "unknown section", "not a table"]))
    if structure == "unknown key":
        section = draw(st.sampled_from(sorted(doc)))
        key = draw(st.text(min_size=1, max_size=300))
        doc[section][key] = 1
        names.append(f"{section}.")
    elif structure == "unknown section":
        doc[draw(st.text(min_size=1, max_size=300))] = {"x": 1}
        names.append("unknown section")
    elif structure == "not a table":
        section = draw(st.sampled_from([s for s, _, _ in FIELDS]))
        doc[section] = draw(_any_scalar())
        names.append(f"[{section}]")
    # cross-section checks name the partner field
    names += ["trajectory.speed_mps", "trajectory.dive_rate_mps", "trajectory.lawnmower_dive_rate_mps",
              "imu.rate_hz", "dvl.outages"]
    if isinstance(doc.get("trajectory"), dict) and is_long_duration(str(doc["trajectory"].get("duration_s", ""))):
        doc["trajectory"]["duration_s"] = MAX_RUN_S
    return doc, names


def dumps(doc: dict[str, Any]) -> bytes:
    return tomli_w.dumps(doc).encode("utf-8")


@st.composite
def mangled_bytes(draw: st.DrawFn, text: bytes) -> tuple[bytes, str]:
    """``text`` broken in one way: syntax, encoding, nesting or size; and what was done."""
    how = draw(st.sampled_from(["truncate", "insert", "utf16", "latin1", "bom", "ff", "deep array", "deep table",
                                "huge array", "over 1 MiB", "nul", "crlf"]))
    if how == "truncate":
        return text[:draw(st.integers(0, max(0, len(text) - 1)))], how
    if how == "insert":
        at = draw(st.integers(0, len(text)))
        return text[:at] + draw(st.binary(min_size=1, max_size=8)) + text[at:], how
    if how == "utf16":
        return text.decode().encode("utf-16"), how
    if how == "latin1":
        return text + "[trajectory]\nname = \"\u00e9\"\n".encode("latin-1"), how
    if how == "bom":
        return b"\xef\xbb\xbf" + text, how
    if how == "ff":
        return b"\xff" + text, how
    if how == "deep array":
        depth = draw(st.integers(100, 200_000))
        return b"a = " + b"[" * depth + b"]" * depth + b"\n", how
    if how == "deep table":
        depth = draw(st.integers(100, 50_000))
        return b"a = " + b"{b = " * depth + b"1" + b"}" * depth + b"\n", how
    if how == "huge array":
        n = draw(st.integers(1000, 150_000))
        return b"[run]\nmethods = [" + b'"lc",' * n + b"]\n", how
    if how == "over 1 MiB":
        return text + b"#" * ((1 << 20) + 1), how
    if how == "nul":
        return text + b"\x00", how
    return text.replace(b"\n", b"\r\n") + b"\r", how
