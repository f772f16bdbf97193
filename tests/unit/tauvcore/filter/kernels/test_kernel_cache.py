"""numba's cache checks only the file of the function it compiles; the kernels' cache is keyed on
the sources of everything a kernel can call (tauvcore.filter.kernels.common.jit), so an edit in
one kernel module recompiles the kernels of the modules that import it, and only those."""

from __future__ import annotations

from pathlib import Path

from tauvcore.engine import loop
from tauvcore.filter.kernels import common, nees
from tauvcore.filter.kernels import rotation_kernels as rotations
from tauvcore.filter.kernels import strapdown_kernels as strapdown


def test_a_kernels_cache_is_checked_against_the_key_of_its_module() -> None:
    assert strapdown.advance._cache._cache_file._source_stamp == common.source_key(strapdown.__name__)
    assert loop.run_stops._cache._cache_file._source_stamp == common.source_key(loop.__name__)
    assert common.radii_nav._cache._cache_file._source_stamp == common.source_key("tauvcore.geo.earth")


def test_an_edit_below_a_kernel_changes_its_key_and_not_the_others(tmp_path, monkeypatch) -> None:
    """Given rotations.py edited, when the keys are taken again, then those of strapdown (which
    imports it) and of the loop (which imports strapdown) change, and that of nees (which does
    not) stays."""
    names = (strapdown.__name__, loop.__name__, nees.__name__)
    before = [common.source_key(name) for name in names]
    edited = tmp_path / "rotations.py"
    edited.write_text(Path(rotations.__file__).read_text() + "\n# an edit\n")
    origin = common._origin
    monkeypatch.setattr(common, "_origin", lambda name: str(edited) if name == rotations.__name__ else origin(name))
    monkeypatch.setattr(common, "_source_keys", {})
    after = [common.source_key(name) for name in names]
    assert after[0] != before[0] and after[1] != before[1]
    assert after[2] == before[2]


def test_an_index_that_cannot_be_read_back_is_a_cache_miss(tmp_path, monkeypatch) -> None:
    """Given a kernel's cache index written by another tree of the source, whose machine code named
    a module since renamed (numba unpickles the index before it compares the stamp), when the
    index is loaded, then it is an empty one (the kernel compiled again), not a ModuleNotFoundError."""
    import pickle
    import sys
    import types

    gone = types.ModuleType("tauvcore_module_since_renamed")
    exec("class Overload:\n    pass\n", gone.__dict__)
    gone.Overload.__module__ = gone.__name__
    sys.modules[gone.__name__] = gone
    payload = pickle.dumps((b"another tree's stamp", {"key": gone.Overload()}))
    del sys.modules[gone.__name__]
    cache_file = strapdown.advance._cache._cache_file
    index = tmp_path / "advance.nbi"
    with index.open("wb") as f:
        pickle.dump(cache_file._version, f, protocol=-1)
        f.write(payload)
    monkeypatch.setattr(cache_file, "_index_path", str(index))
    try:
        pickle.loads(payload)
    except ModuleNotFoundError:
        pass
    else:
        raise AssertionError("the payload should name a module that is gone")
    assert cache_file._load_index() == {}
