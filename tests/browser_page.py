"""Helpers shared by the browser tests: a headless Chromium, screenshots as arrays, colours,
and where a point of the scene lands on the screen (from the tab's own camera)."""

from __future__ import annotations

import io
import tempfile
import time

import numpy as np
from PIL import Image

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1200, "height": 800}
TIMEOUT_MS = 120_000
PANEL_X = 780
"""Screen x [px] where the control panel starts at ``VIEWPORT`` (the scene is left of it)."""


def launch(playwright):
    context = playwright.chromium.launch_persistent_context(
        tempfile.mkdtemp(prefix="cobotsafety-chromium-"), executable_path=CHROMIUM, headless=True,
        args=ARGS, viewport=VIEWPORT)
    context.set_default_timeout(TIMEOUT_MS)
    return context


SOFTWARE_WEBGL_TOAST = "Software WebGL rendering detected"


def close_toasts(page) -> None:
    """Close viser's "Software WebGL rendering detected" notification (it covers the scene's corner)."""
    toast = page.locator(".mantine-Notification-root", has_text=SOFTWARE_WEBGL_TOAST)
    for _ in range(20):
        if toast.count() == 0:
            return
        try:
            toast.first.locator("button").first.click(timeout=5_000)
        except Exception:  # noqa: BLE001 - it may close by itself meanwhile
            pass
        time.sleep(0.3)


def open_page(browser, app, settle_s: float = 1.5):
    page = browser.new_page()
    page.goto(app.url)
    page.get_by_text("EE x=").wait_for()
    close_toasts(page)
    time.sleep(settle_s)  # a few frames of software rendering
    return page


def rgb(page) -> np.ndarray:
    """The page as an (h, w, 3) int array."""
    return np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)


def steady_rgb(page, timeout_s: float = 30.0) -> np.ndarray:
    """A screenshot of the scene area once two in a row agree (what moved has settled)."""
    deadline = time.monotonic() + timeout_s
    last = rgb(page)[:, :PANEL_X]
    while True:
        time.sleep(0.5)
        image = rgb(page)[:, :PANEL_X]
        if (np.abs(image - last).sum(axis=2) > 60).mean() < 1e-4 or time.monotonic() > deadline:
            return image
        last = image


def coarse_difference(a: np.ndarray, b: np.ndarray, block: int = 8) -> float:
    """Fraction of ``block`` x ``block`` tiles whose mean colour differs by more than 12 (L1)
    between two screenshots: the same view drawn at another pixel ratio (viser lowers it while
    the camera moves) differs in thin lines' pixels, not in tiles."""
    h, w = (min(a.shape[0], b.shape[0]) // block) * block, (min(a.shape[1], b.shape[1]) // block) * block
    tiles = lambda image: image[:h, :w].reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))  # noqa: E731
    return float((np.abs(tiles(a) - tiles(b)).sum(axis=2) > 12).mean())


def colour_mask(image: np.ndarray, rgb_target, tolerance: int = 60) -> np.ndarray:
    return np.abs(image - np.array(rgb_target)).sum(axis=2) < tolerance


def colour_pixels(page, rgb_target, tolerance: int = 60) -> int:
    """Pixels of the scene area (left of the panel) within ``tolerance`` (L1) of ``rgb_target``."""
    return int(colour_mask(rgb(page)[:, :PANEL_X], rgb_target, tolerance).sum())


def wait_until(condition, timeout_s: float = 90.0, what: str = "") -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.3)


def camera_of(app):
    """The camera of the tab that connected last (the test's page), as the tab reported it."""
    clients = app.server.get_clients()
    assert clients, "no tab connected"
    return clients[max(clients)].camera


def to_screen(camera, page, p_world_m) -> np.ndarray:
    """Screen pixel (x, y) of world points ``p_world_m`` (n, 3): viser's camera pose is
    ``T_world_camera`` in OpenCV's convention (+z forward, +y down), ``fov`` vertical."""
    from scipy.spatial.transform import Rotation

    w, x, y, z = camera.wxyz
    R = Rotation.from_quat([x, y, z, w]).as_matrix()
    p_cam = (np.atleast_2d(p_world_m) - np.asarray(camera.position)) @ R
    box = page.locator("canvas[data-engine]").bounding_box()
    focal = (box["height"] / 2.0) / np.tan(camera.fov / 2.0)
    u = box["x"] + box["width"] / 2.0 + focal * p_cam[:, 0] / p_cam[:, 2]
    v = box["y"] + box["height"] / 2.0 + focal * p_cam[:, 1] / p_cam[:, 2]
    return np.column_stack([u, v])
