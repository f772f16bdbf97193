"""Configuration: TOML round trip, partial overlays, and errors that name the field and the value."""

from __future__ import annotations

import math
import os
import tomllib
import tracemalloc

import pytest

from tauvcore.config import (
    MAX_CONFIG_BYTES,
    SOURCE_SECTIONS,
    Config,
    from_dict,
    load_toml,
    merge,
    read_toml,
    to_dict,
    to_toml,
)
from tauvcore.validation import ConfigError, show, show_path


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
    ("unknown method", {"run": {"methods": ["pf"]}}, ["run.methods", "pf"]),
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
    assert set(d) == {"trajectory", "earth", "imu", "dvl", "pressure", "magnetometer", "echo_sounder", "rpm", "vkf",
                      "initial_error", "filter", "partial", "run", "replay", "reference", "calibration",
                      *SOURCE_SECTIONS}
    assert isinstance(d["dvl"]["lever_arm_m"], list)


# --- every numeric field has a physical range; zero noise stays legal ----------------------

OUT_OF_RANGE = [
    # (section, key, refused value, accepted value at or near the bound)
    ("imu", "rate_hz", 0.001, 50.0), ("imu", "rate_hz", 1e5, 2000.0),
    ("imu", "accel_bias_mg", 1e300, 100.0), ("imu", "gyro_bias_deg_per_h", 3601.0, 3600.0),
    ("imu", "accel_noise_mps_per_sqrt_h", 10.5, 10.0), ("imu", "gyro_noise_deg_per_sqrt_h", 1e300, 30.0),
    ("imu", "accel_bias_rw_mps2_per_sqrt_s", 0.1, 1e-2), ("imu", "gyro_bias_rw_deg_per_s_per_sqrt_s", 0.1, 1e-2),
    ("dvl", "rate_hz", 0.0, 0.05), ("dvl", "rate_hz", 100.0, 25.0), ("dvl", "beam_pitch_deg", 5.0, 10.0),
    ("dvl", "noise_mps", 1e300, 1.0), ("dvl", "bias_mps", 0.6, 0.5), ("dvl", "scale_factor_pct", 1e300, 10.0),
    ("dvl", "bias_rw_mps_per_sqrt_s", 1.0, 5e-3), ("dvl", "scale_factor_rw_pct_per_sqrt_s", 1.0, 0.5),
    ("pressure", "rate_hz", 0.0, 0.01), ("pressure", "noise_pa", 1e300, 1e5),
    ("pressure", "water_density_kg_m3", 0.0, 1000.0),
    ("magnetometer", "rate_hz", 1e6, 100.0), ("magnetometer", "yaw_noise_deg", 1e300, 90.0),
    ("magnetometer", "roll_pitch_noise_deg", 45.0, 30.0),
    ("trajectory", "duration_s", 86401.0, 86400.0), ("trajectory", "speed_mps", 1e300, 10.0),
    ("trajectory", "speed_mps", 0.0, 0.5), ("trajectory", "depth_m", 12000.0, 50.0),
    ("trajectory", "leg_length_m", 1e9, 10000.0), ("trajectory", "turn_radius_m", 0.1, 1.0),
    ("trajectory", "blend_s", 1e-9, 0.1), ("trajectory", "seabed_depth_m", 0.0, 30.0),
    ("trajectory", "dive_duration_s", 1e300, 86400.0),
    ("filter", "gate_sigma", 0.5, 1.0), ("filter", "output_rate_hz", 0.0, 0.1),
    ("filter", "covariance_rate_hz", 0.5, 1.0), ("partial", "nsv_epsilon_m2_per_s2", 0.0, 1.0),
    ("partial", "nsv_epsilon_m2_per_s2", 101.0, 100.0), ("partial", "nsv_epsilon_m2_per_s2", -1.0, 1e-6),
    ("partial", "vb_nf", 0.0, 1.0), ("partial", "vb_nf", -3.0, 100.0), ("partial", "vb_nf", 101.0, 20.0),
    ("run", "seed", 2**63, 2**63 - 1),
]


@pytest.mark.parametrize("section, key, bad, good", OUT_OF_RANGE, ids=[f"{s}.{k}={b:g}" for s, k, b, _ in OUT_OF_RANGE])
def test_each_field_has_a_range_naming_field_and_value(section, key, bad, good):
    assert getattr(from_dict({section: {key: good}}), section).__getattribute__(key) == good
    with pytest.raises(ConfigError) as info:
        from_dict({section: {key: bad}})
    assert f"{section}.{key}" in str(info.value) and repr(bad) in str(info.value)


@pytest.mark.parametrize("key, value", [("lever_arm_m", [0.6, 0.0, 11.0]), ("lever_arm_m", [1e300, 0.0, 0.0])])
def test_dvl_lever_arm_is_bounded(key, value):
    with pytest.raises(ConfigError, match=r"dvl\.lever_arm_m\[\d\]"):
        from_dict({"dvl": {key: value}})


@pytest.mark.parametrize("key, value", [("pos_m", [2000.0, 0.0, 0.0]), ("vel_mps", [0.0, 11.0, 0.0])])
def test_initial_errors_are_bounded(key, value):
    with pytest.raises(ConfigError, match=rf"initial_error\.{key}\[\d\]"):
        from_dict({"initial_error": {key: value}})


@pytest.mark.parametrize("section, key", [("dvl", "rate_hz"), ("pressure", "rate_hz"), ("magnetometer", "rate_hz"),
                                          ("filter", "output_rate_hz"), ("filter", "covariance_rate_hz")])
def test_no_rate_above_the_imu_rate(section, key):
    ok = from_dict({"imu": {"rate_hz": 50.0}, section: {key: 25.0 if section == "dvl" else 50.0}})
    assert getattr(ok, section).__getattribute__(key) <= ok.imu.rate_hz
    if section == "dvl":
        return          # the DVL's own bound (25 Hz) is below the slowest IMU (50 Hz)
    with pytest.raises(ConfigError, match=rf"{section}\.{key} must not exceed imu\.rate_hz"):
        from_dict({"imu": {"rate_hz": 50.0}, section: {key: 60.0}})


def test_zero_noise_everywhere_is_legal():
    """--ideal and users set noises to zero; the filter handles it (a documented floor), so no refusal."""
    cfg = from_dict({"imu": {k: 0.0 for k in ("accel_bias_mg", "gyro_bias_deg_per_h", "accel_noise_mps_per_sqrt_h",
                                              "gyro_noise_deg_per_sqrt_h", "accel_bias_rw_mps2_per_sqrt_s",
                                              "gyro_bias_rw_deg_per_s_per_sqrt_s")},
                     "dvl": {"noise_mps": 0.0, "bias_mps": 0.0, "scale_factor_pct": 0.0},
                     "pressure": {"noise_pa": 0.0},
                     "magnetometer": {"roll_pitch_noise_deg": 0.0, "yaw_noise_deg": 0.0}})
    assert cfg.dvl.noise_mps == 0.0 and cfg.pressure.noise_pa == 0.0 and cfg.imu == cfg.imu.ideal()


def test_integers_beyond_the_float_range_are_refused():
    with pytest.raises(ConfigError, match=r"imu\.accel_bias_mg must be a finite number, got <an integer of about 401"):
        from_dict({"imu": {"accel_bias_mg": 10**400}})


@pytest.mark.parametrize("section, key, value", [
    ("run", "methods", ["lc", "lc"]), ("run", "aiding", ["dvl", "depth", "dvl"]), ("dvl", "beams", [2, 2]),
])
def test_duplicates_are_refused(section, key, value):
    with pytest.raises(ConfigError, match=rf"{section}\.{key}"):
        from_dict({section: {key: value}})


@pytest.mark.parametrize("section, key, item", [("run", "methods", "lc"), ("run", "aiding", "dvl"), ("dvl", "beams", 1),
                                                ("dvl", "lever_arm_m", 0.5)])
def test_huge_lists_are_refused_cheaply(section, key, item):
    """A 100,000-entry list used to be accepted (methods grew a 3.3 GB run); now its length is
    checked before any entry, and the message quotes the start and the size."""
    huge = [item] * 100_000
    tracemalloc.start()
    try:
        with pytest.raises(ConfigError) as info:
            from_dict({section: {key: huge}})
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert f"{section}.{key}" in str(info.value) and "(100000 items)" in str(info.value)
    assert len(str(info.value)) < 300 and peak < 8 << 20, peak     # one tuple copy at most (0.8 MB)


def test_huge_outage_list_is_refused():
    outage = {"beams": [1], "start_s": 1.0, "end_s": 2.0}
    with pytest.raises(ConfigError, match=r"dvl\.outages must be a list of at most 1000"):
        from_dict({"dvl": {"outages": [outage] * 1001}})


@pytest.mark.parametrize("base, overlay", [
    ({"trajectory": True}, {"trajectory": {"duration_s": 3.0}}),
    ({"trajectory": {"duration_s": 3.0}}, {"trajectory": True}),   # a file's section under a preset's
], ids=["base", "overlay"])
def test_merge_keeps_a_section_that_is_not_a_table(base, overlay):
    with pytest.raises(ConfigError, match=r"\[trajectory\] must be a table, got True"):
        from_dict(merge(base, overlay))


@pytest.mark.parametrize("value, expected", [
    ("short", "'short'"),
    ("x" * 500_000, "'" + "x" * 60 + "'... (500000 characters)"),
    (list(range(100_000)), "... (100000 items)"),
    (10**5000, "<an integer of about 5001 digits>"),
    (1.5, "1.5"),
], ids=["short", "long string", "long list", "huge integer", "float"])
def test_show_shortens_long_values(value, expected):
    text = show(value)
    assert text.endswith(expected) and len(text) < 100


def test_show_path_keeps_the_file_name():
    long = "/" + "d" * 300 + "/run.toml"
    assert show_path(long).startswith("'...") and "run.toml" in show_path(long) and "(310 characters)" in show_path(long)
    assert show_path("a.toml") == "'a.toml'"


def test_read_toml_refuses_special_and_large_files_before_reading(tmp_path, monkeypatch):
    opened = []
    real_open = os.open
    monkeypatch.setattr("tauvcore.config.os.open", lambda *a, **k: opened.append(a[0]) or real_open(*a, **k))
    for path, needle in (("/dev/zero", "not a regular file"), (str(tmp_path), "is a directory")):
        with pytest.raises(ConfigError, match=needle):
            read_toml(path)
    big = tmp_path / "big.toml"
    big.write_bytes(b" " * (MAX_CONFIG_BYTES + 1))
    with pytest.raises(ConfigError, match="larger than"):
        read_toml(str(big))
    assert opened == []                                   # refused on stat alone
    ok = tmp_path / "ok.toml"
    ok.write_bytes(b"[run]\nseed = 4\n" + b" " * (MAX_CONFIG_BYTES - 20))
    assert read_toml(str(ok)) == {"run": {"seed": 4}} and opened == [str(ok)]


@pytest.mark.parametrize("value", ["bogus", "AUTO", "", True, [1], {"a": 1}, float("nan"), float("inf")])
def test_nsv_epsilon_is_a_number_or_auto(value):
    with pytest.raises(ConfigError) as info:
        from_dict({"partial": {"nsv_epsilon_m2_per_s2": value}})
    assert "partial.nsv_epsilon_m2_per_s2" in str(info.value)


def test_nsv_epsilon_auto_is_derived_from_the_vehicle_and_a_number_is_taken_as_given():
    config = Config()
    assert config.partial.nsv_epsilon_m2_per_s2 == "auto"
    tr = config.trajectory
    sway = tr.speed_mps * math.tan(math.radians(tr.turn_sideslip_deg))      # 0.105 m/s
    turn_s = math.pi * tr.turn_radius_m / tr.speed_mps                      # 23.6 s
    assert config.nsv_epsilon_value_m2_per_s2() == pytest.approx(sway**2 * turn_s * config.dvl.rate_hz, rel=1e-12)
    assert config.nsv_epsilon_value_m2_per_s2() == pytest.approx(0.259, abs=1e-3)
    # a hull that does not slip: the 1 cm/s floor, never a zero variance
    assert config.replace("trajectory", turn_sideslip_deg=0.0).nsv_epsilon_value_m2_per_s2() == 1e-4
    # a faster ping rate: more pings share one turn's sway, each carries more variance
    assert config.replace("dvl", rate_hz=5.0).nsv_epsilon_value_m2_per_s2() == pytest.approx(
        5.0 * config.nsv_epsilon_value_m2_per_s2(), rel=1e-12)
    assert from_dict({"partial": {"nsv_epsilon_m2_per_s2": 0.05}}).nsv_epsilon_value_m2_per_s2() == 0.05
    assert from_dict({"partial": {"nsv_epsilon_m2_per_s2": 2}}).partial.nsv_epsilon_m2_per_s2 == 2.0
