"""The ``cobotsafety`` console command: one subcommand per module in this package.

Each subcommand module exposes ``add_arguments(parser)`` and ``run(args) -> int``, and imports
its heavy dependencies (pinocchio, viser) inside ``run`` so ``cobotsafety --help`` stays fast.

Bad input never ends in a traceback: arguments are checked while parsing
(``cobotsafety.cli.arguments``), and the package's own errors (``CobotSafetyError``) and the
operating system's (``OSError``: a folder that cannot be written, a port in use) are printed
as one line, ``cobotsafety COMMAND: message``, with exit status 2. ``--verbose`` adds the
traceback.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
import traceback

from cobotsafety.cli.arguments import CommandParser, one_line

#: subcommand -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("cobotsafety.cli.demo", "start the browser teleoperation demo (viser)"),
    "experiment": ("cobotsafety.cli.experiment", "run one of the papers' experiments headless"),
    "bench": ("cobotsafety.cli.bench", "measure the speed of a pipeline (median over many runs)"),
    "trial": ("cobotsafety.cli.trial", "run a user trial (operator and participant views)"),
    "analyze": ("cobotsafety.cli.analyze", "analyse a folder of trial logs into a report"),
    "campaign": ("cobotsafety.cli.campaign", "validate the controllers over many drawn people (resumable, parallel)"),
}
#: Exit status of a refused command (bad argument, bad file, package error).
EXIT_REFUSED = 2


def build_parser() -> argparse.ArgumentParser:
    from cobotsafety import __version__  # noqa: PLC0415

    parser = CommandParser(
        prog="cobotsafety",
        description="Anticipative sliding and human minimum distance for collaborative robots.",
    )
    parser.add_argument("--version", action="version", version=f"cobotsafety {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log at DEBUG level; tracebacks on errors")
    # Also accepted after the command (``cobotsafety demo --verbose``), without overriding it.
    verbose = argparse.ArgumentParser(add_help=False)
    verbose.add_argument("-v", "--verbose", action="store_true", default=argparse.SUPPRESS,
                         help="log at DEBUG level; tracebacks on errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module_name, help_text) in COMMANDS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name == module_name:
                continue  # that subcommand is not built yet
            raise
        command_parser = sub.add_parser(name, help=help_text, description=help_text, parents=[verbose])
        module.add_arguments(command_parser)
        command_parser.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command in ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    0: done; 2: refused, with one line on stderr saying why (a traceback too with
    ``--verbose``); 130: interrupted.
    """
    from cobotsafety.errors import CobotSafetyError  # noqa: PLC0415

    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as done:  # --help, --version (0) or a refused argument (2, one line printed)
        return done.code if isinstance(done.code, int) else EXIT_REFUSED
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO,
        format="%(levelname)s %(name)s: %(message)s",
        stream=sys.stderr,
    )
    try:
        return int(args._run(args) or 0)
    except KeyboardInterrupt:
        return 130
    except (CobotSafetyError, OSError) as error:
        if args.verbose:
            traceback.print_exc()
        print(f"cobotsafety {args.command}: {one_line(error) or type(error).__name__}", file=sys.stderr)
        return EXIT_REFUSED


if __name__ == "__main__":
    sys.exit(main())
