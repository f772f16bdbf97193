"""The full run configuration: one frozen dataclass per section, TOML in and out.

A TOML file may hold any subset of sections and keys (the rest keeps its default); an unknown
section or key, a wrong type or a bad value raises :class:`~tauvcore.validation.ConfigError`
naming ``section.key`` and the value.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from typing import Any

import tomli_w

from tauvcore import units
from tauvcore.aiding import AIDING_SOURCES
from tauvcore.geo.earth import Earth
from tauvcore.sensors.dvl import DvlConfig, Outage
from tauvcore.sensors.imu import ImuConfig
from tauvcore.sensors.magnetometer import MagnetometerConfig
from tauvcore.sensors.pressure import PressureConfig
from tauvcore.truth.kinematic import TrajectoryConfig
from tauvcore.validation import (
    ConfigError,
    require_choice,
    require_positive,
    require_range,
    require_vector3,
)

METHODS = ("ins", "lc", "tc", "vb", "nsv", "plcf", "vhv", "elc")
"""Fusion methods: ``ins`` standalone INS (no aiding at all), ``lc`` loosely coupled DVL (3-4
beams), ``tc`` tightly coupled (any beams), and the extended loosely coupled methods of section
3 (LC with 3-4 beams, their partial construction with 2): ``vb`` virtual beam, ``nsv``
nullified sway, ``plcf`` partial LC, ``vhv`` virtual heave, ``elc`` the per-axis selector."""


@dataclass(frozen=True)
class InitialErrorConfig:
    """Initial navigation errors (estimate minus truth), Table 2 of Tal et al. 2017.

    ``mode = "fixed"`` applies the values as given (a deterministic single run);
    ``"random"`` draws each as a 1-sigma Gaussian per Monte Carlo run.
    """

    pos_m: tuple[float, float, float] = (2.0, 2.0, 2.0)        # north, east, down [m]
    vel_mps: tuple[float, float, float] = (0.05, 0.05, 0.05)   # surge, sway, heave (u, v, w) [m/s]
    roll_pitch_deg: float = 0.57                                # [deg]
    yaw_deg: float = 1.14                                       # [deg]
    mode: str = "fixed"                                         # "fixed" or "random"

    def __post_init__(self) -> None:
        require_vector3("initial_error.pos_m", self.pos_m)
        require_vector3("initial_error.vel_mps", self.vel_mps)
        require_range("initial_error.roll_pitch_deg", self.roll_pitch_deg, -10.0, 10.0)
        require_range("initial_error.yaw_deg", self.yaw_deg, -30.0, 30.0)
        require_choice("initial_error.mode", self.mode, ("fixed", "random"))

    def ideal(self) -> InitialErrorConfig:
        return InitialErrorConfig(pos_m=(0.0, 0.0, 0.0), vel_mps=(0.0, 0.0, 0.0), roll_pitch_deg=0.0, yaw_deg=0.0,
                                  mode=self.mode)

    @property
    def euler_rad(self) -> tuple[float, float, float]:
        return (self.roll_pitch_deg * units.DEG, self.roll_pitch_deg * units.DEG, self.yaw_deg * units.DEG)


@dataclass(frozen=True)
class FilterConfig:
    """Filter settings that are not sensor models (those are the sensor sections, used as tuning)."""

    gate_sigma: float = 3.0          # innovation gate [standard deviations], section 2.1.1
    output_rate_hz: float = 10.0     # rate of the per-epoch error records [Hz]
    covariance_rate_hz: float = 10.0  # covariance propagation rate (the nominal state runs at the IMU rate) [Hz]

    def __post_init__(self) -> None:
        require_range("filter.gate_sigma", self.gate_sigma, 0.5, 1e6)
        require_positive("filter.output_rate_hz", self.output_rate_hz)
        require_positive("filter.covariance_rate_hz", self.covariance_rate_hz)


@dataclass(frozen=True)
class PartialConfig:
    """Parameters of the extended loosely coupled methods (section 3); the paper gives no values."""

    vb_nf: float = 2.0                      # n_f of eq. 28: inflation of the virtual beam's prediction sigma
    nsv_epsilon_m2_per_s2: float = 1e-4     # epsilon of eq. 36: variance of the "sway = 0" assumption [m^2/s^2]

    def __post_init__(self) -> None:
        require_range("partial.vb_nf", self.vb_nf, 1.0, 100.0)
        require_positive("partial.nsv_epsilon_m2_per_s2", self.nsv_epsilon_m2_per_s2)


@dataclass(frozen=True)
class RunConfig:
    methods: tuple[str, ...] = METHODS            # fusion methods to run side by side
    aiding: tuple[str, ...] = ("dvl",)            # aiding sources on (section 4: DVL alone)
    seed: int = 0                                 # seed of the numpy Generator
    ideal: bool = False                           # zero every sensor and initial error in the simulation

    def __post_init__(self) -> None:
        for name, values, choices in (("run.methods", self.methods, METHODS), ("run.aiding", self.aiding, AIDING_SOURCES)):
            if not isinstance(values, (tuple, list)):
                raise ConfigError(f"{name} must be a list, got {values!r}")
            for v in values:
                require_choice(name, v, choices)
        if not self.methods:
            raise ConfigError("run.methods must name at least one method, got []")
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            raise ConfigError(f"run.seed must be a non-negative integer, got {self.seed!r}")
        if not isinstance(self.ideal, bool):
            raise ConfigError(f"run.ideal must be true or false, got {self.ideal!r}")


@dataclass(frozen=True)
class Config:
    trajectory: TrajectoryConfig = field(default_factory=TrajectoryConfig)
    earth: Earth = field(default_factory=Earth)
    imu: ImuConfig = field(default_factory=ImuConfig)
    dvl: DvlConfig = field(default_factory=DvlConfig)
    pressure: PressureConfig = field(default_factory=PressureConfig)
    magnetometer: MagnetometerConfig = field(default_factory=MagnetometerConfig)
    initial_error: InitialErrorConfig = field(default_factory=InitialErrorConfig)
    filter: FilterConfig = field(default_factory=FilterConfig)
    partial: PartialConfig = field(default_factory=PartialConfig)
    run: RunConfig = field(default_factory=RunConfig)

    def __post_init__(self) -> None:
        duration = self.trajectory.duration_s
        for o in self.dvl.outages:
            if o.start_s >= duration or o.end_s > duration:
                raise ConfigError(f"dvl.outages: window {o.start_s:g}:{o.end_s:g} s lies outside the run "
                                  f"(0 to {duration:g} s)")

    def replace(self, section: str, **changes: Any) -> Config:
        """A copy with ``changes`` applied to one section (validated)."""
        return dataclasses.replace(self, **{section: dataclasses.replace(getattr(self, section), **changes)})


def to_dict(config: Config) -> dict[str, dict[str, Any]]:
    """Plain nested dict (lists for tuples), as written to TOML and JSON."""
    out: dict[str, dict[str, Any]] = {}
    for sec in dataclasses.fields(config):
        obj = getattr(config, sec.name)
        out[sec.name] = {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    return out


def _plain(value: Any) -> Any:
    if dataclasses.is_dataclass(value):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


def _outages(field_name: str, value: Any) -> tuple[Outage, ...]:
    if not isinstance(value, list):
        raise ConfigError(f"{field_name} must be a list of tables {{beams, start_s, end_s}}, got {value!r}")
    out = []
    for i, item in enumerate(value):
        if not isinstance(item, dict) or set(item) != {"beams", "start_s", "end_s"}:
            raise ConfigError(f"{field_name}[{i}] must be a table with keys beams, start_s, end_s, got {item!r}")
        out.append(Outage(beams=tuple(_coerce(f"{field_name}[{i}].beams", (1,), item["beams"])),
                          start_s=_coerce(f"{field_name}[{i}].start_s", 0.0, item["start_s"]),
                          end_s=_coerce(f"{field_name}[{i}].end_s", 0.0, item["end_s"])))
    return tuple(out)


def to_toml(config: Config) -> str:
    return tomli_w.dumps(to_dict(config))


def _coerce(field_name: str, default: Any, value: Any) -> Any:
    """Check a TOML value against the type of its default and convert lists to tuples."""
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{field_name} must be true or false, got {value!r}")
        return value
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ConfigError(f"{field_name} must be an integer, got {value!r}")
        return value
    if isinstance(default, float):
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ConfigError(f"{field_name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ConfigError(f"{field_name} must be a finite number, got {value!r}")
        return float(value)
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{field_name} must be a string, got {value!r}")
        return value
    if isinstance(default, tuple):
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{field_name} must be a list, got {value!r}")
        if default and isinstance(default[0], float):
            return tuple(_coerce(f"{field_name}[{i}]", 0.0, v) for i, v in enumerate(value))
        return tuple(value)
    return value


def from_dict(data: dict[str, Any], base: Config | None = None) -> Config:
    """Overlay a (partial) nested dict on ``base`` (defaults if None).

    Every section is checked on its own first, then the whole (cross-section checks such as an
    outage inside the run), so the order of the sections in a file does not matter.
    """
    config = base or Config()
    if not isinstance(data, dict):
        raise ConfigError(f"configuration must be a table, got {data!r}")
    sections = {f.name: getattr(config, f.name) for f in dataclasses.fields(config)}
    for sec_name, values in data.items():
        if sec_name not in sections:
            raise ConfigError(f"unknown section [{sec_name}] (known: {', '.join(sorted(sections))})")
        if not isinstance(values, dict):
            raise ConfigError(f"[{sec_name}] must be a table, got {values!r}")
        section = sections[sec_name]
        known = {f.name for f in dataclasses.fields(section)}
        changes = {}
        for key, value in values.items():
            if key not in known:
                raise ConfigError(f"unknown key {sec_name}.{key} (known: {', '.join(sorted(known))})")
            if (sec_name, key) == ("dvl", "outages"):
                changes[key] = _outages("dvl.outages", value)
            else:
                changes[key] = _coerce(f"{sec_name}.{key}", getattr(section, key), value)
        sections[sec_name] = dataclasses.replace(section, **changes)
    return Config(**sections)


def merge(base: dict[str, Any], overlay: dict[str, Any]) -> dict[str, Any]:
    """Nested dict ``base`` with ``overlay``'s keys replacing its own (one level of sections)."""
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in base.items()}
    for sec, values in overlay.items():
        if isinstance(values, dict) and isinstance(out.get(sec), dict):
            out[sec].update(values)
        else:
            out[sec] = values
    return out


def read_toml(path: str) -> dict[str, Any]:
    """The raw tables of a TOML file (checked by :func:`from_dict`)."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"--config: file not found: {path!r}") from None
    except IsADirectoryError:
        raise ConfigError(f"--config: is a directory, not a file: {path!r}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"--config: malformed TOML in {path!r}: {exc}") from None


def load_toml(path: str) -> Config:
    """Read a (partial) TOML configuration file."""
    return from_dict(read_toml(path))
