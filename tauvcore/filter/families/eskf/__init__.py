"""The first paper's filter (Tal, Klein & Katz 2017): the 20-state error-state EKF.

Its error state is tauvcore.filter.layout.STATE (position, misalignment, body velocity, the IMU's
biases, the DVL's beam biases and scale factor; the states the aiding sources add come after), its
process model tauvcore.filter.kernels.error_model_kernels, its bank tauvcore.engine.filter_bank.FilterBank.

Methods: ``ins`` the standalone INS (no aiding at all), ``lc`` loosely coupled DVL (3-4 beams),
``tc`` tightly coupled (any beams), and the extended loosely coupled methods of section 3 (LC with
3-4 beams, their partial construction with 2): ``vb`` virtual beam, ``nsv`` nullified sway,
``plcf`` partial LC, ``vhv`` virtual heave, ``elc`` the per-axis selector; and ``iekf``, the
right-invariant EKF (Potokar et al. 2021; tauvcore.filter.invariant) on the same states, fusing
the beams as ``tc`` does. The methods of tauvcore.aiding.registry run on its bank too.
"""

from __future__ import annotations

from tauvcore.filter.families.spec import Family
from tauvcore.filter.layout import NEES_BLOCKS, STATE

FAMILY = Family(
    name="eskf",
    title="the 20-state error-state EKF",
    methods=("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc", "iekf"),
    in_all=True,
    block_dims={"full": STATE.dim, **{name: len(ix) for name, ix in NEES_BLOCKS.items()}},
    position_state=True,
    sensor_blocks=("ba", "bg", "b_dvl", "sf_dvl"),
    log_det=True,
    error_state="eskf",
    dvl_fusion={
        "ins": None,
        "lc": "lc",
        "tc": "tc",
        **{m: "elc" for m in ("vb", "nsv", "plcf", "vhv", "elc")},  # tauvcore.aiding.dvl_extended.ELC_METHODS
        # the invariant EKF fuses the returned beams one row each, as the tightly coupled filter: four
        # beams are the body velocity of Potokar et al., two or three what they see of it
        "iekf": "tc",
    },
)
