"""What every kernel module shares: the decorator, the error-state layout by number, the earth
functions compiled as they are, :func:`flat` (the layout numpy callers hand the kernels) and
``plain`` (the tuples the engine hands them).

:func:`jit` is numba's ``njit`` with the cache on (``cache=True``: the machine code is stored
beside the module, or in numba's user cache when that is read-only, and reused while the source
is unchanged). numba checks only the file of the function it compiles, while a kernel's machine
code holds what it calls, inlined, and the module-level constants it reads, frozen: a kernel of
strapdown.py would keep the exp_so3 of rotations.py it was compiled with after rotations.py
changed. So :func:`jit` keys each function's cache on :func:`source_key` of its module: its file
and, transitively, the files of the tauvcore modules it imports. An edit anywhere below a kernel
recompiles it; an edit elsewhere leaves it cached.
"""

from __future__ import annotations

import hashlib
import importlib.util
import pickle
import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numba
import numpy as np

from tauvcore.geo import earth

_F = TypeVar("_F", bound=Callable[..., Any])
_njit = numba.njit(cache=True, nogil=True, error_model="numpy")

N = 20  # error states
NAV = 9  # rows of F that are not zero: position, misalignment, velocity
CORE = 15  # columns of F that are not zero: those plus accelerometer and gyro biases
POS, ATT, VEL, BA, BG, BDVL, SF = 0, 3, 6, 9, 12, 15, 19  # tauvcore.filter.layout.STATE starts

_source_keys: dict[str, bytes] = {}


def _origin(module_name: str) -> str | None:
    """The file of a module (None: no such module, or no file)."""
    try:
        spec = importlib.util.find_spec(module_name)
    except (ImportError, ValueError):  # a name under a module that is no package
        return None
    return spec.origin if spec is not None and spec.has_location else None


_IMPORT = re.compile(
    rb"^from[ \t]+([\w.]+)[ \t]+import[ \t]+(\([^)]*\)|[^\n]*)|^import[ \t]+([^\n]+)", re.MULTILINE
)
"""A module-level import statement (the imports a kernel's globals can come from)."""


def _imported_modules(module_name: str, source: bytes) -> set[str]:
    """The tauvcore modules the module-level import statements of ``module_name`` name (a
    ``from`` import's names where they are submodules, else the module they come from)."""
    found: set[str] = set()
    for match in _IMPORT.finditer(source):
        if match[3] is not None:
            names = re.sub(rb"#.*", b"", match[3]).decode().split(",")
            found.update(name.split()[0] for name in names if name.split())
            continue
        base = match[1].decode()
        if base.startswith("."):
            base = importlib.util.resolve_name(base, module_name.rpartition(".")[0])
        names = re.sub(rb"#.*", b"", match[2]).decode().strip("()").split(",")
        for name in (name.split()[0] for name in names if name.split()):
            sub = f"{base}.{name}"
            found.add(sub if _origin(sub) is not None else base)
    return {name for name in found if name.split(".")[0] == "tauvcore" and name != module_name}


def source_key(module_name: str) -> bytes:
    """sha256 of a module's source and of the keys of the tauvcore modules it imports."""
    if module_name not in _source_keys:
        _source_keys[module_name] = b""  # a circle of imports (the contract forbids one) ends here
        file = _origin(module_name)
        source = Path(file).read_bytes() if file else b""
        keys = [source_key(name) for name in sorted(_imported_modules(module_name, source))]
        _source_keys[module_name] = hashlib.sha256(b"".join([source, *keys])).digest()
    return _source_keys[module_name]


def jit(function: _F) -> _F:
    """``function`` compiled (numba ``njit``: cached, no GIL, numpy's floating-point semantics),
    its cache valid while :func:`source_key` of its module is unchanged. A kernel calls another by
    the name its module imports (numba resolves globals at compilation)."""
    dispatcher = _njit(function)
    # the stamp numba's cache index is checked against (numba 0.68's IndexDataCacheFile; should
    # that change, tests/unit/tauvcore/filter/kernels/test_kernel_cache.py fails)
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    if cache_file is not None and hasattr(cache_file, "_source_stamp"):
        cache_file._source_stamp = source_key(function.__module__)
    if cache_file is not None and hasattr(cache_file, "_load_index"):
        cache_file._load_index = _index_or_nothing(cache_file._load_index)
    return cast(_F, dispatcher)


def _index_or_nothing(load: Callable[[], dict]) -> Callable[[], dict]:
    """numba's cache index loader, answering an empty index (a cache miss: the kernel is compiled
    again and the index written anew) where the index cannot be read back. numba unpickles the index
    before it compares its stamp, so an index written by another tree of the source, whose machine
    code named a module since renamed or removed, raises instead of missing (ModuleNotFoundError
    after a module's rename, in a checkout updated in place)."""

    def load_or_nothing() -> dict:
        try:
            return load()
        except (ImportError, AttributeError, EOFError, ValueError, TypeError, pickle.UnpicklingError):
            return {}

    return load_or_nothing


def flat(a: np.ndarray, batch: tuple[int, ...], tail: tuple[int, ...], dtype: type = float) -> np.ndarray:
    """``a`` broadcast to ``batch + tail`` as a C-contiguous array with one leading axis: the
    layout the batched kernels take from their numpy callers."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=dtype), batch + tail)).reshape(
        (-1,) + tail
    )


_Args = TypeVar("_Args", bound=tuple[Any, ...])

# plain(args): a kernel's structured argument (one of the typing.NamedTuples named beside the
# kernel) as a plain tuple of the same items, for the call. numba types a plain tuple from its
# items as fast as it types separate arguments, a named tuple about a microsecond slower at every
# call (its fingerprint spells the class), which the filter bank's some 22,000 calls of a longrange
# mission would pay. The kernels unpack their tuples by position, so they take either; the class
# stays the documentation of the order and the type the checker sees. At run time it is tuple
# itself (no Python frame per call).
if TYPE_CHECKING:

    def plain(args: _Args) -> _Args: ...

else:
    plain = tuple


# the earth functions the kernels compile as they are (tauvcore.geo.earth: those that call no
# other); earth's functions take floats or arrays, the kernels call them on floats only: typed so
_F2 = tuple[float, float]
_F3 = tuple[float, float, float]
radii_nav = cast(Callable[[float], _F2], jit(earth.radii_of_curvature_m))
ned_offset = cast(Callable[[float, float, float, float, float, float], _F3], jit(earth.ned_offset_components))
normal_gravity = cast(Callable[[float, float], float], jit(earth.normal_gravity_mps2))
gravity_north = cast(Callable[[float, float], float], jit(earth.gravity_north_mps2))
earth_rate = cast(Callable[[float], _F3], jit(earth.earth_rate_n_rps))
transport_rate = cast(
    Callable[[float, float, float, float, float, float], _F3], jit(earth.transport_rate_with_radii)
)
