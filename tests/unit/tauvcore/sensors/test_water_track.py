"""DVL water-track (tauvcore.sensors.dvl: ``dvl.water_track``, ``water_layer_m``,
``water_track_noise_mps``):

- off, every DVL number is the reference's of the commit before water-track, bit for bit; on, the
  bottom-track numbers (and the draws after the DVL's) stay the same;
- the water-track noise of 10,000 stationary pings: its sample covariance is
  ``water_track_noise_mps^2 I`` (a chi-square test) and its mean ``-(C^T c)(1 + SF) . b_k + bias_k``;
- beyond range in a sheared current: water mode exactly where bottom lock is lost, relative to the
  layer's current, not the vehicle's; in still water, bottom-track's noise-free value;
- "always": no beam bottom-tracks; a layer below the seabed returns nothing;
- "both": the bottom-track beams are "off"'s bit for bit, the water-track beams "always"'s (and so,
  where bottom lock is lost, "beyond_range"'s); a log, ``tauv run --save-log`` and a bag (one topic
  or two) keep both velocities of a beam;
- bad settings are one line naming the field and the value (the CLI's exit 2: tests/unit/app/test_cli.py);
- a log, ``tauv run --save-log`` and a bag keep each beam's mode; an old log reads as bottom-track;
- chunked equals whole.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import pathlib

import numpy as np
import pytest
from scipy.stats import chi2

from tauvcore.aiding import dvl_beams
from tauvcore.config import Config
from tauvcore.engine.simulation import SimChunk, chunks_of, simulate
from tauvcore.engine.source_streams import SourceStream
from tauvcore.eval.replay import log_simulation
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import C_nb_from_euler
from tauvcore.logs import read_log
from tauvcore.logs.bags import read_bag, read_mapping
from tauvcore.logs.bags.dvl_table import _pairs
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors import dvl
from tauvcore.sensors.dvl import MODE_BOTH, MODE_BOTTOM, MODE_NONE, MODE_WATER, DvlConfig, Outage
from tauvcore.sensors.stream import SensorStreams
from tauvcore.truth import Truth, generate
from tauvcore.truth.current import CurrentField, current_field
from tauvcore.truth.kinematic import TruthStream, bathymetry
from tauvcore.validation import ConfigError, LogError
from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

ROOT = pathlib.Path(__file__).resolve().parents[4]
_spec = importlib.util.spec_from_file_location("make_dvl_reference", ROOT / "scripts" / "make_dvl_reference.py")
ref = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ref)
REFERENCE = np.load(ROOT / "tests" / "fixtures" / "dvl_reference.npz")


def same_as_reference(actual: np.ndarray, key: str) -> None:
    """``actual`` is the saved reference's ``key``: the same shape, masks, flags and draws exactly,
    every number within a few units in the last place (the reference was written on one processor;
    another's vector instructions may round a sine or a square root in the last bit)."""
    expected = REFERENCE[key]
    actual = np.asarray(actual)
    assert actual.shape == expected.shape, key
    if expected.dtype.kind == "f":
        np.testing.assert_allclose(actual, expected, rtol=1e-15, atol=1e-300, equal_nan=True, err_msg=key)
    else:
        np.testing.assert_array_equal(actual, expected, err_msg=key)

# the reference's figure eight (its beams cross the 40.2 m range as it rolls) in a sheared current
CURRENT = {"current_n_mps": (0.3, -0.2, 0.0), "current_shear_ne_per_s": (0.01, -0.005)}
TRAJECTORY = dataclasses.replace(ref.TRAJECTORY, **CURRENT)
QUIET = {"noise_mps": 0.0, "water_track_noise_mps": 0.0, "bias_rw_mps_per_sqrt_s": 0.0,
         "scale_factor_rw_pct_per_sqrt_s": 0.0}
"""No white noise and no walks: a beam's value is its model's, the turn-on bias and scale factor kept."""
FIELDS = ("t_s", "index", "y_beam_mps", "available", "bias_mps", "scale_factor", "slant_range_m", "y_water_mps",
          "water_available")


def _layer_current_b(truth: Truth, index: np.ndarray, config: DvlConfig, field: CurrentField) -> np.ndarray:
    """The current of the layer ``water_layer_m`` below the DVL head, in the body frame, (M, 3)."""
    C = truth.C_nb[index]
    depth = truth.depth_m[index] + (C @ config.l_dvl_b)[:, 2] + config.water_layer_m
    return np.einsum("mji,mj->mi", C, field.velocity_n_mps(truth.t_s[index], depth))


# ------------------------------------------------------------------------------------------ off

def test_water_track_off_leaves_every_dvl_number_as_it_was() -> None:
    cases = ref.cases()
    got = ref.arrays(cases)
    assert sorted(got) == sorted(REFERENCE.files)
    for key in REFERENCE.files:
        same_as_reference(got[key], key)
    assert all(d.y_water_mps is None and d.water_available is None for d in cases.values())
    assert all(np.array_equal(d.mode == MODE_BOTTOM, d.available) for d in cases.values())


@pytest.mark.parametrize("mode", ["beyond_range", "always"])
def test_water_track_on_changes_no_bottom_track_number_nor_a_later_draw(mode: str) -> None:
    """The water-track noise comes from a child of the noise stream: the biases, the scale factor, the
    bottom-track beams that keep their lock and what the generator draws next are the off run's."""
    truth = generate(ref.TRAJECTORY, Earth(), ref.RATE_HZ)
    seabed = bathymetry(ref.TRAJECTORY)
    rng_off, rng_on = np.random.default_rng(3), np.random.default_rng(3)
    dvl.simulate(truth, DvlConfig(**ref.DVL), rng_off, 2, seabed)        # the off run, for its generator
    on = dvl.simulate(truth, DvlConfig(**ref.DVL, water_track=mode), rng_on, 2, seabed)
    np.testing.assert_array_equal(rng_on.standard_normal(5), rng_off.standard_normal(5))
    for name in ("t_s", "index", "bias_mps", "scale_factor", "slant_range_m"):
        same_as_reference(getattr(on, name), f"lost/{name}")
    assert on.water_available is not None and on.y_water_mps is not None
    if mode == "beyond_range":
        same_as_reference(on.available, "lost/available")
        same_as_reference(on.y_beam_mps, "lost/y_beam_mps")
        assert on.water_available.any()
    else:
        assert not on.available.any() and np.isnan(on.y_beam_mps).all()
    assert not (on.available & on.water_available).any()
    np.testing.assert_array_equal(np.isfinite(on.y_water_mps), on.water_available)


def test_ideal_zeroes_the_water_track_noise_and_keeps_the_mode() -> None:
    config = DvlConfig(water_track="always", water_layer_m=20.0, water_track_noise_mps=0.3).ideal()
    assert (config.water_track, config.water_layer_m, config.water_track_noise_mps) == ("always", 20.0, 0.0)


# ---------------------------------------------------------------------------------------- noise

def _steady_truth(duration_s: float, rate_hz: float, vel_n: np.ndarray, euler: np.ndarray, depth_m: float) -> Truth:
    """A vehicle at a constant attitude and a constant level velocity at ``depth_m``."""
    t = np.arange(int(round(duration_s * rate_hz)) + 1) / rate_hz
    k = t.size
    C = np.broadcast_to(C_nb_from_euler(euler[None])[0], (k, 3, 3)).copy()
    zero = np.zeros((k, 3))
    pos_n = np.array([0.0, 0.0, depth_m]) + t[:, None] * vel_n
    return Truth(name="steady", earth=Earth(), t_s=t, pos_n=pos_n, vel_n=np.tile(vel_n, (k, 1)),
                 vel_b=np.tile(C[0].T @ vel_n, (k, 1)), C_nb=C, euler=np.tile(euler, (k, 1)), omega_nb_b=zero,
                 omega_ib_b=zero, f_b=zero, dtheta_ib_b=zero, dv_b=zero, step_s=1.0 / rate_hz)


def test_water_track_noise_covariance_and_mean_of_10000_stationary_pings() -> None:
    """Errors ``e_k = y_k - v_b (1 + SF) . b_k`` of 10,000 water-track pings of a vehicle at a steady
    velocity and attitude in a sheared current: their mean is ``-(C^T c)(1 + SF) . b_k + bias_k``
    (c the current 12 m below the head) to 5 standard errors, and their sample covariance about it
    is ``sigma^2 I``: the likelihood-ratio statistic ``N (tr A - ln det A - 4)``, ``A = S / sigma^2``,
    is chi-square with 10 degrees of freedom (below its 1 - 1e-6 quantile, 46.9), each variance's
    ``N S_kk / sigma^2`` within chi-square(N)'s two-sided 1e-6 interval and each covariance within
    5 sigma^2 / sqrt(N)."""
    sigma, n = 0.1, 10_000
    config = DvlConfig(rate_hz=25.0, water_track="always", water_layer_m=12.0, water_track_noise_mps=sigma,
                       bias_rw_mps_per_sqrt_s=0.0, scale_factor_rw_pct_per_sqrt_s=0.0)
    truth = _steady_truth(n / config.rate_hz, 100.0, np.array([1.4, 0.6, 0.0]), np.array([0.05, 0.1, 0.8]), 20.0)
    field = CurrentField(np.array([0.4, -0.3, 0.0]), 20.0, np.array([0.01, 0.004]), np.zeros((2, 0)),
                         np.zeros(0), np.zeros((2, 0)))
    data = dvl.simulate(truth, config, np.random.default_rng(11), seabed=None, current=field)
    assert data.y_water_mps is not None and data.water_available is not None
    assert data.t_s.size == n and data.water_available.all() and not data.available.any()
    sf, bias = data.scale_factor[0], data.bias_mps[0]
    assert np.all(data.scale_factor == sf) and np.all(data.bias_mps == bias) and sf != 0.0
    v_b = truth.vel_b[data.index]
    errors = data.y_water_mps - (v_b * (1.0 + sf)) @ config.A_b.T
    c_b = _layer_current_b(truth, data.index, config, field)
    expected = -(c_b[0] * (1.0 + sf)) @ config.A_b.T + bias
    assert np.ptp(c_b, axis=0).max() < 1e-12                                              # steady
    assert np.abs(expected - bias).min() > 6.0 * sigma / np.sqrt(n)                      # the current seen
    np.testing.assert_allclose(errors.mean(axis=0), expected, rtol=0.0, atol=5.0 * sigma / np.sqrt(n))
    residual = errors - expected
    S = residual.T @ residual / n
    A = S / sigma**2
    statistic = n * (np.trace(A) - np.log(np.linalg.det(A)) - 4)
    assert statistic < chi2.ppf(1.0 - 1e-6, 10), (statistic, S)
    low, high = chi2.ppf([0.5e-6, 1.0 - 0.5e-6], n) / n
    assert np.all((np.diag(A) > low) & (np.diag(A) < high)), np.diag(A)
    assert np.abs(A - np.diag(np.diag(A))).max() < 5.0 / np.sqrt(n), A


# --------------------------------------------------------------------------- beyond range, always

def test_beyond_range_beams_water_track_relative_to_the_layer_s_current() -> None:
    """Where a beam's seabed lies beyond the range it water-tracks, elsewhere it bottom-tracks, with
    the same turn-on bias and scale factor; its value is eq. 15 with the velocity relative to the
    current 10 m below the head, which the shear (0.01 and -0.005 1/s) sets 0.11 m/s apart from the
    current at the vehicle (0.04 m/s along a beam 20 deg from the vertical)."""
    truth = generate(TRAJECTORY, Earth(), ref.RATE_HZ)
    field = current_field(TRAJECTORY)
    assert field is not None and truth.current_n_mps is not None
    config = DvlConfig(rate_hz=5.0, max_altitude_m=40.2, water_track="beyond_range", **QUIET)
    data = dvl.simulate(truth, config, np.random.default_rng(1), 2, bathymetry(TRAJECTORY), field)
    assert data.slant_range_m is not None and data.water_available is not None and data.y_water_mps is not None
    beyond = np.broadcast_to(np.isinf(data.slant_range_m)[:, None], data.available.shape)
    assert 0.02 < beyond.mean() < 0.5
    np.testing.assert_array_equal(data.water_available, beyond)
    np.testing.assert_array_equal(data.available, ~beyond)
    np.testing.assert_array_equal(data.mode, np.where(beyond, MODE_WATER, MODE_BOTTOM))
    i = data.index
    args = (truth.omega_nb_b[i][:, None], config.l_dvl_b, data.scale_factor, data.bias_mps)
    relative = (truth.vel_b[i] - _layer_current_b(truth, i, config, field))[:, None]
    exact = dvl.beam_velocity(config.A_b, relative, *args)
    np.testing.assert_allclose(data.y_water_mps[beyond], exact[beyond], rtol=0.0, atol=1e-12)
    at_vehicle = dvl.beam_velocity(config.A_b, truth.vel_water_b[i][:, None], *args)
    assert np.abs(at_vehicle - exact)[beyond].max() > 0.03                    # the layer's current, not the vehicle's
    bottom = dvl.beam_velocity(config.A_b, truth.vel_b[i][:, None], *args)
    np.testing.assert_allclose(data.y_beam_mps[~beyond], bottom[~beyond], rtol=0.0, atol=1e-12)


def test_in_still_water_water_track_is_bottom_track_s_noise_free_value() -> None:
    truth = generate(ref.TRAJECTORY, Earth(), ref.RATE_HZ)
    config = DvlConfig(rate_hz=5.0, water_track="always", **QUIET)
    data = dvl.simulate(truth, config, np.random.default_rng(2), 1, None, None)
    assert data.water_available is not None and data.water_available.all()
    bottom = DvlConfig(rate_hz=5.0, **QUIET)
    expected = dvl.simulate(truth, bottom, np.random.default_rng(2), 1, None, None)
    np.testing.assert_array_equal(data.y_water_mps, expected.y_beam_mps)


@pytest.mark.parametrize("layer_m, returns", [(10.0, True), (45.0, False)])
def test_always_tracks_the_water_and_a_layer_below_the_seabed_returns_nothing(layer_m: float, returns: bool) -> None:
    """40 m above a flat seabed: a layer 10 m below the head is water-tracked by every beam of every
    ping (no beam bottom-tracks); one 45 m below lies in the seabed: no beam returns."""
    truth = generate(TRAJECTORY, Earth(), ref.RATE_HZ)
    config = DvlConfig(rate_hz=5.0, water_track="always", water_layer_m=layer_m)
    data = dvl.simulate(truth, config, np.random.default_rng(4), 2, bathymetry(TRAJECTORY), current_field(TRAJECTORY))
    assert data.water_available is not None and data.y_water_mps is not None
    assert not data.available.any() and np.isnan(data.y_beam_mps).all()
    assert data.water_available.all() == returns and data.water_available.any() == returns
    np.testing.assert_array_equal(data.mode, MODE_WATER if returns else MODE_NONE)
    np.testing.assert_array_equal(np.isfinite(data.y_water_mps), data.water_available)


def test_schedule_and_dropout_apply_to_water_tracking_beams() -> None:
    truth = generate(TRAJECTORY, Earth(), ref.RATE_HZ)
    config = DvlConfig(rate_hz=5.0, water_track="always", beams=(1, 2, 4), dropout_probability=0.3,
                       outages=(Outage((1,), 10.0, 20.0),))
    data = dvl.simulate(truth, config, np.random.default_rng(5), 2, None, current_field(TRAJECTORY))
    assert data.water_available is not None
    assert not data.water_available[:, :, 2].any()
    assert not data.water_available[(data.t_s >= 10.0) & (data.t_s < 20.0), :, 0].any()
    assert 0.6 < data.water_available[:, :, 1].mean() < 0.8


# ------------------------------------------------------------------------------------------ both

@pytest.mark.parametrize("beyond_range", ["lost", "noisy"])
def test_both_bottom_tracks_as_off_and_water_tracks_as_always(beyond_range: str) -> None:
    """"both" on the reference's figure eight: the bottom-track beams, biases, scale factor and the
    generator's next draws are the reference's of "off" bit for bit (both bottom-lock models); the
    water-track beams, values and mask, are "always"'s; with "lost", where bottom lock is lost they are
    "beyond_range"'s; a beam with bottom lock reports both (MODE_BOTH), the modes bit flags."""
    truth = generate(ref.TRAJECTORY, Earth(), ref.RATE_HZ)
    seabed = bathymetry(ref.TRAJECTORY)
    modes = ("off", "both", "always") + (("beyond_range",) if beyond_range == "lost" else ())
    rngs = {mode: np.random.default_rng(3) for mode in modes}
    runs = {mode: dvl.simulate(truth, DvlConfig(**ref.DVL, beyond_range=beyond_range, water_track=mode), rngs[mode],
                               2, seabed) for mode in modes}
    both = runs["both"]
    for name in ("t_s", "index", "y_beam_mps", "available", "bias_mps", "scale_factor", "slant_range_m"):
        same_as_reference(getattr(both, name), f"{beyond_range}/{name}")
    np.testing.assert_array_equal(rngs["both"].standard_normal(5), rngs["off"].standard_normal(5))
    assert both.y_water_mps is not None and both.water_available is not None
    np.testing.assert_array_equal(both.y_water_mps, runs["always"].y_water_mps)
    np.testing.assert_array_equal(both.water_available, runs["always"].water_available)
    assert (both.available & both.water_available).mean() > 0.5
    np.testing.assert_array_equal(both.mode == MODE_BOTH, both.available & both.water_available)
    np.testing.assert_array_equal(both.mode & MODE_BOTTOM > 0, both.available)
    np.testing.assert_array_equal(both.mode & MODE_WATER > 0, both.water_available)
    if beyond_range == "lost":
        beyond = runs["beyond_range"]
        assert beyond.water_available is not None and beyond.y_water_mps is not None and beyond.water_available.any()
        np.testing.assert_array_equal(both.water_available & ~both.available, beyond.water_available)
        np.testing.assert_array_equal(both.y_water_mps[beyond.water_available],
                                      beyond.y_water_mps[beyond.water_available])
    else:  # a beam beyond range returns its noisy bottom-track velocity and its water-track one
        out = np.broadcast_to(np.isinf(both.slant_range_m)[:, None], both.available.shape)
        assert (out & both.available & both.water_available).any()


@pytest.mark.parametrize("layer_m, returns", [(10.0, True), (45.0, False)])
def test_both_water_tracks_where_the_layer_lies_above_the_seabed(layer_m: float, returns: bool) -> None:
    """40 m above a flat seabed in a sheared current: bottom-track is "off"'s whatever the layer; a layer
    10 m below the head is water-tracked by every beam of every ping, relative to its current; one 45 m
    below lies in the seabed: no beam water-tracks."""
    truth = generate(TRAJECTORY, Earth(), ref.RATE_HZ)
    field, seabed = current_field(TRAJECTORY), bathymetry(TRAJECTORY)
    assert field is not None
    config = DvlConfig(rate_hz=5.0, water_track="both", water_layer_m=layer_m, **QUIET)
    data = dvl.simulate(truth, config, np.random.default_rng(4), 2, seabed, field)
    off = dvl.simulate(truth, dataclasses.replace(config, water_track="off"), np.random.default_rng(4), 2, seabed, field)
    for name in ("y_beam_mps", "available", "bias_mps", "scale_factor"):
        np.testing.assert_array_equal(getattr(data, name), getattr(off, name), err_msg=name)
    assert data.available.all() and data.water_available is not None and data.y_water_mps is not None
    assert data.water_available.all() == returns and data.water_available.any() == returns
    np.testing.assert_array_equal(data.mode, MODE_BOTH if returns else MODE_BOTTOM)
    if returns:
        i = data.index
        relative = (truth.vel_b[i] - _layer_current_b(truth, i, config, field))[:, None]
        exact = dvl.beam_velocity(config.A_b, relative, truth.omega_nb_b[i][:, None], config.l_dvl_b,
                                  data.scale_factor, data.bias_mps)
        np.testing.assert_allclose(data.y_water_mps, exact, rtol=0.0, atol=1e-12)
        assert np.abs(data.y_water_mps - data.y_beam_mps).max() > 0.1          # the current seen by water-track only


def test_source_data_refuses_a_beam_with_both_without_the_both_columns() -> None:
    truth = generate(TRAJECTORY, Earth(), ref.RATE_HZ)
    data = dvl.simulate(truth, DvlConfig(rate_hz=5.0, water_track="both"), np.random.default_rng(4), 1)
    with pytest.raises(ValueError, match="both"):
        dvl_beams.source_data(data)
    values = dvl_beams.source_data(data, both=True).values
    assert set(dvl_beams.WATER_BEAMS) <= set(values) and not set(dvl_beams.WATER_TRACK) & set(values)


# ------------------------------------------------------------------------------------ bad input

@pytest.mark.parametrize("changes, words", [
    ({"water_track": "sometimes"}, ("dvl.water_track", "'sometimes'", "off, beyond_range, always")),
    ({"water_track": "always", "water_layer_m": 150.0},
     ("dvl.water_layer_m 150 m lies beyond the DVL's range dvl.max_altitude_m 100 m",)),
    ({"water_track": "beyond_range", "max_altitude_m": 8.0}, ("dvl.water_layer_m 10 m", "dvl.max_altitude_m 8 m")),
    ({"water_track": "beyond_range", "beyond_range": "noisy"},
     ('dvl.water_track "beyond_range"', 'dvl.beyond_range "lost", got "noisy"')),
    ({"water_layer_m": 0.2}, ("dvl.water_layer_m", "0.2")),
    ({"water_layer_m": float("nan")}, ("dvl.water_layer_m", "nan")),
    ({"water_track_noise_mps": -0.1}, ("dvl.water_track_noise_mps", "-0.1")),
    ({"water_track": "both", "water_layer_m": 150.0}, ("dvl.water_layer_m 150 m", "dvl.max_altitude_m 100 m")),
])
def test_bad_water_track_settings_are_one_line_naming_the_field(changes: dict, words: tuple[str, ...]) -> None:
    with pytest.raises(ConfigError) as raised:
        DvlConfig(**changes)
    message = str(raised.value)
    assert "\n" not in message and all(w in message for w in words), message


def test_water_layer_is_not_held_to_the_range_with_water_track_off() -> None:
    assert DvlConfig(max_altitude_m=5.0).water_layer_m == 10.0              # a shallow-water DVL as before


def test_both_takes_either_bottom_lock_model() -> None:
    """"both" runs water-track beside bottom-track, replacing nothing: "noisy" (a model of the
    bottom-track channel beyond range) is allowed with it, as it is not with "beyond_range"."""
    assert DvlConfig(water_track="both", beyond_range="noisy").beyond_range == "noisy"


# ------------------------------------------------------------------------------ logs and bags

def _water_config(duration_s: float = 20.0) -> Config:
    return (Config().replace("trajectory", name="figure8", duration_s=duration_s, depth_m=20.0, seabed_depth_m=60.0,
                             **CURRENT)
            .replace("dvl", rate_hz=5.0, max_altitude_m=40.2, water_track="beyond_range"))


@pytest.fixture(scope="module")
def water_sim():
    config = _water_config()
    sim = simulate(config, np.random.default_rng(2), 1)
    assert sim.dvl.water_available is not None and sim.dvl.water_available.any() and sim.dvl.available.any()
    return config, sim


def _same_pings(got: dvl.DvlData, expected: dvl.DvlData) -> None:
    for name in ("index", "y_beam_mps", "available", "y_water_mps", "water_available", "bias_mps", "scale_factor"):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_log_round_trip_keeps_each_beam_s_mode(water_sim, tmp_path: pathlib.Path, fmt: str) -> None:
    config, sim = water_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    assert set(dvl_beams.WATER_TRACK) <= set(tables["dvl"])
    write_log(tmp_path / "log", tables, fmt)
    log = read_log(tmp_path / "log")
    assert sim.dvl.water_available is not None
    np.testing.assert_array_equal(log.dvl_water_track, sim.dvl.water_available[:, 0])
    _same_pings(log_simulation(config, log, np.random.default_rng(0)).dvl, sim.dvl)


def test_a_log_without_the_mode_columns_reads_as_bottom_track(water_sim, tmp_path: pathlib.Path) -> None:
    config, sim = water_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    for name in dvl_beams.WATER_TRACK:
        del tables["dvl"][name]
    write_log(tmp_path / "old", tables)
    log = read_log(tmp_path / "old")
    assert log.dvl_water_track is None
    pings = log_simulation(config, log, np.random.default_rng(0)).dvl
    assert pings.y_water_mps is None and pings.water_available is None
    assert sim.dvl.water_available is not None
    np.testing.assert_array_equal(pings.available, sim.dvl.available | sim.dvl.water_available)


def test_bad_mode_columns_are_one_line(water_sim, tmp_path: pathlib.Path) -> None:
    _, sim = water_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    bad = dict(tables["dvl"], beam2_water_track=np.where(np.arange(tables["dvl"]["t_s"].size) == 2, 2.0, 0.0))
    write_log(tmp_path / "two", {**tables, "dvl": bad})
    with pytest.raises(LogError, match=r"dvl\.csv.*: column 'beam2_water_track', row 3: 2\.0 is not 0 or 1"):
        read_log(tmp_path / "two")
    short = {k: v for k, v in tables["dvl"].items() if k != "beam4_water_track"}
    write_log(tmp_path / "three", {**tables, "dvl": short})
    with pytest.raises(LogError, match="missing column 'beam4_water_track'"):
        read_log(tmp_path / "three")


@pytest.fixture(scope="module")
def both_sim():
    config = _water_config().replace("dvl", water_track="both")
    sim = simulate(config, np.random.default_rng(2), 1)
    d = sim.dvl
    assert d.water_available is not None and (d.available & d.water_available).any()
    assert (d.water_available & ~d.available).any()                         # beams beyond range: water-track only
    return config, sim


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_a_log_round_trip_keeps_both_velocities_of_a_beam(both_sim, tmp_path: pathlib.Path, fmt: str) -> None:
    """"both" writes bottom-track in beam1_mps .. and water-track in beam1_water_mps .. (no mode
    columns); the log reads back, and replays, the same pings bit for bit."""
    config, sim = both_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    columns = set(tables["dvl"])
    assert set(dvl_beams.WATER_BEAMS) <= columns and not set(dvl_beams.WATER_TRACK) & columns
    write_log(tmp_path / "log", tables, fmt)
    log = read_log(tmp_path / "log")
    assert log.dvl_water_track is None and log.dvl_water_mps is not None and log.dvl_beams_mps is not None
    assert sim.dvl.y_water_mps is not None
    np.testing.assert_array_equal(log.dvl_water_mps, sim.dvl.y_water_mps[:, 0])
    np.testing.assert_array_equal(log.dvl_beams_mps, sim.dvl.y_beam_mps[:, 0])
    _same_pings(log_simulation(config, log, np.random.default_rng(0)).dvl, sim.dvl)


def test_a_both_log_s_schedule_and_dropout_drop_both_velocities(both_sim, tmp_path: pathlib.Path) -> None:
    config, sim = both_sim
    write_log(tmp_path / "log", simulation_tables([SimChunk.whole(sim)]))
    log = read_log(tmp_path / "log")
    replayed = config.replace("dvl", beams=(1, 2, 4), dropout_probability=0.3)
    pings = log_simulation(replayed, log, np.random.default_rng(6)).dvl
    assert pings.water_available is not None and sim.dvl.water_available is not None
    assert not pings.available[:, :, 2].any() and not pings.water_available[:, :, 2].any()
    dropped = sim.dvl.available & sim.dvl.water_available & ~pings.available
    dropped[:, :, 2] = False
    assert dropped.any() and not (pings.water_available & dropped).any()        # one draw drops a beam's both
    kept = pings.water_available
    np.testing.assert_array_equal(pings.y_water_mps[kept], sim.dvl.y_water_mps[kept])


def test_bad_water_velocity_columns_are_one_line(both_sim, tmp_path: pathlib.Path) -> None:
    _, sim = both_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    flagged = dict(tables["dvl"], **{n: np.zeros(tables["dvl"]["t_s"].size) for n in dvl_beams.WATER_TRACK})
    write_log(tmp_path / "flags", {**tables, "dvl": flagged})
    with pytest.raises(LogError, match=r"dvl\.csv.*: column 'beam1_water_track' beside 'beam1_water_mps': .* not both"):
        read_log(tmp_path / "flags")
    short = {k: v for k, v in tables["dvl"].items() if k != "beam3_water_mps"}
    write_log(tmp_path / "short", {**tables, "dvl": short})
    with pytest.raises(LogError, match="missing column 'beam3_water_mps'") as raised:
        read_log(tmp_path / "short")
    assert "\n" not in str(raised.value)
    fast = dict(tables["dvl"], beam2_water_mps=np.full(tables["dvl"]["t_s"].size, 99.0))
    write_log(tmp_path / "fast", {**tables, "dvl": fast})
    with pytest.raises(LogError, match=r"column 'beam2_water_mps', row 1: 99\.0 is beyond"):
        read_log(tmp_path / "fast")


def test_tauv_replay_refuses_mode_columns_beside_water_velocities(both_sim, tmp_path: pathlib.Path, capsys) -> None:
    from app.cli import main

    _, sim = both_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    write_log(tmp_path / "log", {**tables, "dvl": dict(tables["dvl"], water_track=np.zeros(tables["dvl"]["t_s"].size))})
    assert main(["replay", str(tmp_path / "log"), "--method", "ins"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "column 'water_track' beside 'beam1_water_mps'" in err, err


def test_a_body_velocity_s_water_track_column_marks_every_beam(water_sim, tmp_path: pathlib.Path) -> None:
    _, sim = water_sim
    tables = simulation_tables([SimChunk.whole(sim)])
    t = tables["dvl"]["t_s"]
    flag = (np.arange(t.size) % 3 == 0).astype(float)
    body = {"t_s": t, "vel_x_mps": np.full(t.size, 1.0), "vel_y_mps": np.zeros(t.size),
            "vel_z_mps": np.zeros(t.size), "water_track": flag}
    write_log(tmp_path / "body", {**tables, "dvl": body})
    log = read_log(tmp_path / "body")
    np.testing.assert_array_equal(log.dvl_water_track, np.repeat(flag[:, None] == 1.0, 4, axis=1))


def test_tauv_run_save_log_writes_the_mode(tmp_path: pathlib.Path) -> None:
    from app.cli import main

    (tmp_path / "wt.toml").write_text(
        '[trajectory]\nname = "figure8"\ndepth_m = 20.0\nseabed_depth_m = 60.0\ncurrent_n_mps = [0.3, -0.2, 0.0]\n'
        '[dvl]\nrate_hz = 5.0\nmax_altitude_m = 40.2\nwater_track = "beyond_range"\n')
    code = main(["run", "--config", str(tmp_path / "wt.toml"), "--duration", "20", "--method", "ins,lc",
                 "--save-log", str(tmp_path / "log")])
    assert code == 0
    log = read_log(tmp_path / "log")
    assert log.dvl_water_track is not None and log.dvl_water_track.any() and not log.dvl_water_track.all()


def test_tauv_run_save_log_writes_both_velocities(tmp_path: pathlib.Path) -> None:
    from app.cli import main

    (tmp_path / "both.toml").write_text(
        '[trajectory]\nname = "figure8"\ndepth_m = 20.0\nseabed_depth_m = 60.0\ncurrent_n_mps = [0.3, -0.2, 0.0]\n'
        '[dvl]\nrate_hz = 5.0\nmax_altitude_m = 40.2\nwater_track = "both"\n')
    code = main(["run", "--config", str(tmp_path / "both.toml"), "--duration", "20", "--method", "ins,lc",
                 "--save-log", str(tmp_path / "log")])
    assert code == 0
    log = read_log(tmp_path / "log")
    assert log.dvl_water_track is None and log.dvl_water_mps is not None and log.dvl_beams_mps is not None
    both = np.isfinite(log.dvl_water_mps) & np.isfinite(log.dvl_beams_mps)
    assert both.mean() > 0.5 and (np.isfinite(log.dvl_water_mps) & ~np.isfinite(log.dvl_beams_mps)).any()


def _flagged_mission() -> tuple[Config, dict, dict, np.ndarray]:
    config = mission_config()
    beams, body = mission_tables(config)
    flag = ((np.arange(beams["dvl"]["t_s"].size) // 4) % 2).astype(float)           # 4 pings each way
    beams = {**beams, "dvl": {**beams["dvl"], **{n: flag for n in dvl_beams.WATER_TRACK}}}
    return config, beams, body, flag == 1.0


@pytest.mark.parametrize(("storage", "dvl_type"), [("ros1", "marine_acoustic_msgs/msg/Dvl"),
                                                   ("mcap", "ds_sensor_msgs/msg/Dvl")])
def test_a_bag_s_velocity_mode_becomes_the_beams_mode(tmp_path: pathlib.Path, storage: str, dvl_type: str) -> None:
    """``velocity_mode`` 2 (DVL_MODE_WATER) marks a ping's beams water-track, as the CSV log of the
    same tables does; the mapping's ``water_track = false`` declares them bottom-track."""
    config, beams, _, water = _flagged_mission()
    bag = write_bag(tmp_path / ("m.bag" if storage == "ros1" else "m.mcap"), storage, beams, dvl_type,
                    config.dvl.A_b)
    mapping = tmp_path / "map.toml"
    mapping.write_text('frame = "frd_ned"\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    np.testing.assert_array_equal(log.dvl_water_track, np.repeat(water[:, None], 4, axis=1))
    write_log(tmp_path / "log", beams)
    np.testing.assert_array_equal(read_log(tmp_path / "log").dvl_water_track, log.dvl_water_track)
    mapping.write_text('frame = "frd_ned"\n[dvl]\nwater_track = false\n')
    assert not read_bag(bag, read_mapping(mapping), config.dvl.A_b).dvl_water_track.any()


def test_a_bag_mapping_declares_a_twist_topic_water_track(tmp_path: pathlib.Path) -> None:
    config, _, body, _ = _flagged_mission()
    bag = write_bag(tmp_path / "m.bag", "ros1", body, "geometry_msgs/msg/TwistStamped", config.dvl.A_b)
    mapping = tmp_path / "map.toml"
    mapping.write_text('frame = "frd_ned"\n')
    assert read_bag(bag, read_mapping(mapping), config.dvl.A_b).dvl_water_track is None
    mapping.write_text('frame = "frd_ned"\n[dvl]\nwater_track = true\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    assert log.dvl_water_track is not None and log.dvl_water_track.all()
    mapping.write_text('[dvl]\nwater_track = "yes"\n')
    with pytest.raises(LogError, match=r"map\.toml.*: dvl\.water_track: true .* or false .* got 'yes'") as raised:
        read_mapping(mapping)
    assert "\n" not in str(raised.value)


def _both_mission(max_altitude_m: float = 100.0) -> tuple[Config, dict]:
    """The bag mission with a DVL of water_track "both" (each ping's bottom-track and water-track)."""
    config = (mission_config().replace("trajectory", current_n_mps=(0.3, -0.2, 0.0))
              .replace("dvl", water_track="both", max_altitude_m=max_altitude_m))
    beams, _ = mission_tables(config)
    assert set(dvl_beams.WATER_BEAMS) <= set(beams["dvl"])
    return config, beams


@pytest.mark.parametrize(("storage", "dvl_type", "water_topic", "max_altitude_m"), [
    ("ros1", "marine_acoustic_msgs/msg/Dvl", "/dvl/water", 100.0),     # two topics, every beam both
    ("mcap", "ds_sensor_msgs/msg/Dvl", None, 40.2),                     # one topic, beams beyond range
    ("ros1", "ds_sensor_msgs/msg/Dvl", "/dvl/water", 40.2),
])
def test_a_bag_s_two_messages_of_a_ping_become_one_row_of_both(tmp_path: pathlib.Path, storage: str, dvl_type: str,
                                                               water_topic: str | None, max_altitude_m: float) -> None:
    """A driver that outputs both publishes each ping's bottom-track and water-track (velocity_mode 2)
    messages on one stamp, on its topic or on a second one (the mapping's water_track_topic): the bag
    reads as the CSV log of the same tables, one row per ping, water-track in beam1_water_mps .."""
    config, beams = _both_mission(max_altitude_m)
    bag = write_bag(tmp_path / ("m.bag" if storage == "ros1" else "m.mcap"), storage, beams, dvl_type,
                    config.dvl.A_b, water_topic=water_topic)
    mapping = tmp_path / "map.toml"
    mapping.write_text('frame = "frd_ned"\n' + (f'[dvl]\ntopic = "/dvl"\nwater_track_topic = "{water_topic}"\n'
                                                if water_topic else ""))
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    write_log(tmp_path / "log", beams)
    expected = read_log(tmp_path / "log")
    assert log.dvl_water_track is None and log.dvl_water_mps is not None and expected.dvl_water_mps is not None
    np.testing.assert_array_equal(log.dvl_t_s, expected.dvl_t_s)
    np.testing.assert_array_equal(log.dvl_beams_mps, expected.dvl_beams_mps)
    np.testing.assert_array_equal(log.dvl_water_mps, expected.dvl_water_mps)
    assert np.isfinite(log.dvl_water_mps).all()
    assert np.isnan(log.dvl_beams_mps).any() == (max_altitude_m < 100.0)


def test_a_water_track_topic_is_merged_by_ping_time(tmp_path: pathlib.Path) -> None:
    """Water-track messages on their own topic 3 ms after their bottom-track ones share their rows
    (within the 5 ms of ping_tolerance_s); with ping_tolerance_s = 0.001 each is a row of its own,
    the other mode's columns empty."""
    config, beams = _both_mission()
    dvl, n = beams["dvl"], beams["dvl"]["t_s"].size
    late_s = np.round((dvl["t_s"] + 0.003) * 1e9).astype(np.int64) * 1e-9                # on whole ns, as a bag's
    rows = {"t_s": np.concatenate([dvl["t_s"], late_s]),
            **{b: np.concatenate([dvl[b], np.full(n, np.nan)]) for b in dvl_beams.BEAMS},
            **{w: np.concatenate([np.full(n, np.nan), dvl[w]]) for w in dvl_beams.WATER_BEAMS}}
    order = np.argsort(rows["t_s"], kind="stable")
    apart = {c: v[order] for c, v in rows.items()}
    bag = write_bag(tmp_path / "two.bag", "ros1", {**beams, "dvl": apart}, "ds_sensor_msgs/msg/Dvl", config.dvl.A_b,
                    water_topic="/dvl/water")
    mapping = tmp_path / "map.toml"
    mapping.write_text('frame = "frd_ned"\n[dvl]\ntopic = "/dvl"\nwater_track_topic = "/dvl/water"\n')
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    write_log(tmp_path / "log", beams)
    expected = read_log(tmp_path / "log")
    for name in ("dvl_t_s", "dvl_beams_mps", "dvl_water_mps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(expected, name), err_msg=name)
    mapping.write_text(mapping.read_text() + "ping_tolerance_s = 0.001\n")
    log = read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    write_log(tmp_path / "apart", {**beams, "dvl": apart})
    expected = read_log(tmp_path / "apart")
    assert log.dvl_t_s is not None and log.dvl_t_s.size == 2 * n
    for name in ("dvl_t_s", "dvl_beams_mps", "dvl_water_mps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(expected, name), err_msg=name)


def test_pings_pair_each_water_track_message_with_the_nearest_bottom_track_one_once() -> None:
    t_bottom = np.array([0.0, 1.0, 2.0, 3.0])
    t_water = np.array([0.001, 0.999, 1.002, 2.5, 3.0])
    np.testing.assert_array_equal(_pairs(t_bottom, t_water, 0.005), [0, 1, -1, -1, 3])
    np.testing.assert_array_equal(_pairs(t_bottom, t_water, 0.0), [-1, -1, -1, -1, 3])
    np.testing.assert_array_equal(_pairs(t_bottom[:0], t_water, 0.005), [-1] * 5)


@pytest.mark.parametrize("keys, words", [
    ('topic = "/dvl"\nwater_track_topic = "/dvl"\n', ("dvl.water_track_topic: '/dvl' is the DVL's topic itself",)),
    ('water_track_topic = "/imu/data"\n', ("dvl.water_track_topic: '/imu/data'", "sensor_msgs/msg/Imu",
                                             "cannot feed the dvl table")),
    ('water_track_topic = "/nowhere"\n', ("dvl.water_track_topic: '/nowhere' is not a topic of",)),
    ('ping_tolerance_s = 2.0\n', ("dvl.ping_tolerance_s: 2.0 is outside [0, 1]",)),
])
def test_bad_water_track_topics_are_one_line(tmp_path: pathlib.Path, keys: str, words: tuple[str, ...]) -> None:
    config, beams = _both_mission()
    bag = write_bag(tmp_path / "m.bag", "ros1", beams, "ds_sensor_msgs/msg/Dvl", config.dvl.A_b)
    mapping = tmp_path / "map.toml"
    mapping.write_text('frame = "frd_ned"\n[dvl]\n' + keys)
    with pytest.raises(LogError) as raised:
        read_bag(bag, read_mapping(mapping), config.dvl.A_b)
    message = str(raised.value)
    assert "\n" not in message and all(w in message for w in words), message


# ------------------------------------------------------------------------------ chunked = whole

def _streamed(config: Config, streams: SensorStreams | list[SensorStreams], runs: int, chunk_samples: int) -> dict:
    truth = TruthStream(config.trajectory, Earth(), ref.RATE_HZ, chunk_samples)
    sources = SourceStream(config, np.random.default_rng(0), runs, truth.num_samples, truth.dt_s, streams)
    parts = [dvl_beams.pings(sources.next_chunk(k0, chunk)["dvl"], runs) for k0, chunk in truth]
    return {f: np.concatenate([getattr(p, f) for p in parts]) for f in FIELDS if getattr(parts[0], f) is not None}


@pytest.mark.parametrize("mode", ["beyond_range", "both"])
def test_chunked_equals_whole(mode: str) -> None:
    """Spawned streams cut into chunks of 7, 150 and all samples give the same pings, bit for bit; a
    list of per-run streams gives each run its own alone; the engine's chunks of a simulation
    (chunks_of) hold its pings."""
    config = (_water_config(30.0).replace("trajectory", current_variation_mps=0.1, current_variation_period_s=60.0)
              .replace("dvl", dropout_probability=0.2, outages=(Outage((3,), 5.0, 9.0),), water_track=mode))
    whole = _streamed(config, SensorStreams.spawned(np.random.default_rng(5)), 2, 10**6)
    assert set(whole) == set(FIELDS) - {"slant_range_m"}
    assert whole["water_available"].any() and whole["available"].any()
    for chunk_samples in (7, 150):
        got = _streamed(config, SensorStreams.spawned(np.random.default_rng(5)), 2, chunk_samples)
        for name, value in whole.items():
            np.testing.assert_array_equal(got[name], value, err_msg=f"{chunk_samples} {name}")
    seeds = (3, 4)
    together = _streamed(config, [SensorStreams.spawned(np.random.default_rng(s)) for s in seeds], 2, 150)
    for r, seed in enumerate(seeds):
        alone = _streamed(config, SensorStreams.spawned(np.random.default_rng(seed)), 1, 1000)
        for name in ("y_beam_mps", "y_water_mps", "water_available", "bias_mps"):
            np.testing.assert_array_equal(together[name][:, r], alone[name][:, 0], err_msg=name)
    sim = simulate(config, np.random.default_rng(7), 2)
    chunks = [chunk.dvl for chunk in chunks_of(sim, 130)]
    for name in ("index", "y_beam_mps", "available", "y_water_mps", "water_available"):
        np.testing.assert_array_equal(np.concatenate([getattr(c, name) for c in chunks]), getattr(sim.dvl, name),
                                      err_msg=name)
