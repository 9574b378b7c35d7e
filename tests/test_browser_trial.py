"""The browser trial: the participant view never reveals the condition; the operator panel
appears only behind the token; a trial started by the operator shows the colour word."""

from __future__ import annotations

import re
import tempfile
import time

import pytest

from cobotsafety.ports import free_local_port
from cobotsafety.trial.server import TrialServer

pytestmark = pytest.mark.browser

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
        "--disable-sync", "--no-first-run"]
CONDITION_WORDS = re.compile(r"anticipative|sliding|stop\b|reactive|condition", re.IGNORECASE)


def test_participant_view_never_shows_the_condition(tmp_path):
    from playwright.sync_api import sync_playwright

    server = TrialServer(tmp_path, ["P01", "P02"], seed=3, port=free_local_port()).start_server()
    try:
        with sync_playwright() as playwright:
            context = playwright.chromium.launch_persistent_context(
                tempfile.mkdtemp(prefix="cobotsafety-chromium-"), executable_path=CHROMIUM, headless=True,
                args=ARGS, viewport={"width": 1200, "height": 800})
            context.set_default_timeout(90_000)
            participant = context.new_page()
            participant.goto(server.url)
            participant.get_by_text("Waiting for the operator").wait_for()
            assert not CONDITION_WORDS.search(participant.inner_text("body"))
            # The operator starts a divided-attention trial (whatever its condition).
            divided = next(t for t in server.plan if t.attention == "divided")
            server.start(divided)
            participant.get_by_text("Reach target 1").wait_for()
            participant.get_by_role("button", name="Red").wait_for()
            deadline = time.time() + 60
            while time.time() < deadline and not re.search(r"RED|GREEN|BLUE|YELLOW", participant.inner_text("body")):
                time.sleep(0.5)
            text = participant.inner_text("body")
            assert re.search(r"RED|GREEN|BLUE|YELLOW", text)  # the colour word is shown...
            assert not CONDITION_WORDS.search(text)  # ...the condition never is
            # The operator panel (which does name conditions) appears only after the token.
            operator = context.new_page()
            operator.goto(server.url)
            operator.get_by_text("Operator login").wait_for()
            token_box = operator.get_by_role("textbox").last
            token_box.fill("wrong")
            token_box.press("Enter")
            time.sleep(2)
            assert "Start next trial" not in operator.inner_text("body")
            token_box.fill(server.token)
            token_box.press("Enter")
            operator.get_by_text("Start next trial").wait_for()
            assert re.search(r"anticipative|stop", operator.inner_text("body"))
            time.sleep(1.0)
            assert not CONDITION_WORDS.search(participant.inner_text("body"))
            context.close()
    finally:
        server.stop()
