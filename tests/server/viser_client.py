"""A websocket client speaking viser 1.1's protocol, as the page's JavaScript does (no browser).

Wire format (viser/infra/_infra.py, client/src/WebsocketClientWorker.ts): the client opens
``ws://host:port`` with the subprotocol ``viser-v<version>`` and sends each message as one binary
frame, ``msgpack({"type": <Message class name>, <field>: <value>, ...})``. The server sends
batches: 8 bytes decompressed length and 8 bytes compressed length (little-endian), then the
zstd-compressed msgpack ``{"messages": [...], "timestampSec", "binaryBufferLengths"}`` and the
raw binary buffers the messages' placeholders point to (ignored here). The server builds a tab
only after the page reports its camera (``ViewerCameraMessage``). A GUI control is created by a
``Gui<Kind>Message`` (``uuid``, ``props`` with ``label`` and ``value``); the page changes it with
``GuiUpdateMessage(uuid, updates={"value": v})`` and a button press is ``{"value": True}``.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

import msgspec.msgpack
import viser
import websockets.sync.client
import zstandard

Message = dict[str, Any]
CAMERA = {"type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, 0.0, 5.0],
          "fov": 1.0, "near": 0.01, "far": 1000.0, "image_height": 600, "image_width": 800,
          "look_at": [0.0, 0.0, 0.0], "up_direction": [0.0, 0.0, 1.0]}


def encode(message: Message) -> bytes:
    return msgspec.msgpack.encode(message)


def decode_batch(data: bytes) -> list[Message]:
    """The messages of one server batch; each gets ``_sent``, the server's send time
    (``time.perf_counter()`` there, the same clock as ``time.monotonic()`` here on Linux)."""
    inner_size = int.from_bytes(data[:8], "little")
    compressed_size = int.from_bytes(data[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(data[16:16 + compressed_size], max_output_size=inner_size)
    batch = msgspec.msgpack.decode(inner)
    messages = list(batch["messages"])
    for message in messages:
        if isinstance(message, dict):
            message["_sent"] = batch.get("timestampSec")
    return messages


def connect_raw(url: str, timeout_s: float = 10.0) -> Any:
    """A websocket with viser's subprotocol and nothing sent yet."""
    return websockets.sync.client.connect(url, subprotocols=[f"viser-v{viser.__version__}"],
                                          open_timeout=timeout_s, max_size=None, compression=None)


class ViserClient:
    """One tab: connects, reports a camera, records every message with its arrival time, keeps
    the GUI controls by uuid (props merged with later updates) and answers the page-side
    requests a dashboard run needs (localStorage reads: an empty store, so the server's own
    values stand, which are the values this client sent)."""

    def __init__(self, url: str, timeout_s: float = 60.0) -> None:
        self.ws = connect_raw(url)
        self.lock = threading.Condition()
        self.log: list[tuple[float, Message]] = []     # (time.monotonic() at arrival, message)
        self.controls: dict[str, Message] = {}        # uuid -> {"type", "label", "value", ...}
        self.closed = False
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.send(CAMERA)
        self.wait_for(lambda m: self.find("Run", missing_ok=True) is not None, timeout_s, "the Run button")
        self.settle()

    def settle(self, quiet_s: float = 0.5, timeout_s: float = 60.0) -> None:
        """Wait until no message has arrived for ``quiet_s`` (the tab is built)."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self.lock:
                last = self.log[-1][0] if self.log else 0.0
            if time.monotonic() - last >= quiet_s:
                return
            time.sleep(0.05)

    # ------------------------------------------------------------------ transport
    def send(self, message: Message) -> float:
        t = time.monotonic()
        self.ws.send(encode(message))
        return t

    def close(self) -> None:
        self.closed = True
        self.ws.close()

    def _read(self) -> None:
        try:
            for data in self.ws:
                now = time.monotonic()
                for message in decode_batch(data):
                    self._track(message)
                    with self.lock:
                        self.log.append((now, message))
                        self.lock.notify_all()
                    if message.get("type") == "LocalStorageGetItemRequestMessage":
                        # no JavaScript runs here, so no script wrote the key: absent, as in a
                        # browser's localStorage (the server keeps the values this client sent)
                        self.send({"type": "LocalStorageGetItemResponseMessage", "value": None,
                                   "error": None, "request_uuid": message["request_uuid"]})
        except Exception:   # connection closed: wait_for reports what is missing
            pass
        with self.lock:
            self.closed = True
            self.lock.notify_all()

    def _track(self, message: Message) -> None:
        kind = message.get("type", "")
        if kind.startswith("Gui") and "uuid" in message and isinstance(message.get("props"), dict):
            with self.lock:
                extra = {k: message[k] for k in ("value",) if k in message}
                self.controls[message["uuid"]] = {"type": kind, **message["props"], **extra}
        elif kind == "GuiUpdateMessage":
            with self.lock:
                if message["uuid"] in self.controls:
                    self.controls[message["uuid"]].update(message["updates"])

    # ------------------------------------------------------------------ queries
    def wait_for(self, predicate: Callable[[Message], bool], timeout_s: float, what: str,
                 since: int = 0) -> tuple[float, Message]:
        """The first message from index ``since`` of the log satisfying ``predicate``, with its time."""
        deadline = time.monotonic() + timeout_s
        with self.lock:
            while True:
                for t, message in self.log[since:]:
                    if predicate(message):
                        return t, message
                since = len(self.log)
                remaining = deadline - time.monotonic()
                if remaining <= 0 or self.closed:
                    raise TimeoutError(f"no {what} within {timeout_s:g} s (connection closed: {self.closed})")
                self.lock.wait(remaining)

    def mark(self) -> int:
        with self.lock:
            return len(self.log)

    def find(self, label: str, missing_ok: bool = False) -> str | None:
        with self.lock:
            for uid, props in self.controls.items():
                if props.get("label") == label:
                    return uid
        if missing_ok:
            return None
        raise KeyError(label)

    def value(self, uid: str) -> Any:
        with self.lock:
            return self.controls[uid].get("value", self.controls[uid].get("_markdown"))

    def markdown_containing(self, text: str) -> str | None:
        """uuid of the markdown element whose current content contains ``text``."""
        with self.lock:
            for uid, props in self.controls.items():
                if props["type"] == "GuiMarkdownMessage" and text in str(props.get("_markdown", "")):
                    return uid
        return None

    # ------------------------------------------------------------------ actions
    def set_value(self, label: str, value: Any) -> float:
        uid = self.find(label)
        with self.lock:
            self.controls[uid]["value"] = value
        return self.send({"type": "GuiUpdateMessage", "uuid": uid, "updates": {"value": value}})

    def click(self, label: str) -> float:
        return self.send({"type": "GuiUpdateMessage", "uuid": self.find(label), "updates": {"value": True}})

    def notifications(self, since: int = 0) -> list[Message]:
        with self.lock:
            return [m["props"] for _, m in self.log[since:] if m.get("type") == "NotificationShowMessage"]
