"""The registry's sources in Yoo 2014's 12-state filter (tauvcore.engine.yoo_bank): those whose
measurement weighs only states the filter has.

The 12 states are the NED velocity, the misalignment and the two IMU biases (tauvcore.filter.families.yoo.model).
The misalignment and the biases are the 20-state error's own (the same frames and signs:
``C_true = exp([rho x]) C_est``, ``b_true - b_est`` in b), so a source's H over them carries over
column for column (:data:`COLUMNS`); the 20-state velocity error is in the body frame, Yoo's in
NED, and the filter has no position, so a source that weighs the velocity or the position (the
depth, a USBL fix) is not one for it. Today that leaves the magnetometer's attitude
(:attr:`~tauvcore.aiding.source.AidingSource.observes` says which blocks a source's H weighs).
"""

from __future__ import annotations

import numpy as np

from tauvcore.aiding.source import AidingSource
from tauvcore.filter.families.yoo import model as yoo
from tauvcore.filter.layout import STATE

COLUMNS: dict[str, tuple[slice, slice]] = {
    "att": (STATE.att, yoo.ATT),
    "ba": (STATE.ba, yoo.BA),
    "bg": (STATE.bg, yoo.BG),
}
"""The 20-state blocks the 12-state filter shares: block -> (its 20-state columns, its 12-state ones)."""


def takes(source: AidingSource) -> bool:
    """Whether the 12-state filter fuses ``source``: a measurement whose H weighs only blocks of
    :data:`COLUMNS`."""
    return source.fused and bool(source.observes) and set(source.observes) <= set(COLUMNS)


def yoo_H(H: np.ndarray, num_states: int) -> np.ndarray:
    """A 20-state H (..., m, 20) over the 12-state filter's columns, zero on the consider states:
    (..., m, ``num_states``)."""
    out = np.zeros(H.shape[:-1] + (num_states,))
    for big, small in COLUMNS.values():
        out[..., small] = H[..., big]
    return out
