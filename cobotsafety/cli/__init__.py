"""The ``cobotsafety`` console command: one subcommand per module in this package.

Each subcommand module exposes ``add_arguments(parser)`` and ``run(args) -> int``, and imports
its heavy dependencies (pinocchio, viser) inside ``run`` so ``cobotsafety --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

#: subcommand -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("cobotsafety.cli.demo", "start the browser teleoperation demo (viser)"),
    "experiment": ("cobotsafety.cli.experiment", "run one of the papers' experiments headless"),
    "bench": ("cobotsafety.cli.bench", "measure the speed of a pipeline (median over many runs)"),
    "trial": ("cobotsafety.cli.trial", "run a user trial (operator and participant views)"),
    "analyze": ("cobotsafety.cli.analyze", "analyse a folder of trial logs into a report"),
    "campaign": ("cobotsafety.cli.campaign", "validate the controllers over many drawn people (resumable, parallel)"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cobotsafety",
        description="Anticipative sliding and human minimum distance for collaborative robots.",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="log at DEBUG level")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name == module_name:
                continue  # that subcommand is not built yet
            raise
        command_parser = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(command_parser)
        command_parser.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    return int(args._run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
