"""``cobotsafety analyze DIR [--out DIR]``: the trial report (Markdown + PNGs)."""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("directory", type=Path, help="folder holding trials.jsonl and the trajectories")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR", help="report folder (default DIR/report)")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.trial.analysis import analyze

    print(analyze(args.directory, args.out))
    return 0
