"""A run's settings in words and in its file name (app.reports.settings_text), with known answers."""

from __future__ import annotations

import re

from app.reports.markdown_tables import config_diff_markdown
from app.reports.settings_text import (
    FILE_STEM_MAX,
    changed_settings,
    file_stem,
    flat_config,
    run_words,
    setting_value,
)
from tauvcore.config import Config
from tauvcore.sensors.dvl import Outage

PLAIN = Config().replace("run", methods=("lc", "tc", "nsv", "elc"))
CURRENT = PLAIN.replace("trajectory", current_n_mps=(0.3 * 0.5**0.5, 0.3 * 0.5**0.5, 0.0)).replace(
    "dvl", water_track="both", current_states="random-walk"
)
SAFE = re.compile(r"[A-Za-z0-9._-]+")


def test_the_default_configuration_changes_nothing() -> None:
    assert changed_settings(Config()) == {}
    assert run_words(Config()) == ["straight", "250 s", "seed 0", "INS LC"]
    assert file_stem(Config()) == "tauv-straight-250s-seed0"


def test_a_current_and_water_track_are_in_the_label_and_the_file_name() -> None:
    assert run_words(PLAIN) == ["straight", "250 s", "seed 0", "LC TC NSV ELC"]
    words = run_words(CURRENT)
    assert "current 0.3 m/s towards 45°" in words and "water-track both" in words
    assert "DVL current states random-walk" in words
    stem = file_stem(CURRENT)
    assert stem == "tauv-straight-250s-seed0-lc_tc_nsv_elc-current0.3mps_to45deg-wt_both-dvl_current_states_random-walk"
    assert file_stem(PLAIN) == "tauv-straight-250s-seed0-lc_tc_nsv_elc" != stem


def test_two_runs_differing_only_in_the_smoother_have_different_names() -> None:
    assert file_stem(PLAIN, smoothed=True) == file_stem(PLAIN) + "-smoothed"
    assert run_words(PLAIN, smoothed=True) == [*run_words(PLAIN), "smoother"]


def test_a_replay_names_its_log_and_not_what_the_log_fixes() -> None:
    replayed = PLAIN.replace("trajectory", duration_s=398.0, depth_m=12.0).replace("earth", latitude_deg=54.2)
    assert run_words(replayed, log="dive") == ["log dive", "398 s", "seed 0", "LC TC NSV ELC"]
    assert file_stem(replayed, log="../my log/é") == "tauv-log-.._my_log_-398s-seed0-lc_tc_nsv_elc"


def test_outages_sensors_and_runs_are_named_with_their_units() -> None:
    config = PLAIN.replace("dvl", outages=(Outage((3, 4), 100.0, 150.0),), noise_mps=0.05, beams=(1, 2, 3))
    assert run_words(config, 3)[4:] == ["DVL noise 0.05 m/s", "beams 1,2,3", "beams 3,4 off 100-150 s", "3 runs"]
    assert file_stem(config, 3) == "tauv-straight-250s-seed0-lc_tc_nsv_elc-dvl_noise0.05mps-beams123-b34off100_150s-3runs"


def test_a_monte_carlo_s_random_initial_errors_go_without_saying() -> None:
    drawn = PLAIN.replace("initial_error", mode="random")
    assert file_stem(drawn, 2) == file_stem(PLAIN, 2) == "tauv-straight-250s-seed0-lc_tc_nsv_elc-2runs"
    assert "init_mode_random" in file_stem(drawn, 1)


def test_a_long_name_is_cut_safe_and_still_tells_runs_apart() -> None:
    many = CURRENT.replace(
        "imu", accel_bias_mg=1.0, gyro_bias_deg_per_h=5.0, accel_noise_mps_per_sqrt_h=0.1
    ).replace("dvl", noise_mps=0.05, bias_mps=0.01, scale_factor_pct=1.0)
    stem = file_stem(many, 4, smoothed=True)
    assert len(stem) <= FILE_STEM_MAX and SAFE.fullmatch(stem)
    assert stem == file_stem(many, 4, smoothed=True)  # the same run, the same name
    assert stem != file_stem(many, 4) and stem[:40] == file_stem(many, 4)[:40]


def test_values_are_plain_words_never_python_reprs() -> None:
    assert setting_value("dvl.outages", [{"beams": [3, 4], "start_s": 100.0, "end_s": 150.0}]) == (
        "beams 3,4 off 100-150 s"
    )
    assert setting_value("dvl.outages", []) == "none"
    assert setting_value("trajectory.current_n_mps", [0.0, -0.2, 0.0]) == "0.2 m/s towards 270°"
    assert setting_value("dvl.lever_arm_m", [0.6, 0.0, 0.15]) == "0.6, 0, 0.15 m"
    assert setting_value("imu.gyro_bias_deg_per_h", 3.0) == "3 °/h"
    assert setting_value("partial.nsv_epsilon_m2_per_s2", "auto") == "auto"
    assert setting_value("run.rpm_fallback", True) == "on"


def test_the_difference_table_reads_in_plain_words() -> None:
    config = CURRENT.replace("dvl", outages=(Outage((3, 4), 100.0, 150.0),))
    table = config_diff_markdown(["run 1", "run 2"], [flat_config(PLAIN, 1), flat_config(config, 2)])
    assert "[" not in table and "{" not in table
    lines = table.splitlines()
    assert "| current | still | 0.3 m/s towards 45° |" in lines
    assert "| DVL outages | none | beams 3,4 off 100-150 s |" in lines
    assert "| DVL water track | off | both |" in lines
    assert "| runs | 1 | 2 |" in lines
