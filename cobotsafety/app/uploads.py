"""Files uploaded from a browser, received by the app itself (issue 22 S3, issue 25 item 2).

viser buffers whatever size a client declares and tells the uploading tab "File uploaded
successfully." as soon as the last byte arrives, before the app has looked at the file.
``UploadReceiver`` takes the upload messages of one button instead (``ServerGuard`` routes them
here, viser never sees them):

* a name that is empty, ``.``, ``..``, a path, longer than ``MAX_NAME_CHARS`` or with a control
  character (NUL included), or a declared size above the limit, is refused at the first
  message, before a byte is kept;
* parts beyond the declared size, out of range or repeated end or skip the transfer;
* the last part is acknowledged only after ``on_file(name, content)`` has judged the file in
  a worker thread: on success the tab's own "uploaded" notice appears; on a refusal that
  notice is removed first, then the upload is closed and one red notification says why.

``on_file`` gets the bytes; where it writes them and that it removes them is its business
(the demo loads them from a temporary folder that it deletes at once).
"""

from __future__ import annotations

import concurrent.futures
import logging
import threading
import unicodedata
from dataclasses import dataclass, field
from typing import Callable

import viser
from viser import _messages as messages

logger = logging.getLogger(__name__)

MAX_UPLOAD_BYTES = 64 * 1024 * 1024
"""Largest file accepted [bytes] (the bundled recordings are under 1 MB)."""
MAX_NAME_CHARS = 200
MAX_TRANSFERS = 4
"""Uploads buffered at once over all tabs (one per tab; a tab's new upload replaces its last)."""


def check_upload_name(name) -> str:
    """Why an uploaded file's name is refused ("" when it is a plain file name)."""
    if not isinstance(name, str) or not name.strip():
        return "A file without a name is refused"
    shown = name if name.isprintable() else name.encode("unicode_escape").decode("ascii")
    if name in (".", ".."):
        return f"The file name {shown!r} is refused: it names a folder"
    if "/" in name or "\\" in name:
        return f"The file name {shown[:60]!r} is refused: it is a path, not a file name"
    if any(unicodedata.category(c).startswith("C") for c in name):
        return f"The file name {shown[:60]!r} is refused: it holds control characters"
    if len(name) > MAX_NAME_CHARS:
        return f"The file name {shown[:40]!r}... is refused: longer than {MAX_NAME_CHARS} characters"
    return ""


@dataclass
class _Transfer:
    client_id: int
    name: str
    size_bytes: int
    part_count: int
    parts: dict[int, bytes] = field(default_factory=dict)
    received_bytes: int = 0


class UploadReceiver:
    """Receives the files of one upload button; ``on_file(name, content) -> refusal or ""``."""

    def __init__(self, server: viser.ViserServer, button: viser.GuiUploadButtonHandle,
                 on_file: Callable[[str, bytes], str], max_bytes: int = MAX_UPLOAD_BYTES,
                 refused_title: str = "Upload refused"):
        self.server = server
        self.uuid = button._impl.uuid
        self.on_file = on_file
        self.max_bytes = max_bytes
        self.refused_title = refused_title
        self._transfers: dict[str, _Transfer] = {}
        self._lock = threading.Lock()
        self._worker = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="cobotsafety-upload")

    # ---- messages (on viser's event loop) ------------------------------------------------------
    def receive(self, client_id: int, message) -> None:
        if isinstance(message, messages.FileTransferStartUpload):
            self._start(client_id, message)
        elif isinstance(message, messages.FileTransferPart):
            self._part(client_id, message)

    def _start(self, client_id: int, message) -> None:
        transfer_id, size, parts = message.transfer_uuid, message.size_bytes, message.part_count
        name = message.filename
        shown = name if isinstance(name, str) and name.isprintable() else "the file"
        refusal = check_upload_name(name)
        if not refusal and not (isinstance(size, int) and 0 <= size):
            refusal = f"{shown} declares no valid size"
        elif not refusal and size > self.max_bytes:
            refusal = f"{shown} is larger than the {self.max_bytes // 2**20} MB upload limit ({size / 2**20:.0f} MB)"
        elif not refusal and not (isinstance(parts, int) and (parts == 0) == (size == 0) and 0 <= parts <= size):
            refusal = f"{shown} declares {parts!r} parts for {size} bytes"
        if refusal:
            self._reply(client_id, transfer_id, size if isinstance(size, int) else 0, refusal)
            return
        with self._lock:
            for other_id, other in list(self._transfers.items()):  # one upload per tab
                if other.client_id == client_id:
                    del self._transfers[other_id]
            if len(self._transfers) >= MAX_TRANSFERS:
                refusal = "The server is receiving other uploads: try again in a moment"
            else:
                self._transfers[transfer_id] = _Transfer(client_id, name, size, parts)
        if refusal:
            self._reply(client_id, transfer_id, size, refusal)
        elif parts == 0:
            self._complete(transfer_id)

    def _part(self, client_id: int, message) -> None:
        with self._lock:
            transfer = self._transfers.get(message.transfer_uuid)
            if transfer is None or transfer.client_id != client_id:
                return  # refused, finished or someone else's: ignored
            content, index = message.content, message.part_index
            if not isinstance(content, bytes) or not isinstance(index, int) or not 0 <= index < transfer.part_count \
                    or index in transfer.parts or transfer.received_bytes + len(content) > transfer.size_bytes:
                del self._transfers[message.transfer_uuid]
                refusal = f"{transfer.name} was not sent as it declared (part {index!r})"
            else:
                refusal = ""
                transfer.parts[index] = content
                transfer.received_bytes += len(content)
                complete = len(transfer.parts) == transfer.part_count
        if refusal:
            self._reply(client_id, message.transfer_uuid, transfer.size_bytes, refusal)
        elif complete:
            self._complete(message.transfer_uuid)
        else:
            self._send(client_id, self._ack(message.transfer_uuid, transfer.received_bytes, transfer.size_bytes))

    def _complete(self, transfer_id: str) -> None:
        with self._lock:
            transfer = self._transfers.pop(transfer_id, None)
        if transfer is None:
            return
        if transfer.received_bytes != transfer.size_bytes:
            self._reply(transfer.client_id, transfer_id, transfer.size_bytes,
                        f"{transfer.name} was not sent as it declared ({transfer.received_bytes} of "
                        f"{transfer.size_bytes} bytes)")
            return
        content = b"".join(transfer.parts[i] for i in range(transfer.part_count))
        self._worker.submit(self._judge, transfer, transfer_id, content)

    # ---- judging (worker thread) --------------------------------------------------------------
    def _judge(self, transfer: _Transfer, transfer_id: str, content: bytes) -> None:
        try:
            refusal = self.on_file(transfer.name, content)
        except Exception:  # noqa: BLE001 - the tab must get an answer; the log gets the traceback
            logger.exception("loading the upload %s failed", transfer.name)
            refusal = f"{transfer.name} could not be loaded (server error, see its log)"
        self._reply(transfer.client_id, transfer_id, transfer.size_bytes, refusal)

    # ---- replies -----------------------------------------------------------------------------
    def _ack(self, transfer_id: str, transferred: int, total: int):
        return messages.FileTransferPartAck(source_component_uuid=self.uuid, transfer_uuid=transfer_id,
                                            transferred_bytes=transferred, total_bytes=total)

    def _send(self, client_id: int, *outgoing) -> viser.ClientHandle | None:
        client = self.server.get_clients().get(client_id)
        if client is not None:
            for message in outgoing:
                client._websock_connection.queue_message(message)
        return client

    def _reply(self, client_id: int, transfer_id: str, total: int, refusal: str) -> None:
        """End the tab's upload: the final acknowledgement, after removing its notice on a refusal.

        The tab names its upload notice ``upload-<transfer id>`` and turns it into "File
        uploaded successfully." when the acknowledged bytes reach the total; removed first, the
        notice is gone before that update, which then changes nothing.
        """
        final = self._ack(transfer_id, total, total)
        if not refusal:
            self._send(client_id, final)
            return
        logger.info("upload refused: %s", refusal)
        client = self._send(client_id, messages.RemoveNotificationMessage(uuid=f"upload-{transfer_id}"), final)
        if client is not None:
            client.add_notification(self.refused_title, refusal, color="red", with_close_button=True)

    def close(self) -> None:
        self._worker.shutdown(wait=False, cancel_futures=True)
