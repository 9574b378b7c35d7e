"""The ``cobotsafety`` command refuses nonsense in one line (issue 22, items 3-5, 9 and a
newcomer's path): exit 2, one line on stderr, a traceback only with ``--verbose``."""

from __future__ import annotations

import argparse
import gzip
import importlib
import json
from pathlib import Path

import numpy as np
import pytest

from cobotsafety.cli import main

COMMAND_MODULES = ("cobotsafety.cli.demo", "cobotsafety.cli.trial", "cobotsafety.cli.analyze")
TARGET_MODULES = ("cobotsafety.bench.planar_bench", "cobotsafety.bench.arm_bench", "cobotsafety.bench.distance_bench",
                  "cobotsafety.bench.sensors_bench", "cobotsafety.bench.app_bench",
                  "cobotsafety.experiments.multi_limitation", "cobotsafety.experiments.human_approach")


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_refused_in_one_line(code: int, err: str) -> str:
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err and lines[0].startswith("cobotsafety"), err
    return lines[0]


@pytest.fixture
def nothing_runs(monkeypatch):
    """Every command and bench/experiment replaced by a recorder: parsing alone is tested."""
    ran: list[argparse.Namespace] = []

    def record(args):
        ran.append(args)
        return {} if hasattr(args, "_target_run") else 0

    for name in COMMAND_MODULES + TARGET_MODULES:
        monkeypatch.setattr(importlib.import_module(name), "run", record)
    return ran


@pytest.mark.parametrize("argv", [
    ("demo", "--port", "-5"), ("demo", "--port", "99999"), ("demo", "--port", "80.5"), ("trial", "--port", "0"),
    ("demo", "--rate", "0"), ("demo", "--rate", "-1"), ("demo", "--rate", "1e9"), ("demo", "--rate", "nan"),
    ("demo", "--rate", "inf"), ("demo", "--scene", "cube"),
    ("trial", "--participants", "P1,P1"), ("trial", "--participants", ""), ("trial", "--participants", "a/b"),
    ("trial", "--participants", "../x"), ("trial", "--participants", "P 1"), ("trial", "--simulate", "-1"),
    ("trial", "--repeat", "-2"),
    ("bench", "planar", "--runs", "-5"), ("bench", "planar", "--runs", "0"), ("bench", "planar", "--invariant", "-3"),
    ("bench", "arm", "--runs", "many"), ("bench", "app", "--clients", "1,-8"), ("bench", "app", "--seconds", "0"),
    ("bench", "app", "--rate", "5"), ("bench", "app", "--chromium", "/no/such/chromium"),
    ("experiment", "human-approach", "--dt", "inf"),
    ("experiment", "human-approach", "--dt", "0"), ("nonsense",), (), ("bench",), ("demo", "--no-such-option"),
])
def test_nonsense_is_refused_while_parsing_in_one_line(capsys, nothing_runs, argv):
    code, _, err = run_cli(capsys, *argv)
    line = assert_refused_in_one_line(code, err)
    assert "--help" in line
    assert nothing_runs == []


def test_values_in_range_reach_the_command(capsys, nothing_runs):
    assert main(["demo", "--port", "8081", "--rate", "500"]) == 0
    assert main(["trial", "--participants", "P01, P-2,p_3"]) == 0
    assert main(["bench", "planar", "--runs", "1", "--invariant", "0"]) == 0
    demo, trial, bench = nothing_runs
    assert (demo.port, demo.rate) == (8081, 500.0)
    assert trial.participants == ["P01", "P-2", "p_3"] and trial.port == 8090
    assert (bench.runs, bench.invariant) == (1, 0)


def test_version_and_the_help_of_the_trials_host_and_port(capsys):
    from cobotsafety import __version__

    code, out, _ = run_cli(capsys, "--version")
    assert code == 0 and out.strip() == f"cobotsafety {__version__}"
    pyproject = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    assert f'version = "{__version__}"' in pyproject
    code, out, _ = run_cli(capsys, "trial", "--help")
    help_text = " ".join(out.split())
    assert code == 0 and "--host HOST interface both views bind" in help_text and "8090 and 8091" in help_text
    code, out, _ = run_cli(capsys, "demo", "--help")
    assert code == 0 and "(default 8080)" in " ".join(out.split())


# ---- the package's own errors, one line -------------------------------------------------------
def bad_recordings(folder: Path) -> list[Path]:
    """Fourteen kinds of file a --replay must refuse."""
    files = {
        "missing.jsonl.gz": None,
        "empty.jsonl.gz": b"",
        "plain.jsonl.gz": b'{"format": "cobotsafety-recording"}\n',
        "garbage.jsonl.gz": bytes(range(256)) * 4,
        "truncated.jsonl.gz": gzip.compress(b'{"format": "cobotsafety-recording", "version": 1}\n' * 50)[:40],
        "not-json.jsonl.gz": gzip.compress(b"hello\n"),
        "array.jsonl.gz": gzip.compress(b"[1, 2, 3]\n"),
        "wrong-format.jsonl.gz": gzip.compress(b'{"format": "something-else"}\n'),
        "binary-utf8.jsonl.gz": gzip.compress(b"\xe7\xff\xfe\n"),
        "garbage.bag": b"#ROSBAG V2.0\n" + bytes(100),
        "empty.bag": b"",
        "text.txt": b"just some text\n",
        "nul.mcap": b"\x00" * 64,
    }
    paths = []
    for name, content in files.items():
        path = folder / name
        if content is not None:
            path.write_bytes(content)
        paths.append(path)
    not_a_bag = folder / "folder.db3"
    not_a_bag.mkdir()
    return paths + [not_a_bag]


def test_fourteen_bad_replays_are_one_line_each(capsys, tmp_path):
    paths = bad_recordings(tmp_path)
    assert len(paths) == 14
    for path in paths:
        code, _, err = run_cli(capsys, "demo", "--replay", str(path))
        line = assert_refused_in_one_line(code, err)
        assert path.name in line, line


def test_an_unknown_robot_is_one_line_and_verbose_adds_the_traceback(capsys):
    code, _, err = run_cli(capsys, "demo", "--robot", "r2d2")
    assert "unknown robot 'r2d2'; known robots: planar, panda" in assert_refused_in_one_line(code, err)
    code, _, err = run_cli(capsys, "demo", "--robot", "r2d2", "--verbose")
    assert code == 2 and "Traceback" in err and err.strip().splitlines()[-1].startswith("cobotsafety demo: unknown")


def test_analyze_refuses_a_missing_folder_without_creating_it(capsys, tmp_path):
    missing = tmp_path / "nonexistent"
    code, _, err = run_cli(capsys, "analyze", str(missing))
    assert "no such folder" in assert_refused_in_one_line(code, err)
    assert not missing.exists()
    code, _, err = run_cli(capsys, "analyze", str(tmp_path))
    assert "holds no trials.jsonl" in assert_refused_in_one_line(code, err)
    assert list(tmp_path.iterdir()) == []


def test_options_that_do_not_apply_and_unwritable_folders_are_refused(capsys, tmp_path):
    code, _, err = run_cli(capsys, "trial", "--repeat", "3")
    assert "--repeat K needs --simulate N" in assert_refused_in_one_line(code, err)
    code, _, err = run_cli(capsys, "trial", "--json")
    assert_refused_in_one_line(code, err)
    code, _, err = run_cli(capsys, "trial", "--port", "65535")
    assert "operator" in assert_refused_in_one_line(code, err)
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    code, _, err = run_cli(capsys, "trial", "--simulate", "1", "--out", str(blocker / "trials"))
    assert str(blocker) in assert_refused_in_one_line(code, err)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("command", ["demo", "trial"])
@pytest.mark.parametrize("host", ["999.1.1.1", "192.0.2.1", "no-such-host.invalid"])
def test_a_host_that_cannot_be_bound_is_refused_instead_of_hanging(capsys, tmp_path, command, host):
    extra = ["--out", str(tmp_path / "out")] if command == "trial" else []
    code, _, err = run_cli(capsys, command, "--host", host, *extra)
    assert f"cannot listen on host {host!r}" in assert_refused_in_one_line(code, err)
    assert not (tmp_path / "out").exists()


def test_bench_prints_machine_once(capsys):
    from cobotsafety.cli import bench

    for result in ({"name": "x", "median_us": 1.0, "machine": "the bench's own"}, {"name": "x", "median_us": 1.0}):
        bench.run(argparse.Namespace(_target_run=lambda _args, r=result: r, json=False))
        out = capsys.readouterr().out
        assert sum(line.startswith("machine:") for line in out.splitlines()) == 1


def test_the_demo_and_the_trial_do_not_share_a_port():
    from cobotsafety.cli import demo, trial

    assert {demo.DEFAULT_PORT, trial.DEFAULT_PORT, trial.DEFAULT_PORT + 1} == {8080, 8090, 8091}


def test_a_dead_control_thread_stops_the_demo_with_an_error(capsys, monkeypatch):
    from cobotsafety.app.control_loop import ControlLoop
    from cobotsafety.ports import free_local_port

    monkeypatch.setattr(ControlLoop, "_run", lambda self: None)  # the thread ends at once
    code, out, err = run_cli(capsys, "demo", "--port", str(free_local_port()))
    line = assert_refused_in_one_line(code, err)
    assert "the control loop stopped" in line
    assert "token" not in out  # nothing after the early URL: no start lines for a dead demo


# ---- the trial log ----------------------------------------------------------------------------
def test_the_log_reports_binary_lines_non_records_and_a_truncated_trajectory(tmp_path):
    from cobotsafety.trial.log_store import LogStore, load

    store = LogStore(tmp_path)
    record = {"participant": "P01", "condition": "stop", "attention": "full", "order": 1, "seed": 0,
              "completion_time_s": 3.0, "errors": [], "response_times_s": []}
    store.append(record, np.zeros((50, 4)))
    store.append({**record, "condition": "anticipative"}, np.zeros((50, 4)))
    truncated = tmp_path / "traj_P01_full_anticipative.npy"
    truncated.write_bytes(truncated.read_bytes()[:-64])
    with open(store.path, "ab") as log:
        log.write(b"\xe7\xff binary\n5\n" + json.dumps({**record, "attention": "divided",
                                                          "trajectory": "../../etc/passwd"}).encode() + b"\n")
    loaded = load(tmp_path)
    text = "\n".join(loaded.problems)
    assert f"{store.path}:2: trajectory file traj_P01_full_anticipative.npy is unreadable, truncated?" in text
    assert f"{store.path}:3: not UTF-8 text" in text
    assert f"{store.path}:4: not a trial record" in text
    assert f"{store.path}:5: trajectory file ../../etc/passwd is not a file name in the log's folder" in text
    assert len(loaded.records) == 3  # lines 1, 2 and 5: kept, their problems said
    assert load(tmp_path, read_trajectories=False).problems == [p for p in loaded.problems if "unreadable" not in p]


# ---- pseudonyms ---------------------------------------------------------------------------------
@pytest.mark.parametrize("names", [["P1", "P1"], [], ["a/b"], [".."], ["P01", ""], ["x" * 33], ["-P"], ["P\x00"]])
def test_bad_pseudonyms_are_refused_before_a_trial_server_starts(tmp_path, names):
    from cobotsafety.errors import PseudonymError
    from cobotsafety.trial.trial_app import TrialServer

    with pytest.raises(PseudonymError):
        TrialServer(tmp_path / "out", names, port=1)  # port 1 would fail: nothing may start
    assert not (tmp_path / "out").exists()


def test_a_trial_that_cannot_be_written_is_kept_shown_and_retried(tmp_path, monkeypatch):
    from cobotsafety.ports import free_local_port
    from cobotsafety.trial import trial_app
    from cobotsafety.trial.session import TrialRun

    server = trial_app.TrialServer(tmp_path, ["P01"], port=free_local_port())
    try:
        trial = server.plan[0]
        run = TrialRun(server.course, False, 0)
        server._finished.append((trial, run, None))
        real_append = server.store.append

        def full_disk(record, trajectory):
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(server.store, "append", full_disk)
        server.render_once()
        assert "NOT LOGGED" in server._plan_text() and "No space left on device" in server._plan_text()
        assert server.store.done() == set()
        monkeypatch.setattr(server.store, "append", real_append)
        server.render_once()  # within the retry interval: not yet
        assert server.store.done() == set()
        monkeypatch.setattr(trial_app, "RETRY_WRITE_S", 0.0)
        server._retry_write_s = 0.0
        server.render_once()
        assert (trial.participant, trial.attention, trial.condition) in server.store.done()
        assert "Finished" in server.status
    finally:
        server.stop()
