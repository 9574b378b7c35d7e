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

The browser trial listens on port 8090 (participant) and 8091 (operator) by default, beside
the demo's 8080. Pseudonyms are letters, digits, ``_`` and ``-``; nonsense (a negative count, a
port out of range, an option that does not apply) is refused before anything starts.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cobotsafety.cli.arguments import non_negative_int, port, pseudonyms

DEFAULT_PORT = 8090


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--simulate", type=non_negative_int, default=0, metavar="N",
                        help="run complete sessions with N simulated participants (headless)")
    parser.add_argument("--participants", type=pseudonyms, default="P01,P02,P03,P04",
                        help="pseudonyms, comma-separated: letters, digits, '_' and '-' (default P01,P02,P03,P04)")
    parser.add_argument("--host", default="127.0.0.1",
                        help="interface both views bind (default 127.0.0.1, this machine only; 0.0.0.0 listens on "
                             "every interface: anyone who reaches it can drive the participant view)")
    parser.add_argument("--port", type=port, default=DEFAULT_PORT,
                        help=f"participant view's port, 1-65534; the operator view is on the next one "
                             f"(default {DEFAULT_PORT} and {DEFAULT_PORT + 1})")
    parser.add_argument("--out", type=Path, default=Path("out/trials"), metavar="DIR", help="log folder (resumed if it exists)")
    parser.add_argument("--seed", type=int, default=0, help="plan and participant seed (recorded in the log)")
    parser.add_argument("--scene", choices=["planar", "arm"], default="planar")
    parser.add_argument("--robot", default="panda", help="3D arm for --scene arm (browser trial)")
    parser.add_argument("--device", choices=["none", "joystick", "spacemouse"], default="none",
                        help="browser trial: also drive with a joystick/gamepad or a 3D mouse read on the server")
    parser.add_argument("--answers", choices=["aloud", "buttons"], default="aloud",
                        help="browser trial: colour words answered aloud and logged by the operator (paper 1), "
                             "or with on-screen buttons")
    parser.add_argument("--repeat", type=non_negative_int, default=0, metavar="K",
                        help="with --simulate N: K simulated studies, print how often each comparison is significant")
    parser.add_argument("--vary", action="append", default=[], metavar="NAME=LO:HI",
                        help="with --simulate N --repeat K: sensitivity of the study to one participant parameter "
                             "(repeatable; see cobotsafety.trial.participant_parameters)")
    parser.add_argument("--levels", type=non_negative_int, default=3, help="with --vary: values per parameter, LO to HI")
    parser.add_argument("--json", action="store_true", help="with --repeat: print the table as a JSON list")
    parser.add_argument("--paper-effect", action="store_true",
                        help="with --simulate N --repeat K: draw the studies from paper 1's means and SDs instead")
    parser.add_argument("--course", action="store_true", help="print what the course asks of a participant and exit")


def refusal(args: argparse.Namespace) -> str:
    """Why this combination of options makes no sense ("" when it does)."""
    if args.port > 65534:
        return f"--port {args.port} leaves no port for the operator view (use 1-65534)"
    if args.repeat and not args.simulate:
        return "--repeat K needs --simulate N (N simulated participants per study)"
    if (args.json or args.paper_effect) and not args.repeat:
        return "--json and --paper-effect go with --simulate N --repeat K"
    if args.vary and not args.repeat:
        return "--vary needs --repeat K (the number of simulated studies per value)"
    if args.vary and args.levels < 1:
        return "--levels needs at least 1"
    return ""


def run(args: argparse.Namespace) -> int:
    import json

    from cobotsafety.errors import CobotSafetyError

    problem = refusal(args)
    if problem:
        raise CobotSafetyError(problem)
    if args.course:
        from cobotsafety.trial.trial_scene import describe_course

        print(describe_course(args.scene))
        return 0
    if not args.simulate:
        return _serve(args)
    if args.repeat:
        if args.vary:
            from cobotsafety.trial.participant_parameters import parse_vary
            from cobotsafety.trial.sensitivity import sensitivity, table as sensitivity_table

            try:
                vary = [parse_vary(v) for v in args.vary]
            except ValueError as error:
                raise CobotSafetyError(str(error)) from None
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

    from cobotsafety.app.access import is_loopback, reachable_host
    from cobotsafety.errors import CobotSafetyError
    from cobotsafety.trial.trial_app import TrialServer

    robot = "planar" if args.scene == "planar" else args.robot
    device = None
    if args.device != "none":
        from cobotsafety.app.input_device import open_device

        try:
            device = open_device(args.device)
        except RuntimeError as error:
            raise CobotSafetyError(str(error)) from None
    server = TrialServer(args.out, args.participants, args.seed, args.host, args.port, robot=robot,
                         answers=args.answers, device=device).start_server()
    host = reachable_host(args.host)
    if not is_loopback(args.host):
        print(f"cobotsafety trial: warning: listening on {args.host}, beyond this machine: anyone who can reach "
              f"port {server.server.get_port()} can drive the participant view", flush=True)
    print(f"cobotsafety trial: participant view http://{host}:{server.server.get_port()}  "
          f"operator view http://{host}:{server.operator_server.get_port()}  "
          f"operator token: {server.token}", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return 0
