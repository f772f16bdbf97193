"""The command line's own inputs: the smoother's memory budget bounded, a bare ``tauv`` showing the
commands, a misspelt flag answered with the nearest one, a malformed TOML's position kept."""

import pytest

from app.cli import main


def _run(capsys: pytest.CaptureFixture, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("command", [["run"], ["replay", "some-log"], ["mc", "--runs", "2", "--out", "x"]])
@pytest.mark.parametrize("value", ["1e308", "1e303", "1e12", "1000001"])
def test_smooth_memory_beyond_a_terabyte_is_refused(capsys, command, value) -> None:
    """1e308 MB overflowed to a traceback (OverflowError), 1e12 MB was taken without a word."""
    code, out, err = _run(capsys, *command, "--smooth", "--smooth-memory-mb", value)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1
    assert err.startswith(f"tauv: error: --smooth-memory-mb: '{value}' MB is more than the 1000000 MB")
    assert "Traceback" not in err


def test_bare_tauv_prints_the_usage_and_the_commands(capsys) -> None:
    code, out, err = _run(capsys)
    assert code == 2
    assert out == ""
    assert err.startswith("usage: tauv")
    for command in ("run", "replay", "mc", "reproduce", "serve", "log", "config"):
        assert f"\n  {command} " in err
    assert err.splitlines()[-1] == "tauv: error: a command is required (tauv COMMAND --help for its flags)"


def test_bare_tauv_log_prints_its_commands(capsys) -> None:
    code, _, err = _run(capsys, "log")
    assert code == 2
    assert "\n  info " in err and "\n  convert " in err
    assert err.splitlines()[-1].startswith("tauv: error: log: a command is required")


@pytest.mark.parametrize("argv, hint", [
    (["run", "--trajectroy", "figure8"], "(did you mean --trajectory?)"),
    (["run", "--trajectroy=figure8"], "(did you mean --trajectory?)"),
    (["replay", "x", "--smoth"], "(did you mean --smooth?)"),
    (["log", "convert", "a", "b", "--bag-maping", "m.toml"], "(did you mean --bag-mapping?)"),
    (["mc", "--runs", "2", "--outt", "x"], "(--outt: did you mean --out?)"),
])
def test_a_misspelt_flag_gets_the_nearest_one(capsys, argv, hint) -> None:
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1
    assert err.rstrip("\n").endswith(hint)


def test_a_flag_near_none_gets_no_suggestion(capsys) -> None:
    code, _, err = _run(capsys, "run", "--zzzzzz")
    assert code == 2
    assert err == "tauv: error: unrecognized arguments: --zzzzzz\n"


def test_malformed_toml_keeps_its_line_and_column(capsys, tmp_path) -> None:
    """tomllib's message ("Expected '=' after a key in a key/value pair (at line 2, column 12)") was
    cut at 60 characters, before its column."""
    bad = tmp_path / "bad.toml"
    bad.write_text("[imu]\ngyro_noise 3\n")
    code, _, err = _run(capsys, "config", "--config", str(bad))
    assert code == 2
    assert err.count("\n") == 1
    assert err.rstrip("\n").endswith("Expected '=' after a key in a key/value pair (at line 2, column 12)")
