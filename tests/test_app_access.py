"""Issue 22 S1-S5 over the wire: a websocket client sends what a hostile tab could, and the
demo and trial servers refuse it (no tunnel, no change without the token, no value outside a
control's range, no odd upload, nothing left on disk, no "uploaded" notice for a refused file)."""

from __future__ import annotations

import logging
import time
import types
import uuid

import pytest
import viser

from cobotsafety.app import access, uploads
from cobotsafety.app.access import TokenGate, Verdict, check_value
from cobotsafety.app.demo_app import DemoApp, DemoConfig
from cobotsafety.ports import free_local_port
from wire_client import WireClient, client_id_of


def wait_until(condition, timeout_s: float = 20.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def gui_update(handle, value) -> dict:
    return {"type": "GuiUpdateMessage", "uuid": handle._impl.uuid, "updates": {"value": value}}


def notified(client: WireClient, title: str) -> dict:
    return client.wait_for(lambda m: m.get("type") == "NotificationShowMessage" and m["props"]["title"] == title,
                           what=f"a {title!r} notification")["props"]


@pytest.fixture(scope="module")
def demo():
    app = DemoApp(DemoConfig(port=free_local_port()))  # loopback: every tab may drive
    yield app
    app.stop()


@pytest.fixture
def tab(demo):
    before = set(demo.server.get_clients())
    client = WireClient(demo.url).start()
    client_id_of(demo.server, before)  # listed: refusals can reach it
    yield client
    client.close()


# ---- S1: no share tunnel --------------------------------------------------------------------
class TunnelAttempts:
    """Stands in for viser's ``ViserTunnel``: counts attempts, never connects."""

    made: list = []

    def __init__(self, *args, **kwargs):
        TunnelAttempts.made.append(args)

    def on_connect(self, fn):
        return fn

    on_disconnect = on_connect

    def get_status(self):
        return "failed"

    def get_url(self):
        return None

    def close(self):
        pass


@pytest.fixture
def tunnel_attempts(monkeypatch):
    import viser._viser

    TunnelAttempts.made = []
    monkeypatch.setattr(viser._viser, "ViserTunnel", TunnelAttempts)
    return TunnelAttempts.made


def refuses_share_request(server: viser.ViserServer, url: str, attempts: list) -> None:
    before = set(server.get_clients())
    client = WireClient(url).start()
    try:
        client_id_of(server, before)
        client.wait_for(lambda m: m.get("type") == "ReplayDoneMessage", what="the scene's replay")
        themes = client.messages("ThemeConfigurationMessage")
        assert themes and all(theme["show_share_button"] is False for theme in themes)
        client.send({"type": "ShareUrlRequest"})
        assert notified(client, "Sharing is disabled")
        time.sleep(0.5)  # viser's own handler would have run in its thread pool by now
        assert attempts == [] and server._share_tunnel is None
    finally:
        client.close()


def test_the_share_tunnel_is_refused_on_the_demo(demo, tunnel_attempts):
    refuses_share_request(demo.server, demo.url, tunnel_attempts)


def test_the_share_tunnel_is_refused_on_both_trial_servers_before_login(tmp_path, tunnel_attempts):
    from cobotsafety.trial.trial_app import TrialServer

    server = TrialServer(tmp_path, ["P01"], port=free_local_port())
    try:
        refuses_share_request(server.server, server.url, tunnel_attempts)
        refuses_share_request(server.operator_server, server.operator_url, tunnel_attempts)
    finally:
        server.stop()


# ---- S5: values checked against their control's range -----------------------------------------
def test_out_of_range_values_are_refused_and_the_tab_shows_the_servers_value(demo, tab):
    panel, loop = demo.panel, demo.loop
    speed, gizmo, method = demo.replay.speed, loop.gizmo, loop.method
    tab.send(gui_update(panel.speed, float("nan")))
    body = notified(tab, "Value refused")["body"]
    assert "Speed must be between 0.1 and 4" in body
    tab.send(gui_update(panel.gain_per_s, 1e9))
    tab.send(gui_update(panel.max_speed_m_s, 1e9))
    tab.send(gui_update(panel.mode, "bogus"))
    tab.send(gui_update(panel.ssm, True))  # disabled on the planar scene
    time.sleep(1.0)
    assert demo.replay.speed == speed and panel.speed.value == speed
    assert loop.gizmo == gizmo and panel.gain_per_s.value == gizmo.gain_per_s
    assert loop.method == method and panel.mode.value == method and not panel.ssm.value
    assert demo.guard.refusals["value"] >= 5
    resent = [m for m in tab.messages("GuiUpdateMessage") if m["uuid"] == panel.speed._impl.uuid]
    assert resent and resent[-1]["updates"]["value"] == speed  # the tab's slider is set back
    tab.send(gui_update(panel.speed, 2.0))  # a value in range still works
    wait_until(lambda: demo.replay.speed == 2.0, what="Speed 2.0")
    tab.send(gui_update(panel.speed, 1.0))
    wait_until(lambda: demo.replay.speed == 1.0, what="Speed 1.0")


def test_a_bogus_mode_never_reaches_another_tab(demo, tab):
    other = WireClient(demo.url).start()
    try:
        tab.send(gui_update(demo.panel.mode, "bogus"))
        notified(tab, "Value refused")
        time.sleep(0.5)
        values = [m["updates"].get("value") for m in other.messages("GuiUpdateMessage")]
        assert "bogus" not in values
    finally:
        other.close()


def test_a_non_finite_gizmo_pose_is_refused(demo, tab):
    demo.loop.release_gizmo()
    tab.send({"type": "TransformControlsUpdateMessage", "name": "/gizmo", "wxyz": [1.0, 0.0, 0.0, 0.0],
              "position": [float("nan"), 0.0, 0.0], "owner": ""})
    notified(tab, "Refused")
    assert not demo.loop.snapshot().dragging


@pytest.mark.parametrize("position, wxyz, accepted", [
    ([0.5, -0.2, 0.3], [1.0, 0.0, 0.0, 0.0], True),
    ([access.MAX_GIZMO_M, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], True),
    ([1.01 * access.MAX_GIZMO_M, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], False),  # far beyond any arm
    ([0.0, -1e300, 0.0], [1.0, 0.0, 0.0, 0.0], False),
    ([0.0, 0.0, float("inf")], [1.0, 0.0, 0.0, 0.0], False),
    ([0.0, 0.0], [1.0, 0.0, 0.0, 0.0], False),
    ([0.0, True, 0.0], [1.0, 0.0, 0.0, 0.0], False),
    ("0,0,0", [1.0, 0.0, 0.0, 0.0], False),
    ([0.0, 0.0, 0.0], [1.0, 0.0, float("nan"), 0.0], False),
    ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], False),
])
def test_check_gizmo_takes_only_three_finite_near_coordinates_and_a_finite_quaternion(position, wxyz, accepted):
    reason = access.check_gizmo(types.SimpleNamespace(position=position, wxyz=wxyz))
    assert (reason == "") == accepted, reason


def test_a_message_the_guard_cannot_judge_is_refused_not_applied(demo, tab, monkeypatch, caplog):
    """A message whose check raises is refused (logged), never handed to viser."""
    speed = demo.replay.speed
    target = 2.0 if speed != 2.0 else 1.5

    def cannot_judge(*args, **kwargs):
        raise RuntimeError("cannot judge this message")

    monkeypatch.setattr(demo.guard, "admit", cannot_judge)
    with caplog.at_level(logging.ERROR, logger=access.logger.name):
        tab.send(gui_update(demo.panel.speed, target))
        wait_until(lambda: any("refused a malformed" in r.getMessage() for r in caplog.records),
                   what="the refusal's log line")
    time.sleep(0.5)
    assert demo.replay.speed == speed and demo.panel.speed.value == speed
    monkeypatch.undo()  # the same message, judged, is applied: the refusal above was the guard's
    tab.send(gui_update(demo.panel.speed, target))
    wait_until(lambda: demo.replay.speed == target, what=f"Speed {target}")
    tab.send(gui_update(demo.panel.speed, speed))
    wait_until(lambda: demo.replay.speed == speed, what=f"Speed {speed}")


def test_a_tabs_own_scope_never_passes_a_file_on(demo):
    """Files are the server scope's (a receiver or a refusal); a tab's own scope passes none of
    a transfer's messages to viser's buffering, whoever sends them."""
    for kind in (viser._messages.FileTransferStartUpload, viser._messages.FileTransferPart):
        message = object.__new__(kind)
        assert not demo.guard.admit(0, message, demo.server.gui, client_scope=True)


@pytest.mark.parametrize("make, value, accepted", [
    (lambda g: g.add_slider("Gain", 0.1, 10.0, 0.1, 1.0), 10.0, True),
    (lambda g: g.add_slider("Gain", 0.1, 10.0, 0.1, 1.0), 1e9, False),
    (lambda g: g.add_slider("Gain", 0.1, 10.0, 0.1, 1.0), float("inf"), False),
    (lambda g: g.add_slider("Gain", 0.1, 10.0, 0.1, 1.0), "3", False),
    (lambda g: g.add_slider("Gain", 0.1, 10.0, 0.1, 1.0), True, False),
    (lambda g: g.add_number("N", 1.0, min=0.0), 1e300, True),
    (lambda g: g.add_number("N", 1.0, min=0.0), -3.0, False),
    (lambda g: g.add_dropdown("Mode", ("a", "b")), "b", True),
    (lambda g: g.add_dropdown("Mode", ("a", "b")), "c", False),
    (lambda g: g.add_checkbox("Loop", True), False, True),
    (lambda g: g.add_checkbox("Loop", True), 0, False),
    (lambda g: g.add_button("Reset"), True, True),
    (lambda g: g.add_button("Reset"), False, False),
    (lambda g: g.add_button("Reset", disabled=True), True, False),
    (lambda g: g.add_button("Reset", visible=False), True, False),
    (lambda g: g.add_button_group("Jog", ("+x", "-x")), "+z", False),
    (lambda g: g.add_text("Token", ""), "x" * 200, True),
    (lambda g: g.add_text("Token", ""), "x" * 201, False),
    (lambda g: g.add_text("Token", ""), "a\x00b", False),
    (lambda g: g.add_vector3("p", (0.0, 0.0, 0.0), min=(-1, -1, -1), max=(1, 1, 1)), [0.5, 0.5, 0.5], True),
    (lambda g: g.add_vector3("p", (0.0, 0.0, 0.0), min=(-1, -1, -1), max=(1, 1, 1)), [0.5, float("nan"), 0], False),
    (lambda g: g.add_rgb("c", (1, 2, 3)), [0, 255, 9], True),
    (lambda g: g.add_rgb("c", (1, 2, 3)), [0, 256, 9], False),
    (lambda g: g.add_upload_button("Load"), {"name": "x"}, False),
])
def test_check_value_follows_each_controls_range(demo, make, value, accepted):
    handle = make(demo.server.gui)
    try:
        assert (check_value(handle, value) == "") is accepted
    finally:
        handle.remove()


# ---- S2: beyond loopback, a token to change anything -------------------------------------------
def test_beyond_loopback_a_tab_watches_until_it_enters_the_token(caplog):
    app = DemoApp(DemoConfig(host="0.0.0.0", port=free_local_port()))
    try:
        assert app.token is not None and len(app.token) == 2 * access.TOKEN_BYTES
        lines = app.start_lines()
        assert any(line.startswith("warning: listening on 0.0.0.0") for line in lines)
        assert any(app.token in line for line in lines)
        assert "0.0.0.0" not in app.url
        tab = WireClient(f"http://127.0.0.1:{app.server.get_port()}").start()
        client_id = client_id_of(app.server, set())
        tab.send(gui_update(app.panel.mode, "off"))  # a tab not yet listed by viser is refused too
        time.sleep(0.2)
        assert app.loop.method == "anticipative"
        tab.send(gui_update(app.panel.mode, "off"))
        assert "token" in notified(tab, "View only")["body"]
        tab.send({"type": "TransformControlsUpdateMessage", "name": "/gizmo", "wxyz": [1.0, 0, 0, 0],
                  "position": [0.3, 0.0, 0.0], "owner": ""})
        tab.send(gui_update(app.panel.reset, True))
        time.sleep(1.0)
        assert app.loop.method == "anticipative" and app.panel.mode.value == "anticipative"
        assert not app.loop.snapshot().dragging
        assert app.guard.refusals["view only"] >= 3
        wait_until(lambda: client_id in app.server.get_clients(), what="the client handle")
        client = app.server.get_clients()[client_id]
        wait_until(lambda: any(h.label == "Token" for h in client.gui._gui_input_handle_from_uuid.values()),
                   what="the token field")
        token = next(h for h in client.gui._gui_input_handle_from_uuid.values() if h.label == "Token")
        with caplog.at_level(logging.WARNING, logger="cobotsafety.app.access"):
            tab.send(gui_update(token, "0" * len(app.token)))
            wait_until(lambda: app.token_gate.refused == 1, what="the wrong token counted")
        tab.send(gui_update(token, app.token))  # within the backoff: not even compared
        time.sleep(0.3)
        assert not app.may_change(client_id)
        time.sleep(access.BACKOFF_FIRST_S)
        tab.send(gui_update(token, app.token))
        wait_until(lambda: app.may_change(client_id), what="the token accepted")
        tab.send(gui_update(app.panel.mode, "off"))
        wait_until(lambda: app.loop.method == "off", what="Mode = off from the authorised tab")
        assert sum("demo token refused" in r.getMessage() for r in caplog.records) == 1
        tab.close()
    finally:
        app.stop()


def test_on_loopback_every_tab_may_drive(demo, tab):
    assert demo.token is None and demo.start_lines() == [f"open {demo.url}"]
    tab.send(gui_update(demo.panel.mode, "stop"))
    wait_until(lambda: demo.loop.method == "stop", what="Mode = stop")
    tab.send(gui_update(demo.panel.mode, "anticipative"))
    wait_until(lambda: demo.loop.method == "anticipative", what="Mode = anticipative")


# ---- S4: the token itself ------------------------------------------------------------------------
class Clock:
    def __init__(self):
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_tokens_have_128_bits_and_differ():
    tokens = {TokenGate().token for _ in range(50)}
    assert len(tokens) == 50 and all(len(t) == 32 and int(t, 16) >= 0 for t in tokens)


def test_wrong_tokens_back_off_per_connection_and_are_logged_by_count(caplog, monkeypatch):
    clock = Clock()
    gate = TokenGate("a" * 32, what="operator token", clock=clock)
    compared = []
    real = access.secrets.compare_digest
    monkeypatch.setattr(access.secrets, "compare_digest", lambda a, b: compared.append(1) or real(a, b))
    assert gate.check(1, "a" * 31) is Verdict.INCOMPLETE and not compared  # still typing
    waits = []
    with caplog.at_level(logging.WARNING, logger="cobotsafety.app.access"):
        for _ in range(10):
            assert gate.check(1, "b" * 32) is Verdict.WRONG
            waits.append(gate.wait_s(1))
            assert gate.check(1, "a" * 32) is Verdict.WAIT  # even the right one waits
            clock.now_s += gate.wait_s(1)
    assert waits == [min(access.BACKOFF_FIRST_S * 2 ** k, access.BACKOFF_MAX_S) for k in range(10)]
    assert len(compared) == 10 and gate.refused == 10
    assert [r.getMessage().split(" refused ")[1].split(" ")[0] for r in caplog.records] == ["1", "2", "4", "8"]
    assert gate.check(2, "a" * 32) is Verdict.ACCEPTED  # another connection does not wait
    assert gate.check(1, "a" * 32) is Verdict.ACCEPTED and gate.is_authorised(1)
    gate.forget(1)
    assert not gate.is_authorised(1)


def test_the_operator_login_over_the_wire_backs_off(tmp_path):
    from cobotsafety.trial.trial_app import TrialServer

    server = TrialServer(tmp_path, ["P01"], port=free_local_port())
    try:
        assert len(server.token) == 32
        operator = WireClient(server.operator_url).start()
        client_id = client_id_of(server.operator_server, set())
        wait_until(lambda: client_id in server.operator_server.get_clients(), what="the client handle")
        client = server.operator_server.get_clients()[client_id]
        wait_until(lambda: any(h.label == "Token" for h in client.gui._gui_input_handle_from_uuid.values()),
                   what="the token field")
        token = next(h for h in client.gui._gui_input_handle_from_uuid.values() if h.label == "Token")
        operator.send(gui_update(token, "f" * 32))
        wait_until(lambda: server.gate.refused == 1, what="the wrong token")
        operator.send(gui_update(token, server.token))
        time.sleep(0.3)
        assert not server.gate.is_authorised(client_id)  # within the backoff
        time.sleep(access.BACKOFF_FIRST_S)
        operator.send(gui_update(token, server.token))
        wait_until(lambda: server.gate.is_authorised(client_id), what="the operator logged in")
        wait_until(lambda: any(getattr(h, "label", "") == "Start next trial"
                               for h in client.gui._gui_input_handle_from_uuid.values()), what="the operator panel")
        operator.close()
    finally:
        server.stop()


# ---- S3 and issue 25 item 2: uploads ------------------------------------------------------------
def upload(tab: WireClient, demo, name: str, content: bytes, declared: int | None = None,
           part_bytes: int = 512 * 1024, send_parts: bool = True) -> str:
    """Send a file as the browser does (start, then parts); returns the transfer id."""
    transfer = str(uuid.uuid4())
    parts = [content[i:i + part_bytes] for i in range(0, len(content), part_bytes)]
    tab.send({"type": "FileTransferStartUpload", "source_component_uuid": demo.panel.upload._impl.uuid,
              "transfer_uuid": transfer, "filename": name, "mime_type": "", "part_count": len(parts),
              "size_bytes": len(content) if declared is None else declared})
    for index, part in enumerate(parts if send_parts else ()):
        tab.send({"type": "FileTransferPart", "source_component_uuid": demo.panel.upload._impl.uuid,
                  "transfer_uuid": transfer, "part_index": index, "content": part})
    return transfer


def closed_upload(tab: WireClient, transfer: str) -> tuple[int, int | None]:
    """(index of the final acknowledgement, index of the removal of the tab's upload notice or None)."""
    tab.wait_for(lambda m: m.get("type") == "FileTransferPartAck" and m["transfer_uuid"] == transfer
                 and m["transferred_bytes"] == m["total_bytes"], what="the final acknowledgement")
    received = tab.messages()
    final = next(i for i, m in enumerate(received) if m.get("type") == "FileTransferPartAck"
                 and m["transfer_uuid"] == transfer and m["transferred_bytes"] == m["total_bytes"])
    removed = [i for i, m in enumerate(received) if m.get("type") == "RemoveNotificationMessage"
               and m["uuid"] == f"upload-{transfer}"]
    return final, (removed[0] if removed else None)


@pytest.fixture
def upload_folder(tmp_path, monkeypatch):
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    return tmp_path


@pytest.mark.parametrize("name", ["..", ".", "", "a\x00b.jsonl.gz", "sub/take.bag", "x" * 300])
def test_odd_upload_names_are_refused_with_a_notification(demo, tab, upload_folder, name):
    transfer = upload(tab, demo, name, b"some bytes", send_parts=False)  # refused at the first message
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final  # the tab's own notice goes before it could say "success"
    assert "is refused" in notified(tab, "Recording refused")["body"]
    assert list(upload_folder.iterdir()) == [] and demo.uploads._transfers == {}


def test_an_upload_beyond_the_limit_is_refused_before_a_byte_is_kept(demo, tab, upload_folder):
    transfer = upload(tab, demo, "huge.bag", b"x" * 10, declared=uploads.MAX_UPLOAD_BYTES + 1)
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final
    assert "upload limit" in notified(tab, "Recording refused")["body"]
    assert demo.uploads._transfers == {} and list(upload_folder.iterdir()) == []


def test_parts_beyond_the_declared_size_end_the_transfer(demo, tab, upload_folder):
    transfer = upload(tab, demo, "liar.jsonl.gz", b"y" * 300, declared=200, part_bytes=100)
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final
    assert "not sent as it declared (part 2)" in notified(tab, "Recording refused")["body"]  # not buffered
    assert demo.uploads._transfers == {}


def test_a_part_sent_twice_ends_the_transfer(demo, tab, upload_folder):
    transfer = upload(tab, demo, "twice.jsonl.gz", b"z" * 200, part_bytes=100, send_parts=False)
    part = {"type": "FileTransferPart", "source_component_uuid": demo.panel.upload._impl.uuid,
            "transfer_uuid": transfer, "part_index": 0, "content": b"z" * 100}
    tab.send(part)
    tab.send(part)  # the same part again: 200 bytes "received", one part missing
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final
    assert "not sent as it declared (part 0)" in notified(tab, "Recording refused")["body"]
    assert demo.uploads._transfers == {} and list(upload_folder.iterdir()) == []


def test_parts_short_of_the_declared_size_are_refused_not_loaded(demo, tab, upload_folder):
    previous = demo.replay.replay
    transfer = upload(tab, demo, "short.jsonl.gz", b"s" * 200, declared=300, part_bytes=100)
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final
    assert "not sent as it declared (200 of 300 bytes)" in notified(tab, "Recording refused")["body"]
    assert demo.replay.replay is previous and demo.uploads._transfers == {}


def test_a_loader_that_fails_still_answers_the_tab_in_one_sentence(demo, tab, upload_folder, monkeypatch):
    def broken(name, content):
        raise RuntimeError("the loader broke")

    monkeypatch.setattr(demo.uploads, "on_file", broken)
    transfer = upload(tab, demo, "fine.jsonl.gz", b"f" * 100)
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final  # no "uploaded successfully"
    assert notified(tab, "Recording refused")["body"] == "fine.jsonl.gz could not be loaded (server error, see its log)"


def test_a_corrupt_recording_is_refused_in_one_sentence_and_leaves_nothing(demo, tab, upload_folder):
    import gzip

    previous = demo.replay.replay
    transfer = upload(tab, demo, "corrupt.jsonl.gz", gzip.compress(b"\xe7\x00 not json\n") * 3000, part_bytes=4096)
    final, removed = closed_upload(tab, transfer)
    assert removed is not None and removed < final
    body = notified(tab, "Recording refused")["body"]
    assert body.startswith("corrupt.jsonl.gz is not a readable recording (") and body.count("corrupt.jsonl.gz") == 1
    assert "\n" not in body and "/tmp" not in body and "cobotsafety-upload" not in body
    assert demo.replay.replay is previous and list(upload_folder.iterdir()) == []
    assert body in demo.panel.replay_message.content
    tab.send(gui_update(demo.panel.loop, not demo.panel.loop.value))  # the next action
    wait_until(lambda: "corrupt" not in demo.panel.replay_message.content, what="the refusal to leave the folder")
    tab.send(gui_update(demo.panel.loop, True))


def test_a_valid_recording_is_loaded_kept_in_memory_and_its_file_removed(demo, tab, upload_folder):
    from cobotsafety.human.recording import bundled_recording

    content = bundled_recording().read_bytes()
    transfer = upload(tab, demo, "my take.jsonl.gz", content)
    final, removed = closed_upload(tab, transfer)
    assert removed is None  # the tab's "uploaded" notice is true this time
    wait_until(lambda: demo.replay.name == "my take.jsonl.gz", what="the upload to play")
    assert "my take.jsonl.gz" in demo.panel.recording.options
    assert list(upload_folder.iterdir()) == []
    demo.panel.recording.value = demo.panel.recording.options[0]  # back to the bundled recording
    wait_until(lambda: demo.replay.name == demo.panel.recording.options[0], what="the bundled recording")
