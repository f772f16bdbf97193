"""A USBL position fix: a ship's ultra-short-baseline transceiver fixes the vehicle's position.

The transceiver, on the surface at ``transceiver_n_m`` (NED from the origin, the sea-surface point
above the start), pings the vehicle's transponder (at ``lever_arm_b_m`` in body axes) every
``interval_s``; the fix, the transponder's position in NED, reaches the vehicle ``latency_s`` later
(the acoustic travel, the ship's processing, the acoustic or radio link down). Its error, per axis
of the transceiver's frame (taken as NED: a ship that keeps its heading compensated), is white with
a fixed term and a fraction of the slant range ``s = |p_transponder - p_transceiver|``::

    sigma_i = noise_fixed_m + noise_fraction * s          (0.1 m + 0.2 % of s by default)

A fix is lost with ``dropout_probability`` (the ray bent away, the ship's noise) and, with
``outlier_probability``, off by ``outlier_m`` in a random direction (a multipath return): the
gate must refuse those.

Measurement, at the fix's arrival ``t_a`` of the ping at ``t_p = t_a - tau``::

    z = p(t_p) + C_nb(t_p) l_b + n
    h(x) = p + C_nb l_b - tau v_n              (the state at t_a; v_n = C_nb v_b)

The latency is handled by a documented approximation rather than a delayed state: the position at
ping time is the current one gone back along the current velocity. What it leaves out is the
acceleration's ``a tau^2 / 2`` (a turn's 0.1 m/s^2 over 1 s: 5 cm, against the fix's decimetres to
metres) and the attitude's change over ``tau`` in the lever arm's term (2 deg/s for 1 s over 0.3 m:
1 cm). Ignored altogether (``compensate_latency = false``, ``tau = 0`` in h), the latency puts every
fix ``v tau`` behind the vehicle: 2 m at 2 m/s for 1 s, a bias the filter cannot tell from a
position error (docs/adding_a_sensor.md measures its cost). The error state (tauvcore.filter.layout:
position in NED, the n-frame misalignment ``C_true = exp([rho x]) C_hat``, the body velocity)::

    dh = dp - [(C l_b) x] rho + tau [v_n x] rho - tau C dv_b
    H  = [I,  -[(C l_b) x] + tau [v_n x],  -tau C,  0 ...]      (position, attitude, velocity)

R is the fix's own variance, ``diag(sigma_i^2)`` at the fix's measured slant range (what the USBL
itself knows). On WGS-84 the fix, given in the origin's tangent frame, is taken to geodetic
coordinates and the innovation is its offset from the estimate in the estimate's own NED frame
(tauvcore.geo.earth.ned_offset_m), so a fix far from the origin is not bent by the tangent plane.

Its log table ``usbl.csv``: ``t_s`` the fix's arrival, ``north_m``, ``east_m``, ``down_m`` the
transponder's position in the origin's tangent frame; an empty row is a lost fix. In a ROS bag
(tauvcore.logs.bags, ``[usbl] topic = "/usbl/fix"`` in the bag mapping) the fix is a
``geometry_msgs/PointStamped`` (``point``) or ``PoseWithCovarianceStamped`` (``pose.pose.position``)
in the topic's world frame.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from tauvcore.aiding.fusion_method import Sections
from tauvcore.aiding.source import (
    AidingSource,
    BagField,
    BagMessage,
    Column,
    SourceData,
    check_settings,
    setting,
)
from tauvcore.filter.eskf import Measurement, Nominal
from tauvcore.filter.layout import STATE
from tauvcore.geo.earth import geodetic_from_ned, ned_offset_m
from tauvcore.geo.rotations import mv, skew
from tauvcore.sensors.timing import Rng, standard_normal, uniform
from tauvcore.truth.truth_record import Truth
from tauvcore.truth.world import World
from tauvcore.validation import require_range

AXES = ("north_m", "east_m", "down_m")
"""The fix's columns: the transponder's position in the origin's tangent frame [m]."""
SIGMA_FLOOR_M = 1e-3
"""The least 1-sigma the filter assumes for a fix, per axis [m]: an ideal USBL (zero noise, legal)
keeps an invertible S, as the built-in sources' floors do (tauvcore.aiding.noise_floors)."""


@dataclass(frozen=True)
class UsblConfig:
    """A ship-mounted USBL transceiver fixing the vehicle (module docstring)."""

    interval_s: float = setting(10.0, "fix interval", "s", 0.5, 600.0, hint="time between fixes")
    # [0.5, 600]: a USBL pings at 2 Hz at most, and a fix every ten minutes is all but none
    latency_s: float = setting(1.0, "latency", "s", 0.0, 30.0, hint="ping to fix at the vehicle")
    # [0, 30]: 2 s of acoustic travel for 1.5 km of slant range, the ship's processing and the link down
    compensate_latency: bool = setting(
        True,
        "compensates its latency",
        hint="predict the position at ping time (p - latency v); off: take the fix as of its arrival",
    )  # off: what ignoring the latency costs
    noise_fixed_m: float = setting(0.1, "noise", "m", 0.0, 100.0, hint="per axis, the fixed part")
    # [0, 100]: centimetres for the best systems, 100 m is no fix
    noise_fraction: float = setting(
        0.002, "noise fraction", "", 0.0, 0.1, hint="per axis, of the slant range"
    )  # [0, 0.1]: commercial USBLs quote 0.1-1 % of slant range, 10 % is a bearing error of 6 deg
    transceiver_n_m: tuple[float, float, float] = setting(
        (0.0, 0.0, 2.0),
        "transceiver NED",
        "m",
        bound=1e5,
        hint="the ship's transceiver from the origin: north, east, down (down within [0, 50])",
    )  # north and east within +-1e5 m (a ship 100 km off is out of acoustic range), down within
    # [0, 50]: on a hull or a pole under the surface
    lever_arm_b_m: tuple[float, float, float] = setting(
        (0.0, 0.0, -0.3),
        "lever arm",
        "m",
        bound=10.0,
        hint="the transponder in body axes: forward, right, down",
    )  # each within +-10 m, the size of an AUV
    dropout_probability: float = setting(0.05, "dropout probability", "", 0.0, 1.0, hint="a fix lost")
    outlier_probability: float = setting(
        0.01, "outlier probability", "", 0.0, 1.0, hint="a fix off by the outlier offset"
    )
    outlier_m: float = setting(
        30.0, "outlier offset", "m", 0.0, 1e4, hint="an outlier's offset, in a random direction"
    )

    def __post_init__(self) -> None:
        check_settings("usbl", self)
        require_range("usbl.transceiver_n_m[2]", self.transceiver_n_m[2], 0.0, 50.0)

    def sigma_m(self, slant_range_m: np.ndarray) -> np.ndarray:
        """Per-axis 1-sigma of a fix: ``noise_fixed_m + noise_fraction * s``.

        Parameters
        ----------
        slant_range_m : numpy.ndarray
            Slant range ``s`` from the transceiver to the transponder [m], any shape.

        Returns
        -------
        numpy.ndarray
            The 1-sigma of each NED axis of the fix [m], the shape of ``slant_range_m``.
        """
        return self.noise_fixed_m + self.noise_fraction * np.asarray(slant_range_m, dtype=float)


@dataclass(frozen=True)
class UsblSetup:
    """One epoch's fixes made ready for the batch (:meth:`UsblFix.prepare`)."""

    z: np.ndarray  # (B, 3) the fix, transponder NED from the origin [m] (zero where invalid)
    valid: np.ndarray  # (B,) a fix in this epoch
    R: np.ndarray  # (B, 3, 3) [m^2]
    tau_s: float  # the latency the prediction goes back by [s]


@dataclass(frozen=True)
class UsblFix:
    """The fix as a measurement of the state at its arrival (module docstring), small and pure."""

    config: UsblConfig
    geodetic: bool  # the nominal position is latitude, longitude, depth (WGS-84), else NED [m]
    origin: tuple[float, float, float]  # latitude, longitude [rad], height [m] of the tangent frame

    name = "usbl"

    def prepare(self, z_n_m: np.ndarray, batch: tuple[int, ...]) -> UsblSetup:
        """The fixes of one epoch made ready for the batch, with their variance.

        Parameters
        ----------
        z_n_m : numpy.ndarray
            The epoch's fixes, the transponder's position in the origin's tangent frame, shape
            (R, 3) [m] NED (any shape that broadcasts to ``batch + (3,)``); NaN: a lost fix.
        batch : tuple[int, ...]
            The batch shape B, (M, R): methods x runs.

        Returns
        -------
        UsblSetup
            ``z`` ``batch + (3,)`` [m] NED, zero where lost; ``valid`` ``batch`` bool; ``R``
            ``batch + (3, 3)`` [m^2], ``diag(sigma_i^2)`` at the fix's measured slant range, each
            sigma at least :data:`SIGMA_FLOOR_M`; ``tau_s`` the latency [s] (0 when
            ``compensate_latency`` is off).
        """
        z = np.broadcast_to(np.asarray(z_n_m, dtype=float), batch + (3,))
        valid = np.asarray(np.isfinite(z).all(axis=-1))
        z = np.where(valid[..., None], z, 0.0)
        slant = np.linalg.norm(z - np.asarray(self.config.transceiver_n_m), axis=-1)
        sigma = self.config.sigma_m(slant)
        R = np.zeros(batch + (3, 3))
        R[..., [0, 1, 2], [0, 1, 2]] = np.maximum(sigma, SIGMA_FLOOR_M)[..., None] ** 2
        tau = self.config.latency_s if self.config.compensate_latency else 0.0
        return UsblSetup(z=np.ascontiguousarray(z), valid=valid, R=R, tau_s=tau)

    def offset_n_m(self, nom: Nominal, setup: UsblSetup) -> np.ndarray:
        """What the prediction adds to the estimated position: ``C l_b - tau v_n``.

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B ((M, R) in the bank): ``pos_n`` (B, 3) [m] NED from
            the origin, ``vel_n`` (B, 3) [m/s] NED, ``C_nb`` (B, 3, 3) body FRD to NED.
        setup : UsblSetup
            The epoch's fixes (:meth:`prepare`), for the same batch.

        Returns
        -------
        numpy.ndarray
            The lever arm in NED less the latency's travel, shape (B, 3) [m], NED.
        """
        return mv(nom.nav.C_nb, np.asarray(self.config.lever_arm_b_m)) - setup.tau_s * nom.nav.vel_n

    def predict(self, nom: Nominal, setup: UsblSetup) -> np.ndarray:
        """h(x) on the flat earth: the transponder at ping time.

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B ((M, R) in the bank): ``pos_n`` (B, 3) [m] NED from
            the origin, ``vel_n`` (B, 3) [m/s] NED, ``C_nb`` (B, 3, 3) body FRD to NED.
        setup : UsblSetup
            The epoch's fixes (:meth:`prepare`), for the same batch.

        Returns
        -------
        numpy.ndarray
            The predicted fix ``p + C l_b - tau v_n``, shape (B, 3) [m], NED from the origin.
        """
        return nom.nav.pos_n + self.offset_n_m(nom, setup)

    def jacobian(self, nom: Nominal, setup: UsblSetup) -> np.ndarray:
        """H (module docstring): ``[I, -[(C l_b) x] + tau [v_n x], -tau C, 0 ...]``.

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B ((M, R) in the bank): ``pos_n`` (B, 3) [m] NED from
            the origin, ``vel_n`` (B, 3) [m/s] NED, ``C_nb`` (B, 3, 3) body FRD to NED.
        setup : UsblSetup
            The epoch's fixes (:meth:`prepare`), for the same batch.

        Returns
        -------
        numpy.ndarray
            The Jacobian of h by the 20-state error, shape (B, 3, 20): rows NED [m]; position
            columns [-], attitude (n-frame rho) [m/rad], body velocity [s]; zero elsewhere.
        """
        batch = nom.nav.pos_n.shape[:-1]
        H = np.zeros(batch + (3, STATE.dim))
        H[..., STATE.pos] = np.eye(3)
        lever_n = mv(nom.nav.C_nb, np.asarray(self.config.lever_arm_b_m))
        H[..., STATE.att] = -skew(lever_n) + setup.tau_s * skew(nom.nav.vel_n)
        H[..., STATE.vel] = -setup.tau_s * nom.nav.C_nb
        return H

    def innovation(self, nom: Nominal, setup: UsblSetup) -> np.ndarray:
        """``z (-) h(x)``, in the estimate's NED frame (module docstring).

        On the flat earth ``z - h(x)``; on WGS-84 the fix is taken to geodetic coordinates and its
        offset from the estimate is taken in the estimate's own NED frame
        (:func:`tauvcore.geo.earth.ned_offset_m`), less :meth:`offset_n_m`.

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B ((M, R) in the bank): ``pos_n`` (B, 3) [m] NED from
            the origin (on WGS-84: latitude, longitude [rad], depth [m]), ``vel_n`` (B, 3) [m/s]
            NED, ``C_nb`` (B, 3, 3) body FRD to NED.
        setup : UsblSetup
            The epoch's fixes (:meth:`prepare`), for the same batch.

        Returns
        -------
        numpy.ndarray
            The innovation, shape (B, 3) [m], NED at the estimate.
        """
        if not self.geodetic:
            return setup.z - self.predict(nom, setup)
        lat, lon, h = geodetic_from_ned(setup.z, self.origin)
        pos = nom.nav.pos_n
        offset = ned_offset_m(lat, lon, h, pos[..., 0], pos[..., 1], -pos[..., 2])
        return offset - self.offset_n_m(nom, setup)

    def measure(self, nom: Nominal, data: SourceData, j: int) -> Measurement:
        """The fix of epoch ``j`` as a measurement of the whole batch (:meth:`prepare`,
        :meth:`innovation`, :meth:`jacobian`).

        Parameters
        ----------
        nom : Nominal
            The nominal state of the batch B ((M, R) in the bank): ``pos_n`` (B, 3) [m] NED from
            the origin (on WGS-84: latitude, longitude [rad], depth [m]), ``vel_n`` (B, 3) [m/s]
            NED, ``C_nb`` (B, 3, 3) body FRD to NED.
        data : SourceData
            The USBL's epochs within the chunk: columns ``north_m``, ``east_m``, ``down_m``, each
            (E, R) [m] in the origin's tangent frame (NED), NaN for a lost fix.
        j : int
            The epoch within ``data`` (0 <= j < E).

        Returns
        -------
        Measurement
            ``z`` (B, 3) [m] NED (zero where lost), ``innovation`` (B, 3) [m] NED (zero where
            lost), ``H`` (B, 3, 20), ``R`` (B, 3, 3) [m^2] and ``valid`` (B,) bool.
        """
        batch = nom.nav.pos_n.shape[:-1]
        setup = self.prepare(data.row(AXES, j), batch)
        nu = np.where(setup.valid[..., None], self.innovation(nom, setup), 0.0)
        return Measurement(
            z=setup.z,
            innovation=np.ascontiguousarray(nu),
            H=np.ascontiguousarray(self.jacobian(nom, setup)),
            R=setup.R,
            valid=setup.valid,
        )


@dataclass(frozen=True)
class _Pending:
    """Fixes pinged but not yet arrived at the end of a chunk."""

    data: SourceData | None = None


class Usbl(AidingSource):
    """The USBL as a plug-in source: configuration, simulation, log table and model (module
    docstring)."""

    name = "usbl"
    label = "USBL"
    summary = "a ship's USBL fixing the vehicle's position (slant-range noise, latency, dropouts, outliers)"
    config_type = UsblConfig
    streams = ("noise", "dropout", "outlier", "outlier_direction")  # each drawn alone, so that the
    # numbers do not depend on how the mission is cut into chunks
    columns = tuple(
        Column(axis, "m", -1e7, 1e7, "farther from the origin than the earth is wide", allow_nan=True)
        for axis in AXES
    )
    row_labels = ("north", "east", "down")
    observes = (
        "pos",
        "att",
        "vel",
    )  # the lever arm turns with the attitude; the latency term moves with the velocity
    bag_messages = (
        BagMessage("geometry_msgs/msg/PointStamped", (BagField(AXES, "point"),)),
        BagMessage("geometry_msgs/msg/PoseWithCovarianceStamped", (BagField(AXES, "pose.pose.position"),)),
    )  # the fix's position (the table has no sigma columns: R is the configured noise law's)

    def rate_hz(self, section: UsblConfig) -> float:
        """The ping rate, one ping per ``interval_s``.

        Parameters
        ----------
        section : UsblConfig
            The ``[usbl]`` section.

        Returns
        -------
        float
            Pings per second, ``1 / interval_s`` [Hz].
        """
        return 1.0 / section.interval_s

    def ideal(self, section: UsblConfig) -> UsblConfig:
        """The same USBL with every error zeroed (``run.ideal``).

        Parameters
        ----------
        section : UsblConfig
            The ``[usbl]`` section.

        Returns
        -------
        UsblConfig
            Its noise (fixed [m] and fraction [-]), dropout and outlier probabilities zero; its
            interval [s], latency [s], transceiver [m] NED and lever arm [m] body FRD kept.
        """
        return dataclasses.replace(
            section, noise_fixed_m=0.0, noise_fraction=0.0, dropout_probability=0.0, outlier_probability=0.0
        )

    def initial_state(self, section: UsblConfig, num_runs: int, world: World) -> _Pending:
        """No fix pending before the first chunk.

        Parameters
        ----------
        section : UsblConfig
            The ``[usbl]`` section.
        num_runs : int
            Number of Monte Carlo runs R.
        world : World
            What the vehicle flies through (unused: a fix does not depend on the seabed).

        Returns
        -------
        _Pending
            The fixes pinged but not yet arrived: none.
        """
        return _Pending()

    def simulate_chunk(
        self,
        truth: Truth,
        k0: int,
        epochs: np.ndarray,
        section: UsblConfig,
        state: _Pending,
        rngs: Mapping[str, Rng],
        num_runs: int,
        num_samples: int,
    ) -> tuple[SourceData, _Pending]:
        """The fixes of the pings at ``epochs`` (transponder at ping time, with its errors), due
        ``latency_s`` later; those due within this chunk are returned, the later ones carried.

        The latency is rounded to whole IMU samples; a fix due after the mission's last sample is
        dropped.

        Parameters
        ----------
        truth : Truth
            The chunk's true motion, K samples at the IMU rate (``pos_n`` (K, 3) [m] NED, ``C_nb``
            (K, 3, 3) body FRD to NED); its row k is the mission's sample ``k0 + k``.
        k0 : int
            The mission's IMU sample index of the chunk's first row.
        epochs : numpy.ndarray
            The mission's IMU sample indices of the pings within the chunk, shape (E,) int.
        section : UsblConfig
            The ``[usbl]`` section (zero-noise when the run is ideal: :meth:`ideal`).
        state : _Pending
            The fixes pinged in earlier chunks and not yet arrived.
        rngs : Mapping[str, Rng]
            A generator (or one per run) for each of ``noise``, ``dropout``, ``outlier`` and
            ``outlier_direction``.
        num_runs : int
            Number of Monte Carlo runs R.
        num_samples : int
            The mission's length [IMU samples].

        Returns
        -------
        tuple[SourceData, _Pending]
            The fixes arriving within the chunk (``t_s`` (E',) [s] the mission's time of the arrival
            sample, ``index`` (E',) int, columns ``north_m``, ``east_m``, ``down_m`` (E', R) [m] in
            the origin's tangent frame, NED, NaN where lost) and the fixes carried to later chunks.
        """
        E, R = epochs.size, num_runs
        rows = epochs - k0
        lever_n = mv(truth.C_nb[rows], np.asarray(section.lever_arm_b_m))
        true_n = truth.pos_n[rows] + lever_n  # (E, 3)
        slant = np.linalg.norm(true_n - np.asarray(section.transceiver_n_m), axis=-1)
        sigma = section.sigma_m(slant)[:, None, None]
        fix = true_n[:, None, :] + sigma * standard_normal(rngs["noise"], (E, R, 3), 1)
        lost = uniform(rngs["dropout"], (E, R), 1) < section.dropout_probability
        outlier = uniform(rngs["outlier"], (E, R), 1) < section.outlier_probability
        direction = standard_normal(rngs["outlier_direction"], (E, R, 3), 1)
        direction /= np.maximum(np.linalg.norm(direction, axis=-1, keepdims=True), 1e-12)
        fix = np.where(outlier[..., None], fix + section.outlier_m * direction, fix)
        fix[lost] = np.nan
        lag = round(section.latency_s / truth.dt_s)
        arrival = epochs + lag
        due = arrival < num_samples
        new = SourceData(
            t_s=truth.t_s[rows][due] + lag * truth.dt_s,
            index=arrival[due].astype(np.int64),
            values={axis: fix[due, :, i] for i, axis in enumerate(AXES)},
        )
        pending = new if state.data is None else SourceData.concatenate([state.data, new])
        k1 = k0 + truth.num_samples
        now = pending.index < k1
        take = SourceData(  # at the mission's own clock of its arrival sample
            t_s=truth.t_s[pending.index[now] - k0],
            index=pending.index[now],
            values={k: v[now] for k, v in pending.values.items()},
        )
        later = SourceData(
            t_s=pending.t_s[~now],
            index=pending.index[~now],
            values={k: v[~now] for k, v in pending.values.items()},
        )
        return take, _Pending(later)

    def model(self, section: UsblConfig, config: Sections) -> UsblFix:
        """The fix's measurement model.

        Parameters
        ----------
        section : UsblConfig
            The ``[usbl]`` section.
        config : Sections
            The run's configuration: its ``[earth]`` section says whether the nominal position is
            geodetic (WGS-84) and gives the origin's latitude and longitude [rad].

        Returns
        -------
        UsblFix
            The model, with the origin (latitude, longitude [rad], height 0 m) of the tangent frame.
        """
        earth: Any = config.section("earth")
        return UsblFix(
            config=section,
            geodetic=bool(earth.geodetic),
            origin=(float(earth.latitude_rad), float(earth.longitude_rad), 0.0),
        )


SOURCE = Usbl()
"""The registry's entry (tauvcore.aiding.sources.MODULES names this module)."""
