"""The echo sounder's altitude above the seabed: what switches Yoo 2014's velocity filter between
the DVL and the propeller (eq. 29), data for the methods that read it rather than a measurement of
its own (:attr:`~tauvcore.aiding.source.AidingSource.fused` False).

The sensor (tauvcore.sensors.echosounder) is aboard every vehicle of the lab: ``[echo_sounder]``
configures it, its log table is ``echo`` (``t_s``, ``altitude_m``: empty where no echo came back;
``true_altitude_m`` beside it in a simulated log).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.sensors import echosounder
from tauvcore.sensors.echosounder import EchoSounderConfig
from tauvcore.sensors.timing import Rng
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.world import World

ALTITUDE = "altitude_m"
TRUE_ALTITUDE = "true_altitude_m"


class EchoSource(AidingSource):
    name = "echo"
    section_name = "echo_sounder"
    table = "echo"
    aboard = True
    fused = False  # read by tauvcore.engine.rpm_aid (vkf, run.rpm_fallback)
    label = "Echo sounder"
    summary = "the altitude above the seabed straight below the vehicle"
    config_type = EchoSounderConfig
    streams = ("echo_sounder",)  # tauvcore.sensors.stream.SensorStreams.echo_sounder
    columns = (
        Column(
            ALTITUDE,
            "m",
            -0.5,  # a sounder's noise near the seabed; a "no echo" code such as -1 is refused
            12_000.0,
            "no altitude above the seabed (no echo: leave the cell empty)",
            allow_nan=True,
        ),
    )
    truth_columns = (
        Column(TRUE_ALTITUDE, "m", -12_000.0, 12_000.0, "farther than the deepest ocean", allow_nan=True),
    )

    def initial_state(self, section: EchoSounderConfig, num_runs: int, world: World) -> Bathymetry:
        return world.seabed  # what the sounder sees; nothing else carries over

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: EchoSounderConfig,
        state: Bathymetry,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, Bathymetry]:
        data = echosounder.simulate_chunk(truth, k0, epochs, section, state, rngs["echo_sounder"], num_runs)
        true = np.broadcast_to(data.true_altitude_m[:, None], data.altitude_m.shape)
        return SourceData(
            t_s=data.t_s, index=data.index, values={ALTITUDE: data.altitude_m}, truth={TRUE_ALTITUDE: true}
        ), state


SOURCE = EchoSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
