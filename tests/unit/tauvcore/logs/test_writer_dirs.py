"""One rule for every writer's directory (tauvcore.logs.writer.output_dir): ``tauv run --save-log``,
``tauv mc --out``, ``tauv reproduce --out``, ``tauv log convert`` and scripts/akit_to_log.py refuse
an empty name, a missing parent and a directory that holds anything, in one line and creating
nothing; an earlier study of the same command is replaced only with ``--replace``, which says so."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main
from tests.unit.helpers.bag_fixtures import mission_config, mission_tables, write_bag

ROOT = Path(__file__).resolve().parents[4]
AKIT = ROOT.parent.parent / "shared" / "data" / "akit"
if not AKIT.is_dir():
    AKIT = Path("/work/shared/data/akit")
RUN = ["run", "--duration", "2", "--method", "ins"]
MC = ["mc", "--duration", "2", "--method", "ins", "--runs", "1"]
REPRODUCE = ["reproduce", "--duration", "2", "--runs", "1"]


def _one_line(capsys: pytest.CaptureFixture, argv: list[str], *parts: str) -> str:
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 2, captured.err
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tauv: error: "), captured.err
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    config = mission_config(duration_s=5.0)
    beams, _ = mission_tables(config)
    root = tmp_path_factory.mktemp("bag")
    return write_bag(root / "m.bag", "ros1", beams, "ds_sensor_msgs/msg/Dvl", config.dvl.A_b, frame="flu_enu")


def _writers(bag: Path) -> dict[str, tuple[list[str], str]]:
    """Each writer's command line before its directory, and its label."""
    return {
        "save-log": ([*RUN, "--save-log"], "--save-log"),
        "mc": ([*MC, "--out"], "--out"),
        "reproduce": ([*REPRODUCE, "--out"], "--out"),
        "convert": (["log", "convert", str(bag)], "OUT_DIR"),
    }


@pytest.mark.parametrize("writer", ["save-log", "mc", "reproduce", "convert"])
def test_an_empty_name_is_refused(capsys, tmp_path, monkeypatch, bag, writer) -> None:
    """log convert said "'' exists and is not an empty directory"."""
    monkeypatch.chdir(tmp_path)
    argv, label = _writers(bag)[writer]
    _one_line(capsys, [*argv, ""], f"{label}: '' is not a directory name")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("writer", ["save-log", "mc", "reproduce", "convert"])
def test_a_missing_parent_is_refused_and_nothing_created(capsys, tmp_path, monkeypatch, bag, writer) -> None:
    """log convert created a/b and wrote there, where --save-log refused."""
    monkeypatch.chdir(tmp_path)
    argv, label = _writers(bag)[writer]
    _one_line(capsys, [*argv, "a/b"], f"{label}: cannot create 'a/b': no such parent directory 'a'")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("writer", ["save-log", "mc", "reproduce", "convert"])
def test_a_directory_holding_anything_is_refused_untouched(capsys, tmp_path, monkeypatch, bag, writer) -> None:
    """--save-log and mc --out wrote beside what a directory held."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "notes.txt").write_text("mine")
    argv, label = _writers(bag)[writer]
    _one_line(capsys, [*argv, "d"], f"{label}: 'd' is not an empty directory (it holds 'notes.txt')",
              "nothing is overwritten")
    assert os.listdir(tmp_path / "d") == ["notes.txt"]
    assert (tmp_path / "d" / "notes.txt").read_text() == "mine"


def test_mc_onto_an_earlier_study_is_refused_then_replaced_with_replace(capsys, tmp_path, monkeypatch) -> None:
    """mc --out replaced an earlier study without a word."""
    monkeypatch.chdir(tmp_path)
    assert main([*MC, "--out", "s", "--seed", "1"]) == 0
    first = capsys.readouterr().out
    assert "replaced" not in first
    before = json.loads((tmp_path / "s" / "summary.json").read_text())
    _one_line(capsys, [*MC, "--out", "s", "--seed", "2"],
              "--out: 's' holds an earlier tauv mc study (report.html, runs.parquet, summary.json)",
              "add --replace to replace it")
    assert json.loads((tmp_path / "s" / "summary.json").read_text()) == before
    assert main([*MC, "--out", "s", "--seed", "2", "--replace"]) == 0
    out = capsys.readouterr().out
    assert "replaced the earlier tauv mc study in 's' (--replace)" in out
    assert json.loads((tmp_path / "s" / "summary.json").read_text())["seed"] == 2
    assert sorted(os.listdir(tmp_path / "s")) == ["report.html", "runs.parquet", "summary.json"]


def test_replace_does_not_replace_another_kind_or_other_files(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "r").mkdir()
    for name in ("summary.json", "paper_comparison.md"):
        (tmp_path / "r" / name).write_text("a reproduce study")
    _one_line(capsys, [*MC, "--out", "r", "--replace"], "'r' is not an empty directory")
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "summary.json").write_text("{}")
    (tmp_path / "m" / "mine.txt").write_text("mine")
    _one_line(capsys, [*MC, "--out", "m", "--replace"], "'m' is not an empty directory")
    assert sorted(os.listdir(tmp_path / "m")) == ["mine.txt", "summary.json"]


def test_save_log_onto_a_log_is_refused(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main([*RUN, "--save-log", "L"]) == 0
    capsys.readouterr()
    _one_line(capsys, [*RUN, "--save-log", "L"], "--save-log: 'L' is a log directory (it holds imu.csv)")


def test_replay_of_an_empty_name_is_refused(capsys, tmp_path, monkeypatch) -> None:
    """tauv replay '' replayed the current directory."""
    monkeypatch.chdir(tmp_path)
    assert main([*RUN, "--save-log", "L"]) == 0
    capsys.readouterr()
    monkeypatch.chdir(tmp_path / "L")
    _one_line(capsys, ["replay", ""], "PATH: '' is not a log's name")


def test_the_rule_is_one_function(tmp_path) -> None:
    """The same check for a library writer (tauvcore.logs.writer.output_dir): what it refuses
    and what it returns."""
    from tauvcore.logs.writer import output_dir
    from tauvcore.validation import OutputDirError

    with pytest.raises(OutputDirError, match="^X: '' is not a directory name$"):
        output_dir("", "X")
    with pytest.raises(OutputDirError, match="X: ' ' is not a directory name"):
        output_dir(" ", "X")
    (tmp_path / "f").write_text("")
    with pytest.raises(OutputDirError, match="exists and is not a directory"):
        output_dir(str(tmp_path / "f"), "X")
    (tmp_path / "e").mkdir()
    (tmp_path / "e" / ".tauv.lock").write_text("")  # a killed writer's lock: no content of the user's
    found = output_dir(str(tmp_path / "e"), "X")
    assert found.exists and found.replaces is None and found.path == str(tmp_path / "e")
    new = output_dir(str(tmp_path / "new"), "X")
    assert not new.exists and not (tmp_path / "new").exists()
    (tmp_path / "h").mkdir()
    (tmp_path / "h" / "c.toml").write_text("")
    with pytest.raises(OutputDirError, match="holds the --config file"):
        output_dir(str(tmp_path / "h"), "X", inputs=[("the --config file", str(tmp_path / "h" / "c.toml"))])


def _akit(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "akit_to_log.py"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120, check=False)


@pytest.mark.skipif(not AKIT.is_dir(), reason="the A-KIT dataset is not here (../shared/data/akit)")
def test_akit_converter_given_the_dataset_root_lists_its_segments(tmp_path) -> None:
    """It printed a 20-line traceback."""
    proc = _akit(str(AKIT), str(tmp_path / "out"), cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert "holds segments, not one: give one segment folder" in lines[0]
    assert "Trajectory1, Trajectory2" in lines[0] and "(13 segments)" in lines[0]
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(not AKIT.is_dir(), reason="the A-KIT dataset is not here (../shared/data/akit)")
def test_akit_converter_refuses_an_existing_out_dir(tmp_path) -> None:
    """It overwrote an existing OUT_DIR without a word."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "imu.csv").write_text("mine")
    proc = _akit(str(AKIT / "Trajectory1"), "out", cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [(
        "akit_to_log.py: error: OUT_DIR: 'out' is a log directory (it holds imu.csv), not an empty directory; "
        "give a new or empty one (nothing is overwritten)"
    )]
    assert os.listdir(out) == ["imu.csv"] and (out / "imu.csv").read_text() == "mine"
    proc = _akit(str(AKIT / "Trajectory1"), str(tmp_path / "no" / "out"), cwd=tmp_path)
    assert proc.returncode == 2 and "no such parent directory" in proc.stderr
    assert sorted(os.listdir(tmp_path)) == ["out"]
