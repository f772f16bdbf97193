"""SIGTERM and SIGINT end `tauv serve` and every process it started within 2 s, exit status 0,
with a run in progress: also as PID 1 of its own PID namespace (Docker without --init), where
the kernel drops any signal PID 1 has no handler for."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest

from tests.server.conftest import Server, group_members
from tests.server.viser_client import ViserClient

EXIT_WITHIN_S = 2.0     # the bound (measured: ~0.4 s)


def _run_long_mission(server: Server) -> ViserClient:
    client = ViserClient(server.url)
    client.set_value("Duration [s]", "3000")
    time.sleep(0.1)                       # one message per control, as the page sends them
    mark = client.mark()
    client.click("Run")
    client.wait_for(lambda m: m.get("type") == "SetPositionMessage" or "/traj/truth" == m.get("name"),
                    60.0, "the run's truth in the scene", since=mark)
    server.busy_worker()                  # a worker is computing the run now
    return client


def _signal_and_wait(server: Server, signum: int) -> tuple[int, float]:
    pid = server.server_pid()
    t0 = time.monotonic()
    os.kill(pid, signum)
    deadline = t0 + 10.0
    while server.proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    elapsed = time.monotonic() - t0
    rc = server.proc.poll()
    return (rc if rc is not None else -999), elapsed


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_ends_server_and_children_with_a_run_in_progress(tmp_path: Path, signum: int) -> None:
    server = Server(tmp_path / "server.log")
    try:
        client = _run_long_mission(server)
        assert len(group_members(server.pgid)) >= 4     # server, resource tracker, 2 workers
        rc, elapsed = _signal_and_wait(server, signum)
        left = group_members(server.pgid)
        print(f"{signal.Signals(signum).name}: exit {rc} after {elapsed:.2f} s, {len(left)} process(es) left")
        assert rc == 0, server.text()[-2000:]
        assert elapsed < EXIT_WITHIN_S, elapsed
        assert left == [], left
        assert "Traceback" not in server.text()
        client.close()
    finally:
        server.kill()


def _unshare_works() -> str | None:
    if shutil.which("unshare") is None:
        return "unshare is not installed"
    probe = subprocess.run(["unshare", "--pid", "--fork", "--mount-proc", "true"], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"unshare --pid --fork is not permitted here: {probe.stderr.strip()[:200]}"
    return None


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_ends_server_running_as_pid_1(tmp_path: Path, signum: int) -> None:
    reason = _unshare_works()
    if reason is not None:
        pytest.skip(reason)
    server = Server(tmp_path / "server.log", prefix=["unshare", "--pid", "--fork", "--mount-proc"])
    try:
        pid = server.server_pid()
        with open(f"/proc/{pid}/status") as fh:
            nspid = [line.split()[1:] for line in fh if line.startswith("NSpid:")][0]
        assert nspid[-1] == "1", nspid                    # PID 1 inside its namespace
        client = _run_long_mission(server)
        rc, elapsed = _signal_and_wait(server, signum)     # unshare exits with its child's status
        left = group_members(server.pgid)
        print(f"PID 1, {signal.Signals(signum).name}: exit {rc} after {elapsed:.2f} s, {len(left)} left")
        assert rc == 0, server.text()[-2000:]
        assert elapsed < EXIT_WITHIN_S, elapsed
        assert left == [], left
        client.close()
    finally:
        server.kill()
