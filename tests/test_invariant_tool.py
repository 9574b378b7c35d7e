"""``python -m cobotsafety.tools.invariant``: a run per seed, deterministic, and the summary over
seeds counts the runs that met each failure."""

from __future__ import annotations

import json

import pytest

from cobotsafety.tools import invariant


def test_one_line_per_seed_then_a_summary_that_counts_the_runs(capsys):
    assert invariant.main(["--robot", "panda", "--steps", "30", "--seed", "3", "--seeds", "2"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line.get("seed") for line in lines[:2]] == [3, 4]
    assert lines[0] == invariant.run_invariant("panda", 30, 3)  # deterministic per seed
    summary = lines[2]
    assert (summary["robot"], summary["seeds"], summary["steps"]) == ("panda", 2, 30)
    made = [dict(lines[0], safety_over_smoothness_steps=5), dict(lines[1], safety_over_smoothness_steps=0)]
    counted = invariant.seed_summary(made)
    assert (counted["runs_with_safety_over_smoothness_steps"], counted["safety_over_smoothness_steps"]) == (1, 5)
    assert counted["runs_with_joint_crossings"] == sum(run["joint_crossings"] > 0 for run in made)


@pytest.mark.parametrize("bad, words", [(["--seeds", "0"], "--seeds must be >= 1"), (["--seed", "-1"], "--seed >= 0")])
def test_a_bad_seed_count_or_seed_is_refused_in_one_line(capsys, bad, words):
    with pytest.raises(SystemExit) as stop:
        invariant.main(["--robot", "panda", *bad])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err
