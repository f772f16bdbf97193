"""Calibration: the DVL head's misalignment as the sensor model makes it, the [calibration] section as
the replay applies it (tauvcore.eval.corrections), and its estimation (tauvcore.eval.calibration)
on logs whose answer is known exactly; `tauv calibrate` on the command line."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from app.cli import main
from tauvcore import units
from tauvcore.config import CalibrationConfig, Config, from_dict, load_toml, to_toml
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval import calibration as cal
from tauvcore.eval.corrections import calibrated, corrected_beams
from tauvcore.eval.replay import LogRows
from tauvcore.geo.earth import Earth
from tauvcore.geo.rotations import C_nb_from_euler, euler_from_C_nb
from tauvcore.logs import Log, read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors import dvl
from tauvcore.truth import generate
from tauvcore.truth.kinematic import TrajectoryConfig
from tauvcore.validation import ConfigError

MISALIGNMENT_DEG = (0.3, -0.5, 1.0)
OFFSET_PCT = 0.5
BORESIGHT_DEG = (0.2, -0.15, 0.4)


def _rotated_reference(tables: dict, C_rb: np.ndarray) -> dict:
    """The tables with the reference's attitude that of a body ``C_rb`` off the IMU's: ``C_nr = C_nb C_rb^T``."""
    ref = dict(tables["reference"])
    euler = np.column_stack([ref["roll_rad"], ref["pitch_rad"], ref["yaw_rad"]])
    turned = euler_from_C_nb(C_nb_from_euler(euler) @ C_rb.T)
    ref["roll_rad"], ref["pitch_rad"], ref["yaw_rad"] = turned.T
    return {**tables, "reference": ref}


def _log(tmp_path, config: Config, seed: int = 0, boresight_deg=None, name: str = "log") -> Log:
    tables = simulation_tables([SimChunk.whole(simulate(config, np.random.default_rng(seed)))])
    if boresight_deg is not None:
        tables = _rotated_reference(tables, C_nb_from_euler(np.asarray(boresight_deg) * units.DEG))
    write_log(tmp_path / name, tables, "parquet")
    return read_log(tmp_path / name)


EXCITED = {"name": "figure8", "duration_s": 120.0, "dive_rate_mps": 0.5, "turn_sideslip_deg": 10.0,
           "seabed_depth_m": 120.0}
"""A figure eight diving at 0.5 m/s and slipping 10 deg in its turns: velocity along every body axis,
so the DVL's roll is observable too (docs/calibration.md)."""


def _exact(config: Config) -> Config:
    """``config`` with a perfect IMU and a DVL whose only errors are its misalignment and offset."""
    return config.replace("imu", **dataclasses.asdict(config.imu.ideal())).replace(
        "dvl", noise_mps=0.0, bias_mps=0.0, bias_rw_mps_per_sqrt_s=0.0, scale_factor_pct=0.0,
        scale_factor_rw_pct_per_sqrt_s=0.0, max_altitude_m=300.0,
        misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT)


# --------------------------------------------------------------------------------- sensor model

def test_a_misaligned_head_measures_its_velocity_in_its_own_frame() -> None:
    """Noise-free pings of a head turned by C_bh: each beam is the true beam direction C_bh b_k
    (DvlConfig.true_A_b) times (1 + SF) the head's body velocity; aligned, the nominal beams."""
    truth = generate(TrajectoryConfig(name="figure8", duration_s=30.0), Earth(), 50.0)
    config = dvl.DvlConfig(misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT).ideal()
    assert not config.misaligned and config.scale_factor_offset == 0.0  # ideal(): they are errors
    config = dataclasses.replace(config, misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT)
    data = dvl.simulate(truth, config, np.random.default_rng(0))
    i = data.index
    head_b = truth.vel_b[i] * (1.0 + OFFSET_PCT / 100.0) + np.cross(truth.omega_nb_b[i], config.l_dvl_b)
    np.testing.assert_allclose(data.scale_factor, OFFSET_PCT / 100.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(data.y_beam_mps, head_b @ config.true_A_b.T, rtol=0, atol=1e-12)
    C_bh = C_nb_from_euler(np.asarray(MISALIGNMENT_DEG) * units.DEG)
    np.testing.assert_allclose(data.y_beam_mps, (head_b @ C_bh) @ config.A_b.T, rtol=0, atol=1e-12)
    aligned = dvl.simulate(truth, dataclasses.replace(config, misalignment_deg=(0.0, 0.0, 0.0)), np.random.default_rng(0))
    assert np.abs(aligned.y_beam_mps - data.y_beam_mps).max() > 0.01


def test_the_new_dvl_fields_are_checked_and_round_trip() -> None:
    with pytest.raises(ConfigError, match=r"dvl\.misalignment_deg\[2\] must be within \[-10, 10\]"):
        dvl.DvlConfig(misalignment_deg=(0.0, 0.0, 11.0))
    with pytest.raises(ConfigError, match=r"dvl\.scale_factor_offset_pct must be within \[-10, 10\], got 12"):
        dvl.DvlConfig(scale_factor_offset_pct=12.0)
    config = Config().replace("dvl", misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=-0.3).replace(
        "calibration", dvl_misalignment_deg=(1.0, 2.0, 3.0), dvl_scale_factor_pct=0.4, imu_boresight_deg=(0.1, 0, 0))
    assert from_dict(tomllib.loads(to_toml(config))) == config


@pytest.mark.parametrize("data, needle", [
    ({"calibration": {"dvl_misalignment_deg": [0.0, 31.0, 0.0]}}, r"calibration\.dvl_misalignment_deg\[1\].*31"),
    ({"calibration": {"dvl_scale_factor_pct": 11.0}}, r"calibration\.dvl_scale_factor_pct.*11"),
    ({"calibration": {"imu_boresight_deg": [0.0, 0.0]}}, r"calibration\.imu_boresight_deg.*0\.0, 0\.0"),
    ({"calibration": {"dvl_misalignment": [0.0, 0.0, 0.0]}}, r"calibration\.dvl_misalignment"),
])
def test_a_bad_calibration_section_names_the_key_and_the_value(data, needle) -> None:
    with pytest.raises(ConfigError, match=needle):
        from_dict(data)


# ------------------------------------------------------------------------------------ applied

def test_zero_calibration_leaves_the_replay_s_rows_as_they_were(tmp_path) -> None:
    """A zero [calibration] (the default, or written out) is no correction at all: the same log, the
    same rows and pings, bit for bit."""
    config = Config().replace("trajectory", name="figure8", duration_s=30.0)
    log = _log(tmp_path, config)
    zero = from_dict({"calibration": {"dvl_misalignment_deg": [0.0, 0.0, 0.0], "dvl_scale_factor_pct": 0.0,
                                      "imu_boresight_deg": [0.0, 0.0, 0.0]}}, base=config)
    assert calibrated(log, zero.calibration, zero.dvl.A_b) is log
    a, b = LogRows(config, log, np.random.default_rng(1)), LogRows(zero, log, np.random.default_rng(1))
    for x, y in zip(a.rows(0, a.num_samples), b.rows(0, b.num_samples), strict=True):
        for f in dataclasses.fields(x):
            va, vb = getattr(x, f.name), getattr(y, f.name)
            if isinstance(va, np.ndarray):
                np.testing.assert_array_equal(va, vb, err_msg=f.name)
    for name, sa in a.sources.items():
        for column, values in sa.values.items():
            np.testing.assert_array_equal(values, b.sources[name].values[column], err_msg=f"{name}.{column}")


def test_the_true_calibration_turns_a_misaligned_log_into_the_aligned_one(tmp_path) -> None:
    """Noise-free: a log of a misaligned head with (1 + offset) scale, corrected by its true
    calibration, holds the aligned head's beams (every ping of four beams); its reference turned by a
    boresight and turned back is the IMU's attitude."""
    base = Config().replace("trajectory", name="figure8", duration_s=40.0)
    exact = _exact(base)
    misaligned = _log(tmp_path, exact, boresight_deg=BORESIGHT_DEG, name="mis")
    aligned = _log(tmp_path, exact.replace("dvl", misalignment_deg=(0.0, 0.0, 0.0), scale_factor_offset_pct=0.0),
                   name="aligned")
    truth = CalibrationConfig(dvl_misalignment_deg=MISALIGNMENT_DEG, dvl_scale_factor_pct=OFFSET_PCT,
                              imu_boresight_deg=BORESIGHT_DEG)
    fixed = calibrated(misaligned, truth, base.dvl.A_b)
    assert np.abs(misaligned.dvl_beams_mps - aligned.dvl_beams_mps).max() > 0.01
    # eq. 15 scales the body velocity, not the lever arm's omega x l; the correction divides the
    # head's whole velocity by 1 + s, so the lever arm's part is off by its s / (1 + s): 1e-4 m/s here
    sim = simulate(exact, np.random.default_rng(0))
    rows = sim.dvl.index
    arm = np.cross(sim.truth.omega_nb_b[rows], exact.dvl.l_dvl_b) @ base.dvl.A_b.T
    expected = aligned.dvl_beams_mps + arm * (1.0 / (1.0 + OFFSET_PCT / 100.0) - 1.0)
    np.testing.assert_allclose(fixed.dvl_beams_mps, expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(C_nb_from_euler(fixed.ref_euler), C_nb_from_euler(aligned.ref_euler), rtol=0, atol=1e-12)
    # a body-velocity table (A-KIT's): the same correction on the head velocity
    head = expected @ np.linalg.pinv(base.dvl.A_b).T
    body = dataclasses.replace(misaligned, dvl_beams_mps=None,
                               dvl_body_mps=misaligned.dvl_beams_mps @ np.linalg.pinv(base.dvl.A_b).T)
    np.testing.assert_allclose(calibrated(body, truth, base.dvl.A_b).dvl_body_mps, head, rtol=0, atol=1e-9)


def test_a_ping_with_fewer_than_three_beams_is_corrected_for_the_scale_factor_only() -> None:
    """Three or four beams: the head velocity turned and scaled, the least-squares residual kept;
    one or two: divided by 1 + s."""
    A = dvl.beam_directions_b(20.0 * units.DEG)
    M = C_nb_from_euler(np.array([0.0, 0.0, 0.02])) / 1.01
    v = np.array([2.0, 0.1, 0.05])
    y = np.tile(A @ v, (3, 1)) + np.array([0.01, -0.02, 0.0, 0.005])  # beam biases
    y[1, 3] = np.nan
    y[2, 1:] = np.nan
    out = corrected_beams(y, A, M)
    residual = y[0] - A @ np.linalg.lstsq(A, y[0], rcond=None)[0]
    np.testing.assert_allclose(out[0], A @ (M @ np.linalg.lstsq(A, y[0], rcond=None)[0]) + residual, atol=1e-12)
    np.testing.assert_allclose(out[1, :3], A[:3] @ (M @ np.linalg.solve(A[:3], y[1, :3])), atol=1e-12)
    assert np.isnan(out[1, 3]) and np.isnan(out[2, 1:]).all()
    assert out[2, 0] == pytest.approx(y[2, 0] / 1.01, abs=1e-15)


# ------------------------------------------------------------------------------------ estimated

def test_the_rotation_s_partials_are_its_central_differences() -> None:
    euler = np.array([0.3, -0.2, 1.1])
    C, dC = cal.zyx_partials(euler)
    np.testing.assert_allclose(C, C_nb_from_euler(euler), atol=1e-15)
    h = 1e-6
    for j in range(3):
        step = np.zeros(3)
        step[j] = h
        fd = (C_nb_from_euler(euler + step) - C_nb_from_euler(euler - step)) / (2 * h)
        np.testing.assert_allclose(dC[j], fd, atol=1e-9)


def test_the_correlation_time_of_white_and_of_first_order_noise() -> None:
    rng = np.random.default_rng(3)
    assert cal.correlation_time(rng.standard_normal(20000)) == pytest.approx(1.0, abs=0.1)
    phi, x = 0.8, np.zeros(20000)
    noise = rng.standard_normal(x.size)
    for k in range(1, x.size):
        x[k] = phi * x[k - 1] + noise[k]
    assert cal.correlation_time(x) == pytest.approx((1 + phi) / (1 - phi), rel=0.2)  # 9 samples


def test_a_noise_free_log_gives_its_calibration_exactly(tmp_path) -> None:
    """A perfect IMU and a DVL whose only errors are its mounting and scale factor offset, the
    reference turned by a boresight: the three are recovered to the model's own precision."""
    exact = _exact(Config().replace("trajectory", **EXCITED))
    log = _log(tmp_path, exact, boresight_deg=BORESIGHT_DEG)
    result = cal.calibrate([("log", log, exact)])
    # to 0.002 deg and %: the simulator scales v_b alone by 1 + SF (eq. 15), the calibration the head's
    # whole velocity, omega x l too (what a sound speed does); 0.005 of omega x l is 1e-4 m/s here
    np.testing.assert_allclose(result.dvl.value, [*MISALIGNMENT_DEG, OFFSET_PCT], atol=2e-3)
    np.testing.assert_allclose(result.boresight.value, BORESIGHT_DEG, atol=2e-5)
    fit = result.logs[0]
    assert fit.dvl_rms_after_mps < 2e-4 and fit.dvl_rms_before_mps > 1e-2
    assert fit.rate_rms_after_dps < 1e-6 and fit.force_rms_after_mps2 < 1e-5
    assert result.config == CalibrationConfig(
        dvl_misalignment_deg=tuple(result.dvl.value[:3]), dvl_scale_factor_pct=result.dvl.value[3],
        imu_boresight_deg=tuple(result.boresight.value))


def test_several_logs_are_one_calibration_and_each_its_own(tmp_path) -> None:
    config = Config().replace("trajectory", **EXCITED).replace(
        "dvl", misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT, max_altitude_m=300.0)
    logs = [(f"log{s}", _log(tmp_path, config, seed=s, name=f"log{s}"), config) for s in range(2)]
    both = cal.calibrate(logs)
    alone = [cal.calibrate([entry]) for entry in logs]
    assert [f.name for f in both.logs] == ["log0", "log1"]
    for one, fit in zip(alone, both.logs, strict=True):
        np.testing.assert_allclose(fit.boresight.value, one.boresight.value, atol=1e-9)  # a log's own
        # its own DVL estimate takes the boresight of both: that of the log alone differs by a little
        assert np.all(np.abs(fit.dvl.value - one.dvl.value) < 0.2 * one.dvl.sigma)
        assert np.all(both.dvl.sigma < one.dvl.sigma)  # two logs know more than one
    for name, part in both.dvl.parts.items():
        assert np.all(np.linalg.eigvalsh(part) > -1e-12), name
    np.testing.assert_allclose(both.dvl.cov, sum(both.dvl.parts.values()), rtol=1e-12)


def test_a_log_without_a_reference_is_refused_naming_it(tmp_path) -> None:
    config = Config().replace("trajectory", name="figure8", duration_s=20.0)
    log = dataclasses.replace(_log(tmp_path, config), ref_t_s=None, ref_position=None, ref_euler=None, ref_vel_n=None)
    with pytest.raises(cal.CalibrationError, match="'dive7': the log has no reference"):
        cal.calibrate([("dive7", log, config)])


# ------------------------------------------------------------------------------------ command line

def test_tauv_calibrate_writes_the_section_replay_takes_and_refuses_to_overwrite(tmp_path, capsys) -> None:
    config = Config().replace("trajectory", **EXCITED).replace(
        "dvl", misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT, max_altitude_m=300.0)
    _log(tmp_path, config, name="dive")
    (tmp_path / "dive" / "log.toml").write_text(
        "[dvl]\nmax_altitude_m = 300.0\n[trajectory]\nseabed_depth_m = 120.0\n", encoding="utf-8")
    out = tmp_path / "cal.toml"
    assert main(["calibrate", str(tmp_path / "dive"), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "DVL misalignment yaw [deg]" in printed and "IMU boresight roll [deg]" in printed
    written = load_toml(str(out))
    assert written.calibration != CalibrationConfig() and written.dvl == Config().dvl
    assert abs(written.calibration.dvl_misalignment_deg[2] - 1.0) < 1.0
    assert "# value +- 1-sigma:" in out.read_text(encoding="utf-8")
    before = out.read_bytes()
    assert main(["calibrate", str(tmp_path / "dive"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--replace" in err and out.read_bytes() == before
    assert main(["calibrate", str(tmp_path / "dive"), "--out", str(tmp_path / "dive" / "x.toml")]) == 2
    assert "is in a log" in capsys.readouterr().err
    assert main(["calibrate", str(tmp_path / "nothere"), "--out", str(tmp_path / "c2.toml")]) == 2
    assert capsys.readouterr().err.count("\n") == 1 and not (tmp_path / "c2.toml").exists()


def test_on_a_level_path_the_roll_s_sigma_says_it_is_not_observable(tmp_path) -> None:
    """A level figure eight at constant speed: the velocity is along x, about which the roll turns
    nothing; its sigma is degrees (and the estimate within it), the pitch's and yaw's tenths."""
    config = Config().replace("trajectory", name="figure8", duration_s=250.0).replace(
        "dvl", misalignment_deg=MISALIGNMENT_DEG, scale_factor_offset_pct=OFFSET_PCT)
    result = cal.calibrate([("level", _log(tmp_path, config, seed=3), config)])
    sigma, value = result.dvl.sigma, result.dvl.value
    assert sigma[0] > 1.0 and sigma[1] < 0.2 and sigma[2] < 0.5
    assert np.all(np.abs(value[:3] - MISALIGNMENT_DEG) < 3.0 * sigma[:3])
