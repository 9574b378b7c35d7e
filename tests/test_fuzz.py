"""A property-based fuzz of the command line and the public API (issue 22, item 10).

Random argument strings, non-finite and huge numbers, odd shapes: the CLI ends with exit 0 or
2 and one line, never a traceback; whatever the parser lets through is within range; the API
returns finite values of the documented shape or raises a ``ValueError``/``CobotSafetyError``,
never NaN. Examples are few (and seeded, as every property test: ``conftest.py``) so the
file runs in seconds.
"""

from __future__ import annotations

import argparse
import gzip
import importlib
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cobotsafety.cli import main
from cobotsafety.cli.arguments import MAX_RATE_HZ, MIN_RATE_HZ
from cobotsafety.errors import CobotSafetyError
from cobotsafety.trial.pseudonyms import PSEUDONYM

FUZZ = settings(max_examples=60, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
COMMANDS = (["demo"], ["trial"], ["analyze"], ["bench", "planar"], ["bench", "arm"], ["bench", "app"],
            ["bench", "distance"], ["bench", "sensors"], ["experiment", "multi-limitation"],
            ["experiment", "human-approach"], ["bench"], ["experiment"], ["nonsense"], [])
OPTIONS = ("--port", "--rate", "--host", "--scene", "--robot", "--replay", "--participants", "--simulate", "--repeat",
           "--out", "--seed", "--runs", "--invariant", "--seconds", "--drags", "--clients", "--dt", "--json",
           "--verbose", "-v", "--version", "--controller", "--scenario", "--sweep", "--capsules", "--ssm",
           "--paper-effect", "--skip-startup", "--chromium", "--help")
NUMBERS = st.one_of(st.integers(-10**6, 10**6), st.integers(), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([0, -1, 65535, 65536, 1e9, 1e308, -0.0, 0.5]))
WORDS = st.one_of(NUMBERS.map(str), st.text(max_size=12), st.sampled_from(
    ["", "nan", "inf", "-inf", "1e999", "0x10", "P01,P01", "P01,../x", "a/b", "planar", "panda", "r2d2", ",", "  "]))


def within_range(args: argparse.Namespace) -> None:
    """What a parsed command may hold: every number finite and within its option's range."""
    for name, value in vars(args).items():
        if isinstance(value, float):
            assert math.isfinite(value), (name, value)
    if hasattr(args, "port"):
        assert 1 <= args.port <= 65535
    if getattr(args, "command", None) == "demo":
        assert MIN_RATE_HZ <= args.rate <= MAX_RATE_HZ
    if getattr(args, "target", None) == "app":
        assert MIN_RATE_HZ <= args.rate <= MAX_RATE_HZ and args.seconds > 0 and args.drags >= 1
        assert args.clients and all(c >= 1 for c in args.clients)
    for name in ("runs", "drags"):
        if hasattr(args, name):
            assert getattr(args, name) >= 1, name
    for name in ("simulate", "repeat", "invariant"):
        if hasattr(args, name):
            assert getattr(args, name) >= 0, name
    if hasattr(args, "dt"):
        assert 0.0 < args.dt <= 0.05
    if hasattr(args, "participants"):
        assert args.participants and len(set(args.participants)) == len(args.participants)
        assert all(PSEUDONYM.fullmatch(p) for p in args.participants)


@pytest.fixture
def checked_commands(monkeypatch):
    """Every command's ``run`` replaced by the range check (nothing starts, nothing is written)."""
    ran = []

    def check(args):
        within_range(args)
        ran.append(args)
        return {} if hasattr(args, "_target_run") else 0

    modules = ["cobotsafety.cli.demo", "cobotsafety.cli.trial", "cobotsafety.cli.analyze",
               "cobotsafety.bench.planar_bench", "cobotsafety.bench.arm_bench", "cobotsafety.bench.app_bench",
               "cobotsafety.bench.distance_bench", "cobotsafety.bench.sensors_bench",
               "cobotsafety.experiments.multi_limitation", "cobotsafety.experiments.human_approach"]
    for name in modules:
        monkeypatch.setattr(importlib.import_module(name), "run", check)
    return ran


def exits_cleanly(capsys, argv: list[str]) -> int:
    code = main(argv)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    assert code in (0, 2), (argv, code, captured.err)
    if code == 2:
        assert len(captured.err.strip().splitlines()) == 1, (argv, captured.err)
    return code


@FUZZ
@given(command=st.sampled_from(COMMANDS),
       rest=st.lists(st.one_of(st.sampled_from(OPTIONS), WORDS), max_size=6))
def test_random_command_lines_end_in_exit_0_or_2_with_one_line(capsys, checked_commands, command, rest):
    exits_cleanly(capsys, [*command, *rest])


@FUZZ
@given(option=st.sampled_from(["--port", "--rate", "--participants"]), value=WORDS,
       command=st.sampled_from([["demo"], ["trial"]]))
def test_every_value_of_an_option_is_parsed_within_range_or_refused(capsys, checked_commands, option, value, command):
    if option == "--rate" and command == ["trial"] or option == "--participants" and command == ["demo"]:
        return
    exits_cleanly(capsys, [*command, option, value])


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(content=st.one_of(st.binary(max_size=300), st.binary(max_size=300).map(gzip.compress),
                         st.text(max_size=200).map(lambda t: gzip.compress(t.encode()))),
       suffix=st.sampled_from([".jsonl.gz", ".bag", ".db3", ".mcap", ".txt", ""]))
def test_random_replay_files_are_refused_in_one_line(capsys, tmp_path_factory, monkeypatch, content, suffix):
    """The real ``demo --replay`` path up to the loader: every random file is refused in one line."""
    from cobotsafety.app import demo_app

    def accepted(self, robot_name):
        raise AssertionError("a random file was accepted as a recording")

    monkeypatch.setattr(demo_app.DemoApp, "_build", accepted)  # nothing may start a server
    path = tmp_path_factory.mktemp("replay") / f"random{suffix}"
    path.write_bytes(content)
    assert exits_cleanly(capsys, ["demo", "--replay", str(path)]) == 2


@settings(max_examples=15, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(lines=st.lists(st.one_of(st.binary(max_size=60), st.text(max_size=60).map(str.encode),
                                st.sampled_from([b'{"participant": "P01"}', b"5", b"[]", b"null",
                                                 b'{"participant": 1, "attention": [], "condition": {}, "order": 1,'
                                                 b' "seed": 0, "completion_time_s": 1, "errors": [],'
                                                 b' "response_times_s": [], "trajectory": 5}'])), max_size=6))
def test_random_trial_logs_are_analysed_or_refused_in_one_line(capsys, tmp_path_factory, lines):
    folder = tmp_path_factory.mktemp("log")
    (folder / "trials.jsonl").write_bytes(b"\n".join(line.replace(b"\n", b" ") for line in lines) + b"\n")
    exits_cleanly(capsys, ["analyze", str(folder), "--json"])


# ---- the public API ---------------------------------------------------------------------------
VALUES = st.one_of(st.floats(-10.0, 10.0), st.floats(allow_nan=True, allow_infinity=True),
                   st.sampled_from([np.nan, np.inf, -np.inf, 1e300, -1e300, 1e-300, 0.0]))


def arrays(shape):
    return st.lists(VALUES, min_size=int(np.prod(shape)), max_size=int(np.prod(shape))).map(
        lambda values: np.array(values, dtype=float).reshape(shape))


@FUZZ
@given(data=st.data(), dim=st.integers(1, 5), rows=st.integers(0, 6))
def test_slide_returns_a_finite_velocity_or_refuses(data, dim, rows):
    import cobotsafety

    v = data.draw(arrays((dim,)))
    normals = data.draw(arrays((rows, dim)))
    bounds = data.draw(st.one_of(st.none(), arrays((rows,))))
    try:
        result = cobotsafety.slide(v, normals, bounds)
    except (CobotSafetyError, ValueError):
        return
    assert result.shape == (dim,) and np.all(np.isfinite(result)), (v, normals, bounds, result)


@FUZZ
@given(data=st.data(), batch=st.sampled_from([(), (1,), (4,), (2, 3), (5, 1), (0,)]))
def test_capsule_distance_is_finite_or_refuses(data, batch):
    import cobotsafety

    points = [data.draw(arrays((*batch, 3))) for _ in range(4)]
    radii = [data.draw(arrays(batch)) for _ in range(2)]
    try:
        distance, a, b = cobotsafety.capsule_distance(points[0], points[1], radii[0], points[2], points[3], radii[1])
    except ValueError:
        return
    assert distance.shape == batch and a.shape == b.shape == (*batch, 3)
    assert np.all(np.isfinite(distance)) and np.all(np.isfinite(a)) and np.all(np.isfinite(b))


@FUZZ
@given(data=st.data(), beams=st.integers(0, 400), method=st.sampled_from(["learned", "paper"]))
def test_laser_scans_and_leg_detection_are_finite_or_refused(data, beams, method):
    import cobotsafety

    ranges = data.draw(st.one_of(arrays((beams,)), st.lists(st.floats(0.0, 8.0), min_size=beams,
                                                             max_size=beams).map(np.array)))
    angle_min, increment = data.draw(VALUES), data.draw(st.one_of(st.just(2 * np.pi / max(beams, 1)), VALUES))
    range_min, range_max = data.draw(st.one_of(st.just(0.05), VALUES)), data.draw(st.one_of(st.just(8.0), VALUES))
    try:
        scan = cobotsafety.LaserScan(angle_min, increment, range_min, range_max, ranges)
    except (ValueError, CobotSafetyError):
        return
    max_range_m = data.draw(st.one_of(st.just(1.4), st.floats(0.1, 10.0), VALUES))
    try:
        legs = cobotsafety.detect_legs(scan, max_range_m=max_range_m, method=method)
    except (ValueError, CobotSafetyError):
        return
    assert legs.ndim == 2 and legs.shape[1] == 2 and np.all(np.isfinite(legs))
