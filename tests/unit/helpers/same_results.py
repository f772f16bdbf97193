"""Every field of two runs' results compared: series, records, update records, the velocity
Kalman filter's trace and the smoothed results, to 1e-9 (the batched products may differ in the
last bits), booleans, integers and names exactly."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from tauvcore.engine.results import MethodResult


def assert_same_results(a: Mapping[str, MethodResult], b: Mapping[str, MethodResult], rtol: float = 1e-9) -> None:
    assert list(a) == list(b)
    for method in a:
        _same(a[method], b[method], method, rtol)


def _same(a: object, b: object, where: str, rtol: float) -> None:
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            _same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}", rtol)
    elif isinstance(a, Mapping):
        assert isinstance(b, Mapping) and list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k}]", rtol)
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.shape == b.shape and a.dtype == b.dtype, where
        if a.dtype.kind == "f":
            np.testing.assert_allclose(a, b, rtol=rtol, atol=1e-12, err_msg=where)
        else:
            np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert a == b, f"{where}: {a!r} != {b!r}"
