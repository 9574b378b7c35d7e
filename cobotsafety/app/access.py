"""Who may change what on a viser server, and with which values (issue 22, S1-S5).

viser applies what a browser sends: a GUI value (and broadcasts it to every tab) before any
callback of ours could refuse it, a file of any declared size, and a ``ShareUrlRequest`` that
opens a public tunnel to the server. ``ServerGuard`` sits in front of viser's message dispatch
of one server (and of each of its connections) and lets a message through only when

* it is not a share request (S1: refused from every client, and the Share button hidden by
  ``hide_share_button``);
* its client may change the robot or the scene (S2: ``may_change(client_id)``; the demo
  beyond loopback asks for a token first);
* its value lies within its control's range: a slider's [min, max], a dropdown's options, a
  finite gizmo pose (S5, ``check_value``);
* it is a file for an upload button that has a receiver (S3, ``cobotsafety.app.uploads``).

A refusal reaches that tab as one notification (at most one per ``NOTICE_INTERVAL_S``), the
tab's control is set back to the server's value, and the log counts refusals instead of
printing one line each. ``TokenGate`` checks a token (S4): 128 bits, compared in constant
time, a per-connection backoff after each wrong try, one counted log line.

The one place that reaches into viser's internals (its dispatch method, handle tables and
message classes), so a viser upgrade that moves them fails here, in ``tests/test_app_access.py``.
"""

from __future__ import annotations

import collections
import enum
import ipaddress
import logging
import math
import numbers
import secrets
import socket
import threading
import time
from typing import Callable

import viser
from viser import _messages as messages

logger = logging.getLogger(__name__)

TOKEN_BYTES = 16
"""Random bytes of a token: 128 bits, written as 32 hex digits."""
BACKOFF_FIRST_S = 1.0
"""Wait after a connection's first wrong token [s]; doubled after each further one."""
BACKOFF_MAX_S = 60.0
"""Longest wait between two tries of one connection [s]."""
NOTICE_INTERVAL_S = 2.0
"""At most one refusal notification per tab in this time [s] (a refused drag sends dozens)."""
MAX_TEXT_CHARS = 200
"""Longest text a browser may put in a text field."""
MAX_GIZMO_M = 100.0
"""Largest gizmo coordinate accepted from a browser [m] (the loop pulls targets to 2 m)."""

SHARE_MESSAGES = (messages.ShareUrlRequest, messages.ShareUrlDisconnect)
CHANGE_MESSAGES = (
    messages.GuiUpdateMessage, messages.GuiButtonHoldMessage, messages.GuiFormSubmitMessage,
    messages.FileTransferStartUpload, messages.FileTransferPart, messages.CommandTriggerMessage,
    messages.TransformControlsUpdateMessage, messages.TransformControlsDragStartMessage,
    messages.TransformControlsDragEndMessage, messages.SceneNodeClickMessage, messages.SceneNodeDragMessage,
    messages.ScenePointerMessage, messages.SceneNodeUpdateMessage,
)
"""What a browser sends to change something; a camera move or a reply to the server is not here."""


# ---- hosts and URLs ---------------------------------------------------------------------------
def is_loopback(host: str) -> bool:
    """Whether binding ``host`` keeps the server on this machine (127.0.0.0/8, ::1, localhost)."""
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def check_bindable(host: str) -> None:
    """Raise ``CobotSafetyError`` unless a server can listen on ``host`` (a local address or name).

    viser retries a failed bind on the next 1000 ports and then waits forever: a host that does
    not resolve or is not this machine's is refused here first (bound on port 0, released).
    """
    from cobotsafety.errors import CobotSafetyError  # noqa: PLC0415

    try:
        infos = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)
        family, kind, proto, _, address = infos[0]
        with socket.socket(family, kind, proto) as probe:
            probe.bind(address)
    except (OSError, UnicodeError, IndexError) as error:
        raise CobotSafetyError(f"cannot listen on host {host!r}: {' '.join(str(error).split()) or 'no address'}") from None


def reachable_host(host: str) -> str:
    """A host other machines can use to open a server bound to ``host``.

    For the wildcard addresses (``0.0.0.0``, ``::``, empty) it is the address of the interface
    this machine would use to reach the network (found by routing a UDP socket, which sends
    nothing); 127.0.0.1 when there is no network.
    """
    if host.strip("[]") not in ("0.0.0.0", "::", ""):
        return host
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # TEST-NET-1: routed, never contacted
            return probe.getsockname()[0]
        except OSError:
            return "127.0.0.1"


def hide_share_button(server: viser.ViserServer, **theme) -> None:
    """``configure_theme(**theme)`` with viser's Share button hidden (use it for every theme call)."""
    server.gui.configure_theme(show_share_button=False, **theme)


# ---- tokens (S4) ------------------------------------------------------------------------------
def new_token() -> str:
    """A fresh random token of ``TOKEN_BYTES`` bytes (hex)."""
    return secrets.token_hex(TOKEN_BYTES)


class Verdict(enum.Enum):
    ACCEPTED = "accepted"
    WRONG = "wrong"
    WAIT = "wait"
    """Tried again before the connection's backoff ended: not compared, not counted."""
    INCOMPLETE = "incomplete"
    """Shorter than the token: still being typed (text fields report every key)."""


class TokenGate:
    """Checks tokens per connection: constant-time comparison, backoff, counted logging.

    ``check(client_id, entered)`` returns a ``Verdict``; accepted connections are remembered
    (``is_authorised``) until ``forget``. After the n-th wrong token of a connection it must
    wait ``min(BACKOFF_FIRST_S * 2**(n-1), BACKOFF_MAX_S)`` before the next is compared. The
    log gets a line when the count of wrong tokens reaches 1, 2, 4, 8, ... (not one per guess).
    """

    def __init__(self, token: str | None = None, what: str = "token", clock: Callable[[], float] = time.monotonic):
        self.token = token if token is not None else new_token()
        self.what = what
        self.clock = clock
        self.refused = 0
        """Wrong tokens so far (all connections)."""
        self._lock = threading.Lock()
        self._failures: dict[int, int] = {}
        self._not_before_s: dict[int, float] = {}
        self._authorised: set[int] = set()
        self._refusing_connections: set[int] = set()

    def is_authorised(self, client_id: int) -> bool:
        return client_id in self._authorised

    def wait_s(self, client_id: int) -> float:
        """Seconds before ``client_id`` may try again (0 when it may now)."""
        return max(0.0, self._not_before_s.get(client_id, 0.0) - self.clock())

    def check(self, client_id: int, entered: str) -> Verdict:
        entered = entered.strip()
        with self._lock:
            if client_id in self._authorised:
                return Verdict.ACCEPTED
            if len(entered) < len(self.token):
                return Verdict.INCOMPLETE
            now = self.clock()
            if now < self._not_before_s.get(client_id, 0.0):
                return Verdict.WAIT
            if secrets.compare_digest(entered.encode("utf-8"), self.token.encode("utf-8")):
                self._authorised.add(client_id)
                self._failures.pop(client_id, None)
                self._not_before_s.pop(client_id, None)
                return Verdict.ACCEPTED
            failures = self._failures.get(client_id, 0) + 1
            self._failures[client_id] = failures
            self._not_before_s[client_id] = now + min(BACKOFF_FIRST_S * 2.0 ** (failures - 1), BACKOFF_MAX_S)
            self.refused += 1
            self._refusing_connections.add(client_id)
            count, connections = self.refused, len(self._refusing_connections)
        if count & (count - 1) == 0:  # 1, 2, 4, 8, ...: the log grows with log2 of the guesses
            logger.warning("%s refused %d time%s so far (from %d connection%s)", self.what, count,
                           "" if count == 1 else "s", connections, "" if connections == 1 else "s")
        return Verdict.WRONG

    def forget(self, client_id: int) -> None:
        """A connection closed: drop its state (its id is never reused)."""
        with self._lock:
            self._authorised.discard(client_id)
            self._failures.pop(client_id, None)
            self._not_before_s.pop(client_id, None)


# ---- values (S5) ------------------------------------------------------------------------------
def _finite_number(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def _within(value: float, low, high) -> bool:
    slack = 1e-9 * max(1.0, abs(value))
    return (low is None or value >= low - slack) and (high is None or value <= high + slack)


def _range_text(low, high) -> str:
    return f"between {low:g} and {high:g}" if low is not None and high is not None else (
        f"at least {low:g}" if low is not None else (f"at most {high:g}" if high is not None else "finite"))


def check_value(handle, value) -> str:
    """Why a browser may not set ``handle`` to ``value`` ("" when it may).

    Buttons take ``True``; checkboxes a bool; dropdowns and button groups one of their
    options; sliders and number fields a finite number within their [min, max]; vectors and
    multi-sliders finite numbers within theirs; colours 0-255; text at most
    ``MAX_TEXT_CHARS`` printable characters. An upload button's value comes only from a file
    transfer, and a control of another kind takes nothing.
    """
    label = getattr(handle, "label", "control")
    if getattr(handle, "disabled", False):
        return f"{label} is disabled"
    if not getattr(handle, "visible", True):
        return f"{label} is hidden"
    if isinstance(handle, viser.GuiButtonHandle):
        return "" if value is True else f"{label} is a button: {value!r} is not a click"
    if isinstance(handle, viser.GuiCheckboxHandle):
        return "" if isinstance(value, bool) else f"{label} takes on or off, not {value!r}"
    if isinstance(handle, (viser.GuiDropdownHandle, viser.GuiButtonGroupHandle)):
        return "" if isinstance(value, str) and value in handle.options else \
            f"{label} has no option {str(value)[:40]!r}"
    if isinstance(handle, (viser.GuiSliderHandle, viser.GuiNumberHandle)):
        if not (_finite_number(value) and _within(float(value), handle.min, handle.max)):
            return f"{label} must be {_range_text(handle.min, handle.max)}, not {str(value)[:40]}"
        return ""
    if isinstance(handle, (viser.GuiVector2Handle, viser.GuiVector3Handle, viser.GuiMultiSliderHandle)):
        size = len(handle.value)
        lows = handle.min if isinstance(handle.min, tuple) else (handle.min,) * size
        highs = handle.max if isinstance(handle.max, tuple) else (handle.max,) * size
        if not (isinstance(value, (list, tuple)) and len(value) == size
                and all(_finite_number(v) and _within(float(v), lo, hi) for v, lo, hi in zip(value, lows, highs))):
            return f"{label} takes {size} finite numbers within its range, not {str(value)[:60]}"
        return ""
    if isinstance(handle, (viser.GuiRgbHandle, viser.GuiRgbaHandle)):
        size = len(handle.value)
        if not (isinstance(value, (list, tuple)) and len(value) == size
                and all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 255 for v in value)):
            return f"{label} takes {size} integers 0-255, not {str(value)[:60]}"
        return ""
    if isinstance(handle, viser.GuiTextHandle):
        if not isinstance(value, str) or len(value) > MAX_TEXT_CHARS or not (value.isprintable() or value == ""):
            return f"{label} takes at most {MAX_TEXT_CHARS} printable characters"
        return ""
    return f"{label} takes no value from a browser"


def check_gizmo(message) -> str:
    """Why a gizmo pose from a browser is refused ("" when it is finite and within ``MAX_GIZMO_M``)."""
    position, wxyz = getattr(message, "position", None), getattr(message, "wxyz", None)
    if not (isinstance(position, (list, tuple)) and len(position) == 3
            and all(_finite_number(v) and abs(v) <= MAX_GIZMO_M for v in position)):
        return f"the gizmo position must be 3 finite coordinates within {MAX_GIZMO_M:g} m"
    if not (isinstance(wxyz, (list, tuple)) and len(wxyz) == 4 and all(_finite_number(v) for v in wxyz)):
        return "the gizmo orientation must be 4 finite numbers"
    return ""


# ---- the guard (S1, S2, S3 routing, S5) -------------------------------------------------------
class ServerGuard:
    """Filters what the browsers of one ``ViserServer`` may do; see the module docstring.

    ``may_change(client_id)``: whether that tab may change the robot or the scene (default:
    every tab). ``uploads``: upload button uuid -> receiver (``receive(client_id, message)``,
    taking ``FileTransferStartUpload`` and ``FileTransferPart``); any other upload is refused.
    ``view_only_hint``: the notification a tab that may not change anything gets.
    """

    def __init__(self, server: viser.ViserServer, may_change: Callable[[int], bool] | None = None,
                 view_only_hint: str = "This tab may only watch."):
        self.server = server
        self.may_change = may_change or (lambda _client_id: True)
        self.view_only_hint = view_only_hint
        self.uploads: dict[str, object] = {}
        self.on_change: list[Callable[[int], None]] = []
        """Called with the client id after each change a tab was allowed to make (on viser's loop)."""
        self.refusals: collections.Counter[str] = collections.Counter()
        """Refused messages by kind (``share``, ``view only``, ``value``, ``upload``)."""
        self._last_notice_s: dict[int, float] = {}
        self._protected: set[int] = set()
        self._lock = threading.Lock()
        hide_share_button(server)
        self._wrap(server._websock_server, server.gui, client_scope=False)
        server.on_client_connect(self.protect_client)
        server.on_client_disconnect(lambda client: self._last_notice_s.pop(client.client_id, None))

    # -- installation --
    def protect_client(self, client: viser.ClientHandle) -> None:
        """Guard the values of ``client``'s own controls too (idempotent; call it before adding them)."""
        with self._lock:
            if client.client_id in self._protected:
                return
            self._protected.add(client.client_id)
        self._wrap(client._websock_connection, client.gui, client_scope=True)

    def _wrap(self, interface, gui_api, client_scope: bool) -> None:
        dispatch = interface._handle_incoming_message

        async def guarded(client_id, message) -> None:
            try:
                admitted = self.admit(client_id, message, gui_api, client_scope)
            except Exception:  # noqa: BLE001 - a message we cannot judge is refused, never applied
                logger.exception("refused a malformed %s", type(message).__name__)
                admitted = False
            if admitted:
                await dispatch(client_id, message)
                if not client_scope and isinstance(message, CHANGE_MESSAGES):
                    for hook in self.on_change:
                        hook(client_id)

        interface._handle_incoming_message = guarded

    # -- the decision --
    def admit(self, client_id: int, message, gui_api, client_scope: bool = False) -> bool:
        """Whether ``message`` from ``client_id`` may reach viser's handlers (refusals notified)."""
        if isinstance(message, SHARE_MESSAGES):
            if not client_scope:
                self._refuse(client_id, "share", "Sharing is disabled", "This server is not published on the internet.")
            return False
        if not isinstance(message, CHANGE_MESSAGES):
            return True
        if isinstance(message, messages.GuiUpdateMessage):
            handle = gui_api._gui_input_handle_from_uuid.get(message.uuid)
            if handle is None:
                return True  # not this scope's control: viser ignores it here
            if not client_scope and not self.may_change(client_id):
                self._refuse(client_id, "view only", "View only", self.view_only_hint, handle)
                return False
            if not isinstance(message.updates, dict) or set(message.updates) != {"value"}:
                self._refuse(client_id, "value", "Refused", f"{handle.label} takes only a value", handle)
                return False
            reason = check_value(handle, message.updates["value"])
            if reason:
                self._refuse(client_id, "value", "Value refused", reason + ".", handle)
                return False
            return True
        if client_scope:  # scene and file messages are the server scope's (checked there)
            return not isinstance(message, (messages.FileTransferStartUpload, messages.FileTransferPart))
        if not self.may_change(client_id):
            self._refuse(client_id, "view only", "View only", self.view_only_hint)
            return False
        if isinstance(message, (messages.FileTransferStartUpload, messages.FileTransferPart)):
            receiver = self.uploads.get(message.source_component_uuid)
            if receiver is None:
                self._refuse(client_id, "upload", "Upload refused", "This server takes no files here.")
            else:
                receiver.receive(client_id, message)
            return False  # a receiver handles the file: viser's buffering never sees it
        if isinstance(message, messages.TransformControlsUpdateMessage):
            reason = check_gizmo(message)
            if reason:
                self._refuse(client_id, "value", "Refused", reason + ".")
                return False
        return True

    # -- feedback --
    def _refuse(self, client_id: int, kind: str, title: str, body: str, handle=None) -> None:
        with self._lock:
            self.refusals[kind] += 1
            count = self.refusals[kind]
            now = time.monotonic()
            notify = now - self._last_notice_s.get(client_id, -math.inf) >= NOTICE_INTERVAL_S
            if notify:
                self._last_notice_s[client_id] = now
        if count & (count - 1) == 0:
            logger.warning("refused %s from a browser: %d so far (last: %s)", kind, count, body)
        client = self.server.get_clients().get(client_id)
        if client is None:
            return
        if handle is not None and not isinstance(handle, viser.GuiUploadButtonHandle):  # the server's value again
            client._websock_connection.queue_message(
                messages.GuiUpdateMessage(uuid=handle._impl.uuid, updates={"value": handle.value}))
        if notify:
            client.add_notification(title, body, color="red", with_close_button=True, auto_close_seconds=6.0)
