"""The noise parameters the tuning may identify: each one key of the configuration, its bounds
(the configuration's own limit and the floor the filter puts under it), and the configuration
with values laid over it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tauvcore import units
from tauvcore.config import Config
from tauvcore.sensors.dvl import DvlConfig
from tauvcore.sensors.imu import ERROR_LIMITS
from tauvcore.validation import settings

BOUND_DECADES = 6.0
"""How far below the largest value the configuration accepts a parameter's lower bound lies
[decades]: below any real sensor's figure (a gyro's white noise 3e-5 deg/sqrt(h), a navigation-grade
fibre-optic gyro's is 1e-3 to 3e-3)."""


@dataclass(frozen=True)
class Parameter:
    """A noise parameter the tuning may identify: one key of the configuration."""

    name: str  # its name on the command line (--params)
    section: str  # the configuration's section ("imu", "dvl")
    key: str  # the key in that section, in its unit
    unit: str  # the key's unit, as printed
    label: str  # what it is, for a table
    prior: bool  # a turn-on sigma: one draw per log, so one log says little about it

    @property
    def bounds(self) -> tuple[float, float]:
        """Lowest and highest value searched, in the key's unit: :data:`BOUND_DECADES` below the
        configuration's largest or the floor the filter puts under the value (below it the filter
        and the likelihood do not change), whichever is higher; and that largest."""
        high = _largest(self.section, self.key)
        return max(high * 10.0**-BOUND_DECADES, _floor(self.key)), high


def _largest(section: str, key: str) -> float:
    """The largest value the configuration accepts for ``section.key`` (its own check's bound)."""
    if section == "imu":
        return float(ERROR_LIMITS[key])
    bounds = {name: s.high for name, _, s in settings(DvlConfig)}
    high = bounds[key]
    assert high is not None  # every DVL noise key declares its range (tauvcore.sensors.dvl)
    return float(high)


def _floor(key: str) -> float:
    """The smallest value the filter uses for ``key`` [the key's unit]: its process noise's density
    floor (tauvcore.ins.error_model.PROCESS_NOISE_PSD_FLOOR) or the DVL beam noise's
    (tauvcore.aiding.noise_floors); 0 for a key without one (a turn-on sigma)."""
    from tauvcore.aiding.noise_floors import DVL_BEAM_NOISE_FLOOR_MPS
    from tauvcore.filter.layout import NOISE
    from tauvcore.ins.error_model import PROCESS_NOISE_PSD_FLOOR

    def density(block: slice) -> float:
        return float(np.sqrt(PROCESS_NOISE_PSD_FLOOR[block][0]))

    floors = {
        "gyro_noise_deg_per_sqrt_h": density(NOISE.gyro) / units.DEG_PER_SQRT_HOUR,
        "accel_noise_mps_per_sqrt_h": density(NOISE.accel) / units.MPS_PER_SQRT_HOUR,
        "gyro_bias_rw_deg_per_s_per_sqrt_s": density(NOISE.bg) / units.DEG,
        "accel_bias_rw_mps2_per_sqrt_s": density(NOISE.ba),
        "noise_mps": DVL_BEAM_NOISE_FLOOR_MPS,
        "bias_rw_mps_per_sqrt_s": density(NOISE.b_dvl),
        "scale_factor_rw_pct_per_sqrt_s": density(NOISE.sf_dvl) * 100.0,
    }
    return floors.get(key, 0.0)


PARAMETERS: dict[str, Parameter] = {
    p.name: p
    for p in (
        Parameter(
            "gyro_noise", "imu", "gyro_noise_deg_per_sqrt_h", "deg/sqrt(h)", "gyro white noise (ARW)", False
        ),
        Parameter(
            "accel_noise",
            "imu",
            "accel_noise_mps_per_sqrt_h",
            "m/s/sqrt(h)",
            "accel white noise (VRW)",
            False,
        ),
        Parameter(
            "gyro_bias_walk",
            "imu",
            "gyro_bias_rw_deg_per_s_per_sqrt_s",
            "deg/s/sqrt(s)",
            "gyro bias random walk",
            False,
        ),
        Parameter(
            "accel_bias_walk",
            "imu",
            "accel_bias_rw_mps2_per_sqrt_s",
            "m/s^2/sqrt(s)",
            "accel bias random walk",
            False,
        ),
        Parameter("gyro_bias", "imu", "gyro_bias_deg_per_h", "deg/h", "gyro turn-on bias sigma", True),
        Parameter("accel_bias", "imu", "accel_bias_mg", "mg", "accel turn-on bias sigma", True),
        Parameter("dvl_noise", "dvl", "noise_mps", "m/s", "DVL beam white noise", False),
        Parameter("dvl_bias", "dvl", "bias_mps", "m/s", "DVL beam turn-on bias sigma", True),
        Parameter(
            "dvl_bias_walk",
            "dvl",
            "bias_rw_mps_per_sqrt_s",
            "m/s/sqrt(s)",
            "DVL beam bias random walk",
            False,
        ),
        Parameter("dvl_scale_factor", "dvl", "scale_factor_pct", "%", "DVL scale factor turn-on sigma", True),
        Parameter(
            "dvl_scale_factor_walk",
            "dvl",
            "scale_factor_rw_pct_per_sqrt_s",
            "%/sqrt(s)",
            "DVL scale factor random walk",
            False,
        ),
    )
}
"""The parameters :func:`tauvcore.eval.tuning.search.tune` may identify, by name."""

DEFAULT_PARAMETERS = ("gyro_noise", "accel_noise", "dvl_noise")
"""What :func:`tauvcore.eval.tuning.search.tune` identifies unless told: the white noises, which every update sees. The bias
walks act over minutes to hours, and each turn-on sigma is the spread of one draw per log, so a
400 s log says little about them (docs/tuning.md)."""


def parameter_values(config: Config, names: Sequence[str]) -> dict[str, float]:
    """The values the configuration gives the parameters ``names``.

    Parameters
    ----------
    config : Config
        The configuration.
    names : Sequence[str]
        Keys of :data:`PARAMETERS`.

    Returns
    -------
    dict[str, float]
        Name -> value, in the unit of its configuration key (:attr:`Parameter.unit`).
    """
    return {n: float(getattr(config.section(PARAMETERS[n].section), PARAMETERS[n].key)) for n in names}


def with_values(config: Config, values: Mapping[str, float]) -> Config:
    """``config`` with the parameters' values set.

    Parameters
    ----------
    config : Config
        The configuration.
    values : Mapping[str, float]
        Name (a key of :data:`PARAMETERS`) -> value in its configuration key's unit.

    Returns
    -------
    Config
        The configuration with each value in its section's key.

    Raises
    ------
    ConfigError
        A value outside what its key accepts.
    """
    by_section: dict[str, dict[str, float]] = {}
    for name, value in values.items():
        p = PARAMETERS[name]
        by_section.setdefault(p.section, {})[p.key] = float(value)
    for section, changes in by_section.items():
        config = config.replace(section, **changes)
    return config
