"""Tuning the filter's noise by the likelihood of the innovations: an evaluation is the replay to
the last bit, a short simulated log's DVL and IMU white noises recovered, the search's stop, its
budget and its errors, and ``tauv tune``: its table, its file (which ``tauv replay --config``
reproduces) and its one-line refusals."""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from tauvcore.config import Config, from_dict, to_log_toml
from tauvcore.engine.simulation import SimChunk, simulate
from tauvcore.eval import tuning
from tauvcore.eval.replay import log_config, replay
from tauvcore.logs import read_log
from tauvcore.logs.writer import simulation_tables, write_log
from tauvcore.sensors.imu import IMU_PROFILES

DVL_NOISE_MPS = 0.021  # half Table 2's


def _simulated(directory: Path, seed: int, duration_s: float = 120.0, trajectory: str = "straight") -> Config:
    """A log made with Yoo 2014's IMU and a DVL of half Table 2's noise, its own log.toml with it."""
    config = (
        Config()
        .replace("trajectory", name=trajectory, duration_s=duration_s)
        .replace("imu", **IMU_PROFILES["yoo-table1"].__dict__)
        .replace("dvl", noise_mps=DVL_NOISE_MPS)
        .replace("run", seed=seed)
    )
    sim = simulate(config, np.random.default_rng(seed))
    write_log(directory, simulation_tables([SimChunk.whole(sim)]), "csv", config_toml=to_log_toml(config))
    return config


@pytest.fixture(scope="module")
def straight_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Config]:
    directory = tmp_path_factory.mktemp("straight")
    return directory, _simulated(directory, seed=4)


def _case(directory: Path, method: str = "lc", seed: int = 4, own_config: bool = False) -> tuning.TuningLog:
    """The log with Table 2's tuning (its own log.toml left out: the search starts from Table 2),
    or with its own configuration."""
    raw = log_config(directory)[0] if own_config else {}
    config = from_dict(raw).replace("run", methods=(method,), seed=seed)
    return tuning.TuningLog(str(directory), read_log(directory), config)


def test_an_evaluation_is_the_replay_to_the_last_bit(straight_log: tuple[Path, Config]) -> None:
    """PreparedLog reuses the log's simulation and the generator's state across evaluations; its
    likelihood is that of tauvcore.eval.replay.replay with the values and the gate open, exactly,
    also with initial errors drawn from the seed, and the same on a second evaluation."""
    directory, _ = straight_log
    case = _case(directory)
    case = tuning.TuningLog(
        case.name,
        case.log,
        case.config.replace("replay", initial_errors=True).replace("initial_error", mode="random"),
    )
    prepared = tuning.PreparedLog(case)
    values = {"gyro_noise": 0.2, "accel_noise": 0.05, "dvl_noise": 0.03}
    first = prepared.nll(values)
    _, results = replay(
        tuning.tuning_config(tuning.with_values(case.config, values)), case.log, np.random.default_rng(4)
    )
    assert first == tuning.negative_log_likelihood(results["lc"])
    assert prepared.nll(values) == first
    assert prepared.nll({**values, "dvl_noise": 0.04}) != first
    # the likelihood is every update's: 1/2 (NIS + log det S + dof log 2 pi), rejected or not
    record = results["lc"].updates["dvl"]
    used = record.valid & (record.nis_dof > 0)
    expected = 0.5 * np.sum(record.nis[used] + record.log_det_s[used] + record.nis_dof[used] * math.log(2 * math.pi))
    assert first == pytest.approx(expected, rel=1e-12)
    assert used.sum() == pytest.approx(120, abs=2)  # every ping of the 120 s at 1 Hz


def test_the_gate_is_open_and_the_lockout_off_while_tuning() -> None:
    config = tuning.tuning_config(Config())
    assert config.filter.gate_sigma == tuning.TUNING_GATE_SIGMA == 1000.0  # filter.gate_sigma's largest
    assert config.filter.lockout_reset_updates == 0


def test_a_short_log_s_dvl_and_imu_white_noise_are_recovered(straight_log: tuple[Path, Config]) -> None:
    """From Table 2's tuning, on a 120 s straight run made with Yoo 2014's IMU and half Table 2's DVL
    noise: the DVL noise from the innovations, the IMU's white noises from the still stretch (the
    IMU's output is constant on a straight leg) and the innovations, each within 10 %, with a
    1-sigma that says so."""
    directory, truth = straight_log
    prepared = [tuning.PreparedLog(_case(directory))]
    start = tuning.start_values([p.case for p in prepared], tuning.DEFAULT_PARAMETERS)
    assert start.still is not None and start.still.duration_s > 100.0
    assert set(start.priors) == {"gyro_noise", "accel_noise"}
    seen = []
    result = tuning.tune(prepared, start=start, progress=seen.append)
    assert result.start["dvl_noise"] == Config().dvl.noise_mps and result.start_from["dvl_noise"] == "configuration"
    expected = {
        "gyro_noise": truth.imu.gyro_noise_deg_per_sqrt_h,
        "accel_noise": truth.imu.accel_noise_mps_per_sqrt_h,
        "dvl_noise": DVL_NOISE_MPS,
    }
    for name, value in expected.items():
        assert result.tuned[name] == pytest.approx(value, rel=0.10), name
        assert result.determined(name), name
        assert 0.0 < result.sigma_ln[name] < 0.2, name
    assert result.converged and not result.stopped
    assert result.nll_tuned < result.nll_start - 10.0
    assert [e.count for e in seen] == list(range(1, result.evaluations + 1))
    assert [e.phase for e in seen] == sorted((e.phase for e in seen), key=["scan", "search", "curvature"].index)
    assert {e.phase for e in seen} == {"scan", "search", "curvature"}  # the DVL noise is scanned
    assert result.minimum
    best = [e.best_nll for e in seen if e.phase != "curvature"]
    assert all(b1 <= b0 for b0, b1 in itertools.pairwise(best))


def test_the_search_stops_when_asked_and_within_its_budget(straight_log: tuple[Path, Config]) -> None:
    directory, _ = straight_log
    prepared = [tuning.PreparedLog(_case(directory))]
    calls = []

    def stop() -> bool:
        calls.append(1)
        return len(calls) > 2

    stopped = tuning.tune(prepared, ["dvl_noise"], should_stop=stop)
    # polled before each replay in this process: two replays, then the stop
    assert stopped.stopped and not stopped.converged and stopped.evaluations == 2
    assert all(math.isnan(s) for s in stopped.sigma_ln.values())
    budget = tuning.tune(prepared, ["dvl_noise"], max_evaluations=3, curvature=False)
    assert not budget.stopped and not budget.converged and "3 evaluations" in budget.message
    assert budget.evaluations <= 4  # the search's 3, and the rounded value's


def test_bad_requests_are_refused(straight_log: tuple[Path, Config]) -> None:
    directory, _ = straight_log
    prepared = [tuning.PreparedLog(_case(directory))]
    with pytest.raises(ValueError, match="parameters must be distinct names"):
        tuning.tune(prepared, ["dvl_noise", "dvl_noise"])
    with pytest.raises(ValueError, match="parameters must be distinct names"):
        tuning.tune(prepared, ["nonsense"])
    with pytest.raises(ValueError, match="optimizer must be one of"):
        tuning.tune(prepared, optimizer="bfgs")
    with pytest.raises(ValueError, match="Yoo 2014"):
        _case(directory, method="vkf")
    config = Config().replace("run", methods=("lc", "tc"))
    with pytest.raises(ValueError, match="one method"):
        tuning.TuningLog("x", read_log(directory), config)


def test_every_parameter_names_a_key_and_its_bounds_are_the_configuration_s() -> None:
    config = Config()
    for name, p in tuning.PARAMETERS.items():
        low, high = p.bounds
        assert high * 1e-6 <= low < getattr(config.section(p.section), p.key) or p.prior
        tuning.with_values(config, {name: low})  # accepted
        tuning.with_values(config, {name: high})
        with pytest.raises(Exception, match=f"{p.section}.{p.key}"):
            tuning.with_values(config, {name: high * 1.001})
    assert set(tuning.DEFAULT_PARAMETERS) <= set(tuning.PARAMETERS)


def test_below_its_floor_a_value_changes_nothing(straight_log: tuple[Path, Config]) -> None:
    """The filter floors the DVL's beam noise (tauvcore.aiding.noise_floors): the search's lower
    bound is that floor, below which the likelihood is flat."""
    directory, _ = straight_log
    prepared = tuning.PreparedLog(_case(directory))
    low, _ = tuning.PARAMETERS["dvl_noise"].bounds
    assert low == 1e-3
    assert prepared.nll({"dvl_noise": low / 2}) == prepared.nll({"dvl_noise": low}) != prepared.nll({"dvl_noise": 2 * low})


def _cli(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _row(text: str, label: str) -> list[str]:
    """The cells of the consistency table's row ``label`` (the last such row: ``tauv replay``'s
    errors table has one before it)."""
    line = [line for line in text.splitlines() if line.split()[:1] == [label]][-1]
    return line.split()[1:]


def test_tauv_tune_prints_its_table_and_writes_what_tauv_replay_takes(
    straight_log: tuple[Path, Config], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory, _ = straight_log
    out = tmp_path / "tuned.toml"
    code, text, err = _cli(
        capsys, "tune", str(directory), "--method", "lc", "--seed", "4", "--no-log-config",
        "--params", "dvl_noise", "--out", str(out),
    )
    assert code == 0, err
    assert "tuned LC on 1 log" in text and "dvl_noise" in text and "BEFORE" in text and "AFTER" in text
    written = out.read_text()
    value = float(re.search(r"noise_mps = ([0-9.e-]+)", written).group(1))
    assert value == pytest.approx(DVL_NOISE_MPS, rel=0.1)
    assert set(re.findall(r"^\[(\w+)\]", written, re.MULTILINE)) == {"dvl"}
    # the replay configured by the file gives the table's "after" row
    code, replayed, err = _cli(
        capsys, "replay", str(directory), "--method", "lc", "--seed", "4", "--no-log-config", "--config", str(out)
    )
    assert code == 0, err
    assert _row(replayed, "LC") == _row(text, "AFTER")
    code, before, err = _cli(capsys, "replay", str(directory), "--method", "lc", "--seed", "4", "--no-log-config")
    assert _row(before, "LC") == _row(text, "BEFORE")
    # an existing file is refused unless --replace
    code, _, err = _cli(capsys, "tune", str(directory), "--method", "lc", "--params", "dvl_noise", "--out", str(out))
    assert code == 2 and "--out" in err and "exists" in err and len(err.strip().splitlines()) == 1


def test_the_file_carries_what_the_flags_set(
    straight_log: tuple[Path, Config], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--imu phins starts from that IMU: its section goes into the file whole (what differs from
    the log's own), so the replay of the file is configured as the tuning was."""
    directory, _ = straight_log
    out = tmp_path / "phins.toml"
    code, _, err = _cli(
        capsys, "tune", str(directory), "--method", "lc", "--imu", "phins", "--params", "dvl_noise",
        "--max-evaluations", "3", "--out", str(out),
    )
    assert code == 0, err
    config = from_dict(__import__("tomllib").loads(out.read_text()))
    assert config.imu.gyro_bias_deg_per_h == IMU_PROFILES["phins"].gyro_bias_deg_per_h
    assert "[run]" not in out.read_text() and "[trajectory]" not in out.read_text()


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--method", "lc", "--params", "nonsense"], "--params: unknown parameter"),
        (["--method", "lc", "--params", "dvl_noise,dvl_noise"], "--params: repeated"),
        ([], "--method: tuning needs the one method"),
        (["--method", "lc,tc"], "--method: tuning takes one method"),
        (["--method", "ins"], "ins fuses no aiding source"),
        (["--method", "vkf"], "Yoo 2014's 12-state filter"),
        (["--method", "lc", "--max-evaluations", "0"], "--max-evaluations"),
        (["--method", "lc", "--optimizer", "bfgs"], "--optimizer: unknown"),
        (["--method", "lc", "--aiding", "dvl,usbl"], "usbl"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(
    straight_log: tuple[Path, Config], capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    directory, _ = straight_log
    code, out, err = _cli(capsys, "tune", str(directory), *argv)
    assert code == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_logs_and_outputs_that_are_not_fit_are_refused(
    straight_log: tuple[Path, Config], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory, _ = straight_log
    for argv, message in [
        ([str(tmp_path / "missing")], "missing"),
        ([str(directory), str(directory)], "given twice"),
        ([str(tmp_path / "x.bag")], "ROS bag"),
        ([str(directory), "--out", str(directory / "t.toml")], "is in the log directory"),
        ([str(directory), "--out", str(tmp_path)], "is a directory"),
        ([str(directory), "--out", str(tmp_path / "no" / "t.toml")], "no such directory"),
    ]:
        code, _, err = _cli(capsys, "tune", *argv, "--method", "lc")
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, (argv, err)
    assert not (directory / "t.toml").exists()


def test_the_tuning_page_names_every_parameter_and_its_key() -> None:
    page = (Path(__file__).resolve().parents[5] / "docs" / "tuning.md").read_text(encoding="utf-8")
    for name, p in tuning.PARAMETERS.items():
        assert f"| `{name}` | `{p.section}.{p.key}` |" in page, name


def test_several_logs_sum_and_dask_evaluates_as_this_process_does(
    straight_log: tuple[Path, Config], tmp_path: Path
) -> None:
    """Two logs' likelihood is the sum of each's; a Dask cluster (here its threads, in this
    process) evaluates every (point, log) pair to the same numbers."""
    from distributed import Client

    directory, _ = straight_log
    twin = tmp_path / "twin"
    __import__("shutil").copytree(directory, twin)
    prepared = [tuning.PreparedLog(_case(directory)), tuning.PreparedLog(_case(twin))]
    points = [{"dvl_noise": 0.03}, {"dvl_noise": 0.02}]
    serial = tuning.serial_evaluator(prepared)(points)
    assert serial == [2 * prepared[0].nll(p) for p in points]
    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        assert tuning.dask_evaluator(prepared, client)(points) == serial


def test_tauv_tune_on_two_logs_prints_each_and_both_together(
    straight_log: tuple[Path, Config], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory, _ = straight_log
    twin = tmp_path / "twin"
    __import__("shutil").copytree(directory, twin)
    code, text, err = _cli(
        capsys, "tune", str(directory), str(twin), "--method", "lc", "--seed", "4", "--no-log-config",
        "--params", "dvl_noise", "--max-evaluations", "20",
    )
    assert code == 0, err
    assert "tuned LC on 2 logs" in text and "all 2 logs together:" in text
    afters = [line.split()[1:] for line in text.splitlines() if line.split()[:1] == ["AFTER"]]
    assert len(afters) == 3 and afters[0] == afters[1] == afters[2]  # twins: each, and both, alike


def test_nelder_mead_finds_what_l_bfgs_b_finds(straight_log: tuple[Path, Config]) -> None:
    directory, _ = straight_log
    prepared = [tuning.PreparedLog(_case(directory))]
    by = {opt: tuning.tune(prepared, ["dvl_noise"], optimizer=opt) for opt in tuning.OPTIMIZERS}
    gradient, simplex = by["l-bfgs-b"], by["nelder-mead"]
    assert simplex.converged and gradient.converged
    assert simplex.tuned["dvl_noise"] == pytest.approx(gradient.tuned["dvl_noise"], rel=0.01)
    assert simplex.nll_tuned == pytest.approx(gradient.nll_tuned, abs=0.05)


def _gaussian(true: dict[str, float], sigma_ln: dict[str, float], cap: float = math.inf) -> tuning.Evaluator:
    """A likelihood known in closed form: Gaussian in ln(value) about ``true`` with ``sigma_ln``,
    each term capped at ``cap`` (a plateau far from the minimum, as a filter far from its data has)."""

    def evaluate(points):
        return [
            float(sum(min(0.5 * ((math.log(v[n]) - math.log(true[n])) / sigma_ln[n]) ** 2, cap) for n in true))
            for v in points
        ]

    return evaluate


@pytest.mark.parametrize("optimizer", tuning.OPTIMIZERS)
def test_the_search_and_its_curvature_on_a_known_likelihood(optimizer: str) -> None:
    """The minimum of the likelihood and the weak prior together, and its 1-sigma: the posterior of
    two Gaussians in ln(value)."""
    true = {"dvl_noise": 0.02, "gyro_noise": 0.5}
    sigma = {"dvl_noise": 0.05, "gyro_noise": 0.4}
    start = tuning.Start({"dvl_noise": 0.042, "gyro_noise": 0.34}, dict.fromkeys(true, "configuration"), {}, None)
    result = tuning.tune([object()], list(true), start=start, evaluator=_gaussian(true, sigma), optimizer=optimizer)
    prior = tuning.CONFIG_PRIOR_SIGMA_LN
    for n in true:
        weight = 1 / sigma[n] ** 2 + 1 / prior**2
        expected = (math.log(true[n]) / sigma[n] ** 2 + math.log(start.values[n]) / prior**2) / weight
        assert math.log(result.tuned[n]) == pytest.approx(expected, abs=0.01), n
        assert result.sigma_ln[n] == pytest.approx(weight**-0.5, rel=0.02), n
    assert result.minimum and result.converged


def test_the_scan_crosses_a_plateau_the_local_search_stops_on() -> None:
    true, sigma = {"gyro_noise": 5.0}, {"gyro_noise": 0.3}
    start = tuning.Start({"gyro_noise": 0.0025}, {"gyro_noise": "configuration"}, {}, None)
    evaluator = _gaussian(true, sigma, cap=200.0)  # flat beyond 6 sigma of the minimum
    local = tuning.tune([object()], ["gyro_noise"], start=start, evaluator=evaluator, scan=False)
    scanned = tuning.tune([object()], ["gyro_noise"], start=start, evaluator=evaluator)
    assert local.tuned["gyro_noise"] == pytest.approx(0.0025, rel=0.1)
    prior = tuning.CONFIG_PRIOR_SIGMA_LN  # the weak prior at the start pulls the minimum a little
    weight = 1 / 0.3**2 + 1 / prior**2
    expected = (math.log(5.0) / 0.3**2 + math.log(0.0025) / prior**2) / weight
    assert math.log(scanned.tuned["gyro_noise"]) == pytest.approx(expected, abs=0.01)
    assert scanned.nll_tuned < local.nll_tuned - 100.0
