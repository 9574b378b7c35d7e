"""``cobotsafety analyze DIR [--out DIR] [--json]``: the trial report (Markdown + figures).

``--json`` prints a JSON list, one object per comparison and test:
``{"comparison", "test", "n", "sliding_mean", "stop_mean", "p", "effect_size", "ci95",
"statistic", "p_method", "tail", "p_holm", "role"}``: ``statistic`` is U (Mann-Whitney, of the
sliding sample), W (signed-rank, scipy's) or z (mixed model); ``p_method`` ``"exact"`` or
``"asymptotic"``; ``tail`` ``"less"``, ``"greater"`` or ``"two-sided"`` in the direction
sliding - stop; ``p_holm`` the Holm-adjusted p within the primary or secondary family (null
elsewhere); ``role`` primary, secondary, supporting or check. The attention interaction on log
time is the objects whose ``comparison`` starts with ``"attention interaction"``. Order-check
objects carry ``n_sliding_first``, ``n_stop_first``, ``sliding_first_mean``,
``stop_first_mean`` (the mean advantages their p is about), ``power`` and ``verdict``
(``sliding_mean``/``stop_mean`` null). ``p`` is null when the data are too few for the test
(the Markdown report says why).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("directory", type=Path, help="folder holding trials.jsonl and the trajectories")
    parser.add_argument("--out", type=Path, default=None, metavar="DIR", help="report folder (default DIR/report)")
    parser.add_argument("--json", action="store_true", help="print the comparisons as a JSON list")


def run(args: argparse.Namespace) -> int:
    from cobotsafety.errors import RecordingError
    from cobotsafety.trial.analysis import write_report
    from cobotsafety.trial.log_store import LOG_NAME

    if not args.directory.is_dir():  # refused before anything is written
        raise RecordingError(f"{args.directory}: no such folder of trial logs")
    if not (args.directory / LOG_NAME).is_file():
        raise RecordingError(f"{args.directory}: holds no {LOG_NAME}, nothing to analyse")

    text, results = write_report(args.directory, args.out)
    if args.json:
        print(json.dumps([r.as_json() for r in results]))
    else:
        print(text)
    return 0
