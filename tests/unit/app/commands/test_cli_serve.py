"""``tauv serve`` start-up: the one address to open is the only one printed (viser's
own box printed ``http://127.0.0.1:8080`` beside our ``http://localhost:8080``)."""

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rich
import viser

from app.commands.serve import viser_console_muted

REPO = Path(__file__).resolve().parents[4]
START_TIMEOUT_S = 90.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_viser_s_address_box_is_muted_and_the_console_restored(capsys: pytest.CaptureFixture) -> None:
    port = _free_port()
    with viser_console_muted():
        server = viser.ViserServer(host="127.0.0.1", port=port, verbose=False)
        server.stop()
    out = capsys.readouterr()
    assert f"127.0.0.1:{port}" not in out.out + out.err and "Server stopped" not in out.out + out.err
    assert not rich.get_console().quiet       # as it was before


def test_serve_prints_exactly_one_address(tmp_path: Path) -> None:
    """Given `tauv serve` started, when it is ready, then one line names an address
    (http://localhost:PORT), and after Ctrl-C it has printed no other."""
    port = _free_port()
    log = tmp_path / "serve.log"
    with open(log, "w") as fh:
        proc = subprocess.Popen([sys.executable, "-m", "app.cli", "serve", "--port", str(port), "--workers", "1"],
                                cwd=REPO, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True,
                                env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        while "tauv dashboard: http" not in log.read_text():
            assert proc.poll() is None and time.monotonic() < deadline, log.read_text()[-2000:]
            time.sleep(0.1)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(10) == 0, log.read_text()[-2000:]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(10)
    text = log.read_text()
    assert [line for line in text.splitlines() if "://" in line] == [f"tauv dashboard: http://localhost:{port}"], text
