"""``cobotsafety trial``: user trials. Headless sessions with simulated participants for now.

The browser trial (participant and operator views) is not built yet: see issue 7.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--simulate", type=int, required=True, metavar="N",
                        help="run complete sessions with N simulated participants (headless)")
    parser.add_argument("--out", type=Path, default=Path("out/trials"), metavar="DIR", help="log folder (resumed if it exists)")
    parser.add_argument("--seed", type=int, default=0, help="plan and participant seed (recorded in the log)")
    parser.add_argument("--scene", choices=["planar", "arm"], default="planar")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.trial.simulate import run_simulated_sessions

    written = run_simulated_sessions(args.out, args.simulate, args.seed, args.scene)
    print(f"{len(written)} trials written to {args.out / 'trials.jsonl'}")
    return 0
