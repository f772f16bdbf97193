"""An unscented (sigma-point) error-state Kalman filter on the 20 states of the first paper's filter.

Its error state, process model and bank are the 20-state filter's (tauvcore.filter.families.eskf):
the error propagates by the same linear F and Q, for which the unscented transform is exact, so
sigma points there would give the same P. Where the error-state filter's models are nonlinear, in
the measurements, it differs: every correction (the DVL's velocity or beams, the water-track beams,
the RPM fallback, depth, magnetometer, USBL and any source of tauvcore.aiding.sources) evaluates
the measurement itself at 2d + 1 sigma points of the error about the estimate, d the error state's
size with the sources' states (:mod:`tauvcore.filter.families.ukf.unscented`), and is fused through
the bank's one gated Joseph correction as its statistical linearisation, with which the Kalman
update is the unscented one.

Methods: ``ukf`` fuses the DVL as ``lc`` does (the least-squares velocity of 3-4 beams), ``ukf-tc``
as ``tc`` does (one row per returned beam). Named, not in "all" (the first paper's study).
"""

from __future__ import annotations

from tauvcore.filter.families.spec import Family
from tauvcore.filter.families.ukf.unscented import linearize
from tauvcore.filter.layout import NEES_BLOCKS, STATE

FAMILY = Family(
    name="ukf",
    title="the unscented error-state filter on the 20 states",
    methods=("ukf", "ukf-tc"),
    in_all=False,
    block_dims={"full": STATE.dim, **{name: len(ix) for name, ix in NEES_BLOCKS.items()}},
    position_state=True,
    sensor_blocks=("ba", "bg", "b_dvl", "sf_dvl"),
    log_det=True,
    error_state="eskf",
    dvl_fusion={"ukf": "lc", "ukf-tc": "tc"},
    linearize=linearize,
)
