"""Partial DVL availability: enabled beams, scheduled outages, random dropout, and their config.

Given a beam set and outage windows, ``DvlConfig.scheduled_availability`` is a pure function of
time; ``dvl.simulate`` turns it (and the dropout draws) into NaN beams; every bad value raises a
ConfigError naming the field and the value; the TOML file round-trips the outages.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

from tauvcore.config import Config, from_dict, load_toml, to_toml
from tauvcore.geo.earth import Earth
from tauvcore.sensors import dvl
from tauvcore.sensors.dvl import DvlConfig, Outage
from tauvcore.truth import TrajectoryConfig, generate
from tauvcore.validation import ConfigError

IMU_RATE_HZ = 150.0
ALL = [True, True, True, True]
ONLY_12 = [True, True, False, False]


@pytest.fixture(scope="module")
def truth():
    return generate(TrajectoryConfig(name="figure8", duration_s=100.0), Earth(), IMU_RATE_HZ)


# ------------------------------------------------------------------------------------------ schedule

def test_scheduled_availability_with_beams_1_2():
    t = np.arange(0.0, 250.0, 0.5)
    avail = DvlConfig(beams=(1, 2)).scheduled_availability(t)
    assert avail.shape == (t.size, 4) and avail.dtype == bool
    np.testing.assert_array_equal(avail, np.broadcast_to(ONLY_12, avail.shape))


def test_scheduled_availability_with_an_outage_of_beams_3_4():
    t = np.array([0.0, 49.0, 49.999, 50.0, 50.5, 120.0, 199.999, 200.0, 200.5, 249.0])
    avail = DvlConfig(outages=(Outage((3, 4), 50.0, 200.0),)).scheduled_availability(t)
    inside = (t >= 50.0) & (t < 200.0)                # start included, end excluded
    np.testing.assert_array_equal(inside, [0, 0, 0, 1, 1, 1, 1, 0, 0, 0])
    np.testing.assert_array_equal(avail[inside], np.broadcast_to(ONLY_12, (inside.sum(), 4)))
    np.testing.assert_array_equal(avail[~inside], np.broadcast_to(ALL, ((~inside).sum(), 4)))


def test_scheduled_availability_combines_beams_and_overlapping_outages():
    cfg = DvlConfig(beams=(1, 2, 3), outages=(Outage((1,), 10.0, 30.0), Outage((1, 2), 20.0, 40.0)))
    t = np.array([5.0, 15.0, 25.0, 35.0, 45.0])
    expected = np.array([[1, 1, 1, 0],      # beam 4 never returns
                         [0, 1, 1, 0],      # first window
                         [0, 0, 1, 0],      # both windows
                         [0, 0, 1, 0],      # second window
                         [1, 1, 1, 0]], dtype=bool)
    np.testing.assert_array_equal(cfg.scheduled_availability(t), expected)


# ------------------------------------------------------------------------------------------ simulate

def test_unavailable_beams_are_nan_and_available_ones_are_finite(truth):
    cfg = DvlConfig(beams=(1, 2, 4), outages=(Outage((2, 4), 30.0, 60.0),))
    data = dvl.simulate(truth, cfg, np.random.default_rng(1), num_runs=3)
    expected = cfg.scheduled_availability(data.t_s)
    np.testing.assert_array_equal(data.available, np.broadcast_to(expected[:, None, :], data.available.shape))
    assert np.all(np.isnan(data.y_beam_mps[~data.available]))
    assert np.all(np.isfinite(data.y_beam_mps[data.available]))
    # inside the window only beam 1 is left
    inside = (data.t_s >= 30.0) & (data.t_s < 60.0)
    assert inside.sum() == 30
    np.testing.assert_array_equal(data.available[inside].sum(axis=-1), 1)


def test_dropout_fraction_per_beam(truth):
    p = 0.2
    data = dvl.simulate(truth, DvlConfig(dropout_probability=p), np.random.default_rng(2), num_runs=200)
    missing = ~data.available                          # (M, R, 4); no scheduled loss in this config
    assert missing.shape[0] * missing.shape[1] >= 20_000
    np.testing.assert_allclose(missing.mean(axis=(0, 1)), p, rtol=0, atol=0.02)
    # each beam drops independently: all four together is p^4, not p
    assert np.mean(missing.all(axis=-1)) == pytest.approx(p**4, abs=0.002)
    assert np.all(np.isnan(data.y_beam_mps[missing]))


def test_dropout_only_removes_beams_the_schedule_has(truth):
    cfg = DvlConfig(beams=(1, 2, 3), outages=(Outage((1,), 20.0, 50.0),), dropout_probability=0.3)
    data = dvl.simulate(truth, cfg, np.random.default_rng(3), num_runs=20)
    scheduled = cfg.scheduled_availability(data.t_s)[:, None, :]
    assert not np.any(data.available & ~scheduled)
    frac = 1.0 - data.available[np.broadcast_to(scheduled, data.available.shape)].mean()
    assert frac == pytest.approx(0.3, abs=0.03)


def test_zero_dropout_draws_nothing_from_the_generator(truth):
    """The stream after the DVL is the same with the field at 0 and without it (and with a beam
    schedule, which is deterministic): the sensors simulated after the DVL see the same draws."""
    rng_a, rng_b, rng_c = (np.random.default_rng(4) for _ in range(3))
    a = dvl.simulate(truth, DvlConfig(), rng_a, num_runs=2)
    b = dvl.simulate(truth, DvlConfig(dropout_probability=0.0), rng_b, num_runs=2)
    c = dvl.simulate(truth, DvlConfig(beams=(1, 2), outages=(Outage((1,), 10.0, 20.0),)), rng_c, num_runs=2)
    np.testing.assert_array_equal(a.y_beam_mps, b.y_beam_mps)
    np.testing.assert_array_equal(a.bias_mps, c.bias_mps)
    np.testing.assert_array_equal(a.y_beam_mps[c.available], c.y_beam_mps[c.available])
    after = [r.random(5) for r in (rng_a, rng_b, rng_c)]
    np.testing.assert_array_equal(after[0], after[1])
    np.testing.assert_array_equal(after[0], after[2])


def test_dropout_masks_beams_without_changing_the_others(truth):
    """The dropout draws come after the noise: a returned beam carries the same value as without dropout."""
    clean = dvl.simulate(truth, DvlConfig(), np.random.default_rng(5), num_runs=2)
    rng = np.random.default_rng(5)
    lossy = dvl.simulate(truth, DvlConfig(dropout_probability=0.25), rng, num_runs=2)
    assert (~lossy.available).any()
    np.testing.assert_array_equal(lossy.y_beam_mps[lossy.available], clean.y_beam_mps[lossy.available])
    np.testing.assert_array_equal(lossy.bias_mps, clean.bias_mps)
    np.testing.assert_array_equal(lossy.scale_factor, clean.scale_factor)


# ------------------------------------------------------------------------------------------ validation

@pytest.mark.parametrize(("make", "needles"), [
    pytest.param(lambda: Outage((3, 4), 200.0, 50.0), ["dvl.outages", "200:50"], id="end before start"),
    pytest.param(lambda: Outage((3, 4), 50.0, 50.0), ["dvl.outages", "50:50"], id="empty window"),
    pytest.param(lambda: Outage((3, 4), -1.0, 50.0), ["dvl.outages.start_s", "-1.0"], id="start negative"),
    pytest.param(lambda: Outage((3, 4), 10.0, float("nan")), ["dvl.outages.end_s", "nan"], id="end nan"),
    pytest.param(lambda: Config().replace("dvl", outages=(Outage((3, 4), 50.0, 300.0),)),
                 ["dvl.outages", "50:300", "250"], id="window past the 250 s run"),
    pytest.param(lambda: Config().replace("dvl", outages=(Outage((3, 4), 250.0, 260.0),)),
                 ["dvl.outages", "250:260"], id="window starts at the end"),
    pytest.param(lambda: Config().replace("dvl", outages=(Outage((3, 4), 50.0, 200.0),))
                 .replace("trajectory", duration_s=100.0), ["dvl.outages", "50:200", "100"],
                 id="run shortened below the window"),
    pytest.param(lambda: DvlConfig(dropout_probability=1.5), ["dvl.dropout_probability", "1.5"], id="dropout 1.5"),
    pytest.param(lambda: DvlConfig(dropout_probability=-0.1), ["dvl.dropout_probability", "-0.1"], id="dropout -0.1"),
    pytest.param(lambda: DvlConfig(dropout_probability=float("nan")), ["dvl.dropout_probability", "nan"],
                 id="dropout nan"),
    pytest.param(lambda: Outage((3, 5), 10.0, 20.0), ["dvl.outages.beams", "5"], id="unknown beam 5"),
    pytest.param(lambda: Outage((0,), 10.0, 20.0), ["dvl.outages.beams", "0"], id="unknown beam 0"),
    pytest.param(lambda: Outage((3, 3), 10.0, 20.0), ["dvl.outages.beams", "(3, 3)"], id="repeated beam"),
    pytest.param(lambda: DvlConfig(beams=(1, 5)), ["dvl.beams", "5"], id="dvl.beams unknown beam"),
    pytest.param(lambda: DvlConfig(outages=((3, 4, 50.0, 200.0),)), ["dvl.outages", "(3, 4, 50.0, 200.0)"],
                 id="outage not an Outage"),
])
def test_bad_outage_and_dropout_values_raise_config_error(make, needles):
    with pytest.raises(ConfigError) as info:
        make()
    message = str(info.value)
    for needle in needles:
        assert needle in message, message


def test_window_ending_exactly_at_the_end_of_the_run_is_accepted():
    cfg = Config().replace("dvl", outages=(Outage((3, 4), 50.0, 250.0),))
    assert cfg.dvl.outages[0].end_s == cfg.trajectory.duration_s


@pytest.mark.parametrize(("outages", "needles"), [
    ([{"beams": [3, 4], "start_s": 50.0}], ["dvl.outages[0]", "end_s"]),
    ([{"beams": [3, 4], "start_s": "a", "end_s": 60.0}], ["dvl.outages[0].start_s", "'a'"]),
    ({"beams": [3, 4], "start_s": 50.0, "end_s": 60.0}, ["dvl.outages", "list"]),
    ([{"beams": [9], "start_s": 50.0, "end_s": 60.0}], ["dvl.outages.beams", "9"]),
])
def test_bad_outage_tables_raise_config_error(outages, needles):
    with pytest.raises(ConfigError) as info:
        from_dict({"dvl": {"outages": outages}})
    for needle in needles:
        assert needle in str(info.value), str(info.value)


def test_non_integer_beam_number_is_rejected_or_works():
    """TOML ``beams = [3.0]``: either a ConfigError naming the field, or a working outage of beam 3.
    It must not pass validation and then crash the simulation with an IndexError."""
    try:
        cfg = from_dict({"dvl": {"outages": [{"beams": [3.0], "start_s": 10.0, "end_s": 20.0}]}})
    except ConfigError as exc:
        assert "beams" in str(exc) and "3.0" in str(exc)
        return
    avail = cfg.dvl.scheduled_availability(np.array([5.0, 15.0]))
    np.testing.assert_array_equal(avail, [ALL, [True, True, False, True]])


# ------------------------------------------------------------------------------------------ TOML

def test_toml_round_trip_with_outages_and_dropout(tmp_path):
    cfg = (Config().replace("trajectory", duration_s=300.0)
           .replace("dvl", beams=(1, 2, 3), dropout_probability=0.05,
                    outages=(Outage((3, 4), 50.0, 200.0), Outage((1,), 250.0, 300.0))))
    text = to_toml(cfg)
    assert text.count("[[dvl.outages]]") == 2
    back = from_dict(tomllib.loads(text))
    assert back == cfg
    assert all(isinstance(o, Outage) and isinstance(o.beams, tuple) for o in back.dvl.outages)
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert load_toml(str(path)) == cfg


def test_hand_written_toml_with_integer_times():
    text = "[dvl]\nbeams = [1, 2, 3, 4]\n\n[[dvl.outages]]\nbeams = [3, 4]\nstart_s = 50\nend_s = 200\n"
    cfg = from_dict(tomllib.loads(text))
    assert cfg.dvl.outages == (Outage((3, 4), 50.0, 200.0),)
    assert isinstance(cfg.dvl.outages[0].start_s, float)


def test_toml_section_order_does_not_matter():
    """A file that lengthens the run and schedules an outage late in it is valid whichever section
    comes first; the window check must see the file's duration, not the default 250 s."""
    body_dvl = "[dvl]\noutages = [{beams = [3, 4], start_s = 300.0, end_s = 350.0}]\n"
    body_traj = "[trajectory]\nduration_s = 400.0\n"
    expected = Config().replace("trajectory", duration_s=400.0).replace(
        "dvl", outages=(Outage((3, 4), 300.0, 350.0),))
    assert from_dict(tomllib.loads(body_traj + body_dvl)) == expected
    assert from_dict(tomllib.loads(body_dvl + body_traj)) == expected
