"""Fuzz the command line, configuration files and output paths.

Seeded (``derandomize=True``: the same cases on every run, so CI is reproducible). Each case runs
in-process through ``app.cli.main`` and is checked by :func:`tests.fuzz.harness.run_case`:
exit status 0 or 2, no traceback, one line naming the field/flag/file with the value shortened, no
partial output, bounded time and memory. A small group runs real processes for what only a
process shows (a FIFO that would block, a closed pipe, real exit codes).

Fast tier: a few hundred cases (< 60 s); slow tier (``-m slow``): over a thousand more.
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import app
from tests.fuzz import strategies as S
from tests.fuzz.harness import STATS, run_case

pytestmark = pytest.mark.fuzz

FAST = {"flags": 120, "toml": 120, "files": 40, "outputs": 40}
SLOW = {"flags": 800, "toml": 1000, "files": 150, "outputs": 150}


def _settings(n: int) -> settings:
    return settings(max_examples=n, derandomize=True, database=None, deadline=None, print_blob=True,
                    suppress_health_check=list(HealthCheck))


class Workspace:
    """A directory of hostile files and output targets, the working directory of every case."""

    def __init__(self, root: str) -> None:
        self.root = root
        j = self.path
        os.mkfifo(j("fifo.toml"))
        os.mkdir(j("dir.toml"))
        os.symlink("loop.toml", j("loop.toml"))
        os.symlink("missing.toml", j("dangling.toml"))
        with open(j("big.toml"), "wb") as fh:
            fh.write(b"#" * ((1 << 20) + 1))
        with open(j("empty.toml"), "wb"):
            pass
        with open(j("latin1.toml"), "wb") as fh:
            fh.write('[trajectory]\nname = "\u00e9"\n'.encode("latin-1"))
        with open(j("utf16.toml"), "wb") as fh:
            fh.write('[trajectory]\nduration_s = 2.0\n'.encode("utf-16"))
        with open(j("deep.toml"), "wb") as fh:
            fh.write(b"a = " + b"[" * 100_000 + b"]" * 100_000)
        os.symlink("loop.json", j("loop.json"))
        os.symlink("real-out.json", j("link-out.json"))
        self.config_paths = [j(n) for n in ("good.toml", "fifo.toml", "dir.toml", "loop.toml", "dangling.toml",
                                            "big.toml", "empty.toml", "latin1.toml", "utf16.toml", "deep.toml",
                                            "link-to-good.toml", "hardlink-to-good.toml")] + [
            "", "/dev/zero", "/dev/null", "/dev/urandom", "/proc/self/mem", "/proc/self/environ", "/",
            j("good.toml") + "/x.toml", j("x" * 300), j("/".join(["d" * 250] * 20)), "relative-missing.toml",
            "-", "\u00e9\u2713.toml", "a\nb.toml"]
        self.json_paths = [j("out.json"), j("existing.json"), j("dir.toml"), "/dev/null", j("nodir/out.json"),
                           j("good.toml"), j("link-to-good.toml"), j("hardlink-to-good.toml"), "",
                           j("y" * 300 + ".json"), "/proc/tauv-fuzz.json", j("link-out.json"), j("loop.json"),
                           j("\u00e9 \u2713.json"), j("a\nb.json"), "relative.json", "-", j("fifo.toml")]
        self.initial = set(os.listdir(root)) | {"good.toml", "link-to-good.toml", "hardlink-to-good.toml"}

    def path(self, name: str) -> str:
        return os.path.join(self.root, name)

    GOOD = '[trajectory]\nduration_s = 2.0\n[run]\nmethods = ["ins", "lc"]\n'

    def reset(self) -> None:
        """Remove what the last case wrote (outputs); restore the configuration files (a case may
        legitimately write its --json over one when no --config names it) and the existing output."""
        for name in ("good.toml", "link-to-good.toml", "hardlink-to-good.toml"):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.path(name))
        with open(self.path("good.toml"), "w") as fh:
            fh.write(self.GOOD)
        os.symlink("good.toml", self.path("link-to-good.toml"))
        os.link(self.path("good.toml"), self.path("hardlink-to-good.toml"))
        for name in set(os.listdir(self.root)) - self.initial:
            p = self.path(name)
            if os.path.isdir(p) and not os.path.islink(p):
                shutil.rmtree(p)
            else:
                os.unlink(p)
        with open(self.path("existing.json"), "w") as fh:
            fh.write('{"written": "before the case"}')
        with contextlib.suppress(OSError):
            os.unlink(self.path("real-out.json"))


@pytest.fixture(scope="module")
def ws() -> Iterator[Workspace]:
    root = tempfile.mkdtemp(prefix="tauv-fuzz-")
    cwd = os.getcwd()
    os.chdir(root)
    try:
        w = Workspace(root)
        w.reset()
        yield w
    finally:
        os.chdir(cwd)
        shutil.rmtree(root, ignore_errors=True)


def _json_real(ws: Workspace, target: str) -> str | None:
    """The file a --json target would change (None for '' and device files)."""
    if not target or target.startswith("/dev/") or target == "-":
        return None
    return os.path.realpath(os.path.join(ws.root, target))


# --- flags ----------------------------------------------------------------------------------------

FLAG_NAMES = ("--trajectory", "--method", "--duration", "--seed", "--ideal", "--aiding", "--beams", "--outage",
              "--dropout", "--vb-nf", "--nsv-epsilon", "--config", "--json")
ARGPARSE_NAMES = ["unrecognized arguments", "invalid choice", "expected one argument", "required"]


@st.composite
def flag_case(draw: st.DrawFn, ws: Workspace) -> tuple[list[str], str | None, list[str]]:
    command = draw(st.sampled_from(["run"] * 9 + ["config"]))
    flags = draw(st.lists(st.sampled_from(FLAG_NAMES), min_size=1, max_size=4, unique=True))
    if command == "config":
        flags = [f for f in flags if f == "--config"] or ["--config"]
    argv, values, json_target = [command], [], None
    if command == "run" and "--duration" not in flags:
        argv += ["--duration", draw(S.VALID_FLAG_VALUES["--duration"])]
    for flag in flags:
        if flag == "--ideal":
            argv.append(flag)
            continue
        if flag == "--config":
            value = draw(st.one_of(st.sampled_from(ws.config_paths), S.hostile_text()))
        elif flag == "--json":
            value = draw(st.one_of(st.sampled_from(ws.json_paths),
                                   st.text(st.characters(blacklist_characters="/\x00", blacklist_categories=("Cs",)),
                                           min_size=1, max_size=12).map(lambda s: "f-" + s + ".json")))
            json_target = value
        else:
            value = draw(st.one_of(S.VALID_FLAG_VALUES[flag], S.VALID_FLAG_VALUES[flag], S.hostile_text()))
            if flag == "--duration" and S.is_long_duration(value):
                value = "3"
        values.append(value)
        argv += draw(st.sampled_from([[flag, value], [f"{flag}={value}"]]))
    junk = draw(st.sampled_from([None] * 8 + ["--dur", "--meth", "--conf", "-x", "extra", "--", "--jso", "-"]))
    if junk is not None:
        argv.insert(draw(st.integers(1, len(argv))), junk)
    return argv, json_target, values


def _check_flags(ws: Workspace, tier: str, case: tuple[list[str], str | None, list[str]]) -> None:
    argv, json_target, values = case
    ws.reset()
    names = [a.split("=")[0] for a in argv if a.startswith("-")] + ARGPARSE_NAMES + ["--config", "--json"]
    names += ["trajectory.", "dvl.", "run.", "imu.", "[trajectory]", "[run]", "--duration"]
    run_case(argv, tier, names=names, json_path=_json_real(ws, json_target) if json_target else None,
             watch_dirs=[ws.root], long_values=values)


def test_fuzz_flags(ws) -> None:
    @_settings(FAST["flags"])
    @given(case=flag_case(ws))
    def inner(case):
        _check_flags(ws, "fast", case)
    inner()


@pytest.mark.slow
def test_fuzz_flags_slow(ws) -> None:
    @_settings(SLOW["flags"])
    @given(case=flag_case(ws))
    def inner(case):
        _check_flags(ws, "slow", case)
    inner()


# --- TOML files -----------------------------------------------------------------------------------

@st.composite
def toml_case(draw: st.DrawFn) -> tuple[bytes, list[str], bool]:
    doc, names = draw(S.toml_document())
    try:
        text = S.dumps(doc)
    except (TypeError, ValueError):        # tomli_w cannot write some hostile structures
        text = b"[run]\nseed = -1\n"
        names = ["run.seed"]
    mangled = draw(st.sampled_from([False] * 3 + [True]))
    if mangled:
        text, _how = draw(S.mangled_bytes(text))
        names = names + ["--config", ".", "unknown section", "["]     # any name may appear after a random edit
    return text, names, mangled


def _check_toml(ws: Workspace, tier: str, case: tuple[bytes, list[str], bool]) -> None:
    text, names, mangled = case
    ws.reset()
    path = ws.path("case.toml")
    with open(path, "wb") as fh:
        fh.write(text)
    out = ws.path("out.json")
    argv = ["run", "--config", path, "--json", out] + (["--duration", "2"] if mangled else [])
    run_case(argv, tier, names=names, json_path=out, watch_dirs=[ws.root])
    os.unlink(path)


def test_fuzz_toml(ws) -> None:
    @_settings(FAST["toml"])
    @given(case=toml_case())
    def inner(case):
        _check_toml(ws, "fast", case)
    inner()


@pytest.mark.slow
def test_fuzz_toml_slow(ws) -> None:
    @_settings(SLOW["toml"])
    @given(case=toml_case())
    def inner(case):
        _check_toml(ws, "slow", case)
    inner()


# --- special files as --config, and output paths --------------------------------------------------

@st.composite
def file_case(draw: st.DrawFn, ws: Workspace) -> list[str]:
    config = draw(st.sampled_from(ws.config_paths))
    extra = draw(st.sampled_from([[], ["--method", "ins"], ["--seed", "5"], ["--ideal"]]))
    command = draw(st.sampled_from(["run", "run", "config"]))
    argv = [command, "--config", config] + (["--duration", "2"] + extra if command == "run" else [])
    return argv


def _check_file(ws: Workspace, tier: str, argv: list[str]) -> None:
    ws.reset()
    config = argv[2]
    run_case(argv, tier, names=["--config", "trajectory.", "[trajectory]", "unknown section", "run."],
             watch_dirs=[ws.root], long_values=[config])


def test_fuzz_special_files(ws) -> None:
    @_settings(FAST["files"])
    @given(argv=file_case(ws))
    def inner(argv):
        _check_file(ws, "fast", argv)
    inner()


@st.composite
def output_case(draw: st.DrawFn, ws: Workspace) -> tuple[list[str], str]:
    target = draw(st.sampled_from(ws.json_paths))
    config = draw(st.sampled_from([None, ws.path("good.toml"), ws.path("link-to-good.toml")]))
    argv = ["run", "--duration", draw(S.finite_float_text(1.0, 2.0)), "--method", "ins", "--json", target]
    if config is not None:
        argv += ["--config", config]
    return argv, target


def _check_output(ws: Workspace, tier: str, case: tuple[list[str], str]) -> None:
    argv, target = case
    ws.reset()
    result = run_case(argv, tier, names=["--json", "--config"], json_path=_json_real(ws, target),
                      watch_dirs=[ws.root, "/proc"], long_values=[target])
    if "--config" in argv:
        with open(ws.path("good.toml")) as fh:
            assert fh.read() == ws.GOOD, "the --config file was overwritten"
    if result.code == 0 and target == ws.path("link-out.json"):
        assert os.path.isfile(ws.path("real-out.json")) and os.path.islink(ws.path("link-out.json"))


def test_fuzz_output_paths(ws) -> None:
    @_settings(FAST["outputs"])
    @given(case=output_case(ws))
    def inner(case):
        _check_output(ws, "fast", case)
    inner()


@pytest.mark.slow
def test_fuzz_files_and_outputs_slow(ws) -> None:
    @_settings(SLOW["files"] + SLOW["outputs"])
    @given(which=st.booleans(), file=file_case(ws), out=output_case(ws))
    def inner(which, file, out):
        if which:
            _check_file(ws, "slow", file)
        else:
            _check_output(ws, "slow", out)
    inner()


# --- real processes -------------------------------------------------------------------------------

_ENV = {**os.environ, "PYTHONPATH": os.path.dirname(os.path.dirname(os.path.abspath(app.__file__)))}
"""The subprocesses run the same checkout as the in-process cases (not an installed copy)."""


def _limit_memory() -> None:
    """In the child: at most 2 GiB of address space, so a regression (reading /dev/zero) fails
    with MemoryError instead of calling the OOM killer on the machine."""
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, resource.getrlimit(resource.RLIMIT_AS)[1]))

PROCESS_CASES = [
    (["run", "--config", "{fifo}"], 2),
    (["run", "--config", "/dev/zero"], 2),
    (["run", "--dropout", "-inf"], 2),
    (["run", "--dur", "3"], 2),
    (["run", "--duration", "1e5"], 2),
    (["run", "--json", ""], 2),
    (["config", "--config", "{deep}"], 2),
    (["run", "--duration", "2", "--method", "ins"], 0),
]


@pytest.mark.parametrize("argv, expected", PROCESS_CASES, ids=[" ".join(a) for a, _ in PROCESS_CASES])
def test_process_exit_status_and_no_hang(ws, argv, expected) -> None:
    argv = [a.format(fifo=ws.path("fifo.toml"), deep=ws.path("deep.toml")) for a in argv]
    proc = subprocess.run([sys.executable, "-m", "app.cli", *argv], capture_output=True, text=True, timeout=60,
                          cwd=ws.root, env=_ENV, preexec_fn=_limit_memory)
    STATS.cases["process"] += 1
    STATS.exits[proc.returncode] += 1
    assert proc.returncode == expected, proc.stderr
    assert "Traceback" not in proc.stderr
    if expected == 2:
        assert len(proc.stderr.splitlines()) == 1


@pytest.mark.parametrize("command", [["config"], ["run", "--duration", "2", "--method", "ins"]])
def test_process_with_closed_stdout(command) -> None:
    """``| head -1``: the reader is gone; exit 0 and nothing on stderr."""
    proc = subprocess.Popen([sys.executable, "-m", "app.cli", *command], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, env=_ENV, preexec_fn=_limit_memory)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    code = proc.wait(timeout=60)
    STATS.cases["process"] += 1
    STATS.exits[code] += 1
    assert code == 0 and err == "", err
