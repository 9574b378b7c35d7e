"""``cobotsafety demo``: open the product in a browser (viser). Prints the URL, runs until Ctrl-C."""

from __future__ import annotations

import argparse
import time
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", choices=("planar", "arm"), default=None,
                        help="planar: paper 1's RR arm seen from above (default); arm: a 3D pinocchio arm "
                             "(default when --robot names an arm)")
    parser.add_argument("--robot", default=None, help="arm name for --scene arm (default: the arm package's default)")
    parser.add_argument("--replay", type=Path, default=None,
                        help="human recording (.jsonl.gz) or ROS bag; default: the bundled recording")
    parser.add_argument("--host", default="127.0.0.1", help="interface to bind (default 127.0.0.1; 0.0.0.0 for all)")
    parser.add_argument("--port", type=int, default=8080, help="HTTP/websocket port (default 8080)")
    parser.add_argument("--rate", type=float, default=1000.0, help="control-loop rate [Hz] (default 1000; 500 also supported)")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.app.demo_app import DemoApp, DemoConfig  # noqa: PLC0415 - heavy (viser)

    scene = args.scene or ("arm" if args.robot not in (None, "planar") else "planar")
    app = DemoApp(DemoConfig(scene=scene, robot=args.robot, replay=args.replay, host=args.host,
                             port=args.port, rate_hz=args.rate),
                  announce=lambda url: print(f"cobotsafety demo: open {url}", flush=True)).start()
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        app.stop()
    return 0
