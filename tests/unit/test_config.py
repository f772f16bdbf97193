"""Configuration: TOML round trip, partial overlays, and errors that name the field and the value."""

from __future__ import annotations

import tomllib

import pytest

from tauvcore.config import Config, from_dict, load_toml, to_dict, to_toml
from tauvcore.validation import ConfigError


def test_toml_round_trip_of_defaults():
    text = to_toml(Config())
    assert from_dict(tomllib.loads(text)) == Config()


def test_toml_round_trip_of_a_non_default_config():
    cfg = (Config().replace("trajectory", name="lawnmower", duration_s=120.0)
           .replace("dvl", lever_arm_m=(0.5, -0.1, 0.2), beams=(1, 2, 4))
           .replace("run", methods=("lc",), aiding=("dvl", "depth"), seed=7, ideal=True)
           .replace("initial_error", mode="random"))
    back = from_dict(tomllib.loads(to_toml(cfg)))
    assert back == cfg
    assert back != Config()
    assert isinstance(back.dvl.lever_arm_m, tuple) and isinstance(back.run.methods, tuple)


def test_partial_dict_overlays_defaults():
    cfg = from_dict({"imu": {"gyro_bias_deg_per_h": 1.5}, "trajectory": {"name": "figure8"}})
    assert cfg.imu.gyro_bias_deg_per_h == 1.5
    assert cfg.trajectory.name == "figure8"
    assert cfg.imu.accel_bias_mg == Config().imu.accel_bias_mg
    assert cfg.trajectory.duration_s == Config().trajectory.duration_s
    assert cfg.dvl == Config().dvl and cfg.run == Config().run
    assert from_dict({}) == Config()
    assert from_dict({"dvl": {}}) == Config()


def test_partial_dict_overlays_a_base_and_converts_types():
    base = Config().replace("run", seed=3)
    cfg = from_dict({"dvl": {"lever_arm_m": [1, 2, 3]}, "filter": {"gate_sigma": 4}, "run": {"methods": ["lc"]}},
                    base=base)
    assert cfg.run.seed == 3                       # the base survives where the dict is silent
    assert cfg.run.methods == ("lc",)
    assert cfg.dvl.lever_arm_m == (1.0, 2.0, 3.0)
    assert all(isinstance(v, float) for v in cfg.dvl.lever_arm_m)
    assert cfg.filter.gate_sigma == 4.0 and isinstance(cfg.filter.gate_sigma, float)


def test_load_toml_file(tmp_path):
    path = tmp_path / "run.toml"
    path.write_text('[trajectory]\nname = "figure8"\nduration_s = 60.0\n[run]\nmethods = ["lc"]\n')
    cfg = load_toml(str(path))
    assert cfg == Config().replace("trajectory", name="figure8", duration_s=60.0).replace("run", methods=("lc",))


BAD = [
    # id, dict, what the message must contain
    ("unknown section", {"sonar": {"rate_hz": 1.0}}, ["sonar"]),
    ("unknown key", {"imu": {"gyro_noise": 0.3}}, ["imu.gyro_noise"]),
    ("wrong type", {"imu": {"gyro_noise_deg_per_sqrt_h": "0.34"}}, ["imu.gyro_noise_deg_per_sqrt_h", "'0.34'"]),
    ("bool for number", {"imu": {"gyro_noise_deg_per_sqrt_h": True}}, ["imu.gyro_noise_deg_per_sqrt_h", "True"]),
    ("NaN noise", {"imu": {"gyro_noise_deg_per_sqrt_h": float("nan")}}, ["imu.gyro_noise_deg_per_sqrt_h", "nan"]),
    ("negative noise", {"imu": {"gyro_noise_deg_per_sqrt_h": -0.34}}, ["imu.gyro_noise_deg_per_sqrt_h", "-0.34"]),
    ("negative dvl noise", {"dvl": {"noise_mps": -0.01}}, ["dvl.noise_mps", "-0.01"]),
    ("zero duration", {"trajectory": {"duration_s": 0.0}}, ["trajectory.duration_s", "0.0"]),
    ("unknown trajectory", {"trajectory": {"name": "circle"}}, ["trajectory.name", "circle"]),
    ("bad vector", {"dvl": {"lever_arm_m": [0.6, "x", 0.1]}}, ["dvl.lever_arm_m", "'x'"]),
    ("short vector", {"dvl": {"lever_arm_m": [0.6, 0.1]}}, ["dvl.lever_arm_m", "0.6, 0.1"]),
    ("unknown beam", {"dvl": {"beams": [1, 5]}}, ["dvl.beams", "5"]),
    ("unknown method", {"run": {"methods": ["ukf"]}}, ["run.methods", "ukf"]),
    ("negative seed", {"run": {"seed": -1}}, ["run.seed", "-1"]),
    ("float seed", {"run": {"seed": 1.5}}, ["run.seed", "1.5"]),
    ("section not a table", {"imu": 3}, ["imu", "3"]),
    ("latitude out of range", {"earth": {"latitude_deg": 95.0}}, ["earth.latitude_deg", "95.0"]),
]


@pytest.mark.parametrize(("data", "needles"), [pytest.param(d, n, id=i) for i, d, n in BAD])
def test_bad_values_raise_config_error_naming_field_and_value(data, needles):
    with pytest.raises(ConfigError) as info:
        from_dict(data)
    message = str(info.value)
    for needle in needles:
        assert needle in message, message


def test_direct_construction_validates_too():
    with pytest.raises(ConfigError, match=r"imu\.gyro_noise_deg_per_sqrt_h.*nan"):
        Config().replace("imu", gyro_noise_deg_per_sqrt_h=float("nan"))
    with pytest.raises(ConfigError, match=r"trajectory\.duration_s.*0"):
        Config().replace("trajectory", duration_s=0)


def test_to_dict_has_every_section_and_plain_types():
    d = to_dict(Config())
    assert set(d) == {"trajectory", "earth", "imu", "dvl", "pressure", "magnetometer", "initial_error", "filter", "partial", "run"}
    assert isinstance(d["dvl"]["lever_arm_m"], list)
