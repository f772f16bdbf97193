"""The propeller's shaft speed: the input of Yoo 2014's velocity Kalman filter (eq. 20), data for
the methods that read it rather than a measurement of its own
(:attr:`~tauvcore.aiding.source.AidingSource.fused` False).

The sensor (tauvcore.sensors.rpm) is aboard every vehicle of the lab: ``[rpm]`` configures it,
its log table is ``rpm`` (``t_s``, ``propeller_rpm``). A simulated log carries beside it what the
propeller truly turned at and, on the kinematic truth, the speed model's true scale factor and bias
(``true_propeller_rpm``, ``true_scale_factor_mps_per_rpm``, ``true_bias_mps``): the truth the VKF's
learned scale factor and bias are judged against, NaN for a log without them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.sensors import rpm
from tauvcore.sensors.rpm import RpmConfig, RpmState
from tauvcore.sensors.timing import Rng
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.world import World

RPM = "propeller_rpm"
TRUE_RPM = "true_propeller_rpm"
TRUE_SCALE_FACTOR = "true_scale_factor_mps_per_rpm"
TRUE_BIAS = "true_bias_mps"
_FAST = "faster than any propeller turns"


class RpmSource(AidingSource):
    name = "rpm"
    section_name = "rpm"
    table = "rpm"
    aboard = True
    fused = False  # read by tauvcore.engine.rpm_aid (vkf, run.rpm_fallback)
    label = "Propeller RPM"
    summary = "the propeller's shaft speed"
    config_type = RpmConfig
    streams = ("rpm_scale_factor", "rpm_bias", "rpm_noise")  # tauvcore.sensors.stream.SensorStreams
    columns = (Column(RPM, "rev/min", -1e5, 1e5, _FAST),)
    truth_columns = (
        Column(TRUE_RPM, "rev/min", -1e5, 1e5, _FAST, allow_nan=True),
        Column(
            TRUE_SCALE_FACTOR, "m/s per rev/min", -1.0, 1.0, "no propeller's speed per rpm", allow_nan=True
        ),
        Column(TRUE_BIAS, "m/s", -100.0, 100.0, "faster than any AUV", allow_nan=True),
    )

    def initial_state(self, section: RpmConfig, num_runs: int, world: World) -> RpmState:
        return RpmState()

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: RpmConfig,
        state: RpmState,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, RpmState]:
        data, state = rpm.simulate_chunk(
            truth,
            k0,
            epochs,
            section,
            state,
            rngs["rpm_scale_factor"],
            rngs["rpm_bias"],
            rngs["rpm_noise"],
            num_runs,
        )
        return SourceData(
            t_s=data.t_s,
            index=data.index,
            values={RPM: data.rpm},
            truth={TRUE_RPM: data.true_rpm, TRUE_SCALE_FACTOR: data.scale_factor, TRUE_BIAS: data.bias_mps},
        ), state


SOURCE = RpmSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
