"""The Janus DVL's four beam velocities (eq. 15): the sensor every method but the free INS is built
around, aboard every vehicle of the lab.

It is fused by the methods themselves, not by the engine's update of a source
(:attr:`~tauvcore.aiding.source.AidingSource.fused` False): LC, TC, the partial-beam methods and
their selector (tauvcore.aiding.dvl_loose, dvl_tight, dvl_partial) and Yoo 2014's filters read its
beams through the compiled kernels (tauvcore.filter.kernels.dvl_kernels), and ``"dvl"`` in ``run.aiding``
turns them on (:attr:`~tauvcore.aiding.source.AidingSource.methods_fuse`). ``[dvl]`` configures it
(tauvcore.sensors.dvl.DvlConfig: error model, geometry, lever arm, beams, outages, dropout,
bottom range and water-track). Its log table ``dvl`` holds ``t_s`` and ``beam1_mps`` ..
``beam4_mps`` (empty where a beam did not return), and, from a DVL that water-tracks,
``beam1_water_track`` .. ``beam4_water_track``: 1 where the beam's velocity is water-track
(relative to the water layer), 0 where it is bottom-track (a table without them is bottom-track
throughout). A DVL that outputs both from one ping (``water_track = "both"``) writes instead
``beam1_water_mps`` .. ``beam4_water_mps``: each beam's water-track velocity (empty where none)
beside its bottom-track one in ``beam1_mps`` .. (then bottom-track only), without the mode
columns. A simulated log adds each beam's true bias and the true scale factor. A recorded log
may give a body velocity instead (tauvcore.logs reads both forms); on logged beams the configured
beams, outages and dropout are applied as on simulated ones (:func:`from_log`). The source's
epochs (:class:`~tauvcore.aiding.source.SourceData`) hold the table's columns as the log does;
:func:`pings` parts them into the bottom-track beams the methods fuse and the water-track beams.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from tauvcore.aiding.dvl_water import CURRENT_BLOCK
from tauvcore.aiding.source import AidingSource, Column, SourceData
from tauvcore.conventions import MAX_SPEED_MPS
from tauvcore.filter.layout import StateBlock
from tauvcore.sensors import dvl
from tauvcore.sensors.dvl import DvlConfig, DvlData, DvlState, DvlStreams
from tauvcore.sensors.timing import Rng, uniform
from tauvcore.truth.current import CurrentField
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.world import World

BEAMS = ("beam1_mps", "beam2_mps", "beam3_mps", "beam4_mps")
"""The beam velocity columns [m/s] of the log's ``dvl`` table."""
WATER_TRACK = ("beam1_water_track", "beam2_water_track", "beam3_water_track", "beam4_water_track")
"""The beams' mode columns of the log's ``dvl`` table: 1 water-track, 0 bottom-track (or none, where
the beam's velocity is empty); present only for a DVL that water-tracks."""
WATER_BEAMS = ("beam1_water_mps", "beam2_water_mps", "beam3_water_mps", "beam4_water_mps")
"""The water-track velocity columns [m/s] of the log's ``dvl`` table of a DVL that outputs both
from one ping (``water_track = "both"``), empty where a beam did not water-track; ``beam1_mps`` ..
then hold bottom-track only, and the table has no mode columns."""
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

    def states(self, section: DvlConfig) -> tuple[StateBlock, ...]:
        """The current (north, east) the water-track beams observe, with ``current_states`` on.

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section: ``current_states``, ``current_sigma_mps`` [m/s],
            ``current_tau_s`` [s], ``current_walk_mps_per_sqrt_s`` [m/s/sqrt(s)].

        Returns
        -------
        tuple[StateBlock, ...]
            One block ``current`` of two states [m/s] (tauvcore.aiding.dvl_water), or none.
        """
        if section.current_states == "off":
            return ()
        sigma = section.current_sigma_mps
        if section.current_states == "gauss-markov":
            rate, q = -1.0 / section.current_tau_s, 2.0 * sigma**2 / section.current_tau_s
        else:
            rate, q = 0.0, section.current_walk_mps_per_sqrt_s**2
        return (
            StateBlock(
                name=CURRENT_BLOCK,
                labels=("current_north_mps", "current_east_mps"),
                sigma0=(sigma, sigma),
                rate_per_s=(rate, rate),
                q_psd=(q, q),
            ),
        )

    def states_truth(self, section: DvlConfig, truth: Truth) -> np.ndarray:
        """The current at the vehicle, north and east.

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section.
        truth : Truth
            A chunk of the mission's truth (K samples).

        Returns
        -------
        numpy.ndarray
            Shape (K, 2) [m/s] (``Truth.current_n_mps``), or (K, 0) without current states. Zero
            where the truth records no current: still water, and a replayed log, whose reference
            says nothing of the water (the current's NEES of a replay is then against still water).
        """
        if section.current_states == "off":
            return np.zeros((truth.num_samples, 0))
        if truth.current_n_mps is None:
            return np.zeros((truth.num_samples, 2))
        return np.ascontiguousarray(truth.current_n_mps[:, :2])

    def initial_state(
        self, section: DvlConfig, num_runs: int, world: World
    ) -> tuple[DvlState, Bathymetry, CurrentField | None]:
        """The random walks' state before the first ping, the seabed the beams are traced to and
        the current the water-track layer moves with.

        Parameters
        ----------
        section : DvlConfig
            The ``[dvl]`` section.
        num_runs : int
            Number of Monte Carlo runs R (the walks draw their turn-on values at the first chunk).
        world : World
            What the vehicle flies through: its seabed (depths [m], NED) and its current [m/s].

        Returns
        -------
        tuple[DvlState, Bathymetry, CurrentField or None]
            Fresh bias and scale-factor walks (no ping yet), ``world.seabed`` and
            ``world.current`` (None: still water).
        """
        return DvlState(), world.seabed, world.current

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: DvlConfig,
        state: tuple[DvlState, Bathymetry, CurrentField | None],
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, tuple[DvlState, Bathymetry, CurrentField | None]]:
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
        state : tuple[DvlState, Bathymetry, CurrentField or None]
            The bias and scale-factor walks (and the water-track noise's generator) from the
            previous chunk, the seabed and the current.
        rngs : Mapping[str, Rng]
            A generator (or one per run) for each of ``dvl_bias``, ``dvl_scale_factor``,
            ``dvl_noise`` and ``dvl_dropout``.
        num_runs : int
            Number of Monte Carlo runs R.
        num_samples : int
            The mission's length [IMU samples] (unused: every ping is fused at its own sample).

        Returns
        -------
        tuple[SourceData, tuple[DvlState, Bathymetry, CurrentField or None]]
            The pings (:func:`source_data`: beams (E, R) each [m/s] along its axis, NaN where not
            returned, with water-track their modes (E, R); true biases (E, R) [m/s] and scale
            factor (E, R) [-]) and the state for the next chunk.
        """
        walks, seabed, current = state
        data, walks = dvl.simulate_chunk(
            truth,
            k0,
            epochs,
            section,
            walks,
            DvlStreams(rngs["dvl_bias"], rngs["dvl_scale_factor"], rngs["dvl_noise"], rngs["dvl_dropout"]),
            num_runs,
            seabed,
            current,
        )
        return source_data(data, section.water_track == "both"), (walks, seabed, current)


def source_data(data: DvlData, both: bool = False) -> SourceData:
    """A DVL's pings as the source's epochs, as its log table holds them: each beam's velocity,
    bottom- or water-track, NaN where not returned (and with water-track each beam's mode), or
    with ``both`` each beam's bottom-track and water-track velocities in columns of their own; the
    true errors as truth columns.

    Parameters
    ----------
    data : DvlData
        M pings with the run axis present: ``y_beam_mps`` and ``available`` (M, R, 4), bottom-track
        beam velocities [m/s] along each beam's axis s_k; ``y_water_mps`` and ``water_available``
        (M, R, 4) or None, water-track ones [m/s]; ``bias_mps`` (M, R, 4) [m/s]; ``scale_factor``
        (M, R) [-].
    both : bool, optional
        The DVL outputs both from one ping (``water_track = "both"``): a beam may have both, so
        water-track goes to columns of its own. Set by the configuration, not by ``data``, so
        that every chunk of a run has the same columns.

    Returns
    -------
    SourceData
        ``t_s`` (M,) [s], ``index`` (M,) int; columns ``beam1_mps`` .. ``beam4_mps`` (M, R) [m/s]
        (with ``both`` bottom-track only), and where ``data`` has water-track either (``both``)
        ``beam1_water_mps`` .. ``beam4_water_mps`` (M, R) [m/s], NaN where a beam did not
        water-track, or ``beam1_water_track`` .. ``beam4_water_track`` (M, R) (1.0 water-track,
        0.0 bottom-track or none); truth columns ``true_beam1_bias_mps`` ..
        ``true_beam4_bias_mps`` (M, R) [m/s] and ``true_scale_factor`` (M, R) [-].

    Raises
    ------
    ValueError
        Without ``both``, for pings where a beam has both (one column cannot hold two velocities).
    """
    values = {
        n: np.where(data.available[..., i], data.y_beam_mps[..., i], np.nan) for i, n in enumerate(BEAMS)
    }
    if data.y_water_mps is not None and data.water_available is not None:
        water = data.water_available
        if both:
            values.update(
                {
                    n: np.where(water[..., i], data.y_water_mps[..., i], np.nan)
                    for i, n in enumerate(WATER_BEAMS)
                }
            )
        else:
            if (water & data.available).any():
                raise ValueError("a beam with both bottom-track and water-track needs both=True")
            for i, n in enumerate(BEAMS):
                values[n] = np.where(water[..., i], data.y_water_mps[..., i], values[n])
            values.update({n: water[..., i].astype(float) for i, n in enumerate(WATER_TRACK)})
    return SourceData(
        t_s=data.t_s,
        index=np.asarray(data.index, dtype=np.int64),
        values=values,
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
        The DVL's epochs (:func:`source_data`, :func:`from_log`), each beam column (M, R) [m/s],
        with the mode columns or the water-track velocity columns where the DVL water-tracks;
        None: a log without a DVL.
    num_runs : int
        Number of Monte Carlo runs R (used only for None).

    Returns
    -------
    DvlData
        ``t_s`` (M,) [s], ``index`` (M,) int, bottom-track beams ``y_beam_mps`` (M, R, 4) [m/s]
        along each beam's axis, ``available`` (M, R, 4) bool where finite, true ``bias_mps``
        (M, R, 4) [m/s] and ``scale_factor`` (M, R) [-], NaN where unknown; with the mode columns
        or the water-track velocity columns the water-track beams ``y_water_mps`` (M, R, 4) [m/s]
        and ``water_available`` (M, R, 4) where finite, else None; no pings (M = 0) for None.
    """
    if data is None:
        data = SourceData.empty(DvlSource.columns, num_runs)
    y = data.stacked(BEAMS)
    m, runs = y.shape[:2]
    truth = data.truth
    y_water = water = None
    if WATER_BEAMS[0] in data.values:
        y_water = data.stacked(WATER_BEAMS)
        water = ~np.isnan(y_water)
    elif WATER_TRACK[0] in data.values:
        water = (data.stacked(WATER_TRACK) > 0.5) & ~np.isnan(y)
        y_water = np.where(water, y, np.nan)
        y = np.where(water, np.nan, y)
    return DvlData(
        t_s=data.t_s,
        index=data.index,
        y_beam_mps=y,
        available=~np.isnan(y),
        bias_mps=np.stack([truth[n] for n in TRUE_BIASES], axis=-1)
        if TRUE_BIASES[0] in truth
        else np.full((m, runs, 4), np.nan),
        scale_factor=truth[TRUE_SCALE_FACTOR] if TRUE_SCALE_FACTOR in truth else np.full((m, runs), np.nan),
        y_water_mps=y_water,
        water_available=water,
    )


def from_log(
    t_s: np.ndarray,
    index: np.ndarray,
    beams_mps: np.ndarray,
    truth: Mapping[str, np.ndarray],
    config: DvlConfig,
    rng: np.random.Generator,
    water_track: np.ndarray | None = None,
    water_mps: np.ndarray | None = None,
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
    water_track : numpy.ndarray or None, optional
        Shape (M, 4) bool: the beam's velocity is water-track (the log's mode columns); None: the
        log has none, every beam bottom-track.
    water_mps : numpy.ndarray or None, optional
        The logged water-track beam velocities beside the bottom-track ones (the log's
        ``beam1_water_mps`` .. ``beam4_water_mps``), shape (M, 4) [m/s], NaN where a beam did not
        water-track; ``beams_mps`` is then bottom-track only. None: the log has none.

    Returns
    -------
    SourceData
        ``t_s`` (M,) [s], ``index`` (M,) int, columns ``beam1_mps`` .. ``beam4_mps`` (M, 1)
        [m/s], NaN where not returned, out of schedule or dropped; with ``water_track``
        ``beam1_water_track`` .. ``beam4_water_track`` (M, 1) (1.0 water-track, else 0.0); with
        ``water_mps`` ``beam1_water_mps`` .. ``beam4_water_mps`` (M, 1) [m/s], NaN where not
        returned, out of schedule or dropped (a beam's dropout drops both its velocities, as in a
        simulation); the truth columns given, (M, 1).
    """
    scheduled = config.scheduled_availability(t_s)
    if config.dropout_probability > 0:
        scheduled &= uniform(rng, beams_mps.shape) >= config.dropout_probability
    available = ~np.isnan(beams_mps) & scheduled
    y = np.where(available, beams_mps, np.nan)
    values = {n: y[:, i, None] for i, n in enumerate(BEAMS)}
    if water_mps is not None:
        y_water = np.where(scheduled, water_mps, np.nan)
        values.update({n: y_water[:, i, None] for i, n in enumerate(WATER_BEAMS)})
    if water_track is not None:
        water = np.asarray(water_track, dtype=bool) & available
        values.update({n: water[:, i, None].astype(float) for i, n in enumerate(WATER_TRACK)})
    return SourceData(
        t_s=t_s,
        index=np.asarray(index, dtype=np.int64),
        values=values,
        truth={c.name: truth[c.name][:, None] for c in DvlSource.truth_columns if c.name in truth},
    )


SOURCE = DvlSource()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
