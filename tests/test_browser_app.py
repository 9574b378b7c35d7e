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

from cobotsafety.app.server import DemoApp, DemoConfig
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
    slid, stopped = displacement_after_first_binding(drag(page, app, 60, 2.0))
    assert slid > 0.02 and not stopped, slid
    reset(page, app, "stop")
    held, stopped = displacement_after_first_binding(drag(page, app, 60, 2.0))
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


def test_replay_plays_and_the_distance_readout_changes(browser, app):
    import re

    page = open_page(browser, app)
    reset(page, app, "anticipative")
    page.get_by_text("Replay").first.click()  # open the folder
    play = page.get_by_role("button", name=re.compile("^(Play|Pause)$"))
    if play.inner_text().strip() == "Play":
        play.click()
    app.replay.seek(4.5)  # the recorded person walks in from about 4 s
    status = page.get_by_text("EE x=")
    readouts = set()
    deadline = time.monotonic() + 60
    while len(readouts) < 3 and time.monotonic() < deadline:
        found = re.search(r"min distance (\d+) mm", status.inner_text())
        if found:
            readouts.add(int(found.group(1)))
        time.sleep(0.3)
    assert len(readouts) >= 3, readouts  # the person moves, the readout follows
    assert min(readouts) < 2000
    page.get_by_role("button", name="Pause").click()  # the button toggles playback
    deadline = time.monotonic() + 30
    while app.replay.playing and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not app.replay.playing
    page.close()
