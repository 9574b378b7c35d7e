"""Second-level subcommands (``bench planar``, ``experiment multi-limitation``) by module name."""

from __future__ import annotations

import argparse
import importlib


def add_modules(parser: argparse.ArgumentParser, modules: dict[str, tuple[str, str]]) -> None:
    """Add one sub-parser per module that exists; each module has add_arguments and run."""
    sub = parser.add_subparsers(dest="target", metavar="NAME", required=True)
    for name, (module_name, help_text) in modules.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name == module_name:
                continue
            raise
        target_parser = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(target_parser)
        target_parser.set_defaults(_target_run=module.run)
