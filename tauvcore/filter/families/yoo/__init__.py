"""Yoo 2014's filter: the 12-state indirect feedback Kalman filter (section 2.1).

Its error state is tauvcore.filter.families.yoo.model's (NED velocity, attitude, the IMU's biases; no position),
with the DVL's scale factor and beam biases as consider states; its bank
tauvcore.engine.yoo_bank.YooBank. Methods: ``ins-dvl`` aided by the DVL's velocity, ``vkf`` by the
velocity Kalman filter's switch of DVL and RPM (eq. 29). Named, not in "all".
"""

from __future__ import annotations

from tauvcore.filter.families.spec import Family

FAMILY = Family(
    name="yoo",
    title="Yoo 2014's 12-state filter",
    methods=("ins-dvl", "vkf"),
    in_all=False,
    block_dims={"full": 12, "pos": 3, "vel": 3, "tilt": 2, "heading": 1, "sensor": 6},
    position_state=False,
    sensor_blocks=("ba", "bg"),
    log_det=False,
    error_state="yoo",
)
