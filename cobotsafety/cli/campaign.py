"""``cobotsafety campaign``: a validation campaign over many drawn people (``cobotsafety.tools.campaign``).

    cobotsafety campaign --robot iiwa [--robot panda] --controller all --people 1000 [--seed 0]
        [--workers 2] [--ray ADDRESS|local] [--plant rate-limited|ideal] [--ssm off|scaling|stop] --out DIR
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", action="append", required=True, help="robot name (repeat for several)")
    parser.add_argument("--controller", default="all",
                        help="anticipative, reactive (paper 2's field), stop, or all (default; the same people)")
    parser.add_argument("--people", type=int, required=True, help="people drawn per robot")
    parser.add_argument("--seed", type=int, default=0, help="campaign seed (default 0)")
    parser.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1),
                        help="local worker processes, or Ray CPUs with --ray local (default 2)")
    parser.add_argument("--ray", default=None, metavar="ADDRESS",
                        help="run on a Ray cluster at ADDRESS ('local': start a local instance); needs the 'ray' extra")
    parser.add_argument("--no-escape-check", action="store_true", help="skip the offline escape search of breaches")
    from cobotsafety.tools.campaign.person_run import DEFAULT_PLANT, PLANTS

    parser.add_argument("--plant", default=DEFAULT_PLANT, choices=PLANTS,
                        help="how the arm follows the commands: through the robot's rate limiter, closed loop "
                             "(rate-limited, default: libfranka's rule with the robot's limits), or exactly (ideal)")
    from cobotsafety.experiments.approach_step import SSM_MODES

    parser.add_argument("--ssm", default="off", choices=SSM_MODES,
                        help="ISO/TS 15066 speed and separation monitoring on every controller: off (default), "
                             "scaling (the approach to a person at most the standard's speed for the separation) or "
                             "stop (the protective stop below the protective separation distance)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="results, report.md and report.json")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.arm.robots import robot_spec
    from cobotsafety.tools.campaign.runner import CONTROLLERS, run_campaign

    for robot in args.robot:
        robot_spec(robot)
    controllers = CONTROLLERS if args.controller == "all" else (args.controller,)
    if any(c not in CONTROLLERS for c in controllers):
        raise SystemExit(f"--controller must be one of {CONTROLLERS} or all, got {args.controller!r}")
    if args.people < 1 or args.workers < 1:
        raise SystemExit("--people and --workers must be at least 1")
    if args.ray:
        try:
            import ray  # noqa: F401
        except ImportError:
            raise SystemExit("--ray needs Ray: pip install 'cobotsafety[ray]'") from None
    out = run_campaign(args.out, tuple(args.robot), controllers, args.people, args.seed, args.workers, args.ray,
                       escape_check=not args.no_escape_check, plant=args.plant, ssm=args.ssm)
    print(json.dumps(out["timing"]))
    print(f"report: {args.out / 'report.md'}, {args.out / 'report.json'}")
    return 0
