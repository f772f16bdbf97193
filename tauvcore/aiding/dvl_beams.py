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
    """The Janus DVL as a source: its four beams simulated, logged and read; the methods fuse them
    (module docstring)."""

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
        """The DVL's ping rate.

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section.

        Returns
        -------
        float
            Pings per second [Hz] (``dvl.rate_hz``).
        """
        return section.rate_hz

    def ideal(self, section: DvlConfig) -> DvlConfig:
        """The same DVL with every error zeroed (``run.ideal``: :meth:`DvlConfig.ideal`).

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section.

        Returns
        -------
        DvlConfig
            Its geometry, lever arm [m] (body FRD), beams, outages, dropout and range kept; noise
            [m/s], bias [m/s], bias walk, scale factor and its walk zero.
        """
        return section.ideal()

    def initial_state(self, section: DvlConfig, num_runs: int, world: World) -> tuple[DvlState, Bathymetry]:
        """The random walks' state before the first ping and the seabed the beams are traced to.

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section.
        num_runs : int
            Number of Monte Carlo runs R (the walks draw their turn-on values at the first chunk).
        world : World
            What the vehicle flies through: its seabed (depths [m], NED).

        Returns
        -------
        tuple[DvlState, Bathymetry]
            Fresh bias and scale-factor walks (no ping yet), and ``world.seabed``.
        """
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
        """The pings within the chunk by eq. 15 plus errors (:func:`tauvcore.sensors.dvl.simulate_chunk`).

        Parameters
        ----------
        truth : Truth
            The chunk's true motion, K samples at the IMU rate (body velocity ``vel_b`` (K, 3)
            [m/s], body rate ``omega_nb_b`` (K, 3) [rad/s], both body FRD); its row k is the
            mission's sample ``k0 + k``.
        k0 : int
            The mission's IMU sample index of the chunk's first row.
        epochs : numpy.ndarray
            The mission's IMU sample indices of the pings within the chunk, shape (E,) int.
        section : DvlConfig
            The ``[dvl]`` section (zero-noise when the run is ideal: :meth:`ideal`).
        state : tuple[DvlState, Bathymetry]
            The bias and scale-factor walks from the previous chunk, and the seabed.
        rngs : Mapping[str, Rng]
            A generator (or one per run) for each of ``dvl_bias``, ``dvl_scale_factor``,
            ``dvl_noise`` and ``dvl_dropout``.
        num_runs : int
            Number of Monte Carlo runs R.
        num_samples : int
            The mission's length [IMU samples] (unused: every ping is fused at its own sample).

        Returns
        -------
        tuple[SourceData, tuple[DvlState, Bathymetry]]
            The pings (:func:`source_data`: beams (E, R) each [m/s] along its axis, NaN where not
            returned; true biases (E, R) [m/s] and scale factor (E, R) [-]) and the state for the
            next chunk.
        """
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
    """A DVL's pings as the source's epochs: its beams NaN where not returned, the true errors as
    truth columns.

    Parameters
    ----------
    data : DvlData
        M pings with the run axis present: ``y_beam_mps`` and ``available`` (M, R, 4), beam
        velocities [m/s] along each beam's axis s_k; ``bias_mps`` (M, R, 4) [m/s];
        ``scale_factor`` (M, R) [-].

    Returns
    -------
    SourceData
        ``t_s`` (M,) [s], ``index`` (M,) int; columns ``beam1_mps`` .. ``beam4_mps`` (M, R) [m/s];
        truth columns ``true_beam1_bias_mps`` .. ``true_beam4_bias_mps`` (M, R) [m/s] and
        ``true_scale_factor`` (M, R) [-].
    """
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
    """The source's epochs as the pings the banks read (:class:`tauvcore.sensors.dvl.DvlData`).

    Parameters
    ----------
    data : SourceData or None
        The DVL's epochs (:func:`source_data`, :func:`from_log`), each beam column (M, R) [m/s];
        None: a log without a DVL.
    num_runs : int
        Number of Monte Carlo runs R (used only for None).

    Returns
    -------
    DvlData
        ``t_s`` (M,) [s], ``index`` (M,) int, beams ``y_beam_mps`` (M, R, 4) [m/s] along each
        beam's axis, ``available`` (M, R, 4) bool where finite, true ``bias_mps`` (M, R, 4) [m/s]
        and ``scale_factor`` (M, R) [-], NaN where unknown; no pings (M = 0) for None.
    """
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
    """A log's pings under the configured beams, outages and dropout, as a simulation's would be
    (one run).

    Parameters
    ----------
    t_s : numpy.ndarray
        The mission's times of the IMU samples ``index`` the pings are fused at, shape (M,) [s].
    index : numpy.ndarray
        The mission's IMU sample index of each ping, shape (M,) int.
    beams_mps : numpy.ndarray
        The logged beam velocities along each beam's axis s_k, shape (M, 4) [m/s]; NaN where a
        beam did not return.
    truth : Mapping[str, numpy.ndarray]
        The log's truth columns by name, each (M,): ``true_beam1_bias_mps`` ..
        ``true_beam4_bias_mps`` [m/s], ``true_scale_factor`` [-]; those absent are left out.
    config : DvlConfig
        The ``[dvl]`` section: its enabled beams, outages [s] and ``dropout_probability``.
    rng : numpy.random.Generator
        Draws the dropouts (M, 4), only when ``dropout_probability`` is positive.

    Returns
    -------
    SourceData
        ``t_s`` (M,) [s], ``index`` (M,) int, columns ``beam1_mps`` .. ``beam4_mps`` (M, 1)
        [m/s], NaN where not returned, out of schedule or dropped; the truth columns given, (M, 1).
    """
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
