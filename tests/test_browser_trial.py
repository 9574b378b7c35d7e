"""The browser trial: the participant view never reveals the condition and shows no operator box;
the operator view (its own URL) unlocks only with the token, says when a token is wrong, shows
the participant's scene (drawn, not a blank canvas) with the trial's progress and, for answers
said aloud, the word with Right / Wrong / Missed keys; its plan follows Start, Abort and Repeat;
the colour word appears only once the trial has started."""

from __future__ import annotations

import re
import time

import numpy as np
import pytest
from browser_page import launch

from cobotsafety.ports import free_local_port
from cobotsafety.trial.trial_app import TrialServer

pytestmark = pytest.mark.browser

CONDITION_WORDS = re.compile(r"anticipative|sliding|stop\b|reactive|condition", re.IGNORECASE)
WORD = re.compile(r"RED|GREEN|BLUE|YELLOW")


def wait_text(page, pattern: re.Pattern, timeout_s: float = 60.0) -> str:
    deadline = time.time() + timeout_s
    while True:
        text = page.inner_text("body")
        if pattern.search(text):
            return text
        assert time.time() < deadline, f"{pattern.pattern!r} never appeared in: {text[:400]}"
        time.sleep(0.5)


def test_participant_and_operator_views(tmp_path):
    from playwright.sync_api import sync_playwright

    server = TrialServer(tmp_path, ["P01", "P02"], seed=3, port=free_local_port()).start_server()
    try:
        with sync_playwright() as playwright:
            context = launch(playwright)
            context.set_default_timeout(90_000)
            participant = context.new_page()
            participant.goto(server.url)
            participant.get_by_text("Waiting for the operator").wait_for()
            body = participant.inner_text("body")
            assert not CONDITION_WORDS.search(body)
            assert "Operator" not in body and participant.get_by_role("textbox").count() == 0

            # The operator view: a wrong token is refused and cleared, the right one unlocks.
            operator = context.new_page()
            operator.goto(server.operator_url)
            operator.get_by_text("Operator login").wait_for()
            token_box = operator.get_by_role("textbox").last
            wrong = "0" * len(server.token) if server.token != "0" * len(server.token) else "1" * len(server.token)
            token_box.fill(wrong)
            operator.get_by_text("Wrong token").wait_for()
            assert "Start next trial" not in operator.inner_text("body")
            assert token_box.input_value() == ""
            time.sleep(1.1)  # the connection's backoff after a wrong token (1 s)
            operator.get_by_role("textbox").last.fill(server.token)
            operator.get_by_text("Start next trial").wait_for()
            assert server.token not in operator.inner_text("body")  # the token left the page
            time.sleep(3.0)
            shot = operator.screenshot(path=str(tmp_path / "operator.png"))
            assert shot
            from PIL import Image

            with Image.open(tmp_path / "operator.png") as image:  # the scene is drawn left of the panel
                canvas = np.asarray(image.convert("L"))[100:700, 150:850]
            assert np.mean(canvas < 200) > 0.01, "the operator's canvas is blank"

            # Start a divided-attention trial from the panel (skip the full-attention ones first).
            divided = next(t for t in server.plan if t.attention == "divided")
            server.start(divided)
            participant.get_by_text(f"Trial {divided.order} of 4.").wait_for()
            assert participant.get_by_role("button", name="Red").count() == 0  # answers are said aloud
            time.sleep(3.0)  # no motion yet: the trial, and its colour task, has not started
            assert not WORD.search(participant.inner_text("body"))
            x, y = server.course.targets_m[0]
            server.loop.set_gizmo_target(np.array([x, y, 0.0]))  # the participant starts moving
            text = wait_text(participant, WORD)
            assert f"Trial {divided.order} of 4." in text  # the trial number stays
            assert not CONDITION_WORDS.search(text)
            word = WORD.search(text).group(0)
            operator_text = wait_text(operator, re.compile(word))
            assert "target 1 of 6" in operator_text or "target 2 of 6" in operator_text  # progress
            operator.get_by_role("button", name="Right").click()  # the participant said the ink aloud
            deadline = time.time() + 30
            while time.time() < deadline and not any(s.judged_by == "operator" for s in server.current[1].colour.stimuli):
                time.sleep(0.2)
            assert any(s.judged_by == "operator" and s.answer == s.ink for s in server.current[1].colour.stimuli)
            server.loop.release_gizmo()

            wait_text(operator, re.compile(r"Running: P0\d"))
            assert re.search(r"anticipative|stop", operator.inner_text("body"))
            operator.get_by_role("button", name="Abort trial").click()
            wait_text(operator, re.compile(r"Aborted: P0\d"))
            participant.get_by_text("Trial stopped").wait_for()
            operator.get_by_role("button", name="Repeat last trial").click()
            participant.get_by_text(f"Trial {divided.order} of 4.").wait_for()
            wait_text(operator, re.compile(r"Running: P0\d"))
            assert server.current is not None and server.current[0] == divided
            assert not CONDITION_WORDS.search(participant.inner_text("body"))
            context.close()
    finally:
        server.stop()
