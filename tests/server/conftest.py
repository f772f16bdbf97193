"""Fixtures for the server tests: `tauv serve` as a process in its own process group, its
children read from /proc (no psutil), and websocket clients speaking viser's protocol."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def proc_stat(pid: int) -> list[str] | None:
    """Fields of /proc/<pid>/stat after the command name (state, ppid, pgrp, ...), None if gone."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError):
        return None


def group_members(pgid: int) -> list[int]:
    """Live (non-zombie) processes whose process group is ``pgid``."""
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            st = proc_stat(int(name))
            if st is not None and int(st[2]) == pgid and st[0] != "Z":
                out.append(int(name))
    return out


def children(pid: int) -> list[int]:
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            st = proc_stat(int(name))
            if st is not None and int(st[1]) == pid and st[0] != "Z":
                out.append(int(name))
    return out


def cmdline(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read().replace(b"\0", b" ").decode(errors="replace")
    except (FileNotFoundError, ProcessLookupError):
        return ""


def cpu_ticks(pid: int) -> int:
    st = proc_stat(pid)
    return 0 if st is None else int(st[11]) + int(st[12])   # utime + stime


def rss_bytes(pid: int) -> int:
    with open(f"/proc/{pid}/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    raise AssertionError(f"no VmRSS for {pid}")


class Server:
    """A `tauv serve` process started in a new session (its own process group)."""

    def __init__(self, log_path: Path, prefix: list[str] | None = None, extra: list[str] | None = None) -> None:
        self.port = free_port()
        self.url = f"ws://127.0.0.1:{self.port}"
        self.log_path = log_path
        self.log = open(log_path, "w")
        cmd = [*(prefix or []), sys.executable, "-m", "app.cli", "serve", "--port", str(self.port), *(extra or [])]
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen(cmd, cwd=REPO, stdout=self.log, stderr=subprocess.STDOUT, env=env,
                                     start_new_session=True)
        self.pgid = self.proc.pid
        self._wait_listening()

    def _wait_listening(self, timeout_s: float = 90.0) -> None:
        deadline = time.monotonic() + timeout_s
        while "tauv dashboard: http" not in self.log_path.read_text():
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.kill()
                pytest.fail(f"tauv serve did not start:\n{self.log_path.read_text()[-3000:]}")
            time.sleep(0.1)

    def server_pid(self) -> int:
        """The Python serving (under `unshare --fork` a grandchild of the started process)."""
        pid = self.proc.pid
        for _ in range(3):
            if "app.cli serve" in cmdline(pid) and "unshare" not in cmdline(pid):
                return pid
            kids = children(pid)
            assert kids, f"no child of {pid}"
            pid = kids[0]
        raise AssertionError("serving process not found")

    def workers(self) -> list[int]:
        pid = self.server_pid()
        return [c for c in children(pid) if "spawn_main" in cmdline(c)]

    def busy_worker(self, timeout_s: float = 30.0) -> int:
        """The worker process using CPU (computing a run)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            before = {p: cpu_ticks(p) for p in self.workers()}
            time.sleep(0.5)
            # >= 0.05 s of CPU in 0.5 s: an idle worker takes none, a computing one takes a share of a
            # core that a loaded machine (the suite's other workers) may cut well below half
            busy = [p for p, t in before.items() if cpu_ticks(p) - t >= 5]
            if len(busy) == 1:
                return busy[0]
        raise AssertionError("no single busy worker")

    def text(self) -> str:
        self.log.flush()
        return self.log_path.read_text()

    def kill(self) -> None:
        try:
            os.killpg(self.pgid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait(10)
        self.log.close()


@pytest.fixture
def server(tmp_path: Path) -> Iterator[Server]:
    s = Server(tmp_path / "server.log")
    yield s
    s.kill()
