"""The demo in headless Chromium (Playwright): renders, real mouse drag, sliding vs stop, tabs.

The gizmo is dragged with the real mouse: the test finds its red (x) arrow in a screenshot by
colour and drags it, so the command goes through three.js, the websocket and the server exactly
as a user's drag does. Software WebGL is slow: generous timeouts, few tests.
"""

from __future__ import annotations

import io
import tempfile
import threading
import time

import numpy as np
import pytest
from PIL import Image

from cobotsafety.app.demo_app import DemoApp, DemoConfig
from cobotsafety.ports import free_local_port

pytestmark = pytest.mark.browser

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1200, "height": 800}
#: viser's x-arrow colour (sRGB) as rendered by software WebGL.
GIZMO_X_RGB = np.array([249, 45, 104])
TIMEOUT_MS = 90_000


@pytest.fixture(scope="module")
def app():
    demo = DemoApp(DemoConfig(port=free_local_port())).start()
    yield demo
    demo.stop()


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright

    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="cobotsafety-chromium-"), executable_path=CHROMIUM, headless=True,
            args=ARGS, viewport=VIEWPORT)
        context.set_default_timeout(TIMEOUT_MS)
        yield context
        context.close()


def open_page(browser, app):
    page = browser.new_page()
    page.goto(app.url)
    page.get_by_text("EE x=").wait_for()
    time.sleep(1.5)  # a few frames of software rendering
    return page


def rgb(page) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)


def gizmo_x_arrow(page) -> tuple[float, float]:
    """Screen position of the gizmo's x arrow (centroid of its colour left of the panel)."""
    page.mouse.move(5, 5)  # no hover highlight
    image = rgb(page)
    mask = np.abs(image - GIZMO_X_RGB).sum(axis=2) < 30
    mask[:, 780:] = False  # the panel
    mask[620:, :200] = False  # the orientation widget in the corner
    ys, xs = np.nonzero(mask)
    assert xs.size > 10, "the gizmo's x arrow is not visible"
    return float(xs.mean()), float(ys.mean())


def reset(page, app, mode: str) -> None:
    page.get_by_role("button", name="Reset").click()
    page.get_by_role("combobox", name="Mode").click()
    page.get_by_role("option", name=mode, exact=True).click()
    deadline = time.monotonic() + 30
    while (app.loop.method != mode or app.loop.snapshot().steps > 2000) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert app.loop.method == mode
    time.sleep(1.0)  # the gizmo returns to the end-effector on screen


def record(app, seconds: float) -> list:
    """Snapshots at ~50 Hz for ``seconds``."""
    out, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        out.append(app.loop.snapshot())
        time.sleep(0.02)
    return out


def drag(page, app, dx_px: float, hold_s: float) -> list:
    """Grab the x arrow, drag it ``dx_px`` right, hold, release; snapshots during the hold."""
    x, y = gizmo_x_arrow(page)
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + dx_px, y, steps=15)
    snapshots = record(app, hold_s)
    page.mouse.up()
    return snapshots


def test_page_connects_and_robot_renders(browser, app):
    page = open_page(browser, app)
    canvas = np.asarray(Image.open(io.BytesIO(page.locator("canvas").first.screenshot())).convert("L"), dtype=float)
    assert canvas.std() > 10.0, "the canvas is blank"
    assert len(np.unique(canvas)) > 50
    gizmo_x_arrow(page)  # the gizmo was drawn at the end-effector
    assert "anticipative" in page.get_by_text("EE x=").inner_text()
    page.close()


def test_mouse_drag_moves_robot_and_release_returns_gizmo(browser, app):
    page = open_page(browser, app)
    reset(page, app, "off")
    start = app.loop.snapshot().p_base_ee_m
    snapshots = drag(page, app, -50, 1.0)  # away from the base: free space
    assert any(s.dragging for s in snapshots), "the server never saw the drag"
    time.sleep(1.0)
    end = app.loop.snapshot()
    assert end.p_base_ee_m[0] < start[0] - 0.02, (start, end.p_base_ee_m)
    assert not end.dragging
    np.testing.assert_allclose(app.gizmo.position, end.p_base_ee_m, atol=1e-4)
    page.get_by_text(f"EE x={end.p_base_ee_m[0] * 1e3:.1f}").wait_for()  # the readout follows
    page.close()


def displacement_after_first_binding(snapshots) -> tuple[float, bool]:
    bound = [s for s in snapshots if s.report is not None and s.report.binding]
    assert bound, "the end-effector never reached a limitation"
    return float(np.linalg.norm(bound[-1].p_base_ee_m - bound[0].p_base_ee_m)), bound[-1].report.stopped


def test_at_a_limit_anticipative_slides_and_stop_halts(browser, app):
    page = open_page(browser, app)
    # Towards the base: the end-effector meets joint 2's limit circle (B) almost head-on.
    reset(page, app, "anticipative")
    slid, stopped = displacement_after_first_binding(drag(page, app, 120, 2.0))  # ~0.2 m at this zoom
    assert slid > 0.02 and not stopped, slid
    reset(page, app, "stop")
    held, stopped = displacement_after_first_binding(drag(page, app, 120, 2.0))
    assert held < 0.002 and stopped, held
    page.close()


def test_two_tabs_share_one_robot_and_a_disconnect_keeps_the_loop(browser, app):
    first, second = open_page(browser, app), open_page(browser, app)
    reset(first, app, "anticipative")
    x, y = gizmo_x_arrow(first)
    first.mouse.move(x, y)
    first.mouse.down()
    first.mouse.move(x - 40, y, steps=10)
    deadline = time.monotonic() + 30
    while not app.loop.snapshot().dragging and time.monotonic() < deadline:
        time.sleep(0.05)
    assert app.loop.snapshot().dragging
    first.close()  # disconnect mid-drag: the command must go to zero, the server must go on
    time.sleep(2.0)
    steps = app.loop.snapshot().steps
    ee = app.loop.snapshot().p_base_ee_m
    assert not app.loop.snapshot().dragging
    time.sleep(1.0)
    assert app.loop.running and app.loop.snapshot().steps > steps
    np.testing.assert_allclose(app.loop.snapshot().p_base_ee_m, ee, atol=1e-6)  # holds still
    second.get_by_text(f"EE x={ee[0] * 1e3:.1f}").wait_for()  # the other tab saw the motion
    second.close()


def colour_pixels(page, rgb_target, tolerance: int = 60) -> int:
    """Pixels of the scene area (left of the panel) within ``tolerance`` (L1) of ``rgb_target``."""
    image = rgb(page)[:, :780]
    return int((np.abs(image - np.array(rgb_target)).sum(axis=2) < tolerance).sum())


def wait_until(condition, timeout_s: float = 60.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.3)


def test_open_tab_follows_highlight_fig9_pull_and_refused_upload(browser, app):
    """Items 2, 7, 8: a tab opened before anything happened shows the highlight and its end, the
    Fig. 9 pull moves the gizmo with the arm to a marked target, and a refused upload says why."""
    from cobotsafety.app import draw
    from cobotsafety.planar.planar_scenes import FIG9_TARGET_M

    page = open_page(browser, app)
    reset(page, app, "anticipative")
    assert colour_pixels(page, draw.HIGHLIGHT) < 30
    app.loop.set_gizmo_target(np.array([0.3, 0.03, 0.0]))  # towards the base: joint 2's circle B binds
    wait_until(lambda: "B joint 2" in app.scene.view.active_limitations(), what="B to bind")
    wait_until(lambda: colour_pixels(page, draw.HIGHLIGHT) > 300, what="the highlight in the open tab")
    app.loop.release_gizmo()
    app.loop.reset()
    wait_until(lambda: colour_pixels(page, draw.HIGHLIGHT) < 30, what="the highlight to go")

    page.get_by_role("button", name="Fig. 9 scenario").click()
    wait_until(lambda: app._target_marker is not None and app._scripted_target_m is None
               and app.loop.snapshot().steps > 100 and not app.loop.snapshot().dragging, what="the pull to end")
    ee = app.loop.snapshot().p_base_ee_m
    assert np.linalg.norm(ee[:2] - np.array(FIG9_TARGET_M)) < 0.01, ee
    time.sleep(1.0)
    np.testing.assert_allclose(app.gizmo.position, ee, atol=1e-4)  # the gizmo came along
    from cobotsafety.app.demo_app import FIG9_MARKER_RGB

    assert colour_pixels(page, FIG9_MARKER_RGB, tolerance=45) > 40, "no target marker on screen"
    drag(page, app, -8, 0.5)  # a nudge of the gizmo moves the arm a little, not back to the start
    time.sleep(1.0)
    assert np.linalg.norm(app.loop.snapshot().p_base_ee_m - ee) < 0.05

    page.get_by_text("Replay").first.click()
    page.locator("input[type=file]").set_input_files(
        files=[{"name": "broken.jsonl.gz", "mimeType": "application/gzip", "buffer": b"this is not a recording"}])
    page.get_by_text("Recording refused").wait_for()
    body = page.inner_text("body")
    assert "broken.jsonl.gz" in body
    assert "cobotsafety-upload" not in body and "/tmp" not in body
    assert app.replay.name == "reach-over.jsonl.gz"  # the previous replay stays
    page.close()


def test_panda_replay_draws_the_human_and_one_distance(browser):
    """Items 1, 3, 5: the replay starts paused; once played, the human is drawn in the open tab;
    the status and the scene label show one distance."""
    import re

    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port())).start()
    try:
        page = open_page(browser, demo)
        assert not demo.replay.playing and demo.replay.time_s == 0.0  # the robot waits at home
        assert "SSM off" in page.get_by_text("EE x=").inner_text()
        demo.loop.method = "off"  # no input, no avoidance: the arm holds still, only the human moves
        page.get_by_text("Replay").first.click()
        page.get_by_role("button", name="Play").click()
        wait_until(lambda: demo.replay.playing, what="Play")
        page.get_by_role("button", name="Pause").wait_for()
        demo.replay.seek(5.0)  # the recorded person walks in from about 4 s
        time.sleep(3.0)
        assert demo.replay.playing and demo.human.shown_capsules > 0
        with_human = rgb(page)
        demo.human.visible = False
        time.sleep(1.5)
        without_human = rgb(page)
        demo.human.visible = True
        changed = int((np.abs(with_human - without_human).sum(axis=2) > 60)[:, :780].sum())
        assert changed > 3000, f"hiding the human changed only {changed} pixels: it was not drawn"

        page.get_by_role("button", name="Pause").click()
        wait_until(lambda: not demo.replay.playing, what="Pause")
        demo.replay.seek(8.0)  # paused with the person in view
        time.sleep(2.0)
        status = page.get_by_text("EE x=").inner_text()
        shown = re.search(r"human distance (-?\d+) mm", status)
        assert shown, status
        assert demo.human.label.text == f"{shown.group(1)} mm"  # the label in the scene says the same
        page.close()
    finally:
        demo.stop()


SUCCESS_WATCH = """() => {
    window.__uploadedSuccessfully = 0;
    new MutationObserver(() => {
        if (document.body.textContent.includes("File uploaded successfully")) window.__uploadedSuccessfully += 1;
    }).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def test_a_refused_upload_never_says_it_was_uploaded_successfully(browser, app):
    """Issue 25 item 2: no viser "File uploaded successfully." for a refused file, one plain
    sentence naming it once, gone from the Replay folder at the next action; a good file still
    gets viser's notice (the watch can see it)."""
    from cobotsafety.human.recording import bundled_recording

    page = open_page(browser, app)
    page.evaluate(SUCCESS_WATCH)
    page.get_by_text("Replay").first.click()
    page.locator("input[type=file]").set_input_files(
        files=[{"name": "corrupt.jsonl.gz", "mimeType": "application/gzip", "buffer": b"\x1f\x8b\x08 truncated"}])
    page.get_by_text("Recording refused").wait_for()
    time.sleep(3.0)  # viser's notice would have shown by now
    assert page.evaluate("window.__uploadedSuccessfully") == 0
    sentence = page.get_by_text("corrupt.jsonl.gz is not a readable recording (").first.inner_text()
    assert sentence.count("corrupt.jsonl.gz") == 1 and "refused corrupt" not in sentence
    page.get_by_role("checkbox", name="Loop").click()  # the next action
    wait_until(lambda: "corrupt.jsonl.gz is not" not in app.panel.replay_message.content, what="the folder cleared")
    page.get_by_role("checkbox", name="Loop").click()
    page.locator("input[type=file]").set_input_files(
        files=[{"name": "take.jsonl.gz", "mimeType": "application/gzip", "buffer": bundled_recording().read_bytes()}])
    wait_until(lambda: page.evaluate("window.__uploadedSuccessfully") > 0, what="viser's notice for a good file")
    assert app.replay.name == "take.jsonl.gz"
    app.panel.recording.value = "reach-over.jsonl.gz"  # as the other tests expect
    wait_until(lambda: app.replay.name == "reach-over.jsonl.gz", what="the bundled recording again")
    page.close()
