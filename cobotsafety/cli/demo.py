"""``cobotsafety demo``: open the product in a browser (viser). Prints the URL, runs until Ctrl-C.

Bound to 127.0.0.1 (the default), every tab may drive the robot. Bound beyond loopback
(``--host 0.0.0.0``), the command warns, prints a URL other machines can open and a token:
a tab sees the demo but changes nothing until the token is entered. A control thread that
dies stops the command with an error (exit 2) instead of serving a robot that never moves.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from cobotsafety.cli.arguments import MAX_RATE_HZ, MIN_RATE_HZ, port, rate_hz

DEFAULT_PORT = 8080
HEALTH_CHECK_S = 0.5
"""How often the command checks that the demo's threads are alive [s]."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", choices=("planar", "arm"), default=None,
                        help="planar: paper 1's RR arm seen from above (default); arm: a 3D pinocchio arm "
                             "(default when --robot names an arm)")
    parser.add_argument("--robot", default=None, help="arm name for --scene arm (default: the arm package's default)")
    parser.add_argument("--replay", type=Path, default=None,
                        help="human recording (.jsonl.gz) or ROS bag; default: the bundled recording")
    parser.add_argument("--host", default="127.0.0.1",
                        help="interface to bind (default 127.0.0.1, this machine only; 0.0.0.0 listens on every "
                             "interface and asks visitors for a printed token before they may change anything)")
    parser.add_argument("--port", type=port, default=DEFAULT_PORT,
                        help=f"HTTP/websocket port, 1-65535 (default {DEFAULT_PORT})")
    parser.add_argument("--rate", type=rate_hz, default=1000.0,
                        help=f"control-loop rate [Hz], {MIN_RATE_HZ:.0f}-{MAX_RATE_HZ:.0f} "
                             "(default 1000; 500 also supported)")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.app.compile_notice import announce_compilation  # noqa: PLC0415
    from cobotsafety.errors import CobotSafetyError  # noqa: PLC0415

    scene = args.scene or ("arm" if args.robot not in (None, "planar") else "planar")
    with announce_compilation("cobotsafety demo"):
        from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415 - heavy (viser)

        # The URL as soon as the server listens (the page loads while the scene is built).
        app = DemoApp(DemoConfig(scene=scene, robot=args.robot, replay=args.replay, host=args.host,
                                 port=args.port, rate_hz=args.rate),
                      announce=lambda url: print(f"cobotsafety demo: open {url}", flush=True)).start()
        problem = app.wait_until_running()  # the first step and frame compile what is left
    try:
        if problem:
            raise CobotSafetyError(f"{problem}; the demo is stopped")
        for line in app.start_lines():
            if line != f"open {app.url}":  # announced already
                print(f"cobotsafety demo: {line}", flush=True)
        while True:
            time.sleep(HEALTH_CHECK_S)
            problem = app.failure()
            if problem:
                raise CobotSafetyError(f"{problem}; the demo is stopped")
    except KeyboardInterrupt:
        pass
    finally:
        app.stop()
    return 0
