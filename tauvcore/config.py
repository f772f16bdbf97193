"""The full run configuration: one frozen dataclass per section, TOML in and out.

A TOML file may hold any subset of sections and keys (the rest keeps its default); an unknown
section or key, a wrong type or a bad value raises :class:`~tauvcore.validation.ConfigError`
naming ``section.key`` and the value.
"""

from __future__ import annotations

import dataclasses
import errno
import math
import os
import stat
import tomllib
from dataclasses import dataclass, field
from typing import Any

import tomli_w

from tauvcore import units
from tauvcore.aiding import AIDING_SOURCES, elc_nsv
from tauvcore.aiding.registry import REGISTRY
from tauvcore.aiding.source import AidingSource
from tauvcore.aiding.sources import SOURCES
from tauvcore.filter.families import FAMILIES
from tauvcore.filter.reference import ReferenceConfig
from tauvcore.filter.vkf import VkfConfig
from tauvcore.geo.earth import Earth
from tauvcore.sensors.dvl import MAX_OUTAGES, DvlConfig, Outage
from tauvcore.sensors.echosounder import EchoSounderConfig
from tauvcore.sensors.imu import ImuConfig
from tauvcore.sensors.magnetometer import MagnetometerConfig
from tauvcore.sensors.pressure import PressureConfig
from tauvcore.sensors.rpm import RpmConfig
from tauvcore.truth.kinematic import TrajectoryConfig
from tauvcore.validation import (
    ConfigError,
    one_line,
    require_choice,
    require_choices,
    require_range,
    require_vector3,
    shorten,
    show,
    show_path,
)

METHODS = tuple(m for family in FAMILIES.values() if family.in_all for m in family.methods)
"""The methods ``--method all`` runs: the first paper's (tauvcore.filter.families.eskf: ``ins``,
``lc``, ``tc``, the extended ``vb``, ``nsv``, ``plcf``, ``vhv``, ``elc``, and ``iekf``)."""

YOO_METHODS = FAMILIES["yoo"].methods
"""Yoo 2014's 12-state filter (tauvcore.filter.families.yoo): ``ins-dvl`` aided by the DVL's
velocity, ``vkf`` by the velocity Kalman filter's switch of DVL and RPM (eq. 29). Named, not in "all"."""
ALL_METHODS = tuple(m for family in FAMILIES.values() for m in family.methods)
"""Every family's methods (tauvcore.filter.families), in the registry's order."""
REGISTERED_METHODS = tuple(REGISTRY)
"""Methods added as one file each (tauvcore.aiding.registry; ``cv``: constant body velocity, no
DVL). ``run.methods`` (a TOML file, the library), the CLI's ``--method`` and the dashboard take
them like the papers' methods."""
RUN_METHODS = ALL_METHODS + REGISTERED_METHODS
"""Every method ``run.methods`` may hold: what the CLI's --method and the dashboard offer (app/
gives each a colour: app.figures.shared.METHOD_COLORS)."""

DEFAULT_METHODS = ("ins", "lc")
"""Methods run when none are named: the standalone INS and loosely coupled DVL (--help)."""
AUTO = "auto"
"""A parameter derived from the rest of the configuration (``partial.nsv_epsilon_m2_per_s2``)."""

MAX_CONFIG_BYTES = 1 << 20
"""Largest configuration file read [bytes]: the full configuration is ~2 kB; 1 MiB leaves room
for long outage schedules and refuses /dev/zero-like inputs before a byte is read."""

MAX_SEED = 2**63 - 1
"""Largest seed: TOML integers are signed 64-bit, so every seed `tauv config` prints reads back."""


@dataclass(frozen=True)
class InitialErrorConfig:
    """Initial navigation errors (estimate minus truth), Table 2 of Tal et al. 2017.

    ``mode = "fixed"`` applies the values as given (a deterministic single run);
    ``"random"`` draws each as a 1-sigma Gaussian per Monte Carlo run.
    """

    pos_m: tuple[float, float, float] = (2.0, 2.0, 2.0)  # north, east, down [m]; each within +-1000 m: a
    # surface fix is good to metres, 1 km is a lost start
    vel_mps: tuple[float, float, float] = (
        0.05,
        0.05,
        0.05,
    )  # surge, sway, heave (u, v, w) [m/s]; each within
    # +-10 m/s, the speed bound of trajectory.speed_mps
    roll_pitch_deg: float = 0.57  # [deg]; [-10, 10]: the small-angle error model
    yaw_deg: float = 1.14  # [deg]; [-30, 30]: the small-angle error model
    mode: str = "fixed"  # "fixed" or "random"

    def __post_init__(self) -> None:
        require_vector3("initial_error.pos_m", self.pos_m, bound=1000.0)
        require_vector3("initial_error.vel_mps", self.vel_mps, bound=10.0)
        require_range("initial_error.roll_pitch_deg", self.roll_pitch_deg, -10.0, 10.0)
        require_range("initial_error.yaw_deg", self.yaw_deg, -30.0, 30.0)
        require_choice("initial_error.mode", self.mode, ("fixed", "random"))

    def ideal(self) -> InitialErrorConfig:
        """The same section with every initial error zero (``run.ideal``).

        Returns
        -------
        InitialErrorConfig
            Position [m] (NED), body velocity [m/s] and attitude errors [deg] zero; ``mode`` kept.
        """
        return InitialErrorConfig(
            pos_m=(0.0, 0.0, 0.0), vel_mps=(0.0, 0.0, 0.0), roll_pitch_deg=0.0, yaw_deg=0.0, mode=self.mode
        )

    @property
    def euler_rad(self) -> tuple[float, float, float]:
        """The attitude errors roll, pitch, yaw [rad] (roll and pitch both ``roll_pitch_deg``)."""
        return (self.roll_pitch_deg * units.DEG, self.roll_pitch_deg * units.DEG, self.yaw_deg * units.DEG)


@dataclass(frozen=True)
class FilterConfig:
    """Filter settings that are not sensor models (those are the sensor sections, used as tuning)."""

    gate_sigma: float = 3.0  # innovation gate [standard deviations], section 2.1.1; [1, 1000]: below 1
    # the gate rejects most good pings, 1000 is no gate at all
    output_rate_hz: float = 10.0  # rate of the per-epoch error records [Hz]; [0.1, imu.rate_hz]: at least one
    # record every 10 s, at most one per IMU sample
    covariance_rate_hz: float = (
        10.0  # covariance propagation rate (the nominal state runs at the IMU rate) [Hz];
    )
    # [1, imu.rate_hz]: below 1 Hz Phi = I + F dt misses the turns
    lockout_reset_updates: int = 10  # at this many consecutive DVL pings the gate rejected (10 s at
    # 1 Hz) the filter resets its velocity to the last of them (tauvcore.engine.lockout); 0: never;
    # [0, 1000]: the divergence monitor calls 10 a lock-out (1e-21 for a consistent filter)
    scale_factor_velocity_tau_s: float = 300.0  # the DVL scale factor's column of H is evaluated at
    # the filter's body velocity averaged with this time constant [s] (tauvcore.engine.scale_factor);
    # 0: at the current estimate (the plain EKF, whose scale factor drifts on long straight legs);
    # [0, 86400]

    def __post_init__(self) -> None:
        require_range("filter.gate_sigma", self.gate_sigma, 1.0, 1000.0)
        require_range("filter.scale_factor_velocity_tau_s", self.scale_factor_velocity_tau_s, 0.0, 86400.0)
        if (
            isinstance(self.lockout_reset_updates, bool)
            or not isinstance(self.lockout_reset_updates, int)
            or not 0 <= self.lockout_reset_updates <= 1000
        ):
            raise ConfigError(
                f"filter.lockout_reset_updates must be a whole number within [0, 1000], "
                f"got {show(self.lockout_reset_updates)}"
            )
        require_range("filter.output_rate_hz", self.output_rate_hz, 0.1, 2000.0)
        require_range("filter.covariance_rate_hz", self.covariance_rate_hz, 1.0, 2000.0)


@dataclass(frozen=True)
class PartialConfig:
    """Parameters of the extended loosely coupled methods (section 3); the paper gives no values."""

    vb_nf: float = 20.0  # n_f of eq. 28: inflation of the virtual beam's prediction sigma;
    # [1, 100]: an inflation, and beyond 100 the beam carries nothing.
    # 20 from benchmarks/vb_nf_sweep.py: VB consistent on all three
    # trajectories (NEES/dim 0.99-1.05, 89-100 % of epochs in the 99 %
    # band); at 2 it fused its own prediction as news (NEES/dim to 5000)
    nsv_epsilon_m2_per_s2: float | str = AUTO  # epsilon of eq. 36: variance of the "sway = 0" assumption
    # [m^2/s^2]; "auto" derives it from the vehicle's sideslip in its
    # tightest turn (tauvcore.aiding.elc_nsv.epsilon_from_vehicle; 0.26
    # for the defaults, benchmarks/nsv_epsilon_sweep.py); or a number in
    # (0, 100]: a variance; beyond 10 m/s of sway it says nothing
    sensor_columns: bool = True  # the two-beam velocity's rows carry the columns of the beam biases
    # and scale factor its compensated beams were corrected with (tauvcore.filter.kernels.dvl_kernels); false:
    # the paper's H = [0 0 I 0 0 0 0] (eq. 24), which takes those slowly varying errors for white
    # noise and is over-confident in position within the hour

    def __post_init__(self) -> None:
        require_range("partial.vb_nf", self.vb_nf, 1.0, 100.0)
        if not isinstance(self.sensor_columns, bool):
            raise ConfigError(
                f"partial.sensor_columns must be true or false, got {show(self.sensor_columns)}"
            )
        if isinstance(self.nsv_epsilon_m2_per_s2, str):
            if self.nsv_epsilon_m2_per_s2 != AUTO:
                raise ConfigError(
                    f'partial.nsv_epsilon_m2_per_s2 must be a number in (0, 100] or "{AUTO}", '
                    f"got {show(self.nsv_epsilon_m2_per_s2)}"
                )
        else:
            require_range(
                "partial.nsv_epsilon_m2_per_s2", self.nsv_epsilon_m2_per_s2, 0.0, 100.0, low_open=True
            )


@dataclass(frozen=True)
class RunConfig:
    """What a run does: its methods, aiding sources, seed and the ideal switch."""

    methods: tuple[str, ...] = DEFAULT_METHODS  # fusion methods to run side by side, each at most once
    aiding: tuple[str, ...] = ("dvl",)  # aiding sources on (section 4: DVL alone), each at most once
    seed: int = 0  # seed of the numpy Generator, [0, MAX_SEED]
    ideal: bool = False  # zero every sensor and initial error in the simulation
    rpm_fallback: bool = False  # the first paper's DVL methods fuse the velocity Kalman filter's
    # RPM velocity when they have no DVL velocity (neither paper does)

    def __post_init__(self) -> None:
        require_choices("run.methods", self.methods, RUN_METHODS)
        require_choices("run.aiding", self.aiding, AIDING_SOURCES, allow_empty=True)
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or not 0 <= self.seed <= MAX_SEED:
            raise ConfigError(f"run.seed must be an integer within [0, 2**63 - 1], got {show(self.seed)}")
        if not isinstance(self.ideal, bool):
            raise ConfigError(f"run.ideal must be true or false, got {show(self.ideal)}")
        if not isinstance(self.rpm_fallback, bool):
            raise ConfigError(f"run.rpm_fallback must be true or false, got {show(self.rpm_fallback)}")


@dataclass(frozen=True)
class ReplayConfig:
    """How a recorded log is replayed (tauvcore.eval.replay); a simulation ignores it."""

    initial_errors: bool = (
        False  # true: the filters start off the log's reference by the initial errors, as a
    )
    # simulation's do (``initial_error``: its values as given when mode = "fixed", drawn from the
    # seed with them as 1-sigma when "random"); false: they start on the reference's first row,
    # ``initial_error``'s values serving as P0's sigmas only

    def __post_init__(self) -> None:
        if not isinstance(self.initial_errors, bool):
            raise ConfigError(f"replay.initial_errors must be true or false, got {show(self.initial_errors)}")


CALIBRATION_BOUND_DEG = 30.0
"""Largest calibration angle [deg]: a correction, not a mounting (``tauv calibrate`` says so)."""


@dataclass(frozen=True)
class CalibrationConfig:
    """Corrections a replay applies to a log's measurements before the filters see them
    (tauvcore.eval.corrections; estimated by ``tauv calibrate``, tauvcore.eval.calibration); zero:
    none. A simulation ignores it (its DVL's true mounting is ``dvl.misalignment_deg``)."""

    dvl_misalignment_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the DVL head's roll, pitch, yaw
    # from the IMU's body, ``C_bh`` of tauvcore.conventions: a logged head velocity v_h is the body's
    # ``C_bh v_h / (1 + s)``; each within +-CALIBRATION_BOUND_DEG
    dvl_scale_factor_pct: float = 0.0  # the DVL's scale factor error s [%]: it measures (1 + s) times the
    # true velocity; [-10, 10] as dvl.scale_factor_pct
    imu_boresight_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)  # the IMU's body from the reference's
    # body, ``C_rb`` of tauvcore.conventions: the IMU's attitude is ``C_nr C_rb``; as above

    def __post_init__(self) -> None:
        require_vector3(
            "calibration.dvl_misalignment_deg", self.dvl_misalignment_deg, bound=CALIBRATION_BOUND_DEG
        )
        require_range("calibration.dvl_scale_factor_pct", self.dvl_scale_factor_pct, -10.0, 10.0)
        require_vector3("calibration.imu_boresight_deg", self.imu_boresight_deg, bound=CALIBRATION_BOUND_DEG)

    @property
    def dvl_corrected(self) -> bool:
        """Whether the DVL's velocities are corrected (a misalignment or scale factor nonzero)."""
        return self.dvl_scale_factor_pct != 0.0 or any(a != 0.0 for a in self.dvl_misalignment_deg)

    @property
    def reference_corrected(self) -> bool:
        """Whether the reference's attitude is turned to the IMU's body (a boresight angle nonzero)."""
        return any(a != 0.0 for a in self.imu_boresight_deg)


@dataclass(frozen=True)
class Config:
    """The full run configuration: one section per field, each a frozen dataclass (module
    docstring); the cross-section checks (every rate within the IMU's, outages within the run)."""

    trajectory: TrajectoryConfig = field(default_factory=TrajectoryConfig)
    earth: Earth = field(default_factory=Earth)
    imu: ImuConfig = field(default_factory=ImuConfig)
    dvl: DvlConfig = field(default_factory=DvlConfig)
    pressure: PressureConfig = field(default_factory=PressureConfig)
    magnetometer: MagnetometerConfig = field(default_factory=MagnetometerConfig)
    echo_sounder: EchoSounderConfig = field(default_factory=EchoSounderConfig)
    rpm: RpmConfig = field(default_factory=RpmConfig)
    vkf: VkfConfig = field(default_factory=VkfConfig)
    initial_error: InitialErrorConfig = field(default_factory=InitialErrorConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    partial: PartialConfig = field(default_factory=PartialConfig)
    run: RunConfig = field(default_factory=RunConfig)
    replay: ReplayConfig = field(default_factory=ReplayConfig)
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    calibration: CalibrationConfig = field(default_factory=CalibrationConfig)
    sources: tuple[tuple[str, Any], ...] = field(
        default_factory=lambda: tuple((name, SOURCE_SECTIONS[name].config_type()) for name in SOURCE_SECTIONS)
    )  # the sections of the sources of tauvcore.aiding.sources whose section is not one of the
    # above (the USBL's), each by its section name; in TOML each its own [<section_name>] section, in
    # the library config.section(name) and config.replace(name, ...)

    def __post_init__(self) -> None:
        imu_rate = self.imu.rate_hz
        rates = []
        for source in SOURCES.values():  # every source's rate (a plug-in's may derive from its fields)
            section = self.section(source.section_name)
            rate = source.rate_hz(section)
            rates.append(
                (f"{source.section_name}.rate_hz", rate)
                if getattr(section, "rate_hz", None) == rate
                else (f"{source.section_name} (its rate)", rate)
            )
        for name, rate in (
            *rates,
            ("filter.output_rate_hz", self.filter.output_rate_hz),
            ("filter.covariance_rate_hz", self.filter.covariance_rate_hz),
        ):
            if rate > imu_rate:  # every epoch falls on an IMU sample; a faster one would repeat samples
                raise ConfigError(f"{name} must not exceed imu.rate_hz ({imu_rate:g} Hz), got {show(rate)}")
        duration = self.trajectory.duration_s
        for o in self.dvl.outages:
            if o.start_s >= duration or o.end_s > duration:
                raise ConfigError(
                    f"dvl.outages: window {o.start_s:g}:{o.end_s:g} s lies outside the run "
                    f"(0 to {duration:g} s)"
                )

    def nsv_epsilon_value_m2_per_s2(self) -> float:
        """NSV's epsilon: the configured number, or for "auto" the one derived from the vehicle.

        "auto" derives it from the vehicle's sideslip in its tightest turn
        (:func:`tauvcore.aiding.elc_nsv.epsilon_from_vehicle`: speed [m/s], turn sideslip [deg],
        turn radius [m] of ``trajectory`` and the DVL's rate [Hz]).

        Returns
        -------
        float
            Epsilon of eq. 36, the variance of the "sway = 0" assumption [m^2/s^2].
        """
        eps = self.partial.nsv_epsilon_m2_per_s2
        if not isinstance(eps, str):
            return float(eps)
        tr = self.trajectory
        return elc_nsv.epsilon_from_vehicle(
            tr.speed_mps, tr.turn_sideslip_deg, tr.turn_radius_m, self.dvl.rate_hz
        )

    def section(self, name: str) -> Any:
        """Section ``name``: how a plug-in reads the configuration without importing this module.

        The plug-in sees the configuration as :class:`tauvcore.aiding.fusion_method.Sections`.

        Parameters
        ----------
        name : str
            A section's TOML name: ``"trajectory"``, ``"dvl"``, ... (:data:`SECTION_NAMES`), or a
            plug-in source's section name (``"usbl"``).

        Returns
        -------
        Any
            The section's frozen dataclass (e.g. :class:`~tauvcore.sensors.dvl.DvlConfig`), its
            fields in the units their names say.

        Raises
        ------
        KeyError
            No configuration section ``name``.
        """
        plugins = dict(self.sources)
        if name in plugins:
            return plugins[name]
        if name not in SECTION_NAMES:
            raise KeyError(f"no configuration section {name!r}")
        return getattr(self, name)

    def replace(self, section: str, **changes: Any) -> Config:
        """A copy with ``changes`` applied to one section (validated).

        Parameters
        ----------
        section : str
            The section's TOML name (built-in or a plug-in source's, as :meth:`section` takes).
        **changes : Any
            New field values by field name, in the units the names say (e.g. ``duration_s=600.0``
            [s]).

        Returns
        -------
        Config
            The configuration with that section replaced, checked on its own and as a whole.

        Raises
        ------
        KeyError
            No configuration section ``section``.
        ConfigError
            A changed value out of its range, or a cross-section check failing (a rate above the
            IMU's, an outage outside the run).
        """
        new = dataclasses.replace(self.section(section), **changes)
        if section in SOURCE_SECTIONS:
            return dataclasses.replace(
                self, sources=tuple((n, new if n == section else s) for n, s in self.sources)
            )
        return dataclasses.replace(self, **{section: new})

    def sections(self) -> dict[str, Any]:
        """Every section by its TOML name, the plug-in sources' after the others.

        Returns
        -------
        dict[str, Any]
            Section name -> its frozen dataclass: :data:`SECTION_NAMES` in order, then the
            plug-in sources' sections (:attr:`sources`).
        """
        return {**{name: getattr(self, name) for name in SECTION_NAMES}, **dict(self.sources)}


SECTION_NAMES: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(Config) if f.name != "sources")
"""The built-in sections (a plug-in source's is named after it: Config.sources)."""
SOURCE_SECTIONS: dict[str, AidingSource] = {
    s.section_name: s for s in SOURCES.values() if s.section_name not in SECTION_NAMES
}
"""The sources whose sections :attr:`Config.sources` holds, by section name (the others, the
depth's ``pressure`` and the magnetometer's ``magnetometer``, are sections of their own above)."""


def trajectory_preset(name: str) -> dict[str, dict[str, Any]]:
    """The sections a scenario brings with it, as a partial configuration to lay under a file's
    and the flags' values (``tauv run --trajectory longrange`` flies the paper's mission without
    further flags; a file or flag still wins).

    ``longrange`` (Yoo 2014 section 3): 24 minutes at 10 knots, at 50 m over a seabed at 110 m
    (60 m of altitude, 140 m over its trenches), the paper's IMU (Table 1, ``yoo-table1``, 100 Hz)
    and DVL rate (5 Hz). The other scenarios bring nothing.

    Parameters
    ----------
    name : str
        A trajectory scenario's name (``trajectory.name``, ``--trajectory``), e.g. ``"longrange"``.

    Returns
    -------
    dict[str, dict[str, Any]]
        Section -> key -> value, in the units the keys say (``duration_s`` [s], ``speed_mps`` [m/s],
        ``depth_m`` [m] down, ``rate_hz`` [Hz]); lists for tuples; empty for a scenario that brings
        nothing.
    """
    if name != "longrange":
        return {}
    from tauvcore.sensors.imu import imu_profile

    return {
        "trajectory": {
            "duration_s": 1440.0,
            "speed_mps": 10.0 * units.KNOT,
            "depth_m": 50.0,
            "seabed_depth_m": 110.0,
        },
        "imu": {
            f.name: _plain(getattr(imu_profile("yoo-table1"), f.name))
            for f in dataclasses.fields(imu_profile("yoo-table1"))
        },
        "dvl": {"rate_hz": 5.0},
    }


def to_dict(config: Config) -> dict[str, dict[str, Any]]:
    """Plain nested dict (lists for tuples), as written to TOML and JSON.

    Parameters
    ----------
    config : Config
        The configuration.

    Returns
    -------
    dict[str, dict[str, Any]]
        Section TOML name -> field name -> plain value (bool, int, float, str, list, or a dict for
        a nested dataclass such as a DVL outage), in the units the names say; every section, the
        plug-in sources' after the others.
    """
    return {
        name: {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
        for name, obj in config.sections().items()
    }


def _plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _outages(field_name: str, value: Any) -> tuple[Outage, ...]:
    if not isinstance(value, list) or len(value) > MAX_OUTAGES:
        raise ConfigError(
            f"{field_name} must be a list of at most {MAX_OUTAGES} tables {{beams, start_s, end_s}}, "
            f"got {show(value)}"
        )
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, dict) or set(item) != {"beams", "start_s", "end_s"}:
            raise ConfigError(
                f"{field_name}[{i}] must be a table with keys beams, start_s, end_s, got {show(item)}"
            )
        out.append(
            Outage(
                beams=tuple(_coerce(f"{field_name}[{i}].beams", (1,), item["beams"])),
                start_s=_coerce(f"{field_name}[{i}].start_s", 0.0, item["start_s"]),
                end_s=_coerce(f"{field_name}[{i}].end_s", 0.0, item["end_s"]),
            )
        )
    return tuple(out)


def to_toml(config: Config) -> str:
    """The configuration as TOML text: :func:`to_dict` written by ``tomli_w``.

    Parameters
    ----------
    config : Config
        The configuration.

    Returns
    -------
    str
        TOML text, one ``[section]`` table per section, every key; :func:`load_toml` reads it back.
    """
    return tomli_w.dumps(to_dict(config))


LOG_TOML_OMITTED: dict[str, tuple[str, ...]] = {"dvl": ("outages", "dropout_probability")}
"""Keys a log's own configuration leaves out: the simulated events its tables already hold (the
DVL's outages and dropouts), which a replay would otherwise apply to them again."""


def to_log_toml(config: Config) -> str | None:
    """A simulated log's own configuration (:data:`tauvcore.logs.CONFIG_FILE`) as TOML text: each
    section of the simulation that differs from the defaults, whole.

    A section equal to the defaults but not to the scenario's own (:func:`trajectory_preset` of
    ``trajectory.name``, which a replay lays under the file as ``tauv run`` does) is written too,
    so the file says what the log was made with whatever the scenario brings. The
    ``run`` and ``replay`` sections (what to run, not what was sensed) are left out, and so are
    the keys of :data:`LOG_TOML_OMITTED`. The log's own values (the IMU's rate, the length, the
    origin) still win over the file's in a replay (tauvcore.eval.replay.replay_config).

    Parameters
    ----------
    config : Config
        The simulation's configuration.

    Returns
    -------
    str or None
        TOML text as :func:`to_toml` writes it (section -> key -> value, in the units the keys
        say), or None when no section differs.
    """
    default = to_dict(Config())
    preset = to_dict(from_dict(trajectory_preset(config.trajectory.name)))
    out = {}
    for name, values in to_dict(config).items():
        if name in ("run", "replay") or values == default.get(name) == preset.get(name):
            continue
        out[name] = {k: v for k, v in values.items() if k not in LOG_TOML_OMITTED.get(name, ())}
    return tomli_w.dumps(out) if out else None


def _coerce(field_name: str, default: Any, value: Any) -> Any:
    """Check a TOML value against the type of its default and convert lists to tuples."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{field_name} must be true or false, got {show(value)}")
        return value
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ConfigError(f"{field_name} must be an integer, got {show(value)}")
        return value
    if isinstance(default, float):
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ConfigError(f"{field_name} must be a number, got {show(value)}")
        try:
            number = float(value)  # an integer such as 10**400 has no float
        except OverflowError:
            raise ConfigError(f"{field_name} must be a finite number, got {show(value)}") from None
        if math.isnan(number) or number in (float("inf"), float("-inf")):
            raise ConfigError(f"{field_name} must be a finite number, got {show(value)}")
        return number
    if isinstance(default, str):
        if default == AUTO:  # "auto" or a number
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                return _coerce(field_name, 0.0, value)
            if not isinstance(value, str):
                raise ConfigError(f'{field_name} must be a number or "{AUTO}", got {show(value)}')
        if not isinstance(value, str):
            raise ConfigError(f"{field_name} must be a string, got {show(value)}")
        return value
    if isinstance(default, tuple):
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{field_name} must be a list, got {show(value)}")
        if default and isinstance(default[0], float):
            if len(value) != len(default):  # before any element: a huge list costs nothing
                raise ConfigError(f"{field_name} must be a list of {len(default)} numbers, got {show(value)}")
            return tuple(_coerce(f"{field_name}[{i}]", 0.0, v) for i, v in enumerate(value))
        return tuple(value)
    return value


def from_dict(data: dict[str, Any], base: Config | None = None) -> Config:
    """Overlay a (partial) nested dict on ``base`` (defaults if None).

    Every section is checked on its own first, then the whole (cross-section checks such as an
    outage inside the run), so the order of the sections in a file does not matter.

    Parameters
    ----------
    data : dict[str, Any]
        Section name -> key -> value, as read from TOML (:func:`read_toml`); any subset of sections
        and keys, each value in the unit its key says (``duration_s`` [s], ``lever_arm_m`` [m] body
        FRD, ``*_deg`` in degrees).
    base : Config or None
        The configuration the values are laid on; None: the defaults (``Config()``).

    Returns
    -------
    Config
        ``base`` with ``data``'s values, checked.

    Raises
    ------
    ConfigError
        ``data`` or one of its sections is not a table; an unknown section or key; a value of the
        wrong type or a bad value (naming ``section.key`` and the value); a cross-section check
        failing.
    """
    config = base or Config()
    if not isinstance(data, dict):
        raise ConfigError(f"configuration must be a table, got {show(data)}")
    sections = config.sections()
    for sec_name, values in data.items():
        if sec_name not in sections:
            raise ConfigError(
                f"unknown section [{shorten(str(sec_name))}] (known: {', '.join(sorted(sections))})"
            )
        if not isinstance(values, dict):
            raise ConfigError(f"[{sec_name}] must be a table, got {show(values)}")
        section = sections[sec_name]
        known = {f.name for f in dataclasses.fields(section)}
        changes = {}
        for key, value in values.items():
            if key not in known:
                raise ConfigError(
                    f"unknown key {sec_name}.{shorten(str(key))} (known: {', '.join(sorted(known))})"
                )
            if (sec_name, key) == ("dvl", "outages"):
                changes[key] = _outages("dvl.outages", value)
            else:
                changes[key] = _coerce(f"{sec_name}.{key}", getattr(section, key), value)
        sections[sec_name] = dataclasses.replace(section, **changes)
    return Config(
        **{name: sections[name] for name in SECTION_NAMES},
        sources=tuple((name, sections[name]) for name in SOURCE_SECTIONS),
    )


def merge(base: dict[str, Any], overlay: dict[str, Any]) -> dict[str, Any]:
    """Nested dict ``base`` with ``overlay``'s keys replacing its own (one level of sections).

    A section that is not a table (``trajectory = true``) is never hidden: one of ``base`` is
    kept as it is, one of ``overlay`` replaces ``base``'s table, so :func:`from_dict` reports it.

    Parameters
    ----------
    base : dict[str, Any]
        Section name -> key -> value (a raw configuration, :func:`read_toml`); left unchanged.
    overlay : dict[str, Any]
        Section name -> key -> value whose keys win, each value in the unit its key says.

    Returns
    -------
    dict[str, Any]
        A new nested dict: ``base``'s sections (copied) with ``overlay``'s keys laid over them, and
        ``overlay``'s sections that ``base`` lacks.
    """
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for sec, values in overlay.items():
        if isinstance(values, dict) and isinstance(out.get(sec), dict):
            out[sec].update(values)
        elif sec not in out or not isinstance(values, dict):
            out[sec] = values
    return out


def read_toml(path: str, label: str = "--config") -> dict[str, Any]:
    """The raw tables of a TOML file (checked by :func:`from_dict`).

    Only a regular file of at most :data:`MAX_CONFIG_BYTES` is read, and that is checked with
    ``stat`` before the file is opened, so a FIFO never blocks and ``/dev/zero`` is never read.
    The file is opened non-blocking and checked again on the open descriptor (it could have been
    replaced in between). It must be UTF-8 TOML; every failure is one ``ConfigError`` naming the
    file.

    Parameters
    ----------
    path : str
        The file's path.
    label : str
        What the file is to the user, at the head of every error (``--config``, "the log's
        configuration").

    Returns
    -------
    dict[str, Any]
        The file's tables as ``tomllib`` reads them: section name -> key -> value, unchecked.

    Raises
    ------
    ConfigError
        An empty name or one with a NUL character; a file not found, unreadable, a directory, not
        a regular file (a device, FIFO or socket) or larger than :data:`MAX_CONFIG_BYTES`; not
        UTF-8 text; malformed TOML (or arrays or tables nested too deeply).
    """
    name = show_path(path)
    if not path:
        raise ConfigError(f"{label}: expected a file name, got ''")
    if "\x00" in path:  # no system call takes it (argv cannot carry one; main(argv) can)
        raise ConfigError(f"{label}: a file name cannot contain a NUL character, got {name}")
    try:
        _require_small_regular_file(path, os.stat(path), label)
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
        try:
            _require_small_regular_file(path, os.fstat(fd), label)
            with os.fdopen(fd, "rb", closefd=False) as fh:
                data = fh.read(MAX_CONFIG_BYTES + 1)
        finally:
            os.close(fd)
    except FileNotFoundError:
        raise ConfigError(f"{label}: file not found: {name}") from None
    except OSError as exc:  # ELOOP, ENAMETOOLONG, EACCES, ENOTDIR, EIO, ...
        reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
        raise ConfigError(f"{label}: cannot read {name}: {reason}") from None
    if len(data) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{label}: {name} is larger than {MAX_CONFIG_BYTES} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(
            f"{label}: {name} is not UTF-8 text (byte 0x{data[exc.start]:02x} at offset {exc.start})"
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{label}: malformed TOML in {name}: {one_line(str(exc))}") from None
    except RecursionError:
        raise ConfigError(f"{label}: malformed TOML in {name}: arrays or tables nested too deeply") from None


def _require_small_regular_file(path: str, st: os.stat_result, label: str) -> None:
    """A ConfigError naming the file unless it is a regular file within the size limit."""
    if stat.S_ISDIR(st.st_mode):
        raise ConfigError(f"{label}: is a directory, not a file: {show_path(path)}")
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"{label}: not a regular file (a device, FIFO or socket): {show_path(path)}")
    if st.st_size > MAX_CONFIG_BYTES:
        raise ConfigError(
            f"{label}: {show_path(path)} is larger than {MAX_CONFIG_BYTES} bytes ({st.st_size} bytes)"
        )


def load_toml(path: str) -> Config:
    """Read a (partial) TOML configuration file: :func:`read_toml` then :func:`from_dict`.

    Parameters
    ----------
    path : str
        The file's path.

    Returns
    -------
    Config
        The defaults with the file's values, checked.

    Raises
    ------
    ConfigError
        The file cannot be read as TOML (:func:`read_toml`) or its values are not a configuration
        (:func:`from_dict`), naming the file (``--config``) or ``section.key`` and the value.
    """
    return from_dict(read_toml(path))
