"""Janus DVL in the "x" configuration (Tal et al. 2017 eq. 12-16).

Beam k (1..4) points along ``b_k = [cos(psi_k) sin(theta), sin(psi_k) sin(theta), cos(theta)]``
in the body frame (eq. 13), beam pitch ``theta`` (20 deg), beam yaw ``psi_k = 45 + (k-1) 90 deg``
(eq. 14). The beam velocity (eq. 15) is

    y_k = [v_b (1 + SF) + omega_nb_b x l_dvl_b] . b_k + b_dvl_k + n_k

with one scale factor SF common to all beams (speed of sound, eq. 12), a bias per beam, white
noise, and all four transducers at the DVL head ``l_dvl_b`` (the transducer spacing on a
small head is a few centimetres, below the 0.042 m/s noise for any plausible rate).

Mounting misalignment (``misalignment_deg``): the beams are fixed in the DVL's head frame h
(tauvcore.conventions), which a head mounted off its nominal orientation has rotated from b by
``C_bh`` (ZYX angles roll, pitch, yaw). The head then measures its velocity in h, and beam k is
``b_k`` of h::

    y_k = [C_bh^T (v_b (1 + SF) + omega_nb_b x l_dvl_b)] . b_k + b_dvl_k + n_k

It is a sensor error the filters do not know, as the beams' true biases are; with zero angles
(the default) h is b and eq. 15 above is the model, to the last bit. ``scale_factor_offset_pct``
is a fixed part of SF, added to the one drawn at turn-on.

Range: given the mission's seabed (tauvcore.truth.seabed), each beam is traced from the
head to the bottom; a beam whose slant range exceeds ``max_range_m`` (``max_altitude_m / cos(beam
pitch)``: the range of a beam of a level DVL at its rated altitude, Yoo 2014's 100 m) has no
bottom lock. ``beyond_range = "lost"``: it returns nothing, and the availability mask the
partial-beam methods read says so; ``"noisy"``: Yoo 2014's own model (section 3.2, eq. 30-32),
it returns with ``beyond_range_noise_mps`` (5 m/s) of extra white noise and is marked available,
so only a gate or an echo sounder can tell.

Water-track (``water_track``): beyond bottom-track range a DVL still measures its velocity
relative to a layer of water ``water_layer_m`` below the head (:func:`simulate_chunk`); in
``"both"`` it measures it on every ping beside bottom-track, as DVLs that output both from one
ping do (Nortek DVL1000, Teledyne Pathfinder). Its pings (:class:`DvlData` ``y_water_mps``) are
apart from the bottom-track ones (``y_beam_mps``): fusing them needs the current as a state
(tauvcore.aiding.dvl_water).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tauvcore import units
from tauvcore.conventions import NUM_DVL_BEAMS
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.sensors.timing import (
    Rng,
    WalkState,
    batch_shape,
    epoch_indices,
    random_walk_chunk,
    standard_normal,
    uniform,
)
from tauvcore.truth.current import CurrentField
from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import (
    ConfigError,
    check_settings,
    require_choice,
    require_finite,
    require_nonnegative,
    setting,
    show,
)

BEYOND_RANGE = ("lost", "noisy")
WATER_TRACK = ("off", "beyond_range", "always", "both")
"""``off``: bottom-track only; ``beyond_range``: a beam without bottom lock water-tracks instead;
``always``: every beam water-tracks (bottom-track off by configuration); ``both``: every beam
bottom-tracks where it has bottom lock, as with ``off``, and water-tracks where the layer lies
above the seabed along it, as with ``always``, both from the same ping (with ``beyond_range =
"lost"`` a beam beyond range water-tracks only, as with ``beyond_range``)."""
MODE_NONE, MODE_BOTTOM, MODE_WATER = 0, 1, 2
"""A beam's mode at a ping (:attr:`DvlData.mode`): no return, bottom-track, water-track."""
MODE_BOTH = MODE_BOTTOM | MODE_WATER
"""A beam that returned both at one ping (``water_track = "both"``): the modes are bit flags, so
``mode & MODE_BOTTOM`` is every beam that bottom-tracked."""
CURRENT_STATES = ("off", "gauss-markov", "random-walk")
"""How the filters model the current they estimate (tauvcore.aiding.dvl_water): not at all, a
first-order Gauss-Markov process (``current_sigma_mps``, ``current_tau_s``) or a random walk
(``current_walk_mps_per_sqrt_s``)."""
MAX_OUTAGES = 1000
"""Scheduled outage windows per run: a schedule, not a per-ping mask (random losses are
``dropout_probability``); each window is applied to every ping."""


def beam_directions_b(beam_pitch_rad: float) -> np.ndarray:
    """Unit beam directions in b, one row per beam (the matrix A of eq. 16).

    Row k-1 is ``b_k = [cos(psi_k) sin(theta), sin(psi_k) sin(theta), cos(theta)]`` (eq. 13) with
    beam yaw ``psi_k = 45 + (k-1) 90 deg`` (eq. 14).

    Parameters
    ----------
    beam_pitch_rad : float
        Beam pitch ``theta``, each beam's angle from the body z axis [rad].

    Returns
    -------
    numpy.ndarray
        ``A``, shape (4, 3) [-]: unit vectors, body frame b (FRD), beams 1-4 in rows 0-3.
    """
    yaw = np.deg2rad(45.0 + 90.0 * np.arange(NUM_DVL_BEAMS))
    s = np.sin(beam_pitch_rad)
    return np.stack(
        [np.cos(yaw) * s, np.sin(yaw) * s, np.full(NUM_DVL_BEAMS, np.cos(beam_pitch_rad))], axis=-1
    )


@dataclass(frozen=True)
class Outage:
    """Beams lost (no bottom lock) during ``start_s <= t < end_s``."""

    beams: tuple[int, ...]  # beam numbers 1-4
    start_s: float  # [s]
    end_s: float  # [s]

    def __post_init__(self) -> None:
        _check_beams("dvl.outages.beams", self.beams)
        require_nonnegative("dvl.outages.start_s", self.start_s)
        require_finite("dvl.outages.end_s", self.end_s)
        if self.end_s <= self.start_s:
            raise ConfigError(f"dvl.outages: window {self.start_s:g}:{self.end_s:g} s ends before it starts")


def _check_beams(field: str, beams: object) -> None:
    if (
        not isinstance(beams, (tuple, list)) or len(beams) > NUM_DVL_BEAMS
    ):  # length first: cheap on huge lists
        raise ConfigError(f"{field} must be a list of distinct beam numbers 1-4, got {show(beams)}")
    for b in beams:
        if not isinstance(b, int) or isinstance(b, bool) or b not in (1, 2, 3, 4):
            raise ConfigError(f"{field}: unknown beam {show(b)} (beams are 1, 2, 3, 4)")
    if len(set(beams)) != len(beams):
        raise ConfigError(f"{field} must be a list of distinct beam numbers 1-4, got {show(beams)}")


@dataclass(frozen=True)
class DvlConfig:
    """DVL error model; 1-sigma values, defaults Table 2 of Tal et al. 2017."""

    # Ranges: zero error is legal (verification, --ideal); each bound's reason is beside it.
    rate_hz: float = setting(1.0, "rate", "Hz", 0.05, 25.0, hint="pings per second")
    # [0.05, 25]: DVLs ping from every 20 s to ~25 Hz
    beam_pitch_deg: float = setting(20.0, "beam pitch", "deg", 10.0, 45.0, hint="each beam from the vertical")
    # eq. 13-14, [10, 45]: Janus heads are 20-30 deg; below 10 the horizontal velocity is barely
    # observed, above 45 beams graze
    noise_mps: float = setting(0.042, "noise", "m/s", 0.0, 1.0, hint="1-sigma white noise per beam")
    # <= 1: beyond half the AUV's 2 m/s a ping says nothing about the velocity
    bias_mps: float = setting(0.005, "bias", "m/s", 0.0, 0.5, hint="1-sigma turn-on bias per beam")
    # <= 0.5 (100x Table 2)
    bias_rw_mps_per_sqrt_s: float = setting(
        5e-5, "bias walk", "m/s/sqrt(s)", 0.0, 5e-3, hint="beam bias random walk"
    )  # <= 5e-3 (100x Table 2)
    scale_factor_pct: float = setting(
        0.7, "scale factor", "%", 0.0, 10.0, hint="1-sigma turn-on scale factor error"
    )
    # <= 10: a sound speed off by 150 m/s, more than any water mass differs from 1500 m/s
    scale_factor_offset_pct: float = setting(
        0.0, "scale factor offset", "%", -10.0, 10.0, hint="fixed scale factor error added to the drawn one"
    )
    # not in the paper: a sound speed set wrong in the DVL, the same on every run; [-10, 10] as above
    scale_factor_rw_pct_per_sqrt_s: float = setting(
        5e-3, "scale factor walk", "%/sqrt(s)", 0.0, 0.5, hint="scale factor random walk"
    )  # <= 0.5 (100x Table 2)
    lever_arm_m: tuple[float, float, float] = setting(
        (0.6, 0.0, 0.15), "lever arm", "m", bound=10.0, hint="the DVL head from the IMU, body frame"
    )  # not in the paper; each axis within +-10 m: an AUV is a few metres long
    misalignment_deg: tuple[float, float, float] = setting(
        (0.0, 0.0, 0.0),
        "misalignment",
        "deg",
        bound=10.0,
        hint="the head's true roll, pitch, yaw from its mounting",
    )  # not in the paper: C_bh of tauvcore.conventions, a sensor error the filters do not know; each
    # within +-10 deg: a head mounted further off has another beam geometry, not a misalignment
    beams: tuple[int, ...] = setting((1, 2, 3, 4), "beams", hint="beams that return (others never do)")
    # checked below: distinct numbers 1 to 4
    outages: tuple[Outage, ...] = setting((), "outages", "s", hint="scheduled losses of some beams")
    # checked below: at most MAX_OUTAGES windows
    dropout_probability: float = setting(
        0.0, "dropout", "", 0.0, 1.0, hint="chance that a beam misses a ping, each beam independently"
    )  # [0, 1] (a probability)
    max_altitude_m: float = setting(
        100.0, "bottom range", "m", 0.0, 11000.0, low_open=True, hint="bottom lock up to this altitude"
    )  # Yoo 2014 section 3.2; (0, 11000]: the deepest ocean
    beyond_range: str = setting(
        "lost", "beyond range", hint='"lost" (no return) or "noisy" (Yoo 2014 eq. 30-32)'
    )
    # checked below: one of BEYOND_RANGE
    beyond_range_noise_mps: float = setting(
        5.0, "beyond-range noise", "m/s", 0.0, 100.0, hint="extra noise of a noisy beam beyond range"
    )  # Yoo: 5 m/s; [0, 100]
    water_track: str = setting(
        "off",
        "water-track",
        hint='"off", "beyond_range" (beams without bottom lock), "always" or "both" (beside bottom-track)',
    )
    # checked below: one of WATER_TRACK; "beyond_range" only with beyond_range = "lost" (a "noisy"
    # beam beyond range returns a bottom-track velocity, so it never lacks one to replace); "both"
    # with either: its water-track does not replace bottom-track but runs beside it on every ping,
    # whatever the bottom lock, and "noisy" is a model of the bottom-track channel alone (a beam
    # beyond range then returns its noisy bottom-track velocity and its water-track one)
    water_layer_m: float = setting(
        10.0, "water layer", "m", 0.5, 11000.0, hint="from the head down to the tracked layer's centre"
    )
    # >= 0.5: nearer, the transducer still rings (a DVL's blanking distance) and the hull drags the
    # water along; below max_altitude_m (checked below): the layer's echo is weaker than the seabed's
    water_track_noise_mps: float = setting(
        0.1, "water-track noise", "m/s", 0.0, 1.0, hint="1-sigma white noise per water-tracking beam"
    )
    # 0.1, 2.4 times bottom-track's 0.042: the echo of a layer of water is scattered back by weak
    # scatterers (plankton, particles) spread through the layer, not by one strong seabed, and they
    # move with the water's turbulence within it, so a single ping's Doppler estimate is several
    # times noisier; <= 1 as noise_mps
    current_states: str = setting(
        "off",
        "current states",
        hint='"off", "gauss-markov" or "random-walk": the filters estimate the current',
    )
    # checked below: one of CURRENT_STATES; the current (north, east) as two error states the
    # water-track beams observe (tauvcore.aiding.dvl_water)
    current_sigma_mps: float = setting(
        0.5, "current sigma", "m/s", 0.0, 3.0, low_open=True, hint="1-sigma of the current, at the start"
    )
    # the Gauss-Markov process's steady 1-sigma too; (0, 3] as trajectory.current_n_mps
    current_tau_s: float = setting(
        3600.0, "current time constant", "s", 1.0, 864000.0, hint="Gauss-Markov correlation time"
    )
    # an hour: tides turn in six; [1, 864000]: a second to ten days
    current_walk_mps_per_sqrt_s: float = setting(
        1e-3, "current walk", "m/s/sqrt(s)", 0.0, 1.0, hint="random walk of the current"
    )
    # 6 cm/s in an hour; [0, 1]

    def __post_init__(self) -> None:
        check_settings("dvl", self)  # the numbers and the lever arm
        _check_beams("dvl.beams", self.beams)
        if not isinstance(self.outages, (tuple, list)) or len(self.outages) > MAX_OUTAGES:
            raise ConfigError(
                f"dvl.outages must be a list of at most {MAX_OUTAGES} windows, got {show(self.outages)}"
            )
        for outage in self.outages:
            if not isinstance(outage, Outage):
                raise ConfigError(f"dvl.outages must hold beams/start_s/end_s tables, got {show(outage)}")
        require_choice("dvl.beyond_range", self.beyond_range, BEYOND_RANGE)
        require_choice("dvl.water_track", self.water_track, WATER_TRACK)
        require_choice("dvl.current_states", self.current_states, CURRENT_STATES)
        if self.water_track == "beyond_range" and self.beyond_range == "noisy":
            raise ConfigError(
                'dvl.water_track "beyond_range" needs dvl.beyond_range "lost", got "noisy" (a noisy beam '
                "beyond range keeps returning its bottom-track velocity)"
            )
        if self.water_track != "off" and self.water_layer_m >= self.max_altitude_m:
            raise ConfigError(
                f"dvl.water_layer_m {self.water_layer_m:g} m lies beyond the DVL's range "
                f"dvl.max_altitude_m {self.max_altitude_m:g} m"
            )

    def ideal(self) -> DvlConfig:
        """The same DVL (geometry, lever arm, beams) with every error set to zero.

        Returns
        -------
        DvlConfig
            This configuration's rate [Hz], beam pitch [deg], lever arm [m], beams, outages,
            dropout probability, range and water-track settings, with zero noise, bias, bias
            walk, scale factor, scale factor offset, scale factor walk, misalignment and
            water-track noise.
        """
        return DvlConfig(
            rate_hz=self.rate_hz,
            beam_pitch_deg=self.beam_pitch_deg,
            noise_mps=0.0,
            bias_mps=0.0,
            bias_rw_mps_per_sqrt_s=0.0,
            scale_factor_pct=0.0,
            scale_factor_offset_pct=0.0,
            scale_factor_rw_pct_per_sqrt_s=0.0,
            lever_arm_m=self.lever_arm_m,
            misalignment_deg=(0.0, 0.0, 0.0),
            beams=self.beams,
            outages=self.outages,
            dropout_probability=self.dropout_probability,
            max_altitude_m=self.max_altitude_m,
            beyond_range=self.beyond_range,
            beyond_range_noise_mps=self.beyond_range_noise_mps,
            water_track=self.water_track,
            water_layer_m=self.water_layer_m,
            water_track_noise_mps=0.0,
            current_states=self.current_states,
            current_sigma_mps=self.current_sigma_mps,
            current_tau_s=self.current_tau_s,
            current_walk_mps_per_sqrt_s=self.current_walk_mps_per_sqrt_s,
        )

    @property
    def beam_pitch_rad(self) -> float:
        """Beam pitch from the body z axis (vertical of a level DVL) [rad]."""
        return self.beam_pitch_deg * units.DEG

    @property
    def max_range_m(self) -> float:
        """Longest slant range with bottom lock [m]: a level DVL's beam at ``max_altitude_m``."""
        return self.max_altitude_m / np.cos(self.beam_pitch_rad)

    @property
    def A_b(self) -> np.ndarray:
        """Beam direction matrix (4, 3), eq. 16."""
        return beam_directions_b(self.beam_pitch_rad)

    @property
    def l_dvl_b(self) -> np.ndarray:
        """Lever arm of the DVL head from the IMU, shape (3,) [m], body frame b (FRD)."""
        return np.asarray(self.lever_arm_m, dtype=float)

    @property
    def scale_factor(self) -> float:
        """1-sigma turn-on scale factor error [-] (a fraction)."""
        return self.scale_factor_pct * units.PERCENT

    @property
    def scale_factor_offset(self) -> float:
        """Fixed scale factor error added to the drawn one [-] (a fraction)."""
        return self.scale_factor_offset_pct * units.PERCENT

    @property
    def misaligned(self) -> bool:
        """Whether the head is rotated from its mounting (any of :attr:`misalignment_deg` nonzero)."""
        return any(a != 0.0 for a in self.misalignment_deg)

    @property
    def C_bh(self) -> np.ndarray:
        """The head's true rotation from b, shape (3, 3) [-]: ``v_b = C_bh @ v_h``
        (tauvcore.conventions), ZYX from :attr:`misalignment_deg`; the identity when aligned."""
        return C_nb_from_euler(np.asarray(self.misalignment_deg, dtype=float) * units.DEG)

    @property
    def true_A_b(self) -> np.ndarray:
        """The beams' true directions in b, shape (4, 3) [-]: row k-1 is ``C_bh b_k``, which is
        :attr:`A_b` itself when the head is aligned."""
        return self.A_b @ self.C_bh.T if self.misaligned else self.A_b

    @property
    def scale_factor_rw_per_sqrt_s(self) -> float:
        """Scale factor random walk density [1/sqrt(s)] (a fraction per sqrt(s))."""
        return self.scale_factor_rw_pct_per_sqrt_s * units.PERCENT

    @property
    def beam_mask(self) -> np.ndarray:
        """(4,) bool: beams enabled in the configuration."""
        return np.isin(np.arange(1, NUM_DVL_BEAMS + 1), self.beams)

    def scheduled_availability(self, t_s: np.ndarray) -> np.ndarray:
        """Beams enabled and not in an outage at the ping times ``t_s``.

        Parameters
        ----------
        t_s : numpy.ndarray
            Ping times, shape (M,) [s], on the mission's clock.

        Returns
        -------
        numpy.ndarray
            Shape (M, 4), bool: beam k-1 of ping m is in :attr:`beams` and in no outage window
            ``start_s <= t < end_s`` naming it.
        """
        available = np.broadcast_to(self.beam_mask, t_s.shape + (NUM_DVL_BEAMS,)).copy()
        for outage in self.outages:
            lost = (t_s >= outage.start_s) & (t_s < outage.end_s)
            for b in outage.beams:
                available[lost, b - 1] = False
        return available


@dataclass(frozen=True)
class DvlData:
    """DVL pings with the true error states; M pings, run axis R optional.

    A beam at a ping returns nothing, bottom-track (``available``: its velocity over ground in
    ``y_beam_mps``), water-track (``water_available``: its velocity relative to the water layer in
    ``y_water_mps``) or, with ``water_track = "both"``, both: the two arrays then hold a value for
    the same beam and ping (:attr:`mode` :data:`MODE_BOTH`); in the other modes never both.
    """

    t_s: np.ndarray  # (M,) ping times [s]
    index: np.ndarray  # (M,) IMU sample index of each ping
    y_beam_mps: np.ndarray  # (M, [R,] 4) bottom-track beam velocities (NaN where not returned) [m/s]
    available: np.ndarray  # (M, [R,] 4) bool, beam returned bottom-track
    bias_mps: np.ndarray  # (M, [R,] 4) true beam biases [m/s]
    scale_factor: np.ndarray  # (M, [R]) true scale factor error [-]
    slant_range_m: np.ndarray | None = None  # (M, 4) range from the head to the seabed along each beam, inf
    # beyond max_range_m [m]; None: no seabed given (a log, a test)
    y_water_mps: np.ndarray | None = None  # (M, [R,] 4) water-track beam velocities, relative to the
    # layer (NaN where the beam did not water-track) [m/s]; None: a DVL that does not water-track
    # (water_track "off", a log without the mode)
    water_available: np.ndarray | None = None  # (M, [R,] 4) bool, beam returned water-track (with
    # water_track "both" also where it returned bottom-track); None with y_water_mps

    @property
    def mode(self) -> np.ndarray:
        """(M, [R,] 4) int8: each beam's mode at each ping, :data:`MODE_NONE` (0),
        :data:`MODE_BOTTOM` (1), :data:`MODE_WATER` (2) or :data:`MODE_BOTH` (3, ``water_track =
        "both"``: bottom-track and water-track from the same ping), bit flags: ``available`` is
        ``mode & MODE_BOTTOM``, ``water_available`` ``mode & MODE_WATER``."""
        mode = np.where(self.available, MODE_BOTTOM, MODE_NONE).astype(np.int8)
        if self.water_available is not None:
            mode |= np.where(self.water_available, MODE_WATER, MODE_NONE).astype(np.int8)
        return mode


def beam_velocity(
    A_b: np.ndarray,
    vel_b: np.ndarray,
    omega_nb_b: np.ndarray,
    l_dvl_b: np.ndarray,
    scale_factor: np.ndarray,
    bias: np.ndarray,
    C_bh: np.ndarray | None = None,
) -> np.ndarray:
    """Eq. 15 without noise: ``(v_b (1 + SF) + omega_nb_b x l) . b_k + bias_k``; with a misaligned
    head ``(C_bh^T (v_b (1 + SF) + omega_nb_b x l)) . b_k + bias_k``.

    The inputs broadcast against each other over their leading batch shape ``(...)`` (pings, runs).

    Parameters
    ----------
    A_b : numpy.ndarray
        Beam directions, shape (4, 3) [-], body frame b (FRD) (:func:`beam_directions_b`).
    vel_b : numpy.ndarray
        Velocity relative to the earth, shape (..., 3) [m/s], body frame b (FRD).
    omega_nb_b : numpy.ndarray
        Body rate relative to the n frame, shape (..., 3) [rad/s], body frame b (FRD).
    l_dvl_b : numpy.ndarray
        Lever arm of the DVL head from the IMU, shape (3,) [m], body frame b (FRD).
    scale_factor : numpy.ndarray
        Scale factor error ``SF``, shape (...) [-] (a fraction), common to the four beams.
    bias : numpy.ndarray
        Beam biases, shape (..., 4) [m/s], along each beam.
    C_bh : numpy.ndarray or None, optional
        The head's rotation from b, shape (3, 3) [-] (:attr:`DvlConfig.C_bh`); None: the head is
        aligned (h is b, no product at all).

    Returns
    -------
    numpy.ndarray
        Beam velocities, shape (..., 4) [m/s], along beams 1-4 (beam frames s_k).
    """
    v_head = vel_b * (1.0 + scale_factor[..., None]) + np.cross(omega_nb_b, l_dvl_b)
    if C_bh is not None:  # into the head, v_h = C_bh^T v_b, term by term as the projection below
        v_head = v_head[..., 0:1] * C_bh[0] + v_head[..., 1:2] * C_bh[1] + v_head[..., 2:3] * C_bh[2]
    # the projection summed term by term, not by matmul: BLAS may round a product differently for
    # another batch shape, and a run's pings must not depend on how many runs are drawn with it
    return v_head[..., 0:1] * A_b[:, 0] + v_head[..., 1:2] * A_b[:, 1] + v_head[..., 2:3] * A_b[:, 2] + bias


@dataclass(frozen=True)
class DvlStreams:
    """The DVL's random streams (tauvcore.sensors.stream.SensorStreams' ``dvl_*``), each one
    generator or one per run (tauvcore.sensors.timing.Rng)."""

    bias: Rng  # beam biases: turn-on values and walks
    scale_factor: Rng  # scale factor: turn-on value and walk
    noise: Rng  # white noise and the extra beyond-range noise; the water-track noise's spawned from it
    dropout: Rng  # dropouts (drawn only if dropout_probability > 0)


@dataclass(frozen=True)
class DvlState:
    """What a DVL simulated chunk by chunk carries from one chunk to the next.

    The walks count the pings emitted so far.
    """

    bias: WalkState = field(default_factory=WalkState)  # beam bias walk, one step per ping
    scale_factor: WalkState = field(default_factory=WalkState)  # scale factor walk, one step per ping
    water_noise: Rng | None = None  # the water-track noise's generator(s): a child of the noise
    # stream's (one per run with per-run streams), spawned at the first chunk; None until then


def simulate(
    truth: Truth,
    config: DvlConfig,
    rng: np.random.Generator,
    num_runs: int | None = None,
    seabed: Bathymetry | None = None,
    current: CurrentField | None = None,
) -> DvlData:
    """Pings of the whole mission as one chunk, every draw from ``rng``.

    The pings are at the IMU samples nearest to ``t = m / config.rate_hz``, m = 1, 2, ...
    (:func:`~tauvcore.sensors.timing.epoch_indices`); see :func:`simulate_chunk` for the model.

    Parameters
    ----------
    truth : Truth
        The whole mission's true motion at the IMU samples (K samples).
    config : DvlConfig
        The DVL's rate [Hz], geometry, lever arm and error model (1-sigma values).
    rng : numpy.random.Generator
        Generator of every draw (bias, scale factor, noise, dropout; the water-track noise from a
        child of it).
    num_runs : int or None, optional
        Number of Monte Carlo runs R, drawn as an array axis after the pings; None: a single run
        (no run axis).
    seabed : Bathymetry or None, optional
        The mission's seabed (tauvcore.truth.seabed) the beams are traced to; None: no range limit,
        every beam in its schedule returns.
    current : CurrentField or None, optional
        The water's current (tauvcore.truth.current) the water-track layer moves with; None: still
        water.

    Returns
    -------
    DvlData
        M pings: times ``t_s`` (M,) [s], IMU sample indices ``index`` (M,), bottom-track beam
        velocities ``y_beam_mps`` (M, [R,] 4) [m/s] (NaN where not returned), ``available``
        (M, [R,] 4) bool, true beam biases ``bias_mps`` (M, [R,] 4) [m/s], scale factor error
        ``scale_factor`` (M, [R]) [-], with a seabed ``slant_range_m`` (M, 4) [m], and when the
        DVL water-tracks ``y_water_mps`` (M, [R,] 4) [m/s] and ``water_available`` (M, [R,] 4).
    """
    index = epoch_indices(truth, config.rate_hz)
    data, _ = simulate_chunk(
        truth, 0, index, config, DvlState(), DvlStreams(rng, rng, rng, rng), num_runs, seabed, current
    )
    return data


def slant_ranges_m(truth: Truth, rows: np.ndarray, config: DvlConfig, seabed: Bathymetry) -> np.ndarray:
    """Range from the DVL head along each beam to ``seabed`` at the truth's ``rows``.

    The head's horizontal position is the tangent-plane NED one, its vertical the true depth (on
    WGS-84 the plane falls below the surface with distance); the head is the IMU's position plus
    the lever arm ``C_nb l_dvl_b``, the beams ``C_nb C_bh b_k`` in the n frame (their true
    directions, :attr:`DvlConfig.true_A_b`).

    Parameters
    ----------
    truth : Truth
        True motion: ``pos_n`` (K, 3) [m] NED, depth ``depth_m`` (K,) [m] and attitude ``C_nb``
        (K, 3, 3) [-], body to NED.
    rows : numpy.ndarray
        Rows of ``truth`` at the pings, shape (M,), integer indices.
    config : DvlConfig
        The DVL: lever arm [m], beam directions, ``max_range_m`` [m].
    seabed : Bathymetry
        The mission's seabed (tauvcore.truth.seabed), depths in the n frame [m].

    Returns
    -------
    numpy.ndarray
        Slant ranges, shape (M, 4) [m], along beams 1-4; inf where a beam finds no bottom within
        ``config.max_range_m``.
    """
    C = truth.C_nb[rows]
    head = np.concatenate([truth.pos_n[rows, :2], truth.depth_m[rows, None]], axis=1)
    head = head + np.einsum("mij,j->mi", C, config.l_dvl_b)
    beams_n = np.einsum("mij,kj->mki", C, config.true_A_b)
    return seabed.slant_range_m(head[:, None, :], beams_n, config.max_range_m)


def water_layer(
    truth: Truth, rows: np.ndarray, config: DvlConfig, slant_range_m: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray]:
    """The water-track layer's depth and the beams that reach it at the truth's ``rows``.

    The layer's centre lies ``water_layer_m`` below the head (the IMU's depth plus the lever arm's
    down part, ``(C_nb l_dvl_b)_z``). Beam k, at ``cos_k = (C_nb C_bh b_k)_z`` from the vertical, meets
    it after ``water_layer_m / cos_k``; it water-tracks if it points down, that slant distance is
    within ``max_range_m`` and the seabed along the beam lies beyond it (else the beam sees the
    bottom before the layer).

    Parameters
    ----------
    truth : Truth
        True motion: depth ``depth_m`` (K,) [m] and attitude ``C_nb`` (K, 3, 3) [-], body to NED.
    rows : numpy.ndarray
        Rows of ``truth`` at the pings, shape (M,), integer indices.
    config : DvlConfig
        The DVL: lever arm [m], beam directions, ``water_layer_m`` [m], ``max_range_m`` [m].
    slant_range_m : numpy.ndarray or None
        Range to the seabed along each beam (:func:`slant_ranges_m`), shape (M, 4) [m], inf beyond
        ``max_range_m``; None: no seabed (every beam that points down far enough reaches it).

    Returns
    -------
    depth_m : numpy.ndarray
        The layer's depth, shape (M,) [m], positive down.
    reaches : numpy.ndarray
        Shape (M, 4) bool: beam k-1 reaches the layer.
    """
    C = truth.C_nb[rows]
    depth = truth.depth_m[rows] + np.einsum("mj,j->m", C[:, 2, :], config.l_dvl_b) + config.water_layer_m
    cos_down = np.einsum("mj,kj->mk", C[:, 2, :], config.true_A_b)
    down = cos_down > 0.0  # a beam level or pointing up never meets the layer
    distance = np.where(down, config.water_layer_m / np.where(down, cos_down, 1.0), np.inf)
    reaches = distance <= config.max_range_m
    if slant_range_m is not None:
        reaches &= slant_range_m > distance
    return depth, reaches


def simulate_chunk(
    truth: Truth,
    k0: int,
    index: np.ndarray,
    config: DvlConfig,
    state: DvlState,
    streams: DvlStreams,
    num_runs: int | None,
    seabed: Bathymetry | None = None,
    current: CurrentField | None = None,
) -> tuple[DvlData, DvlState]:
    """Pings at the mission's IMU samples ``index``, by eq. 15 plus noise.

    ``index`` lies within ``truth``, whose sample 0 is the mission's sample ``k0``; a beam out of
    its schedule or that drops is NaN. Bias (4 per run) and scale factor are random walks
    stepping once per ping (period ``1 / rate_hz``) from a turn-on value; the
    scale factor is that walk plus ``scale_factor_offset_pct``. A misaligned head
    (``misalignment_deg``) measures in its own frame (module docstring). Draws, in order: bias
    (turn-on value at the first chunk, then its walk), scale factor, noise, dropout (only if its
    probability is positive, so that a single generator shared with the other sensors draws the
    same numbers as without dropout). With a ``seabed``, beams beyond ``max_range_m`` are lost,
    or, ``beyond_range = "noisy"``, get the extra noise, drawn for every beam of every ping after
    the noise. Each generator may be one per run (tauvcore.sensors.timing.Rng).

    Water-track (``water_track`` not "off"): a beam water-tracks where it has no bottom lock
    (``"beyond_range"``), always (``"always"``, no beam bottom-tracks) or always beside its
    bottom-track (``"both"``: the bottom-track beams are those of ``"off"``), if it reaches the
    layer (:func:`water_layer`; one that does not sees the bottom first and returns no
    water-track). It measures its velocity relative to the layer's water::

        y_k = [(v_b - C_nb^T c_n(t, z_layer)) (1 + SF) + omega_nb_b x l_dvl_b] . b_k + b_dvl_k + w_k

    with ``c_n`` the ``current`` at the layer's depth (None: still water, and ``y_k`` less its
    noise is bottom-track's), the same scale factor and beam biases as bottom-track (the same
    transducers and the same sound speed), and white noise ``w_k`` of ``water_track_noise_mps``
    in place of ``noise_mps``. Its schedule (beams, outages) and dropout are bottom-track's. The
    water-track noise is drawn for every beam of every ping from a child of ``streams.noise``
    (spawned at the first chunk, ``Generator.spawn``, which draws nothing from its parent), so
    every other draw is the same as with water-track off, and a run's numbers do not depend on
    where a chunk ends.

    Parameters
    ----------
    truth : Truth
        True motion at the mission's samples ``k0 .. k0 + K - 1``: ``vel_b`` (K, 3) [m/s] and
        ``omega_nb_b`` (K, 3) [rad/s], body frame b (FRD), and what :func:`slant_ranges_m` reads.
    k0 : int
        The mission's index of the chunk's first sample (0 for the first chunk).
    index : numpy.ndarray
        The mission's IMU sample indices of the chunk's pings, shape (M,), integers in
        ``[k0, k0 + K)`` (:func:`~tauvcore.sensors.timing.epoch_indices_between`).
    config : DvlConfig
        The DVL's rate [Hz], geometry, lever arm and error model (1-sigma values).
    state : DvlState
        What the chunk before left (bias and scale factor walks, the water-track noise's
        generator); ``DvlState()`` for the first.
    streams : DvlStreams
        Generator(s) of the beam biases, the scale factor, the noise (the water-track noise's
        spawned from it) and the dropouts.
    num_runs : int or None
        Number of Monte Carlo runs R, an array axis after the pings; None: a single run (no run
        axis).
    seabed : Bathymetry or None, optional
        The mission's seabed (tauvcore.truth.seabed) the beams are traced to; None: no range limit.
    current : CurrentField or None, optional
        The water's current (tauvcore.truth.current); None: still water.

    Returns
    -------
    data : DvlData
        The chunk's M pings: ``t_s`` (M,) [s], ``index`` (M,), bottom-track beam velocities
        ``y_beam_mps`` (M, [R,] 4) [m/s] (NaN where not returned), ``available`` (M, [R,] 4) bool,
        true beam biases ``bias_mps`` (M, [R,] 4) [m/s], scale factor error ``scale_factor``
        (M, [R]) [-], ``slant_range_m`` (M, 4) [m] with a seabed, else None; water-track beam
        velocities ``y_water_mps`` (M, [R,] 4) [m/s] and ``water_available`` (M, [R,] 4) bool,
        None with water-track off.
    state : DvlState
        The state for the next chunk.
    """
    m = index.size
    runs = batch_shape(num_runs)
    period = 1.0 / config.rate_hz
    bias, bias_state = random_walk_chunk(
        streams.bias, state.bias, runs + (4,), config.bias_mps, config.bias_rw_mps_per_sqrt_s, period, m
    )
    sf, sf_state = random_walk_chunk(
        streams.scale_factor,
        state.scale_factor,
        runs,
        config.scale_factor,
        config.scale_factor_rw_per_sqrt_s,
        period,
        m,
    )
    if config.scale_factor_offset_pct != 0.0:  # the walk carries the drawn part; the offset is fixed
        sf = sf + config.scale_factor_offset
    C_bh = config.C_bh if config.misaligned else None
    rows = index - k0
    t_s = truth.t_s[rows]
    expand = (slice(None),) + (None,) * len(runs)
    vel_b, omega_nb_b = truth.vel_b[rows][expand], truth.omega_nb_b[rows][expand]
    y = beam_velocity(config.A_b, vel_b, omega_nb_b, config.l_dvl_b, sf, bias, C_bh)
    y = y + standard_normal(streams.noise, y.shape, 1) * config.noise_mps
    scheduled = np.broadcast_to(config.scheduled_availability(t_s)[expand], y.shape)
    available = scheduled.copy()
    ranges = None
    lock = np.ones(y.shape, dtype=bool)  # bottom lock
    if seabed is not None:
        ranges = slant_ranges_m(truth, rows, config, seabed)
        beyond = np.broadcast_to(np.isinf(ranges)[expand], y.shape)
        if config.beyond_range == "noisy":
            extra = standard_normal(streams.noise, y.shape, 1) * config.beyond_range_noise_mps
            y = np.where(beyond, y + extra, y)
        else:
            lock = ~beyond
            available &= lock
    if config.dropout_probability > 0:
        kept = uniform(streams.dropout, y.shape, 1) >= config.dropout_probability
        available &= kept
    else:
        kept = np.ones(y.shape, dtype=bool)
    y_water = water = None
    water_state = state.water_noise
    if config.water_track != "off":
        if water_state is None:
            water_state = _spawned(streams.noise)
        noise = standard_normal(water_state, y.shape, 1) * config.water_track_noise_mps
        depth, reaches = water_layer(truth, rows, config, ranges)
        water = np.broadcast_to(reaches[expand], y.shape) & scheduled & kept
        if config.water_track == "always":
            available[...] = False
        elif config.water_track == "beyond_range":
            water &= ~lock
        vel_water_b = vel_b
        if current is not None:
            c_n = current.velocity_n_mps(t_s, depth)
            vel_water_b = vel_b - np.einsum("mji,mj->mi", truth.C_nb[rows], c_n)[expand]
        y_water = beam_velocity(config.A_b, vel_water_b, omega_nb_b, config.l_dvl_b, sf, bias, C_bh) + noise
        y_water = np.where(water, y_water, np.nan)
    y = np.where(available, y, np.nan)
    return (
        DvlData(
            t_s=t_s,
            index=index,
            y_beam_mps=y,
            available=available,
            bias_mps=bias,
            scale_factor=sf,
            slant_range_m=ranges,
            y_water_mps=y_water,
            water_available=water,
        ),
        DvlState(bias=bias_state, scale_factor=sf_state, water_noise=water_state),
    )


def _spawned(rng: Rng) -> Rng:
    """A child of ``rng`` (of each generator of a per-run list): drawing from it leaves ``rng``'s
    numbers as they were."""
    if isinstance(rng, np.random.Generator):
        return rng.spawn(1)[0]
    return [g.spawn(1)[0] for g in rng]
