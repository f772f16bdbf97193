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
