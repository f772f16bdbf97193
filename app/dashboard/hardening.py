"""What keeps the dashboard's server up and contained, apart from what it shows.

- Hostile clients: :func:`harden_client_messages` makes viser drop a malformed client message (and
  a frame over MAX_CLIENT_MESSAGE_BYTES) instead of failing on it, counting it in :data:`DROPPED`
  (one summed log line per period, no traceback); :func:`disable_share_tunnel` makes viser's
  share tunnel (an external relay) impossible to start, so nothing leaves this machine.
- The listening address: :func:`check_listen` refuses a port viser would silently move from.
- Shutdown: SIGTERM and SIGINT end the server with status 0 within SHUTDOWN_DEADLINE_S
  (:func:`install_shutdown_handlers`, :func:`shutdown`, :func:`exit_now`), also as PID 1.
- Memory: :func:`bound_malloc_arenas` and :data:`RECLAIM` keep the server's resident memory flat
  under a stream of tabs that connect and close.
"""

from __future__ import annotations

import gc
import inspect
import logging
import os
import signal
import socket
import sys
import threading
import time
import traceback
import warnings
from typing import TYPE_CHECKING, Any, NoReturn

import viser
from viser import _messages as viser_messages

if TYPE_CHECKING:
    from app.dashboard import worker
HARDENED_MARKER = "_tauv_hardened"  # set on viser's _infra module once harden_client_messages patched it
MAX_CLIENT_MESSAGE_BYTES = 1 << 20  # a page sends control changes and camera poses: a few kB
MALFORMED_LOG_PERIOD_S = 10.0  # dropped client messages are summed into one log line per period
SHUTDOWN_DEADLINE_S = 1.5  # after SIGTERM/SIGINT the process exits by then, whatever hangs
REFUSED_CLIENT_MESSAGES = ("ShareUrlRequest", "ShareUrlDisconnect")  # the share tunnel reaches the internet
RECLAIM_PERIOD_S = 2.0  # after a tab closes, its memory is collected and trimmed this much later
MALLOC_ARENAS = 2  # glibc malloc arenas of the server process (see bound_malloc_arenas)
M_ARENA_MAX = -8  # mallopt parameter number (glibc malloc.h)


class _DropLog:
    """Counts dropped client messages; at most one line per MALFORMED_LOG_PERIOD_S on stderr, no traceback."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.count = 0  # dropped since the server started
        self.unlogged = 0
        self.last_log = -MALFORMED_LOG_PERIOD_S

    def drop(self, reason: str) -> None:
        with self.lock:
            self.count += 1
            self.unlogged += 1
            now = time.monotonic()
            if now - self.last_log < MALFORMED_LOG_PERIOD_S:
                return
            n, self.unlogged, self.last_log = self.unlogged, 0, now
        reason = reason if len(reason) <= 200 else reason[:200] + "..."
        print(
            f"tauv dashboard: dropped {n} malformed client message(s); last: {reason}",
            file=sys.stderr,
            flush=True,
        )


DROPPED = _DropLog()


def display_error(exc: BaseException) -> tuple[str, str, bool]:
    """The notification (title, text, error) of a bug in drawing a tab, its traceback written to
    the server's stderr: the tab shows one line, whoever runs the server can find where it came from."""
    print("tauv dashboard: display error", file=sys.stderr, flush=True)
    traceback.print_exception(exc, file=sys.stderr)
    sys.stderr.flush()
    return "Display error", f"{type(exc).__name__}: {exc}", True


def harden_client_messages() -> bool:
    """Make viser drop a malformed client message instead of failing on it; True if installed.

    viser 1.1 reads each connection's frames in ``viser.infra._infra._message_consumer``
    (``raw = await websocket.recv(); assert isinstance(raw, bytes); message =
    Message.deserialize(raw); handle_message(message)``): random bytes, truncated msgpack, an
    unknown ``type`` or a text frame raise there, which ends the connection with a traceback in
    the log; a message that decodes but carries wrong field types raises later in its handler
    task (``WebsockMessageHandler._handle_incoming_message``), logged by asyncio with a traceback
    as "Task exception was never retrieved". This replaces the consumer with one that drops such
    a frame (and any frame over MAX_CLIENT_MESSAGE_BYTES; websockets itself refuses larger frames
    before reading them, see :func:`_limit_frames`) and the share-tunnel requests, and wraps the
    handler dispatch so a handler's exception drops that one message. Both are counted in
    :data:`DROPPED` and summed into one log line per MALFORMED_LOG_PERIOD_S. The connection and
    every other client carry on. Process-wide and idempotent; if viser's internals have changed
    shape, nothing is patched and False is returned (the server still runs, as viser made it).
    """
    try:
        from viser.infra import _infra

        consumer_params = list(inspect.signature(_infra._message_consumer).parameters)
        dispatch = _infra.WebsockMessageHandler._handle_incoming_message
    except (ImportError, AttributeError, TypeError, ValueError):
        return False
    if getattr(_infra, HARDENED_MARKER, False):
        return True
    if consumer_params != ["websocket", "handle_message", "message_class"]:
        return False

    async def message_consumer(websocket: Any, handle_message: Any, message_class: Any) -> None:
        _limit_frames(websocket)
        while True:
            raw = await websocket.recv()  # ConnectionClosed ends the connection, as in viser
            if not isinstance(raw, (bytes, bytearray)):
                DROPPED.drop("a text frame")
                continue
            if len(raw) > MAX_CLIENT_MESSAGE_BYTES:
                DROPPED.drop(f"a frame of {len(raw)} bytes")
                continue
            try:
                message = message_class.deserialize(bytes(raw))
            except Exception as exc:  # noqa: BLE001 - any decoding failure is the client's: drop the frame
                DROPPED.drop(f"{type(exc).__name__}: {exc}")
                continue
            if type(message).__name__ in REFUSED_CLIENT_MESSAGES:
                DROPPED.drop(f"{type(message).__name__} (the share tunnel is disabled)")
                continue
            handle_message(message)

    async def guarded_dispatch(self: Any, client_id: Any, message: Any) -> None:
        try:
            await dispatch(self, client_id, message)
        except Exception as exc:  # noqa: BLE001 - a handler refusing a malformed message: drop that one
            DROPPED.drop(f"{type(message).__name__}: {type(exc).__name__}: {exc}")

    _infra._message_consumer = message_consumer
    _infra.WebsockMessageHandler._handle_incoming_message = guarded_dispatch
    logging.getLogger("websockets.server").addFilter(_connection_failure_filter)
    setattr(_infra, HARDENED_MARKER, True)
    return True


def _connection_failure_filter(record: logging.LogRecord) -> bool:
    """websockets logs a connection that is not a websocket handshake (a port scan, a bare TCP
    connect, garbage instead of HTTP) or whose handler failed with a full traceback: count it as
    a dropped client message instead (one summed line, see :data:`DROPPED`)."""
    message = record.getMessage()
    if message in ("opening handshake failed", "connection handler failed"):
        exc = record.exc_info[1] if record.exc_info else None
        DROPPED.drop(f"{message}: {type(exc).__name__}: {exc}" if exc is not None else message)
        return False
    return True


def _limit_frames(websocket: Any) -> None:
    """Lower this connection's largest accepted message to MAX_CLIENT_MESSAGE_BYTES (viser asks
    websockets for 50 MB). websockets checks a frame's declared length before reading its payload
    and closes the connection with code 1009, so an oversized frame costs no memory."""
    protocol = getattr(websocket, "protocol", None)
    current = getattr(protocol, "max_message_size", None)
    if protocol is not None and (current is None or current > MAX_CLIENT_MESSAGE_BYTES):
        protocol.max_message_size = MAX_CLIENT_MESSAGE_BYTES


def disable_share_tunnel(server: viser.ViserServer) -> None:
    """Make viser's share tunnel (a relay at share.viser.studio) impossible to start.

    ``show_share_button=False`` only hides the button: viser still registers handlers that start
    the tunnel on a client's ``ShareUrlRequest``. They are unregistered here, and
    ``request_share_url`` (which they call) is replaced by a refusal, so neither a client message
    nor a stray call reaches outside this machine; :func:`harden_client_messages` also drops the
    two messages before dispatch.
    """
    websock = getattr(server, "_websock_server", None)
    for name in REFUSED_CLIENT_MESSAGES:
        cls = getattr(viser_messages, name, None)
        handlers = getattr(websock, "_incoming_handlers", {})
        if websock is not None and cls is not None and cls in handlers:
            websock.unregister_handler(cls)

    def refuse(verbose: bool = True) -> None:
        print(
            "tauv dashboard: share URL refused (the dashboard never connects outside this machine)",
            file=sys.stderr,
            flush=True,
        )

    server.request_share_url = refuse  # type: ignore[method-assign]


def check_listen(host: str, port: int) -> None:
    """Raise OSError if ``host:port`` cannot be bound: viser would silently move to another
    port, and a user (or a Docker port mapping) would look for the dashboard in the wrong place."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((host, port))


class ShutdownRequest:
    """Set by SIGTERM or SIGINT (see :func:`install_shutdown_handlers`)."""

    def __init__(self) -> None:
        self.signum: int | None = None  # the first signal received
        self.serving = False  # startup finished: a signal now only asks the loop to end


def install_shutdown_handlers() -> ShutdownRequest:
    """Handle SIGTERM and SIGINT explicitly, both ending the server with exit status 0.

    Explicit handlers matter as PID 1 of a PID namespace (Docker without ``--init``): the kernel
    drops a signal PID 1 has no handler for, so SIGTERM did nothing and ``docker stop`` waited
    10 s for SIGKILL. The handler only records the signal (it runs between two bytecodes of the
    main thread, possibly inside a lock, so it must not take one); :func:`main`'s loop sees it
    within 0.1 s. During startup it raises SystemExit(0) instead, so a slow start can be stopped.
    """
    request = ShutdownRequest()

    def handler(signum: int, frame: Any) -> None:
        if request.signum is None:
            request.signum = signum
        if not request.serving:
            raise SystemExit(0)

    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, handler)
    return request


def bound_malloc_arenas(arenas: int = MALLOC_ARENAS) -> bool:
    """Cap glibc's malloc arenas for this process (True if set).

    glibc gives each thread that allocates concurrently its own arena (up to 8 per core) and
    rarely returns their memory: viser builds each tab and runs each callback on a pool of up to
    32 threads, so a burst of connections (even hostile ones, closed at once) left the server's
    resident memory hundreds of MB higher for good. Two arenas keep it flat at no measurable
    cost to a server whose threads mostly wait. Must run before those threads start."""
    try:
        import ctypes

        return ctypes.CDLL(None).mallopt(M_ARENA_MAX, arenas) == 1
    except (OSError, AttributeError):  # not glibc
        return False


class _MemoryReclaimer:
    """After tabs close, collect their cycles and hand freed heap back to the OS (glibc's
    ``malloc_trim``), at most once per RECLAIM_PERIOD_S: a tab's Session holds MBs of figures and
    scene buffers in reference cycles, and without this the server's resident memory only grows
    under a stream of connections, even hostile ones that close at once."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.scheduled = False

    def soon(self) -> None:
        with self.lock:
            if self.scheduled:
                return
            self.scheduled = True
        timer = threading.Timer(RECLAIM_PERIOD_S, self._run)
        timer.daemon = True
        timer.start()

    def _run(self) -> None:
        with self.lock:
            self.scheduled = False
        gc.collect()
        try:
            import ctypes

            ctypes.CDLL(None).malloc_trim(0)
        except (OSError, AttributeError):  # not glibc
            pass


RECLAIM = _MemoryReclaimer()


def exit_now() -> NoReturn:
    """Leave at once with status 0, output flushed, without the interpreter's finalization: when
    the shutdown deadline passed (a callback thread hangs), and after a clean stop (app.cli)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(0)


def shutdown(server: viser.ViserServer, pool: worker.RunPool) -> None:
    """Kill the run workers first (a busy one is not awaited), then stop viser. Whatever still
    hangs after SHUTDOWN_DEADLINE_S (a tab's callback thread waiting on its page, say) is cut
    short by a daemon timer that ends the process with status 0 (the children are dead by then)."""
    # a tab's run thread may still update its page after viser has closed the connections
    warnings.filterwarnings("ignore", message="Queued a .* on a closed connection")
    watchdog = threading.Timer(SHUTDOWN_DEADLINE_S, exit_now)
    watchdog.daemon = True
    watchdog.start()  # never cancelled: it also bounds the interpreter's own exit
    try:
        pool.shutdown()
    finally:
        server.stop()
