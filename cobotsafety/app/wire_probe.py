"""``WireProbe``: a headless viser client that decodes and counts what the server sends it.

It connects to the demo's websocket like a browser tab (subprotocol ``viser-v<version>``),
reads every frame and decodes viser's wire format (16-byte header, zstd-compressed msgpack,
raw binary buffers) into message type names. ``counts()`` then says how many bytes and how
many messages of each type arrived in a window: the bandwidth one browser tab costs, measured
at the receiving end and independent of the server's own bookkeeping.
"""

from __future__ import annotations

import asyncio
import collections
import threading
import time

import msgspec.msgpack
import zstandard


def decode_frame(frame: bytes) -> list[str]:
    """The message type names in one websocket frame of viser's wire format."""
    return [kind for kind, _ in decode_messages(frame)]


def decode_payloads(frame: bytes) -> list[dict]:
    """Each message in one websocket frame as the dict viser serialised (``"type"`` and fields;
    numpy arrays are left as viser's placeholders for the frame's binary buffers)."""
    inner_size = int.from_bytes(frame[0:8], "little")
    compressed_size = int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16:16 + compressed_size], max_output_size=inner_size)
    return list(msgspec.msgpack.decode(inner).get("messages", ()))


def decode_messages(frame: bytes) -> list[tuple[str, str]]:
    """``(type, node or GUI name)`` of each message in one websocket frame."""
    return [(str(message.get("type", "?")), str(message.get("name", message.get("uuid", ""))))
            for message in decode_payloads(frame)]


class WireProbe:
    """One counting client in a background thread; ``start()``, ``reset()``, ``counts()``, ``stop()``."""

    def __init__(self, url: str):
        import viser  # noqa: PLC0415

        self.url = url.replace("http://", "ws://")
        self.subprotocol = f"viser-v{viser.__version__}"
        self._lock = threading.Lock()
        self._bytes = 0
        self._types: collections.Counter[str] = collections.Counter()
        self._names: collections.Counter[tuple[str, str]] = collections.Counter()
        self._since_s = time.perf_counter()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.connected = threading.Event()
        self.error: BaseException | None = None

    def start(self, timeout_s: float = 30.0) -> "WireProbe":
        self._thread = threading.Thread(target=lambda: asyncio.run(self._run()), daemon=True, name="wire-probe")
        self._thread.start()
        if not self.connected.wait(timeout_s):
            raise RuntimeError(f"wire probe could not connect to {self.url}: {self.error!r}")
        return self

    async def _run(self) -> None:
        import websockets  # noqa: PLC0415

        try:
            async with websockets.connect(self.url, subprotocols=[self.subprotocol], max_size=None,
                                          compression=None) as socket:
                self.connected.set()
                while not self._stop.is_set():
                    try:
                        frame = await asyncio.wait_for(socket.recv(), timeout=0.2)
                    except asyncio.TimeoutError:
                        continue
                    if isinstance(frame, str):
                        continue
                    messages = decode_messages(frame)
                    with self._lock:
                        self._bytes += len(frame)
                        self._types.update(kind for kind, _ in messages)
                        self._names.update(messages)
        except Exception as error:  # noqa: BLE001 - reported through .error / start()
            self.error = error
            self.connected.set()

    def reset(self) -> None:
        """Start a new counting window now."""
        with self._lock:
            self._bytes, self._since_s = 0, time.perf_counter()
            self._types, self._names = collections.Counter(), collections.Counter()

    def counts(self) -> dict:
        """``{"seconds", "bytes", "bytes_per_s", "messages_per_s", "types": {type: count},
        "names": {(type, node): count}}`` since ``reset``."""
        with self._lock:
            seconds = max(time.perf_counter() - self._since_s, 1e-9)
            types, names = dict(self._types), dict(self._names)
            total = self._bytes
        return {"seconds": seconds, "bytes": total, "bytes_per_s": total / seconds,
                "messages_per_s": sum(types.values()) / seconds, "types": types, "names": names}

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)


def main(url: str, clients: int, warmup_s: float, seconds: float) -> None:
    """Run ``clients`` probes against ``url`` in this process (not the server's) and print JSON.

    Prints ``ready`` once every probe is connected and ``warmup_s`` has passed (the counting
    window starts then), and one JSON list of ``counts()`` (without per-node names) at the end.
    """
    import json  # noqa: PLC0415

    probes = [WireProbe(url).start() for _ in range(clients)]
    time.sleep(warmup_s)
    for probe in probes:
        probe.reset()
    print("ready", flush=True)
    time.sleep(seconds)
    counts = [probe.counts() for probe in probes]
    for probe in probes:
        probe.stop()
    print(json.dumps([{key: value for key, value in c.items() if key != "names"} for c in counts]), flush=True)


if __name__ == "__main__":
    import argparse  # noqa: PLC0415

    parser = argparse.ArgumentParser(description="count what a viser server sends to N clients")
    parser.add_argument("url")
    parser.add_argument("--clients", type=int, default=1)
    parser.add_argument("--warmup", type=float, default=2.0, help="seconds before counting [s]")
    parser.add_argument("--seconds", type=float, default=10.0, help="counting window [s]")
    arguments = parser.parse_args()
    main(arguments.url, arguments.clients, arguments.warmup, arguments.seconds)
