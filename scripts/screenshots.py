"""Take the README's screenshots of the demo and the trial page in headless Chromium.

    python scripts/screenshots.py [--out docs/screenshots] [--chromium /usr/bin/chromium]

Writes ``planar.png`` (paper 1's arm with its limitations, one highlighted), ``panda_human.png``
(the panda with the replayed human playing) and ``trial.png`` (a participant's view of a
divided-attention trial). Software WebGL is slow: each page gets time to draw.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
VIEWPORT = {"width": 1400, "height": 900}


def _settle(page, text: str, seconds: float) -> None:
    page.get_by_text(text).first.wait_for(timeout=120_000)
    time.sleep(seconds)


def planar(context, out: Path) -> None:
    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415
    from cobotsafety.ports import free_local_port  # noqa: PLC0415

    app = DemoApp(DemoConfig(port=free_local_port())).start()
    try:
        page = context.new_page()
        page.goto(app.url)
        _settle(page, "EE x=", 4.0)
        app.loop.set_gizmo_target(np.array([0.25, 0.05, 0.0]))  # towards the base: slides on a limit
        time.sleep(3.0)
        page.screenshot(path=str(out / "planar.png"))
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
        page.get_by_role("button", name="Play").click()  # the visitor presses Play
        app.replay.seek(4.0)  # the recorded person walks in from about 4 s
        time.sleep(1.0)
        page.get_by_role("button", name="Pause").click()  # paused: the canvas and the status agree
        app.replay.seek(4.5)  # on their way in
        app.loop.reset()  # the arm at home, as a visitor first sees it
        time.sleep(4.0)
        page.get_by_text("Drag the arrow handle").scroll_into_view_if_needed()
        page.screenshot(path=str(out / "panda_human.png"))
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
        page.screenshot(path=str(out / "trial.png"))
        page.close()
    finally:
        server.stop()


SHOTS = ("planar", "panda_human", "trial")


def main(out: Path = Path("docs/screenshots"), chromium: str = "/usr/bin/chromium", only: tuple[str, ...] = SHOTS) -> None:
    from playwright.sync_api import sync_playwright  # noqa: PLC0415

    out.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="cobotsafety-shots-"), executable_path=chromium, headless=True, args=ARGS,
            viewport=VIEWPORT)
        context.set_default_timeout(120_000)
        try:
            for take in (planar, panda_human, trial):
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
