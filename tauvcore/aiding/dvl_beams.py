"""The Janus DVL's four beam velocities (eq. 15): the sensor every method but the free INS is built
around, aboard every vehicle of the lab.

It is fused by the methods themselves, not by the engine's update of a source
(:attr:`~tauvcore.aiding.source.AidingSource.fused` False): LC, TC, the partial-beam methods and
their selector (tauvcore.aiding.dvl_loose, dvl_tight, dvl_partial) and Yoo 2014's filters read its
beams through the compiled kernels (tauvcore.filter.kernels.dvl), and ``"dvl"`` in ``run.aiding``
turns them on (:attr:`~tauvcore.aiding.source.AidingSource.methods_fuse`). ``[dvl]`` configures it
(tauvcore.sensors.dvl.DvlConfig: error model, geometry, lever arm, beams, outages, dropout and
bottom range). Its log table ``dvl`` holds ``t_s`` and ``beam1_mps`` .. ``beam4_mps`` (empty where
a beam did not return); a simulated log adds each beam's true bias and the true scale factor. A
recorded log may give a body velocity instead (tauvcore.logs reads both forms); on logged beams
the configured beams, outages and dropout are applied as on simulated ones (:func:`from_log`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.conventions import MAX_SPEED_MPS
from tauvcore.sensors import dvl
from tauvcore.sensors.dvl import DvlConfig, DvlData, DvlState
from tauvcore.sensors.timing import Rng, uniform
from tauvcore.truth.record import Truth
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.world import World

BEAMS = ("beam1_mps", "beam2_mps", "beam3_mps", "beam4_mps")
"""The beam velocity columns [m/s] of the log's ``dvl`` table."""
TRUE_BIASES = ("true_beam1_bias_mps", "true_beam2_bias_mps", "true_beam3_bias_mps", "true_beam4_bias_mps")
TRUE_SCALE_FACTOR = "true_scale_factor"


class DvlSource(AidingSource):
    name = "dvl"
    aboard = True
    fused = False  # the methods fuse it through the compiled kernels (module docstring)
    methods_fuse = True
    label = "DVL"
    summary = "the four Janus beams' velocities along their axes"
    config_type = DvlConfig
    streams = ("dvl_bias", "dvl_scale_factor", "dvl_noise", "dvl_dropout")  # SensorStreams' DVL streams
    columns = tuple(
        Column(n, "m/s", -MAX_SPEED_MPS, MAX_SPEED_MPS, "faster than any AUV", allow_nan=True) for n in BEAMS
    )
    # a simulation knows them at every ping: a log that has them has them in every row
    truth_columns = tuple(
        Column(n, "m/s", -MAX_SPEED_MPS, MAX_SPEED_MPS, "faster than any AUV") for n in TRUE_BIASES
    ) + (Column(TRUE_SCALE_FACTOR, "", -1.0, 1.0, "a DVL off by more than its speed"),)

    def rate_hz(self, section: DvlConfig) -> float:
        return section.rate_hz

    def ideal(self, section: DvlConfig) -> DvlConfig:
        return section.ideal()

    def initial_state(self, section: DvlConfig, num_runs: int, world: World) -> tuple[DvlState, Bathymetry]:
        return DvlState(), world.seabed  # the walks' state, and the seabed the beams are traced to

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: DvlConfig,
        state: tuple[DvlState, Bathymetry],
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, tuple[DvlState, Bathymetry]]:
        walks, seabed = state
        data, walks = dvl.simulate_chunk(
            truth,
            k0,
            epochs,
            section,
            walks,
            rngs["dvl_bias"],
            rngs["dvl_scale_factor"],
            rngs["dvl_noise"],
            rngs["dvl_dropout"],
            num_runs,
            seabed,
        )
        return source_data(data), (walks, seabed)


def source_data(data: DvlData) -> SourceData:
    """A DVL's pings (run axis present) as the source's epochs: its beams NaN where not returned,
    the true errors as truth columns."""
    return SourceData(
        t_s=data.t_s,
        index=np.asarray(data.index, dtype=np.int64),
        values={
            n: np.where(data.available[..., i], data.y_beam_mps[..., i], np.nan) for i, n in enumerate(BEAMS)
        },
        truth={
            **{n: data.bias_mps[..., i] for i, n in enumerate(TRUE_BIASES)},
            TRUE_SCALE_FACTOR: data.scale_factor,
        },
    )


def pings(data: SourceData | None, num_runs: int) -> DvlData:
    """The source's epochs as the pings the banks read (tauvcore.sensors.dvl.DvlData: beams (M, R, 4),
    returned where finite, true errors NaN where unknown); no pings for None (a log without a DVL)."""
    if data is None:
        data = SourceData.empty(DvlSource.columns, num_runs)
    y = data.stacked(BEAMS)
    m, runs = y.shape[:2]
    truth = data.truth
    return DvlData(
        t_s=data.t_s,
        index=data.index,
        y_beam_mps=y,
        available=~np.isnan(y),
        bias_mps=np.stack([truth[n] for n in TRUE_BIASES], axis=-1)
        if TRUE_BIASES[0] in truth
        else np.full((m, runs, 4), np.nan),
        scale_factor=truth[TRUE_SCALE_FACTOR] if TRUE_SCALE_FACTOR in truth else np.full((m, runs), np.nan),
    )


def from_log(
    t_s: np.ndarray,
    index: np.ndarray,
    beams_mps: np.ndarray,
    truth: Mapping[str, np.ndarray],
    config: DvlConfig,
    rng: np.random.Generator,
) -> SourceData:
    """A log's pings (``beams_mps`` (M, 4), NaN where a beam did not return; ``t_s`` the mission's
    times of the IMU samples ``index`` they are fused at) under the configured beams, outages and
    dropout, as a simulation's would be (one run)."""
    available = ~np.isnan(beams_mps) & config.scheduled_availability(t_s)
    if config.dropout_probability > 0:
        available &= uniform(rng, beams_mps.shape) >= config.dropout_probability
    y = np.where(available, beams_mps, np.nan)
    return SourceData(
        t_s=t_s,
        index=np.asarray(index, dtype=np.int64),
        values={n: y[:, i, None] for i, n in enumerate(BEAMS)},
        truth={c.name: truth[c.name][:, None] for c in DvlSource.truth_columns if c.name in truth},
    )


SOURCE = DvlSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
