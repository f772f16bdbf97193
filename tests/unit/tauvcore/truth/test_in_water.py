"""Every mission stays in the water, for any duration: between the surface and the seabed.

The kinematic missions hold their depth schedules exactly (the heave cancels the rolled sway's
vertical part, which otherwise lifted the figure eight 4.6 mm/s, out of the water within
5 hours); the dynamic vehicle tracks them with its autopilot. A configuration that would leave
the water is refused, naming its field.
"""

import numpy as np
import pytest

from tauvcore.geo.earth import EARTH_MODELS, Earth
from tauvcore.truth import TRAJECTORIES, TrajectoryConfig, truth_stream
from tauvcore.truth.kinematic import (
    MIN_ALTITUDE_M,
    bathymetry,
    figure8_level_off_s,
    lawnmower_level_depth_m,
    seabed_floor_m,
)
from tauvcore.validation import ConfigError

RATE_HZ = 10.0  # the depth's schedule does not depend on the sample rate; 10 Hz keeps 24 h cheap


def _depth_envelope(cfg: TrajectoryConfig, earth: Earth) -> tuple[float, float, float, float]:
    """(shallowest depth, least altitude, depth at the end, largest |depth - the schedule's end|
    in the last hour) over the mission [m]."""
    seabed, target_m = bathymetry(cfg), _schedule_end_m(cfg)
    shallowest, lowest, last_hour = np.inf, np.inf, 0.0
    end = np.nan
    for _, chunk in truth_stream(cfg, earth, RATE_HZ, 36_000):
        depth = chunk.depth_m
        shallowest = min(shallowest, float(depth.min()))
        lowest = min(lowest, float((seabed.depth_m(chunk.pos_n[:, 0], chunk.pos_n[:, 1]) - depth).min()))
        end = float(depth[-1])
        late = chunk.t_s > cfg.duration_s - 3600.0
        if late.any():
            last_hour = max(last_hour, float(np.abs(depth[late] - target_m).max()))
    return shallowest, lowest, end, last_hour


def _schedule_end_m(cfg: TrajectoryConfig) -> float:
    if cfg.name == "figure8":
        return seabed_floor_m(cfg) - MIN_ALTITUDE_M + cfg.dive_rate_mps * 0.5 * cfg.blend_s
    if cfg.name == "lawnmower":
        return lawnmower_level_depth_m(cfg)
    return cfg.depth_m


@pytest.mark.slow
@pytest.mark.parametrize("duration_s", [36000.0, 86400.0], ids=["10h", "24h"])
@pytest.mark.parametrize("truth", ["kinematic", "dynamic"])
@pytest.mark.parametrize("model", EARTH_MODELS)
@pytest.mark.parametrize("name", TRAJECTORIES)
def test_every_mission_holds_its_depth_between_surface_and_seabed(name, model, truth, duration_s):
    cfg = TrajectoryConfig(name=name, duration_s=duration_s, truth=truth)
    shallowest, lowest, end, last_hour = _depth_envelope(cfg, Earth(model=model))
    assert shallowest >= 0.0 and lowest > 0.0, (shallowest, lowest)
    if truth == "kinematic":  # the schedule exactly (the blend's integral to a few millimetres)
        assert end == pytest.approx(_schedule_end_m(cfg), abs=0.01)
        assert last_hour < 0.01
    else:  # the autopilot through the turns: 1.07 m at most measured (the figure eight's, 10 h)
        assert last_hour < 1.5, last_hour


def test_the_figure8_schedule_levels_off_above_the_seabed():
    cfg = TrajectoryConfig(name="figure8", duration_s=86400.0)
    level_s = figure8_level_off_s(cfg)
    assert level_s == pytest.approx((60.0 - MIN_ALTITUDE_M - 20.0) / 0.1)
    assert _schedule_end_m(cfg) < seabed_floor_m(cfg)


def test_a_lawnmower_dive_into_the_seabed_is_refused_naming_its_fields():
    TrajectoryConfig(name="lawnmower", dive_duration_s=90.0)  # 20 + 0.3 x 92 = 47.6 m: above 50 m
    with pytest.raises(ConfigError) as info:
        TrajectoryConfig(name="lawnmower", dive_duration_s=200.0)
    message = str(info.value)
    assert "trajectory.dive_duration_s 200.0 s" in message and "lawnmower_dive_rate_mps 0.3" in message
    assert "80.6 m" in message and "seabed (60.0 m)" in message and "\n" not in message
    TrajectoryConfig(name="straight", dive_duration_s=200.0)  # the lawnmower's dive: not flown here


def test_a_dynamic_vehicle_too_slow_to_hold_its_depth_is_refused_when_it_surfaces():
    # 0.5 % positive buoyancy: at 0.5 m/s the fins cannot hold it down; from 1 m it surfaces at once
    cfg = TrajectoryConfig(name="straight", duration_s=600.0, truth="dynamic", depth_m=1.0, speed_mps=0.5)
    with pytest.raises(ConfigError) as info:
        for _ in truth_stream(cfg, Earth(model="flat"), RATE_HZ, 1000):
            pass
    message = str(info.value)
    assert "breaks the surface at t = " in message
    assert "trajectory.depth_m 1.0 m" in message and "trajectory.speed_mps 0.5 m/s" in message


def test_a_terrain_crest_above_the_floor_is_refused_where_the_vehicle_meets_it():
    # a steep relief: the level depth (floor + 10 m) leaves room for crests beyond three RMS
    cfg = TrajectoryConfig(name="straight", duration_s=3600.0, seabed="terrain", depth_m=20.0,
                           seabed_depth_m=45.0, terrain_relief_m=8.0, terrain_wavelength_m=200.0, terrain_seed=2)
    seabed = bathymetry(cfg)
    north = np.arange(0.0, 2.0 * 3600.0, 1.0)
    crest = seabed.depth_m(north, np.zeros_like(north)) <= cfg.depth_m
    assert crest.any()  # the track meets a crest shallower than the vehicle
    with pytest.raises(ConfigError) as info:
        for _ in truth_stream(cfg, Earth(model="flat"), RATE_HZ, 1000):
            pass
    message = str(info.value)
    assert "enters the seabed at t = " in message and "trajectory.seabed_depth_m (45.0 m)" in message
    t_first_s = north[np.argmax(crest)] / cfg.speed_mps  # where the 1 m grid first finds it
    assert abs(float(message.split("t = ")[1].split(" s")[0]) - t_first_s) < 1.0
