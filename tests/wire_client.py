"""A websocket client that speaks viser's protocol like a (possibly hostile) browser tab.

``WireClient(url).start()`` connects with viser's subprotocol, keeps every message the server
sends (decoded to dicts by ``cobotsafety.app.wire_probe.decode_payloads``) and ``send``s any
message dict (msgpack, as the browser does), whatever its content.
"""

from __future__ import annotations

import asyncio
import threading
import time

import msgspec.msgpack

from cobotsafety.app.wire_probe import decode_payloads


class WireClient:
    def __init__(self, url: str):
        import viser

        self.url = url.replace("http://", "ws://")
        self.subprotocol = f"viser-v{viser.__version__}"
        self.received: list[dict] = []
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._socket = None
        self._connected = threading.Event()
        self._closed = threading.Event()
        self.error: BaseException | None = None

    def start(self, timeout_s: float = 30.0, camera: bool = True) -> "WireClient":
        """Connect; with ``camera``, report a camera as a browser does (viser lists a client only then)."""
        threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True, name="wire-client").start()
        assert self._connected.wait(timeout_s), f"could not connect to {self.url}: {self.error!r}"
        assert self.error is None, self.error
        if camera:
            self.send({"type": "ViewerCameraMessage", "wxyz": [1.0, 0.0, 0.0, 0.0], "position": [0.0, 0.0, 2.0],
                       "fov": 1.0, "near": 0.01, "far": 100.0, "image_height": 600, "image_width": 800,
                       "look_at": [0.0, 0.0, 0.0], "up_direction": [0.0, 0.0, 1.0]})
        return self

    async def _run(self) -> None:
        import websockets

        self._loop = asyncio.get_running_loop()
        try:
            async with websockets.connect(self.url, subprotocols=[self.subprotocol], max_size=None,
                                          compression=None) as socket:
                self._socket = socket
                self._connected.set()
                async for frame in socket:
                    if isinstance(frame, bytes):
                        decoded = decode_payloads(frame)
                        with self._lock:
                            self.received.extend(decoded)
        except Exception as error:  # noqa: BLE001 - reported to the test
            self.error = error
        finally:
            self._connected.set()
            self._closed.set()

    def send(self, message: dict) -> None:
        """Send one message dict (``{"type": "GuiUpdateMessage", ...}``) as msgpack."""
        payload = msgspec.msgpack.encode(message)
        asyncio.run_coroutine_threadsafe(self._socket.send(payload), self._loop).result(timeout=10)

    def messages(self, kind: str | None = None) -> list[dict]:
        with self._lock:
            return [m for m in self.received if kind is None or m.get("type") == kind]

    def wait_for(self, predicate, timeout_s: float = 20.0, what: str = "a message") -> dict:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for message in self.messages():
                if predicate(message):
                    return message
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {what}")

    def notifications(self) -> list[dict]:
        """The props of every notification shown to this tab (``title``, ``body``, ``color``)."""
        return [m["props"] for m in self.messages("NotificationShowMessage")]

    def close(self) -> None:
        if self._socket is not None and self._loop is not None and not self._closed.is_set():
            asyncio.run_coroutine_threadsafe(self._socket.close(), self._loop).result(timeout=10)
            self._closed.wait(10)


def client_id_of(server, before: set[int], timeout_s: float = 10.0) -> int:
    """The id of the one client that connected to ``server`` since ``before`` was taken."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        new = set(server.get_clients()) - before
        if new:
            return new.pop()
        time.sleep(0.05)
    raise AssertionError("no new client connected")
