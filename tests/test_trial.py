"""User trials: plan, colour task, durable logs (killed mid-session), analysis, simulation."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections import Counter

import numpy as np
import pytest

from cobotsafety.ports import free_local_port
from cobotsafety.trial.analysis import analyze
from cobotsafety.trial.colour_task import ColourTask
from cobotsafety.trial.log_store import LogStore, load
from cobotsafety.trial.plan import session_plan
from cobotsafety.trial.simulate import run_simulated_sessions


def test_orders_are_counterbalanced_and_reproducible_from_the_seed():
    ids = [f"P{i}" for i in range(10)]
    plan = session_plan(ids, seed=4)
    first = {p: next(t.condition for t in plan if t.participant == p and t.order == 1) for p in ids}
    assert Counter(first.values()) == {"anticipative": 5, "stop": 5}
    for p in ids:  # every participant does every condition in both attention modes
        assert sorted((t.attention, t.condition) for t in plan if t.participant == p) == [
            ("divided", "anticipative"), ("divided", "stop"), ("full", "anticipative"), ("full", "stop")]
    attention_first = {p: next(t.attention for t in plan if t.participant == p and t.order == 1) for p in ids}
    assert Counter(attention_first.values()) == {"full": 5, "divided": 5}  # attention order counterbalanced too
    crossed = Counter((first[p], attention_first[p]) for p in ids)
    assert max(crossed.values()) - min(crossed.values()) <= 1 and len(crossed) == 4
    assert session_plan(ids, seed=4) == plan
    assert any(session_plan(ids, seed=s) != plan for s in range(5, 10))
    three = session_plan([f"P{i}" for i in range(12)], ("anticipative", "stop", "reactive"), seed=1)
    orders = Counter(tuple(t.condition for t in three if t.participant == p and t.attention == "full") for p in {t.participant for t in three})
    assert len(orders) == 6 and set(orders.values()) == {2}
    with pytest.raises(ValueError, match="unique"):
        session_plan(["P1", "P1"])


def test_colour_words_always_conflict_and_are_scored_like_the_paper():
    task = ColourTask(seed=1)
    for k in range(6):
        s = task.tick(2.0 * k)
        assert s is not None and s.word != s.ink
        assert task.tick(2.0 * k + 1.0) is None
        if k % 3 == 0:
            task.answer(2.0 * k + 0.7, s.ink)  # right
        elif k % 3 == 1:
            task.answer(2.0 * k + 0.9, next(c for c in ("red", "green", "blue", "yellow") if c != s.ink))  # wrong
    # 2 right, 2 wrong (-1 each), 2 missed (-2 each)
    assert task.score() == -6
    np.testing.assert_allclose(task.response_times_s(), [0.7, 0.9, 0.7, 0.9])


def test_a_session_killed_mid_way_loses_nothing_already_finished(tmp_path):
    out = tmp_path / "logs"
    proc = subprocess.Popen([sys.executable, "-m", "cobotsafety", "trial", "--simulate", "6", "--out", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    log = out / "trials.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and (not log.exists() or log.read_text().count("\n") < 3):
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    loaded = load(out)
    assert 3 <= len(loaded.records) < 24
    assert loaded.problems == []  # every finished trial is whole, with its trajectory
    for record in loaded.records:
        assert np.load(out / record["trajectory"]).shape[1] == 4
    run_simulated_sessions(out, 6)  # resume
    resumed = load(out)
    assert len(resumed.records) == 24 and resumed.problems == []


def write_paper_like_logs(directory, seed=0, participants=10, learning=0.0):
    """Completion times drawn from the paper's own means and SDs, n = 10 per condition; error
    scores from Poisson(4.7) and Poisson(0.9) wrong answers in divided attention. Orders are
    counterbalanced (conditions and attention modes); ``learning`` makes each participant's second
    trial of a mode that much faster."""
    rng = np.random.default_rng(seed)
    store = LogStore(directory)
    stats = {("full", "stop"): (40.0, 6.3), ("full", "anticipative"): (31.9, 3.8),
             ("divided", "stop"): (63.4, 9.3), ("divided", "anticipative"): (43.2, 3.93)}
    for i in range(participants):
        first = ("anticipative", "stop") if i % 2 == 0 else ("stop", "anticipative")
        for (attention, condition), (mean, sd) in stats.items():
            second = first.index(condition) == 1
            full_first = (i // 2) % 2 == 0  # attention order counterbalanced in pairs, as the plan does
            order = (0 if (attention == "full") == full_first else 2) + 1 + second
            time_s = float(rng.normal(mean, sd)) * (1.0 - learning * second)
            wrong = int(rng.poisson(4.7 if condition == "stop" else 0.9)) if attention == "divided" else 0
            errors = [{"kind": "wrong", "t_s": 1.0 + 2.0 * k, "points": -1} for k in range(wrong)]
            store.append({"participant": f"P{i:02d}", "condition": condition, "attention": attention, "order": order,
                          "seed": seed, "completion_time_s": time_s, "error_score": -wrong,
                          "errors": errors, "response_times_s": []}, np.zeros((2, 4)))


def analyze_json(directory, capsys):
    from cobotsafety.cli import main

    assert main(["analyze", str(directory), "--json"]) == 0
    return {(r["comparison"], r["test"]): r for r in json.loads(capsys.readouterr().out)}


KEYS = {"comparison", "test", "n", "sliding_mean", "stop_mean", "p", "effect_size", "ci95"}
NEW_KEYS = {"statistic", "p_method", "tail", "p_holm"}
TESTS = ("mann-whitney one-tailed", "wilcoxon signed-rank one-tailed")


def test_analysis_on_the_papers_numbers(tmp_path, capsys):
    write_paper_like_logs(tmp_path)
    results = analyze_json(tmp_path, capsys)
    assert all(KEYS | NEW_KEYS <= set(r) for r in results.values())
    assert all(r["p_method"] in ("exact", "asymptotic") for r in results.values() if r["p"] is not None)
    assert all(r["tail"] in ("less", "greater", "two-sided") for r in results.values())
    interaction = [r for r in results.values() if r["comparison"].startswith("attention interaction")]
    assert len(interaction) == 3 and all(r["tail"] == "less" for r in interaction)  # 2 rank tests + the mixed model
    for r in results.values():
        if r["role"] in ("primary", "secondary") and r["p"] is not None:
            assert r["p_holm"] >= r["p"]
        else:
            assert r["p_holm"] is None
    order = [r for r in results.values() if r["comparison"].startswith("order check")]
    assert len(order) == 2 and all(r["sliding_mean"] is None and r["n_sliding_first"] == 5 for r in order)
    for attention in ("full", "divided"):
        for test in TESTS:  # sliding faster, with both tests, in the paper's direction
            r = results[f"{attention} attention: completion time [s]", test]
            assert r["n"] == 10 and r["p"] < 0.05 and r["sliding_mean"] < r["stop_mean"]
            assert r["effect_size"] > 0.5 and r["ci95"][1] < 0  # sliding - stop < 0
            assert r["ci95"][0] <= r["sliding_mean"] - r["stop_mean"] <= r["ci95"][1]
    for test in TESTS:
        r = results["divided attention: error score [points]", test]
        assert r["p"] < 0.05 and r["sliding_mean"] > r["stop_mean"]
    report = (tmp_path / "report" / "report.md").read_text()
    assert "| divided - full completion time [s] (paper 1's IV.B comparison) | wilcoxon signed-rank one-tailed | 10 |" \
        in report
    assert "No `plan.json`" in report  # these logs were written without one: the report says so
    from PIL import Image

    for name in ("times_full", "times_divided", "error_scores", "interaction"):
        assert (tmp_path / "report" / f"{name}.png").stat().st_size > 10_000
        assert (tmp_path / "report" / f"{name}.pdf").read_bytes()[:4] == b"%PDF"
        assert "<svg" in (tmp_path / "report" / f"{name}.svg").read_text()
        with Image.open(tmp_path / "report" / f"{name}.png") as image:
            assert image.info["dpi"][0] == pytest.approx(300, abs=1)


def test_effect_sizes_match_a_count_over_all_pairs():
    """Rank-biserial correlations against their definitions, counted pair by pair."""
    from cobotsafety.trial.statistics import mann_whitney, signed_rank

    rng = np.random.default_rng(3)
    sliding, stop = rng.normal(30, 5, 9), rng.normal(36, 6, 9)
    wins = sum(np.sign(b - a) for a in sliding for b in stop)  # stop slower = favours sliding
    assert mann_whitney("t", sliding, stop, with_ci=False).effect_size == pytest.approx(wins / 81)
    d = stop - sliding
    ranks = {i: 1 + sum(abs(d[j]) < abs(d[i]) for j in range(9)) for i in range(9)}
    expected = (sum(ranks[i] for i in range(9) if d[i] > 0) - sum(ranks[i] for i in range(9) if d[i] < 0)) / 45
    assert signed_rank("t", sliding, stop, with_ci=False).effect_size == pytest.approx(expected)


def test_the_order_check_finds_a_learning_effect(tmp_path, capsys):
    write_paper_like_logs(tmp_path, seed=1, learning=0.35)
    strong = analyze_json(tmp_path, capsys)
    key = next(k for k in strong if k[0].startswith("order check, full"))
    assert strong[key]["p"] < 0.05
    write_paper_like_logs(tmp_path / "none", seed=1, learning=0.0)
    assert analyze_json(tmp_path / "none", capsys)[key]["p"] > strong[key]["p"]


def test_too_few_data_are_reported_with_the_reason(tmp_path, capsys):
    write_paper_like_logs(tmp_path, participants=1)
    results = analyze_json(tmp_path, capsys)
    r = results["full attention: completion time [s]", "mann-whitney one-tailed"]
    assert r["p"] is None and r["n"] == 1
    report = (tmp_path / "report" / "report.md").read_text()
    assert "too few data: 1 sliding and 1 stop values (2 per group needed)" in report
    assert "too few data: 1 participant(s) with both conditions (2 needed)" in report


def test_power_of_the_papers_effect_with_both_tests():
    from cobotsafety.trial.power import power

    def study(k):
        import tempfile

        with tempfile.TemporaryDirectory() as d:
            write_paper_like_logs(d, seed=100 + k)
            return load(d).records

    rows = {(r.comparison, r.test): r for r in power(study(k) for k in range(20))}
    for attention in ("full", "divided"):
        for test in TESTS:
            assert rows[f"{attention} attention: completion time [s]", test].power >= 0.9


def test_paper_effect_power_grows_with_participants_and_the_signed_rank_needs_five():
    from cobotsafety.trial.power import paper_power

    def by_key(n):
        return {(r.comparison, r.test): r.power for r in paper_power(n, 30, seed=5)}

    four, ten = by_key(4), by_key(10)
    key = ("divided attention: completion time [s]", "wilcoxon signed-rank one-tailed")
    assert four[key] == 0.0  # 4 pairs: the smallest one-tailed p is 1/16
    assert ten[key] >= 0.95
    assert all(ten[k] >= four[k] for k in ten if not k[0].startswith("order"))


def test_bad_logs_are_reported_with_file_and_line_and_the_rest_is_analysed(tmp_path):
    write_paper_like_logs(tmp_path)
    log = tmp_path / "trials.jsonl"
    lines = log.read_text().splitlines()
    lines.insert(5, "{not json")
    lines.append(lines[0])  # duplicate trial
    log.write_text("\n".join(lines) + "\n")
    first = json.loads(lines[1])
    (tmp_path / first["trajectory"]).unlink()
    loaded = load(tmp_path)
    assert len(loaded.records) == 40
    text = "\n".join(loaded.problems)
    assert f"{log}:6: corrupt line" in text
    assert f"{log}:{len(lines)}: duplicate trial" in text
    assert f"{log}:2: trajectory file" in text
    report = analyze(tmp_path)
    assert "corrupt line" in report and "| full attention: completion time [s] | mann-whitney" in report


def test_simulated_sessions_end_to_end(tmp_path):
    written = run_simulated_sessions(tmp_path, participants=3, seed=2)
    assert len(written) == 12
    assert all(r["completion_time_s"] is not None and r["completion_time_s"] > 0 for r in written)
    divided = [r for r in written if r["attention"] == "divided"]
    assert all(r["response_times_s"] for r in divided)
    assert all(not r["response_times_s"] for r in written if r["attention"] == "full")
    scored = [r for r in written if r["attention"] == "divided"]
    assert all(s["shown_s"] >= 0 for r in scored for s in r["stimuli"])
    report = analyze(tmp_path)
    assert "| full attention: completion time [s]" in report


@pytest.mark.parametrize("robot", ["planar", "panda"])
def test_trial_server_runs_a_trial_on_the_planar_and_the_3d_arm(tmp_path, robot):
    """Without a browser: the operator starts a trial, the gizmo drives the robot to the first
    target, and the trial's progress follows."""
    from cobotsafety.trial.trial_app import TrialServer

    server = TrialServer(tmp_path, ["P01"], seed=0, port=free_local_port(), robot=robot)
    try:
        trial = server.start_next()
        assert trial is not None and server.current is not None
        x, y = server.course.targets_m[0]
        z = server.course.height_m or 0.0
        for _ in range(3000):
            server.loop.set_gizmo_target(np.array([x, y, z]))
            server.loop.step_once()
            if server.current is None or server.current[1].next_target >= 1:
                break
        run = server.current[1] if server.current else None
        assert run is not None and run.started_s is not None and run.next_target >= 1
        server.render_once()
        assert "target 2" in server.progress.content
    finally:
        server.server.stop()
