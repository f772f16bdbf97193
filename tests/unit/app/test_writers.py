"""Every file tauv writes: never an input, all or nothing, one writer per directory.

The oracle for each command: exit 0 and complete output, or exit 2 with exactly one line on
stderr naming the flag or file and the value; never a traceback, nothing half-written left
(no temporary, no partial table, nothing that looks like a log), no input ever changed.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from app import cli
from app.reports import study_output
from app.reports.study_output import LOCK_FILE, OUTPUT_FILES, DirectoryLock, OutputDirError, StudyWriter
from tauvcore import logs
from tauvcore.aiding.sources import SOURCES
from tauvcore.logs import CONFIG_FILE, read_log
from tauvcore.logs import table_io as log_tables
from tauvcore.logs import writer as log_writer
from tauvcore.logs.writer import replace_files, write_log

SIMULATED_TABLES = tuple(dict.fromkeys(logs.TABLES + tuple(s.table for s in SOURCES.values() if s.aboard)))
"""The tables of a simulation's log: the log's own and those of the sources aboard (depth, attitude)."""
RUN = ["run", "--duration", "5", "--method", "ins"]
MC = ["mc", "--duration", "10", "--method", "ins", "--runs", "2"]
REPRODUCE = ["reproduce", "--duration", "5", "--runs", "1"]
LIMITED = textwrap.dedent("""
    import resource, signal, sys
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)   # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), resource.RLIM_INFINITY))
    from app.cli import main
    raise SystemExit(main(sys.argv[2:]))
""")
"""``python -c LIMITED BYTES ARGV...``: tauv with no file larger than BYTES, as on a full disk."""
HOLD = textwrap.dedent("""
    import sys
    from app.reports.study_output import DirectoryLock
    lock = DirectoryLock(sys.argv[1])
    print("held", flush=True)
    sys.stdin.read()
""")
"""``python -c HOLD DIR``: another process holding DIR's lock until its stdin closes."""


def _run(capsys: pytest.CaptureFixture, *argv: str) -> tuple[int, str, str]:
    code = cli.main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def _one_line(code: int, err: str, *parts: str) -> str:
    assert code == 2, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]


def _limited(cwd: Path, limit: int, *argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", LIMITED, str(limit), *argv], cwd=cwd, capture_output=True,
                          text=True, timeout=300, check=False)


def _everything(directory: Path) -> dict[str, bytes]:
    """Every file below ``directory`` (hidden ones too) and its content."""
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    """A log as ``tauv run --save-log`` writes it, with its own configuration file."""
    log = tmp_path_factory.mktemp("recorded") / "log"
    assert cli.main([*RUN, "--save-log", str(log)]) == 0
    (log / CONFIG_FILE).write_text("[dvl]\nnoise_mps = 0.01\n")
    return log


@pytest.fixture()
def log_dir(recorded, tmp_path, monkeypatch) -> Path:
    """A copy of the recorded log at ``log`` in the test's own working directory."""
    monkeypatch.chdir(tmp_path)
    shutil.copytree(recorded, tmp_path / "log")
    return Path("log")


def _never(*args, **kwargs):
    pytest.fail("the command ran before refusing its output")


# --- inputs are never outputs ---------------------------------------------------------------------

@pytest.mark.parametrize("target", ["imu.csv", "reference.csv", CONFIG_FILE, "symlink", "hardlink", "relative",
                                    "new.json"])
def test_replay_json_onto_the_log_is_refused_before_anything_runs(capsys, log_dir, tmp_path, monkeypatch,
                                                                  target) -> None:
    """Nothing of the replayed log may become ``--json``: its tables, its log.toml, any other
    file in it, or a link to one of them."""
    before = _everything(log_dir)
    if target == "symlink":
        path = Path("s.json")
        path.symlink_to(log_dir / "imu.csv")
    elif target == "hardlink":
        path = Path("h.json")
        os.link(log_dir / "dvl.csv", path)
    elif target == "relative":
        path = Path("log/../log/./imu.csv")
    else:
        path = log_dir / target
    monkeypatch.setattr("tauvcore.logs.read_log", _never)
    code, out, err = _run(capsys, "replay", str(log_dir), "--method", "ins", "--json", str(path))
    _one_line(code, err, f"--json: {str(path)!r} is", "log directory 'log'")
    assert out == "" and _everything(log_dir) == before


def test_replay_json_onto_the_log_s_parquet_table_is_refused(capsys, tmp_path, monkeypatch, recorded) -> None:
    monkeypatch.chdir(tmp_path)
    log = Path("pq")
    write_log(log, {t: log_tables.read_table(p) for t in logs.TABLES + tuple(logs.SOURCE_TABLES.values()) if (p := log_tables.table_path(recorded, t))},
              "parquet")
    before = _everything(log)
    _one_line(*_run(capsys, "replay", str(log), "--json", str(log / "imu.parquet"))[::2], "--json", "imu.parquet")
    assert _everything(log) == before


def test_replay_json_onto_its_config_file_is_refused(capsys, log_dir) -> None:
    config = Path("c.toml")
    config.write_text("[run]\nmethods = [\"ins\"]\n")
    _one_line(*_run(capsys, "replay", str(log_dir), "--config", str(config), "--json", str(config))[::2],
              "--json", "--config file")
    assert config.read_text() == "[run]\nmethods = [\"ins\"]\n"


def test_run_outputs_that_hold_or_are_inputs_are_refused(capsys, tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", _never)
    Path("d").mkdir()
    Path("d/x.toml").write_text("[run]\nseed = 1\n")
    _one_line(*_run(capsys, *RUN, "--save-log", "d", "--config", "d/x.toml")[::2], "--save-log", "'d'",
              "--config file", "'d/x.toml'")
    _one_line(*_run(capsys, *RUN, "--save-log", "new", "--json", "new/out.json")[::2], "--json", "'new/out.json'",
              "--save-log directory")
    _one_line(*_run(capsys, *RUN, "--save-log", "new", "--json", "new")[::2], "--json", "--save-log directory")
    assert sorted(os.listdir(tmp_path)) == ["d"] and os.listdir("d") == ["x.toml"]


def test_mc_out_that_is_a_log_or_holds_the_config_is_refused(capsys, log_dir, monkeypatch) -> None:
    before = _everything(log_dir)
    monkeypatch.setattr("tauvcore.eval.study.run_study", _never)
    _one_line(*_run(capsys, *MC, "--out", "log")[::2], "--out: 'log' is a log directory (it holds imu.csv)")
    _one_line(*_run(capsys, *REPRODUCE, "--out", "log")[::2], "--out: 'log' is a log directory")
    config = Path("study/c.toml")
    config.parent.mkdir()
    config.write_text("[run]\nseed = 1\n")
    _one_line(*_run(capsys, *MC, "--out", "study", "--config", str(config))[::2],
              "--out: 'study' holds the --config file 'study/c.toml'")
    link = Path("linked")
    link.mkdir()
    os.link(config, link / "mine.toml")
    _one_line(*_run(capsys, *MC, "--out", str(link), "--config", str(config))[::2], "--out", "--config file")
    assert _everything(log_dir) == before and os.listdir(config.parent) == ["c.toml"]
    assert os.listdir(link) == ["mine.toml"]


# --- all or nothing -------------------------------------------------------------------------------

@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_save_log_on_a_full_disk_leaves_nothing_and_a_retry_works(capsys, tmp_path, fmt) -> None:
    """Under a file-size limit (SIGXFSZ ignored: writes fail with EFBIG, as on a full disk) no
    table, no partial file and no temporary is left, a directory that was there is left empty,
    and a retry without the limit writes a log that reads back."""
    for target in ("new", "empty"):
        (tmp_path / "empty").mkdir(exist_ok=True)
        proc = _limited(tmp_path, 20_000, *RUN, "--save-log", target, "--log-format", fmt)
        _one_line(proc.returncode, proc.stderr, f"--save-log: cannot write '{target}': File too large")
        assert proc.stdout == ""
    assert sorted(os.listdir(tmp_path)) == ["empty"] and os.listdir(tmp_path / "empty") == []
    code, _, err = _run(capsys, *RUN, "--save-log", str(tmp_path / "empty"), "--log-format", fmt)
    assert code == 0, err
    assert sorted(os.listdir(tmp_path / "empty")) == sorted([CONFIG_FILE, *(f"{t}.{fmt}" for t in SIMULATED_TABLES)])
    assert read_log(tmp_path / "empty").duration_s == pytest.approx(5.0)


@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()])
@pytest.mark.parametrize("failing", ["depth", "imu"])
def test_save_log_failing_mid_way_leaves_nothing(capsys, tmp_path, monkeypatch, failure, failing) -> None:
    real = log_writer._TableFile.append

    def fail_at_one(self, columns):
        if self.path.name.startswith(f"{failing}."):
            self.path.write_text("t_s\n0.0\n")      # a partial file exists at this point
            raise failure
        real(self, columns)

    monkeypatch.setattr(log_writer._TableFile, "append", fail_at_one)
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(capsys, *RUN, "--save-log", "log")
    if isinstance(failure, KeyboardInterrupt):
        assert code == 130 and err.strip() == "tauv: interrupted"
    else:
        _one_line(code, err, "--save-log: cannot write 'log': No space left on device")
    assert out == "" and os.listdir(tmp_path) == []
    monkeypatch.setattr(log_writer._TableFile, "append", real)
    assert _run(capsys, *RUN, "--save-log", "log")[0] == 0
    assert read_log("log").duration_s == pytest.approx(5.0)


def test_write_log_moves_the_imu_table_last_and_undoes_every_move_on_failure(tmp_path, monkeypatch) -> None:
    t = np.arange(4.0)
    old = {"imu": {"t_s": t}, "dvl": {"t_s": t}, "depth": {"t_s": t, "depth_m": t}}
    write_log(tmp_path, old, config_toml="[dvl]\nnoise_mps = 0.01\n")
    before = _everything(tmp_path)
    assert sorted(before) == ["depth.csv", "dvl.csv", "imu.csv", CONFIG_FILE]
    moved = []
    real_rename = os.rename

    def rename(src, dst):
        if str(src).endswith(".partial"):
            moved.append(Path(dst).name)
            if Path(dst).name == "imu.csv":
                raise OSError(errno.EIO, "Input/output error")
        real_rename(src, dst)

    monkeypatch.setattr(os, "rename", rename)
    new = {name: {"t_s": t + 10.0} for name in ("imu", "dvl", "attitude")}
    with pytest.raises(OSError, match="Input/output error"):
        write_log(tmp_path, new, config_toml="[dvl]\nnoise_mps = 0.5\n")
    assert moved[-1] == "imu.csv" and set(moved) == {CONFIG_FILE, "dvl.csv", "attitude.csv", "imu.csv"}
    assert _everything(tmp_path) == before                   # every table back, nothing new, no temporary
    monkeypatch.setattr(os, "rename", real_rename)
    write_log(tmp_path, new, config_toml="[dvl]\nnoise_mps = 0.5\n")
    assert sorted(os.listdir(tmp_path)) == ["attitude.csv", "depth.csv", "dvl.csv", "imu.csv", CONFIG_FILE]
    assert (tmp_path / "dvl.csv").read_text() == "t_s\n10.0\n11.0\n12.0\n13.0\n"


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


def test_write_log_removes_the_directories_it_made_on_failure(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(log_writer, "_write_table", _interrupt)
    with pytest.raises(KeyboardInterrupt):
        write_log(tmp_path / "a" / "b" / "log", {"imu": {"t_s": np.arange(3.0)}})
    assert os.listdir(tmp_path) == []


def test_replace_files_refuses_a_directory_target_before_moving_anything(tmp_path) -> None:
    (tmp_path / "a.new").write_text("a")
    (tmp_path / "b.new").write_text("b")
    (tmp_path / "b").mkdir()
    with pytest.raises(IsADirectoryError):
        replace_files([(tmp_path / "a.new", tmp_path / "a"), (tmp_path / "b.new", tmp_path / "b")],
                      tmp_path / "aside")
    assert sorted(os.listdir(tmp_path)) == ["a.new", "b", "b.new"]


@pytest.mark.parametrize("command", [MC, REPRODUCE])
def test_a_study_whose_report_cannot_be_written_is_one_line_and_leaves_nothing(tmp_path, command) -> None:
    """report.html (a few MB, plotly.js inline) past a 1 MB file-size limit: one line naming the
    file and the reason, nothing of the study left, an older study's files untouched."""
    proc = _limited(tmp_path, 1_000_000, *command, "--out", "new")
    _one_line(proc.returncode, proc.stderr, "--out: cannot write 'new/report.html': File too large")
    assert os.listdir(tmp_path) == []
    older = tmp_path / "older"
    older.mkdir()
    earlier = {"summary.json": b'{"an": "older study"}'}
    if command == REPRODUCE:
        earlier["paper_comparison.md"] = b"an older comparison\n"
    for name, data in earlier.items():
        (older / name).write_bytes(data)
    proc = _limited(tmp_path, 1_000_000, *command, "--out", "older", "--replace")
    _one_line(proc.returncode, proc.stderr, "'older/report.html'", "File too large")
    assert _everything(older) == earlier


def test_a_study_on_a_full_disk_names_the_file_in_one_line(capsys, tmp_path, monkeypatch) -> None:
    def no_space(self, name, text):
        with self._writing(name):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(StudyWriter, "_write_text", no_space)
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(capsys, *MC, "--out", "s")
    _one_line(code, err, "--out: cannot write 's/summary.json': No space left on device")
    assert out == "" and os.listdir(tmp_path) == []


def test_a_parquet_chunk_that_cannot_be_written_is_one_line(capsys, tmp_path, monkeypatch) -> None:
    def no_space(self, trajectory, chunk):
        with self._writing("runs.parquet"):
            raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No space left on device")

    monkeypatch.setattr(StudyWriter, "add_chunk", no_space)
    monkeypatch.chdir(tmp_path)
    _one_line(*_run(capsys, *MC, "--out", "s")[::2], "--out: cannot write 's/runs.parquet': No space left on device")
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("command", [["run", "--duration", "5", "--method", "ins"],
                                     ["replay", "LOG", "--method", "ins"]])
def test_json_on_a_full_disk_is_one_line_and_leaves_nothing(tmp_path, recorded, command) -> None:
    argv = [str(recorded) if a == "LOG" else a for a in command]
    before = _everything(recorded)
    proc = _limited(tmp_path, 20_000, *argv, "--json", "out.json")
    _one_line(proc.returncode, proc.stderr, "--json: cannot write 'out.json': File too large")
    assert os.listdir(tmp_path) == [] and _everything(recorded) == before


# --- one writer per directory ---------------------------------------------------------------------

@pytest.fixture()
def holder(tmp_path):
    """Another process holding the lock of ``tmp_path / "held"`` (it creates the directory)."""
    proc = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path / "held")], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        yield proc
    finally:
        proc.kill()
        proc.wait(timeout=30)


@pytest.mark.parametrize("argv, flag", [(MC, "--out"), (REPRODUCE, "--out"), (RUN, "--save-log")])
def test_a_directory_another_tauv_writes_is_refused_at_once(capsys, tmp_path, monkeypatch, holder, argv,
                                                            flag) -> None:
    held = tmp_path / "held"
    monkeypatch.setattr("tauvcore.eval.study.run_study", _never)
    monkeypatch.setattr("tauvcore.engine.mission.run_streaming", _never)
    started = time.perf_counter()
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, *argv, flag, "held")
    _one_line(code, err, f"{flag}: 'held' is being written by another tauv (pid {holder.pid})")
    assert time.perf_counter() - started < 10.0
    assert os.listdir(held) == [LOCK_FILE]                            # the holder's, untouched
    assert (held / LOCK_FILE).read_text() == f"{holder.pid}\n"


def test_a_lock_left_by_a_killed_writer_is_harmless(capsys, tmp_path, holder) -> None:
    held = tmp_path / "held"
    holder.send_signal(signal.SIGKILL)
    holder.wait(timeout=30)
    assert os.listdir(held) == [LOCK_FILE]                            # left behind, no longer held
    code, _, err = _run(capsys, *MC, "--out", str(held))
    assert code == 0, err
    assert sorted(os.listdir(held)) == sorted(set(OUTPUT_FILES) - {"paper_comparison.md"})


def test_two_tauv_runs_saving_into_one_directory(capsys, tmp_path, monkeypatch) -> None:
    """A second ``tauv run --save-log D`` while a first (a real process) runs is refused with
    the first's pid; the first completes its log."""
    argv = ["run", "--duration", "300", "--method", "ins", "--save-log", "D"]
    first = subprocess.Popen([sys.executable, "-m", "app.cli", *argv], cwd=tmp_path, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
    lock = tmp_path / "D" / LOCK_FILE
    deadline = time.monotonic() + 120
    while first.poll() is None and time.monotonic() < deadline:
        if lock.exists() and lock.read_text().strip():
            break
        time.sleep(0.01)
    monkeypatch.chdir(tmp_path)
    second = _run(capsys, *argv)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    _one_line(*second[::2], f"--save-log: 'D' is being written by another tauv (pid {first.pid})")
    assert sorted(os.listdir(tmp_path / "D")) == sorted([CONFIG_FILE, *(f"{t}.csv" for t in SIMULATED_TABLES)])
    assert read_log(tmp_path / "D").duration_s == pytest.approx(300.0)


def test_a_directory_lock_is_exclusive_and_let_go(tmp_path) -> None:
    lock = DirectoryLock(str(tmp_path / "d"))
    assert lock.created and (tmp_path / "d" / LOCK_FILE).read_text() == f"{os.getpid()}\n"
    with pytest.raises(OutputDirError, match=f"is being written by another tauv \\(pid {os.getpid()}\\)"):
        DirectoryLock(str(tmp_path / "d"))
    lock.release(remove_created=True)
    assert os.listdir(tmp_path) == []
    again = DirectoryLock(str(tmp_path / "d"))
    again.release()
    assert os.listdir(tmp_path / "d") == []


def test_a_study_removes_its_lock_and_temporary(tmp_path) -> None:
    writer = StudyWriter(str(tmp_path / "s"))
    temporary, lock = sorted(os.listdir(tmp_path / "s"))
    assert lock == LOCK_FILE and temporary.startswith(".tauv-mc-")
    writer.finish({"a": 1}, "<html></html>")
    assert writer.commit() == [str(tmp_path / "s" / "summary.json"), str(tmp_path / "s" / "report.html")]
    assert sorted(os.listdir(tmp_path / "s")) == ["report.html", "summary.json"]
    assert json.loads((tmp_path / "s" / "summary.json").read_text()) == {"a": 1}


def test_os_reason_is_the_system_s_words() -> None:
    wrapped = OSError(errno.EFBIG, "Error writing bytes to file. Detail: [errno 27] File too large")
    assert study_output.os_reason(wrapped) == "File too large"
    assert study_output.os_reason(OSError("odd\nfailure")) == "odd\\nfailure"


# --- value flags from the parser ------------------------------------------------------------------

def test_value_flags_are_the_parser_s() -> None:
    """Every option of every subcommand is in VALUE_FLAGS or OTHER_FLAGS by its nargs, the path
    and profile flags (--truth, --earth, --imu, --imu-errors, --save-log, --log-format, --logs)
    among the value flags."""
    assert {"--truth", "--earth", "--imu", "--imu-errors", "--save-log", "--log-format", "--logs"} <= cli.VALUE_FLAGS
    assert not cli.VALUE_FLAGS & cli.OTHER_FLAGS                  # no flag takes a value in one command only
    for actions in cli.option_actions(cli.build_parser()).values():
        for action in actions:
            assert set(action.option_strings) <= (cli.OTHER_FLAGS if action.nargs == 0 else cli.VALUE_FLAGS)
    assert {"--ideal", "--rpm-fallback", "-h", "--help"} <= cli.OTHER_FLAGS


def test_a_flag_added_to_the_parser_is_known() -> None:
    parser = cli._Parser(prog="t")
    sub = parser.add_subparsers(dest="command")
    p = sub.add_parser("x")
    p.add_argument("--new-value")
    p.add_argument("--new-switch", action="store_true")
    p.add_argument("--many", action="append", default=[])
    found = cli.option_actions(parser)
    assert [a.option_strings for a in found["x"] if a.nargs != 0] == [["--new-value"], ["--many"]]
    assert [a.option_strings for a in found["x"] if a.nargs == 0] == [["-h", "--help"], ["--new-switch"]]
    assert found[""][0].option_strings == ["-h", "--help"]


def _no_address(*args, **kwargs):
    raise OSError(errno.EADDRNOTAVAIL, "Cannot assign requested address")


REQUIRED = {"replay": ["no-such-log"], "mc": ["--runs", "2", "--out", "study"], "reproduce": ["--out", "study"],
            "log info": ["no-such.bag"], "log convert": ["no-such.bag", "out"],
            "calibrate": ["no-such-log", "--out", "cal.toml"], "tune": ["no-such-log", "--method", "lc"]}
"""What each command needs besides the flag under test."""
OUTPUTS = ("--json", "--mcap", "--save-log", "--out")
"""Flags for which '-x' would be a good new output: given an existing log directory '-x', each refuses it."""
CASES = [(command, action.option_strings[-1]) for command, actions in cli.OPTIONS.items() if command
         for action in actions if action.nargs != 0]


@pytest.mark.parametrize("command, flag", CASES)
def test_every_value_flag_names_a_value_beginning_with_a_dash(capsys, tmp_path, monkeypatch, command, flag) -> None:
    monkeypatch.chdir(tmp_path)
    if flag in OUTPUTS:
        os.mkdir("-x")
        Path("-x/imu.csv").write_text("t_s\n")
    if flag == "--host":                     # no server is started for a test: the address is refused
        monkeypatch.setattr("app.dashboard.server.main", _no_address)
    base = REQUIRED.get(command, [])
    if flag in base:
        k = base.index(flag)
        base = base[:k] + base[k + 2:]
    code, out, err = _run(capsys, *command.split(), *base, flag, "-x")
    line = _one_line(code, err, flag, "-x")
    assert "expected one argument" not in line and out == ""


@pytest.mark.parametrize("value, message", [
    ("@1:2", "--outage: no beams before '@' in '@1:2'"),
    (" @1:2", "--outage: no beams before '@' in ' @1:2'"),
    ("3,,4@1:2", "--outage: an empty beam in '3,,4@1:2'"),
    ("3,x@1:2", "--outage: unknown beam 'x' in '3,x@1:2'"),
    ("3,3@1:2", "--outage: beam 3 repeated in '3,3@1:2'"),
])
def test_outage_messages_name_the_whole_value_and_what_is_missing(capsys, value, message) -> None:
    """The message names the flag, the whole value and what is missing or wrong in it."""
    _one_line(*_run(capsys, *RUN, "--outage", value)[::2], message)


@pytest.mark.parametrize("value, message", [("", "--beams: no beams in ''"), ("1,,2", "--beams: an empty beam in '1,,2'")])
def test_beams_messages_say_what_is_missing(capsys, value, message) -> None:
    _one_line(*_run(capsys, *RUN, "--beams", value)[::2], message)
