"""Take the README's screenshots of the demo and the trial page in headless Chromium.

    python scripts/screenshots.py [--out docs/screenshots] [--chromium /usr/bin/chromium]

Writes ``planar.png`` (paper 1's arm sliding round joint 2's limit circle B, highlighted),
``panda_human.png`` (the panda giving way to, or moving out of the way of, paper 2's co-worker,
the replay playing),
``panda_limit.png`` (the panda's elbow at its joint limit: the arc at the joint) and
``trial.png`` (a participant's view of a divided-attention trial). viser's "Software WebGL
rendering detected" notification is closed before each shot. Software WebGL is slow: each page
gets time to draw.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import time
from pathlib import Path

import numpy as np

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1400, "height": 900}


def _settle(page, text: str, seconds: float) -> None:
    page.get_by_text(text).first.wait_for(timeout=120_000)
    _close_toasts(page)
    time.sleep(seconds)


def _close_toasts(page) -> None:
    """Close viser's "Software WebGL rendering detected" notification (it covers the scene)."""
    toast = page.locator(".mantine-Notification-root", has_text="Software WebGL rendering detected")
    for _ in range(20):
        if toast.count() == 0:
            return
        try:
            toast.first.locator("button").first.click(timeout=5_000)
        except Exception:  # noqa: BLE001 - it may close by itself meanwhile
            pass
        time.sleep(0.3)


def _shoot(page, path: Path, wait_for: str | None = None) -> None:
    if wait_for is not None:
        page.get_by_text(wait_for).first.wait_for(timeout=120_000)
    _close_toasts(page)
    page.screenshot(path=str(path))


def planar(context, out: Path) -> None:
    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415
    from cobotsafety.ports import free_local_port  # noqa: PLC0415

    app = DemoApp(DemoConfig(port=free_local_port())).start()
    try:
        page = context.new_page()
        page.goto(app.url)
        _settle(page, "EE x=", 4.0)
        from cobotsafety.app.gizmo import GizmoSettings  # noqa: PLC0415

        app.panel.max_speed_m_s.value = 0.04  # slow: the slide lasts longer than a software-WebGL screenshot
        app.loop.gizmo = GizmoSettings(max_speed_m_s=0.04)
        app.loop.set_gizmo_target(np.array([0.45, -0.15, 0.0]))  # across the base: slides round joint 2's circle B
        page.get_by_text("Sliding along B").wait_for(timeout=120_000)
        time.sleep(2.0)
        _shoot(page, out / "planar.png", "Sliding along B")
        page.close()
    finally:
        app.stop()


def panda_human(context, out: Path) -> None:
    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415
    from cobotsafety.ports import free_local_port  # noqa: PLC0415

    app = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port())).start()
    try:
        page = context.new_page()
        page.goto(app.url)
        _settle(page, "EE x=", 4.0)
        page.get_by_text("Replay", exact=True).click()
        page.get_by_role("button", name="Play").click()  # the visitor presses Play: paper 2's experiment 1
        page.get_by_role("button", name="Pause").wait_for(timeout=120_000)
        app.panel.speed.value = 0.2  # slowed, still playing: software WebGL takes seconds to take a screenshot
        app.replay.speed = 0.2
        app.replay.seek(4.4)  # the co-worker walks in and reaches for the pick pose from about 4 s
        page.get_by_text(re.compile(r"Giving way|Moving out of the person's way")).first.wait_for(timeout=120_000)
        time.sleep(0.5)
        _shoot(page, out / "panda_human.png")  # playing
        page.close()
    finally:
        app.stop()


def panda_limit(context, out: Path) -> None:
    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415
    from cobotsafety.ports import free_local_port  # noqa: PLC0415

    app = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port())).start()
    try:
        page = context.new_page()
        page.goto(app.url)
        _settle(page, "EE x=", 4.0)
        app.loop.set_gizmo_target(np.array([0.2, 0.0, 0.1]))  # folded in towards the base: joint 4's lower end
        page.get_by_text("joint 4 at its lower end").first.wait_for(timeout=120_000)
        time.sleep(4.0)
        _shoot(page, out / "panda_limit.png", "joint 4 at its lower end")
        page.close()
    finally:
        app.stop()


def trial(context, out: Path) -> None:
    from cobotsafety.ports import free_local_port  # noqa: PLC0415
    from cobotsafety.trial.trial_app import TrialServer  # noqa: PLC0415

    server = TrialServer(Path(tempfile.mkdtemp(prefix="cobotsafety-shots-")), ["P01"], seed=1,
                         port=free_local_port()).start_server()
    try:
        page = context.new_page()
        page.goto(server.url)
        _settle(page, "Waiting for the operator", 3.0)
        server.start(next(t for t in server.plan if t.attention == "divided"))
        x, y = server.course.targets_m[0]
        server.loop.set_gizmo_target(np.array([x, y, 0.0]))  # the participant starts moving
        time.sleep(4.0)
        server.loop.release_gizmo()
        _shoot(page, out / "trial.png")
        page.close()
    finally:
        server.stop()


SHOTS = ("planar", "panda_human", "panda_limit", "trial")


def main(out: Path = Path("docs/screenshots"), chromium: str = "/usr/bin/chromium", only: tuple[str, ...] = SHOTS) -> None:
    from playwright.sync_api import sync_playwright  # noqa: PLC0415

    out.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="cobotsafety-shots-"), executable_path=chromium, headless=True, args=ARGS,
            viewport=VIEWPORT)
        context.set_default_timeout(120_000)
        try:
            for take in (planar, panda_human, panda_limit, trial):
                if take.__name__ not in only:
                    continue
                take(context, out)
                print(f"wrote {out / (take.__name__ + '.png')}", flush=True)
        finally:
            context.close()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/screenshots"))
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    parser.add_argument("--only", nargs="+", choices=SHOTS, default=SHOTS, help="take only these")
    arguments = parser.parse_args()
    main(arguments.out, arguments.chromium, tuple(arguments.only))
