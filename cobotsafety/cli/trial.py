"""``cobotsafety trial``: run user trials in the browser, or headless with simulated participants.

``cobotsafety trial --participants P01,P02 --out DIR`` serves the participant view and prints
the operator token (``--device joystick|spacemouse`` drives with an input device read on the
server; ``--answers buttons`` puts the colour answers on the participant's screen instead of
the operator's Right / Wrong / Missed keys); ``cobotsafety trial --simulate N --out DIR`` runs N
simulated participants; ``cobotsafety trial --simulate N --repeat K [--json]`` estimates the
power of each comparison over K simulated studies of N participants (nothing is written);
``--vary NAME=LO:HI`` (repeatable) turns that into a sensitivity table over the participant
model's parameter NAME; ``cobotsafety trial --course`` prints what the course asks of a
participant (measured in the trial scene).
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
    parser.add_argument("--device", choices=["none", "joystick", "spacemouse"], default="none",
                        help="browser trial: also drive with a joystick/gamepad or a 3D mouse read on the server")
    parser.add_argument("--answers", choices=["aloud", "buttons"], default="aloud",
                        help="browser trial: colour words answered aloud and logged by the operator (paper 1), "
                             "or with on-screen buttons")
    parser.add_argument("--repeat", type=int, default=0, metavar="K",
                        help="with --simulate N: K simulated studies, print how often each comparison is significant")
    parser.add_argument("--vary", action="append", default=[], metavar="NAME=LO:HI",
                        help="with --simulate N --repeat K: sensitivity of the study to one participant parameter "
                             "(repeatable; see cobotsafety.trial.participant_parameters)")
    parser.add_argument("--levels", type=int, default=3, help="with --vary: values per parameter, LO to HI")
    parser.add_argument("--json", action="store_true", help="with --repeat: print the table as a JSON list")
    parser.add_argument("--paper-effect", action="store_true",
                        help="with --simulate N --repeat K: draw the studies from paper 1's means and SDs instead")
    parser.add_argument("--course", action="store_true", help="print what the course asks of a participant and exit")


def run(args: argparse.Namespace) -> int:
    import json

    if args.course:
        from cobotsafety.trial.trial_scene import describe_course

        print(describe_course(args.scene))
        return 0
    if not args.simulate:
        return _serve(args)
    if args.simulate < 1:
        raise SystemExit("--simulate N needs N >= 1")
    if args.vary and not args.repeat:
        raise SystemExit("--vary needs --repeat K (the number of simulated studies per value)")
    if args.repeat:
        if args.repeat < 1:
            raise SystemExit("--repeat K needs K >= 1")
        if args.vary:
            from cobotsafety.trial.participant_parameters import parse_vary
            from cobotsafety.trial.sensitivity import sensitivity, table as sensitivity_table

            try:
                vary = [parse_vary(v) for v in args.vary]
            except ValueError as error:
                raise SystemExit(str(error)) from None
            if args.levels < 1:
                raise SystemExit("--levels needs at least 1")
            levels = sensitivity(args.simulate, args.repeat, vary, args.seed, args.levels, args.scene)
            print(json.dumps([level.as_json() for level in levels]) if args.json
                  else sensitivity_table(levels, args.simulate, args.repeat))
            return 0
        from cobotsafety.trial.power import paper_power, simulated_power, table

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


def _serve(args: argparse.Namespace) -> int:
    import time

    from cobotsafety.trial.trial_app import TrialServer

    participants = [p.strip() for p in args.participants.split(",") if p.strip()]
    robot = "planar" if args.scene == "planar" else args.robot
    device = None
    if args.device != "none":
        from cobotsafety.app.input_device import open_device

        try:
            device = open_device(args.device)
        except RuntimeError as error:
            raise SystemExit(f"cobotsafety trial: {error}") from None
    server = TrialServer(args.out, participants, args.seed, args.host, args.port, robot=robot,
                         answers=args.answers, device=device).start_server()
    print(f"cobotsafety trial: participant view {server.url}  operator view {server.operator_url}  "
          f"operator token: {server.token}", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        server.stop()
    return 0
