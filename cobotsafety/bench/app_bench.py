"""``cobotsafety bench app``: the demo's control-loop rate and jitter with a browser connected,
what the server sends per client (bytes and messages per second, decoded by ``WireProbe``
clients), drag-to-motion latency, and start-up time from the command to the first frame.

Start-up (``startup``, one entry per ``--startup-scenes`` scene): ``cobotsafety demo`` is
launched and the URL it prints opened at once, in ``--tabs`` tabs at the same time (a fresh
browser profile: nothing cached). Per tab: ``status_s`` (the status text shown),
``first_frame_s`` (the scene drawn: the gizmo's red arrow in the canvas, read in the page
from the WebGL canvas, not by a screenshot, which under software WebGL took seconds itself),
``settled_s`` (the canvas unchanged for a second: the meshes are in). Beside them the server's
side: ``url_s`` (the command printed its URL) and the first client's initial scene
(``initial_messages``, ``initial_kB``: what a ``WireProbe`` received, in a later run of the same
command, until the gizmo (made last) had come and 1.5 s brought less than 30 kB; the last
1.5 s of the idle stream included). The command prints its URL as soon as the server listens
(``DemoApp(announce=...)``): the page loads while the server builds the robot's scene.

The wire figures come in four phases of ``--seconds`` each: ``idle`` (replay paused, no input)
and ``moving`` (replay playing, the gizmo pulled round a 10 cm circle at 20 Hz), each with 1 and
with 8 counting clients connected beside the browser tab. Each phase resets the loop statistics:
``loop_rate_hz`` is ticks per wall-clock second, the ``period_*`` figures are the wall-clock
times between tick starts, ``tick_late_p99_ms`` how late a tick started after its deadline, and
``overruns`` the ticks that dropped missed ones (``cobotsafety.app.tick_schedule``).

Needs Chromium at ``--chromium`` (default /usr/bin/chromium) and the ``playwright`` package.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from cobotsafety.cli.arguments import existing_file, positive_int, positive_ints, positive_seconds, rate_hz
from cobotsafety.ports import free_local_port

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
GIZMO_X_RGB = np.array([249, 45, 104])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--chromium", type=existing_file, default="/usr/bin/chromium", help="Chromium executable")
    parser.add_argument("--seconds", type=positive_seconds, default=10.0, help="loop-rate measurement window [s]")
    parser.add_argument("--drags", type=positive_int, default=10, help="drag-to-motion latency samples")
    parser.add_argument("--robot", default="planar",
                        help="scene for the loop-rate window: planar (default) or an arm name (panda, ur5, ...)")
    parser.add_argument("--rate", type=rate_hz, default=1000.0, help="control-loop rate [Hz] (default 1000)")
    parser.add_argument("--clients", type=positive_ints, default="1,8", help="counting clients per phase, comma-separated")
    parser.add_argument("--skip-startup", action="store_true", help="do not time the start-up of `cobotsafety demo`")
    parser.add_argument("--startup-only", action="store_true", help="time the start-up only (no loop, wire, drags)")
    parser.add_argument("--startup-scenes", default="planar,panda",
                        help="scenes whose start-up is timed: planar and/or arm names (default planar,panda)")
    parser.add_argument("--tabs", type=int, default=1, help="tabs opened at once on the printed URL (default 1)")


def _arrow(page, timeout_s: float = 30.0) -> tuple[float, float]:
    """Screen position of the gizmo's x arrow; retried while software WebGL draws the scene."""
    from PIL import Image  # noqa: PLC0415

    page.mouse.move(5, 5)
    deadline = time.perf_counter() + timeout_s
    while True:
        image = np.asarray(Image.open(io.BytesIO(page.screenshot())).convert("RGB")).astype(int)
        mask = np.abs(image - GIZMO_X_RGB).sum(axis=2) < 30
        mask[:, 780:] = False
        mask[620:, :200] = False
        ys, xs = np.nonzero(mask)
        if xs.size:
            return float(xs.mean()), float(ys.mean())
        if time.perf_counter() > deadline:
            raise RuntimeError("gizmo not found on screen")
        time.sleep(0.5)


CANVAS_PROBE_JS = """() => {
  const c = document.querySelector('canvas[data-engine]');
  if (!c || !c.width || !c.height) return null;
  const s = document.createElement('canvas'); s.width = 160; s.height = 100;
  const g = s.getContext('2d'); g.drawImage(c, 0, 0, 160, 100);
  const d = g.getImageData(0, 0, 160, 100).data;
  let red = 0, hash = 0, m = 0, q = 0;
  for (let i = 0; i < d.length; i += 4) {
    const v = (d[i] + d[i + 1] + d[i + 2]) / 3; m += v; q += v * v;
    if (Math.abs(d[i] - 249) + Math.abs(d[i + 1] - 45) + Math.abs(d[i + 2] - 104) < 60) red++;
    hash = (hash * 31 + (d[i] >> 3) * 1024 + (d[i + 1] >> 3) * 32 + (d[i + 2] >> 3)) | 0;
  }
  const n = d.length / 4; m /= n;
  return {std: Math.sqrt(Math.max(q / n - m * m, 0)), red: red, hash: hash};
}"""
"""Downscaled canvas read in the page: grey-level spread, gizmo-red pixels, a hash of the image."""
SETTLED_S = 1.0


def _demo_command(port: int, scene: str) -> list[str]:
    command = [sys.executable, "-m", "cobotsafety", "demo", "--port", str(port)]
    return command + ([] if scene == "planar" else ["--robot", scene])


def _tab_timeline(page, start: float, timeout_s: float = 240.0) -> dict:
    """Seconds from ``start`` to the status shown, the first frame and the settled canvas."""
    out: dict = {}
    deadline = time.perf_counter() + timeout_s
    page.get_by_text("EE x=").first.wait_for(timeout=timeout_s * 1e3)
    out["status_s"] = time.perf_counter() - start
    last_hash, same_since = None, None
    while time.perf_counter() < deadline:
        probe = page.evaluate(CANVAS_PROBE_JS)
        now = time.perf_counter()
        if probe is not None and probe["std"] > 5.0 and probe["red"] >= 3:
            out.setdefault("first_frame_s", now - start)
            if probe["hash"] != last_hash:
                last_hash, same_since = probe["hash"], now
            elif now - same_since >= SETTLED_S:
                out["settled_s"] = same_since - start
                return out
        time.sleep(0.05)
    return out


def _startup(playwright, chromium: str, port: int, scene: str, tabs: int) -> dict:
    """Launch ``cobotsafety demo`` for ``scene``, open its URL in ``tabs`` tabs at once (a fresh
    browser each), time each tab; then count the first client's initial scene on a second run."""
    import threading  # noqa: PLC0415

    from cobotsafety.app.wire_probe import WireProbe  # noqa: PLC0415

    browser = playwright.chromium.launch(executable_path=chromium, headless=True, args=CHROMIUM_ARGS)
    pages = []
    for _ in range(tabs):
        context = browser.new_context(viewport={"width": 1200, "height": 800})
        page = context.new_page()
        page.set_content("<p>warm-up</p>")
        page.screenshot()  # a context's first screenshot is slow: not counted
        pages.append(page)
    result: dict = {"scene": scene, "tabs": tabs, "load_average_1min": round(os.getloadavg()[0], 2)}
    start = time.perf_counter()
    process = subprocess.Popen(_demo_command(port, scene), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        for line in process.stdout:  # the user opens the URL the command prints
            if "open http" in line:
                break
        result["url_s"] = round(time.perf_counter() - start, 2)
        url = line.split("open ", 1)[1].strip()
        timelines: list[dict] = [{} for _ in pages]
        for page in pages:
            page.goto(url, wait_until="commit", timeout=240_000)  # all tabs navigate before any is awaited
        for i, page in enumerate(pages):
            timelines[i] = {key: round(value, 2) for key, value in _tab_timeline(page, start).items()}
        result["per_tab"] = timelines
    finally:
        process.terminate()
        process.wait(timeout=10)
        browser.close()
    process = subprocess.Popen(_demo_command(port, scene), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        for line in process.stdout:
            if "open http" in line:
                break
        probe = WireProbe(line.split("open ", 1)[1].strip()).start()
        quiet = threading.Event()
        last = -1
        while not quiet.wait(1.5):  # the initial scene: the gizmo (made last) in, then the stream
            counts = probe.counts()  # falls to the idle trickle (~15 kB per 1.5 s, counted too)
            gizmo = counts["types"].get("TransformControlsMessage", 0) > 0
            if gizmo and counts["bytes"] - last < 30_000 and last >= 0:
                break
            last = counts["bytes"]
        result["initial_messages"] = int(sum(counts["types"].values()))
        result["initial_kB"] = round(counts["bytes"] / 1e3, 1)
        probe.stop()
    finally:
        process.terminate()
        process.wait(timeout=10)
    return result


def _phase(app, clients: int, moving: bool, seconds: float) -> dict:
    """One measurement window: ``clients`` counting clients, idle or moving; loop and wire figures.

    The counting clients run in a separate process (``python -m cobotsafety.app.wire_probe``),
    as browsers would: they do not share the server's interpreter.
    """
    import json  # noqa: PLC0415
    import threading  # noqa: PLC0415

    from cobotsafety.app.control_loop import LoopStats  # noqa: PLC0415

    app.loop.reset()
    app.replay.seek(0.0)
    app.replay.playing = moving
    stop = threading.Event()

    def pull() -> None:  # the gizmo pulled round a circle, as a user's drag would
        home = app.loop.snapshot().p_base_ee_m.copy()
        start = time.perf_counter()
        while not stop.wait(0.05):
            angle = 2.0 * np.pi * (time.perf_counter() - start) / 4.0
            app.loop.set_gizmo_target(home + 0.1 * np.array([np.cos(angle) - 1.0, np.sin(angle), 0.0]))

    puller = threading.Thread(target=pull, daemon=True) if moving else None
    if puller is not None:
        puller.start()
    probes = subprocess.Popen([sys.executable, "-m", "cobotsafety.app.wire_probe", app.url, "--clients",
                               str(clients), "--warmup", "3", "--seconds", str(seconds)],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        if probes.stdout.readline().strip() != "ready":  # the initial scene backlog is not steady state
            raise RuntimeError("wire probes did not start")
        app.loop.stats = LoopStats(window=int(seconds * app.config.rate_hz * 2))
        frames = app.frames
        counts = json.loads(probes.stdout.readline())
        stats = app.loop.stats.summary()
        frames = app.frames - frames
    finally:
        probes.wait(timeout=60)
        stop.set()
    if puller is not None:
        puller.join()
    app.loop.release_gizmo()
    app.replay.playing = False
    mesh_per_s = [c["types"].get("MeshMessage", 0) / c["seconds"] for c in counts]
    return {"clients": clients, "state": "moving" if moving else "idle",
            "kB_per_s_per_client": round(float(np.mean([c["bytes_per_s"] for c in counts])) / 1e3, 1),
            "kB_per_s_per_client_max": round(float(np.max([c["bytes_per_s"] for c in counts])) / 1e3, 1),
            "messages_per_s_per_client": round(float(np.mean([c["messages_per_s"] for c in counts])), 1),
            "mesh_messages_per_s": round(float(np.max(mesh_per_s)), 2),
            "loop_rate_hz": round(stats["rate_hz"], 1), "period_p50_ms": round(stats["p50_ms"], 3),
            "period_p99_ms": round(stats["p99_ms"], 3), "period_max_ms": round(stats["max_ms"], 3),
            "tick_late_p99_ms": round(stats["late_p99_ms"], 3), "overruns": int(stats["overruns"]),
            "render_frames_per_s": round(frames / seconds, 1), "load_average_1min": round(os.getloadavg()[0], 2)}


def run(args: argparse.Namespace) -> dict:
    from playwright.sync_api import sync_playwright  # noqa: PLC0415

    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415
    from cobotsafety.bench.stopwatch import machine_description  # noqa: PLC0415

    result: dict = {"name": "app"}
    with sync_playwright() as playwright:
        if not args.skip_startup:
            result["startup"] = [_startup(playwright, args.chromium, free_local_port(), scene, args.tabs)
                                 for scene in args.startup_scenes.split(",")]
            for entry in result["startup"]:
                first = [tab.get("first_frame_s") for tab in entry["per_tab"]]
                result[f"startup_{entry['scene']}"] = (
                    f"URL {entry['url_s']} s, status {[tab.get('status_s') for tab in entry['per_tab']]} s, "
                    f"first frame {first} s, settled {[tab.get('settled_s') for tab in entry['per_tab']]} s; "
                    f"{entry['initial_messages']} messages, {entry['initial_kB']} kB; load {entry['load_average_1min']}")
        if args.startup_only:
            result["load_average_1min"] = round(os.getloadavg()[0], 2)
            result["machine"] = machine_description()
            return result
        context = playwright.chromium.launch_persistent_context(
            tempfile.mkdtemp(prefix="cobotsafety-bench-"), executable_path=args.chromium, headless=True,
            args=CHROMIUM_ARGS, viewport={"width": 1200, "height": 800})

        app = DemoApp(DemoConfig(port=free_local_port(), rate_hz=args.rate)).start()
        try:
            page = context.new_page()
            page.goto(app.url)
            page.get_by_text("EE x=").wait_for(timeout=60000)
            time.sleep(1.0)
            latencies, to_server = [], []
            for _ in range(args.drags):
                app.loop.reset()
                time.sleep(0.5)
                x, y = _arrow(page)
                page.mouse.move(x, y)
                page.mouse.down()
                before = app.loop.snapshot().p_base_ee_m
                start = time.perf_counter()
                page.mouse.move(x - 30, y)
                while np.linalg.norm(app.loop.snapshot().p_base_ee_m - before) < 1e-4:
                    if time.perf_counter() - start > 10:
                        break
                    time.sleep(0.0002)
                latencies.append(time.perf_counter() - start)
                to_server.append(app.last_gizmo_update_s - start)
                page.mouse.up()
            latency_ms = np.array(latencies) * 1e3
            result["drag_to_motion_ms_p50"] = round(float(np.median(latency_ms)), 1)
            result["drag_to_motion_ms_max"] = round(float(latency_ms.max()), 1)
            result["drag_to_server_ms_p50"] = round(float(np.median(to_server) * 1e3), 1)

            if args.robot != "planar":
                app.switch_scene(args.robot)
                app.ensure_replay()
                page.reload()
                page.get_by_text("EE x=").wait_for(timeout=60000)
                time.sleep(2.0)
            result["robot"] = args.robot
            result["phases"] = [_phase(app, clients, moving, args.seconds)
                                for clients in args.clients
                                for moving in (False, True)]
            page.screenshot(path=f"/tmp/cobotsafety_app_{args.robot}.png")
            for phase in result["phases"]:
                result[f"{phase['state']}_{phase['clients']}_clients"] = (
                    f"{phase['kB_per_s_per_client']} kB/s per client, {phase['messages_per_s_per_client']} msg/s, "
                    f"{phase['mesh_messages_per_s']} meshes/s; loop {phase['loop_rate_hz']} Hz, "
                    f"p99 period {phase['period_p99_ms']} ms; load {phase['load_average_1min']}")
        finally:
            app.stop()
            context.close()
    result["target_rate_hz"] = args.rate
    result["load_average_1min"] = round(os.getloadavg()[0], 2)
    result["machine"] = machine_description()
    return result
