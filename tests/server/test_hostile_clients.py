"""Hostile websocket clients: malformed frames are dropped without a traceback and without
memory growth while a normal client keeps working; the share tunnel cannot be started by any
client message; a worker killed as the out-of-memory killer would is reported to its tab."""

from __future__ import annotations

import random
import socket
import time

import msgspec.msgpack
import pytest

from tests.server.conftest import Server, rss_bytes
from tests.server.viser_client import CAMERA, ViserClient, connect_raw, encode

FRAMES = 200
CONNECTIONS = 50
RSS_GROWTH_BOUND = 50 * 2**20


def malformed_frames(rng: random.Random, n: int) -> list[bytes | str]:
    """Random bytes, truncated msgpack, wrong field types, unknown types, text and huge frames
    (plus, in the test, connections that are no websocket handshake at all)."""
    valid = encode({"type": "GuiUpdateMessage", "uuid": "x", "updates": {"value": 1.0}})
    kinds = [
        lambda: rng.randbytes(rng.randint(1, 300)),                                  # random bytes
        lambda: valid[:rng.randint(1, len(valid) - 1)],                              # truncated msgpack
        lambda: encode({"type": "GuiUpdateMessage", "uuid": 5, "updates": [1, 2]}),  # wrong types
        lambda: encode({"type": "GuiUpdateMessage", "uuid": "x", "updates": {"no_such_prop": 1}}),
        lambda: encode({"type": "ViewerCameraMessage", "wxyz": "abc", "position": None}),
        lambda: encode({"type": "NoSuchMessage", "a": 1}),                           # unknown type
        lambda: encode({"no_type": True}),
        lambda: encode([1, 2, 3]),
        lambda: encode({"type": "GuiUpdateMessage"}),                                # missing fields
        lambda: "a text frame",
        lambda: b"\x00" * (4 * 2**20),                                               # a huge frame
    ]
    return [kinds[i % len(kinds)]() for i in range(n)]


def settled_rss(pid: int, timeout_s: float = 30.0) -> int:
    """The server's RSS once the tabs the attack opened are gone: read every second until it falls
    by less than 1 MiB (each attacking tab builds a whole session, a few MiB, and the server drops
    it some seconds after its connection closed), at most ``timeout_s``."""
    time.sleep(2.0)
    previous = rss_bytes(pid)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        time.sleep(1.0)
        now = rss_bytes(pid)
        if previous - now < 2**20:
            return now
        previous = now
    return previous


def test_malformed_frames_are_dropped_quietly_and_cost_no_memory(server: Server) -> None:
    rng = random.Random(7)
    normal = ViserClient(server.url)
    pid = server.server_pid()
    # warm-up: the same frames over the same connections first, so caches and pools are filled
    frames = malformed_frames(rng, FRAMES)
    per_conn = FRAMES // CONNECTIONS

    def attack(batch: list[bytes | str], with_tab: bool) -> None:
        try:
            ws = connect_raw(server.url)
        except OSError:
            return
        try:
            if with_tab:
                ws.send(encode(CAMERA))
            for frame in batch:
                ws.send(frame)
            time.sleep(0.2)
        except Exception:   # the server may close a connection after a huge frame
            pass
        finally:
            ws.close()

    def not_websocket(payload: bytes) -> None:
        with socket.create_connection(("127.0.0.1", server.port), timeout=5) as s:
            s.sendall(payload)
            time.sleep(0.05)

    # the first round: half the connections are tabs, each builds a whole session (a few MiB) that
    # the server drops once its connection closed; the allocator keeps the high-water mark of the
    # sessions alive at once, so memory is compared after a second, identical round: a leak grows
    # with every round, that mark does not
    for k in range(CONNECTIONS):
        attack(frames[k * per_conn:(k + 1) * per_conn], with_tab=k % 2 == 0)
    for payload in (b"", b"\x16\x03\x01 not http\r\n\r\n", b"GET / HTTP/1.1\r\nUpgrade: websocket\r\n\r\n"):
        not_websocket(payload)                                   # a port scan, TLS, a bad handshake
    rss_before = settled_rss(pid)
    for k in range(CONNECTIONS):
        attack(frames[k * per_conn:(k + 1) * per_conn], with_tab=k % 2 == 0)
    rss_after = settled_rss(pid)
    print(f"{FRAMES} malformed frames over {CONNECTIONS} connections: server RSS {rss_before / 2**20:.0f} -> "
          f"{rss_after / 2**20:.0f} MiB")
    # the normal client still works: a run completes
    normal.set_value("Duration [s]", "5")
    time.sleep(0.1)
    mark = normal.mark()
    normal.click("Run")
    _, note = normal.wait_for(lambda m: m.get("type") == "NotificationShowMessage"
                              and m["props"]["title"] in ("Run complete", "Run failed", "Cannot run"),
                              120.0, "the run's end", since=mark)
    assert note["props"]["title"] == "Run complete", note["props"]
    log = server.text()
    assert "Traceback" not in log, log[-3000:]
    assert "dropped" in log and "malformed client message" in log
    assert rss_after - rss_before < RSS_GROWTH_BOUND, (rss_before, rss_after)


def test_no_client_message_starts_the_share_tunnel(monkeypatch: pytest.MonkeyPatch) -> None:
    import viser._viser

    from app.dashboard import server as dashboard
    from tests.server.conftest import free_port

    tunnels: list[tuple] = []
    outward: list[object] = []

    class RecordingTunnel:
        def __init__(self, *args: object, **kwargs: object) -> None:
            tunnels.append(args)
            raise OSError("a tunnel was about to start")

    def loopback(address: object) -> bool:
        host = address[0] if isinstance(address, tuple) else address
        return isinstance(host, str) and (host in ("localhost", "::1") or host.startswith("127."))

    real_connect, real_create, real_getaddrinfo = socket.socket.connect, socket.create_connection, socket.getaddrinfo

    def connect(self: socket.socket, address: object) -> None:
        if self.family in (socket.AF_INET, socket.AF_INET6) and not loopback(address):
            outward.append(address)
        return real_connect(self, address)

    def create_connection(address: object, *args: object, **kwargs: object) -> socket.socket:
        if not loopback(address):
            outward.append(address)
        return real_create(address, *args, **kwargs)

    def getaddrinfo(host: object, *args: object, **kwargs: object) -> list:
        if host is not None and not loopback(host):
            outward.append(host)
        return real_getaddrinfo(host, *args, **kwargs)

    monkeypatch.setattr(viser._viser, "ViserTunnel", RecordingTunnel)
    monkeypatch.setattr(socket.socket, "connect", connect)
    monkeypatch.setattr(socket, "create_connection", create_connection)
    monkeypatch.setattr(socket, "getaddrinfo", getaddrinfo)
    port = free_port()
    server, pool = dashboard.build_server("127.0.0.1", port, workers=1)
    try:
        url = f"ws://127.0.0.1:{port}"
        tab = ViserClient(url)                        # a tab, as the page is
        tab.send({"type": "ShareUrlRequest"})         # what viser's share button sends
        bare = connect_raw(url)                       # and a connection that is no tab
        bare.send(msgspec.msgpack.encode({"type": "ShareUrlRequest"}))
        bare.send(msgspec.msgpack.encode({"type": "ShareUrlDisconnect"}))
        time.sleep(2.0)
        assert server.request_share_url() is None     # a direct call refuses too
        assert tunnels == [] and server._share_tunnel is None
        assert outward == [], outward
        assert tab.find("Run")                        # the tab still works
        bare.close()
        tab.close()
    finally:
        server.stop()
        pool.shutdown()


def test_a_killed_worker_ends_its_run_with_a_notification_and_later_runs_work(server: Server) -> None:
    import os
    import signal

    tab = ViserClient(server.url)
    tab.set_value("Duration [s]", "3000")
    time.sleep(0.1)
    mark = tab.mark()
    tab.click("Run")
    busy = server.busy_worker()
    os.kill(busy, signal.SIGKILL)                     # as the out-of-memory killer does
    _, note = tab.wait_for(lambda m: m.get("type") == "NotificationShowMessage", 30.0, "a notification", mark)
    assert note["props"]["title"] == "Run failed"
    assert "worker computing this run died" in note["props"]["body"] and "signal 9" in note["props"]["body"]
    # the next run in this tab, and one in another tab, both complete
    other = ViserClient(server.url)
    for client in (tab, other):
        client.set_value("Duration [s]", "5")
    time.sleep(0.1)
    marks = [tab.mark(), other.mark()]
    tab.click("Run")
    other.click("Run")
    for client, m0 in zip((tab, other), marks):
        _, done = client.wait_for(lambda m: m.get("type") == "NotificationShowMessage", 120.0, "the run's end", m0)
        assert done["props"]["title"] == "Run complete", done["props"]
    assert busy not in server.workers() and len(server.workers()) == 2
    assert "Traceback" not in server.text()
