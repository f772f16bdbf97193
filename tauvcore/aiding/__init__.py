"""Aiding measurement models, one file each; every model is small and pure.

A model turns the data of one epoch and the predicted nominal state into a
:class:`~tauvcore.filter.eskf.Measurement` (z, innovation, H, R, valid) and exposes its nonlinear
``predict`` so the tests can check H against finite differences. "When to fuse" lives in the
runner (tauvcore.engine), not here.
"""

from tauvcore.aiding.attitude_mag import MagAttitude
from tauvcore.aiding.depth import Depth
from tauvcore.aiding.dvl_loose import DvlLoose
from tauvcore.aiding.sources import AIDING

AIDING_SOURCES = AIDING
"""Every source ``run.aiding`` may hold: the DVL (fused by each method its own way) and the fused sources
of tauvcore.aiding.sources."""

__all__ = ["AIDING_SOURCES", "Depth", "DvlLoose", "MagAttitude"]
