"""Staying in the water: the seabed's floor under a mission, the depth the lawnmower levels off
at, and the check every truth passes, that the vehicle is between the surface and the seabed.

The kinematic missions hold their depth schedules (tauvcore.truth.kinematic), which
:class:`~tauvcore.truth.kinematic.TrajectoryConfig` keeps above the seabed's floor; the dynamic
vehicle tracks them with its autopilot and may not manage (too slow for its fins to carry its
buoyancy), and a terrain's crest may rise above the floor: :func:`check_in_water` refuses both,
at the first sample out of the water.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from tauvcore.truth.seabed import Bathymetry
from tauvcore.truth.truth_record import Truth
from tauvcore.validation import ConfigError, show


class Mission(Protocol):
    """The fields of a mission these functions read (tauvcore.truth.kinematic.TrajectoryConfig's)."""

    @property
    def truth(self) -> str: ...
    @property
    def depth_m(self) -> float: ...
    @property
    def speed_mps(self) -> float: ...
    @property
    def seabed(self) -> str: ...
    @property
    def seabed_depth_m(self) -> float: ...
    @property
    def terrain_relief_m(self) -> float: ...
    @property
    def lawnmower_dive_rate_mps(self) -> float: ...
    @property
    def dive_duration_s(self) -> float: ...
    @property
    def blend_s(self) -> float: ...


MIN_ALTITUDE_M = 10.0
"""The figure eight's descent ends this high above the seabed
(tauvcore.truth.kinematic.figure8_level_off_s), and no dive may end closer to it."""


def seabed_floor_m(cfg: Mission) -> float:
    """The shallowest the seabed is taken to be under a mission [m].

    Its mean depth, less three times the terrain's RMS relief when there is terrain.

    Parameters
    ----------
    cfg : Mission
        Scenario: ``seabed_depth_m`` [m], ``seabed``, ``terrain_relief_m`` [m].

    Returns
    -------
    float
        Depth of the seabed's floor, positive down (NED down coordinate) [m].
    """
    return cfg.seabed_depth_m - (3.0 * cfg.terrain_relief_m if cfg.seabed == "terrain" else 0.0)


def lawnmower_level_depth_m(cfg: Mission) -> float:
    """The depth the lawnmower levels off at [m], positive down.

    Its dive at ``lawnmower_dive_rate_mps`` for ``dive_duration_s``, then half the pitch blend
    (the sine of a half-cosine blend of the pitch averages to about half its start).

    Parameters
    ----------
    cfg : Mission
        Scenario: ``depth_m`` [m], ``lawnmower_dive_rate_mps`` [m/s], ``dive_duration_s`` [s],
        ``blend_s`` [s].

    Returns
    -------
    float
        Depth after the dive [m] (within a few millimetres: the blend's exact integral differs).
    """
    if cfg.dive_duration_s <= 0.0:
        return cfg.depth_m
    return cfg.depth_m + cfg.lawnmower_dive_rate_mps * (cfg.dive_duration_s + 0.5 * cfg.blend_s)


def check_in_water(cfg: Mission, seabed: Bathymetry, chunk: Truth) -> None:
    """Refuse a truth that leaves the water: above the surface or below the seabed.

    The kinematic missions stay between the two by construction (their depth schedules and the
    checks of :class:`TrajectoryConfig`); a dynamic vehicle that cannot hold its schedule (too
    slow for its fins to carry its buoyancy), or a terrain crest above the seabed's floor
    (:func:`seabed_floor_m`, three RMS reliefs up), is caught here, at the first sample out.

    Parameters
    ----------
    cfg : Mission
        The mission (its fields are named in the message).
    seabed : tauvcore.truth.seabed.Bathymetry
        The mission's seabed (:func:`bathymetry`).
    chunk : Truth
        Samples of the mission: positions NED [m], depths [m].

    Raises
    ------
    ConfigError
        At the first sample above the surface ("... breaks the surface at t = ... s") or in the
        seabed ("... enters the seabed at t = ... s"), naming the fields that would keep it in
        the water.
    """
    depth_m = chunk.depth_m
    altitude_m = seabed.depth_m(chunk.pos_n[:, 0], chunk.pos_n[:, 1]) - depth_m
    out = np.flatnonzero((depth_m < -1e-9) | (altitude_m <= 0.0))
    if out.size == 0:
        return
    k = int(out[0])
    where = f"at t = {chunk.t_s[k]:.1f} s (depth {depth_m[k]:.3f} m"
    if depth_m[k] < -1e-9:
        raise ConfigError(
            f"trajectory: the {cfg.truth} vehicle breaks the surface {where}): it cannot hold "
            f"trajectory.depth_m {show(cfg.depth_m)} m at trajectory.speed_mps {show(cfg.speed_mps)} m/s; "
            f"fly deeper or faster"
        )
    raise ConfigError(
        f"trajectory: the {cfg.truth} vehicle enters the seabed {where}, seabed "
        f"{depth_m[k] + altitude_m[k]:.3f} m): raise trajectory.seabed_depth_m "
        f"({show(cfg.seabed_depth_m)} m) or lower trajectory.terrain_relief_m "
        f"({show(cfg.terrain_relief_m)} m)"
    )
