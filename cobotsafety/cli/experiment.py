"""``cobotsafety experiment NAME``: the papers' experiments, headless."""

from __future__ import annotations

import argparse

from cobotsafety.cli._dispatch import add_modules

EXPERIMENTS: dict[str, tuple[str, str]] = {
    "multi-limitation": ("cobotsafety.experiments.multi_limitation", "paper 1, experiment 3 (Fig. 9)"),
    "human-approach": ("cobotsafety.experiments.human_approach",
                       "paper 2, experiments 1 and 2 and the reach-over stress case (Figs. 11, 12, 14)"),
    "limits": ("cobotsafety.experiments.limit_runs",
               "the commanded motion against the robot's velocity, acceleration and jerk limits"),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_modules(parser, EXPERIMENTS)


def run(args: argparse.Namespace) -> int:
    return int(args._target_run(args) or 0)
