"""``cobotsafety trial``: run user trials in the browser, or headless with simulated participants.

``cobotsafety trial --participants P01,P02 --out DIR`` serves the participant view and prints
the operator token; ``cobotsafety trial --simulate N --out DIR`` runs N simulated participants;
``cobotsafety trial --simulate N --repeat K [--json]`` estimates the power of each comparison
over K simulated studies of N participants (nothing is written).
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--simulate", type=int, default=0, metavar="N",
                        help="run complete sessions with N simulated participants (headless)")
    parser.add_argument("--participants", default="P01,P02,P03,P04", help="pseudonyms, comma-separated")
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8080)
    parser.add_argument("--out", type=Path, default=Path("out/trials"), metavar="DIR", help="log folder (resumed if it exists)")
    parser.add_argument("--seed", type=int, default=0, help="plan and participant seed (recorded in the log)")
    parser.add_argument("--scene", choices=["planar", "arm"], default="planar")
    parser.add_argument("--robot", default="panda", help="3D arm for --scene arm (browser trial)")
    parser.add_argument("--repeat", type=int, default=0, metavar="K",
                        help="with --simulate N: K simulated studies, print how often each comparison is significant")
    parser.add_argument("--json", action="store_true", help="with --repeat: print the power table as a JSON list")
    parser.add_argument("--paper-effect", action="store_true",
                        help="with --simulate N --repeat K: draw the studies from paper 1's means and SDs instead")


def run(args: argparse.Namespace) -> int:
    if not args.simulate:
        import time

        from cobotsafety.trial.trial_app import TrialServer

        participants = [p.strip() for p in args.participants.split(",") if p.strip()]
        robot = "planar" if args.scene == "planar" else args.robot
        server = TrialServer(args.out, participants, args.seed, args.host, args.port, robot=robot).start_server()
        print(f"cobotsafety trial: participant view {server.url}  operator view {server.operator_url}  "
              f"operator token: {server.token}", flush=True)
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            server.stop()
        return 0
    if args.repeat:
        import json

        from cobotsafety.trial.power import paper_power, simulated_power, table

        if args.repeat < 1 or args.simulate < 1:
            raise SystemExit("--repeat K needs K >= 1 and --simulate N with N >= 1")
        if args.paper_effect:
            rows = paper_power(args.simulate, args.repeat, args.seed)
        else:
            rows = simulated_power(args.simulate, args.repeat, args.seed, args.scene)
        print(json.dumps([r.as_json() for r in rows]) if args.json else table(rows))
        return 0
    from cobotsafety.trial.simulate import run_simulated_sessions

    written = run_simulated_sessions(args.out, args.simulate, args.seed, args.scene)
    print(f"{len(written)} trials written to {args.out / 'trials.jsonl'}")
    return 0
