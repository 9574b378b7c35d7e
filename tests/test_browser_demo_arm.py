"""The 3D demo (panda, replayed co-worker) in headless Chromium, as a presenter sees it (issue 25):
a first Play that shows the arm giving way, one distance, a chart that neither invents nor
bridges nor clips, big gizmo arrows, and every binding limit drawn where it binds.

Software WebGL is slow: generous timeouts, few tests, each a browser session doing several checks.
"""

from __future__ import annotations

import colorsys
import re
import time

import numpy as np
import pytest
from browser_page import PANEL_X, camera_of, colour_mask, open_page, rgb, to_screen, wait_until

from cobotsafety.app import draw
from cobotsafety.app.demo_app import BUNDLED_RECORDINGS, DEFAULT_RECORDING, DemoApp, DemoConfig
from cobotsafety.ports import free_local_port

pytestmark = pytest.mark.browser

#: The gizmo's arrows (x, y, z) as software WebGL draws them (sRGB).
ARROW_RGB = {"x": (249, 45, 104), "y": (124, 220, 156), "z": (52, 140, 228)}

DISTANCE_CHART_JS = """() => {
  const entries = Object.values((window.__viserTestpoints || {}).uplots || {});
  const chart = entries.map((e) => e.chart).find(
      (c) => (c.root.querySelector('.u-title') || {}).textContent === 'Robot-human distance');
  if (!chart) return null;
  const status = document.querySelector('.cobotsafety-status');
  return {x: Array.from(chart.data[0]), y: Array.from(chart.data[1]).map((v) => Number.isFinite(v) ? v : null),
          yMax: chart.scales.y.max, yMin: chart.scales.y.min, status: status ? status.innerText : ''};
}"""

RED_IN_CHART_JS = """([x0, x1, margin]) => {
  const entries = Object.values(window.__viserTestpoints.uplots);
  const chart = entries.map((e) => e.chart).find(
      (c) => (c.root.querySelector('.u-title') || {}).textContent === 'Robot-human distance');
  const left = Math.round(chart.bbox.left), right = Math.round(chart.bbox.left + chart.bbox.width);
  const clip = (px) => Math.min(Math.max(px, left), right);
  const a = Math.ceil(clip(chart.valToPos(x0, 'x', true) + margin));
  const b = Math.floor(clip(chart.valToPos(x1, 'x', true) - margin));
  const top = Math.round(chart.bbox.top), height = Math.round(chart.bbox.height);
  if (b - a < 1) return {width: b - a, red: 0, xmin: chart.scales.x.min, xmax: chart.scales.x.max};
  const data = chart.ctx.getImageData(a, top, b - a, height).data;
  let red = 0;
  for (let i = 0; i < data.length; i += 4)
    if (data[i + 3] > 100 && Math.abs(data[i] - 214) + Math.abs(data[i + 1] - 39) + Math.abs(data[i + 2] - 40) < 90) red++;
  return {width: b - a, red: red};
}"""
#: The longest time nobody was on the distance chart and the red pixels drawn over it, read from
#: one snapshot of the chart (its data, its scale and its pixels in one evaluation: read apart,
#: a chart that moved on in between had scrolled the absence off its scale, width 0).
ABSENCE_IN_CHART_JS = """(margin) => {
  const entries = Object.values((window.__viserTestpoints || {}).uplots || {});
  const chart = entries.map((e) => e.chart).find(
      (c) => (c.root.querySelector('.u-title') || {}).textContent === 'Robot-human distance');
  if (!chart) return null;
  const x = chart.data[0], y = chart.data[1];
  let best = {seconds: 0, x0: null, x1: null}, last = null;
  for (let i = 0; i < x.length; i++) {
    if (!Number.isFinite(y[i])) continue;
    if (last !== null && i > last + 1 && x[i] - x[last] > best.seconds)
      best = {seconds: x[i] - x[last], x0: x[last], x1: x[i]};
    last = i;
  }
  if (best.x0 === null) return {seconds: 0, width: 0, red: 0};
  const left = Math.round(chart.bbox.left), right = Math.round(chart.bbox.left + chart.bbox.width);
  const clip = (px) => Math.min(Math.max(px, left), right);
  const a = Math.ceil(clip(chart.valToPos(best.x0, 'x', true) + margin));
  const b = Math.floor(clip(chart.valToPos(best.x1, 'x', true) - margin));
  const top = Math.round(chart.bbox.top), height = Math.round(chart.bbox.height);
  if (b - a < 1) return {seconds: best.seconds, width: b - a, red: 0, x0: best.x0, x1: best.x1,
                         xmin: chart.scales.x.min, xmax: chart.scales.x.max};
  const data = chart.ctx.getImageData(a, top, b - a, height).data;
  let red = 0;
  for (let i = 0; i < data.length; i += 4)
    if (data[i + 3] > 100 && Math.abs(data[i] - 214) + Math.abs(data[i + 1] - 39) + Math.abs(data[i + 2] - 40) < 90) red++;
  return {seconds: best.seconds, width: b - a, red: red, x0: best.x0, x1: best.x1};
}"""


@pytest.fixture(scope="module")
def app():
    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port())).start()
    yield demo
    demo.stop()


def chart(page) -> dict:
    for _ in range(50):
        data = page.evaluate(DISTANCE_CHART_JS)
        if data is not None:
            return data
        time.sleep(0.2)
    raise AssertionError("no distance chart in the page")


def test_first_play_shows_the_method_working_with_one_distance_and_an_honest_chart(browser, app):
    """Items 1, 3, 8: the default recording is paper 2's experiment 1 (the stress case is named
    as such); before anyone appears the chart is empty; played, the status says in words that
    the arm gives way or moves out of the person's way; the status and the chart show the same number; the person leaves and
    returns: the chart leaves that time empty (not bridged), and its range holds every value."""
    page = open_page(browser, app)
    page.get_by_text("or press Play under Replay").wait_for()
    assert [v for v in chart(page)["y"] if v is not None] == []  # no point before anyone appears
    page.get_by_text("Replay", exact=True).click()
    labels = dict(BUNDLED_RECORDINGS)
    dropdown = page.get_by_role("combobox", name="Recording")
    assert dropdown.input_value() == labels[DEFAULT_RECORDING] and "paper 2, experiment" in dropdown.input_value()
    dropdown.click()
    page.get_by_role("option", name=labels["reach-over"]).wait_for()
    assert "stress case" in labels["reach-over"]
    page.keyboard.press("Escape")

    page.get_by_role("button", name="Play").click()
    wait_until(lambda: app.replay.replay is not None and app.replay.playing, what="Play")
    app.replay.seek(3.5)  # the co-worker walks in and reaches for the pick pose from about 4 s
    page.get_by_text(re.compile(r"Giving way: the person's|Moving out of the person's way")).wait_for()
    pairs = []
    for _ in range(5):  # the status and the chart's newest row: one report, one update
        data = chart(page)
        shown = re.search(r"Person: (\d+) mm", data["status"])
        newest = [None if v is None else round(v) for v in reversed(data["y"])][:2]
        pairs.append((int(shown.group(1)) if shown else None, newest, data["status"].splitlines()[2]))
        time.sleep(0.7)
    # the panel applies the chart's data a moment after the text of the same update (uPlot's
    # data is set after React's commit): the status is the chart's newest row or, caught in
    # between, the one before it; never another reading (the 260 vs 106 mm)
    assert all(shown in newest for shown, newest, _ in pairs), pairs
    assert sum(shown == newest[0] for shown, newest, _ in pairs) >= 3, pairs
    app.replay.playing = False  # held still with the co-worker at the table: drawn, then hidden
    app.replay.seek(6.0)
    time.sleep(2.0)
    with_human = rgb(page)
    app.human.visible = False
    time.sleep(2.0)
    without_human = rgb(page)
    app.human.visible = True
    changed = int((np.abs(with_human - without_human).sum(axis=2) > 60)[:, :PANEL_X].sum())
    assert changed > 3000, f"hiding the person changed only {changed} pixels: they were not drawn"
    app.replay.playing = True

    app.replay.speed = 2.0  # on to the return at 17 s: leaves (out of the scanner's clip by ~10 s)

    gap = {}

    def returned() -> bool:  # left (a short dropout of the legs is not leaving) and came back,
        # the absence on the chart's scale: measured in the snapshot that found it (read again
        # after it, a chart still taking queued updates under load had scrolled it off, width 0)
        gap.update(page.evaluate(ABSENCE_IN_CHART_JS, 6) or {"seconds": 0, "width": 0})  # 6 px: the dots' radius
        return gap["seconds"] > 2.5 and gap["width"] > 10

    wait_until(returned, timeout_s=120, what="the co-worker to leave and come back on the chart")
    app.replay.playing = False
    assert gap["red"] == 0, gap  # nothing drawn while nobody was there
    data = chart(page)
    present = page.evaluate(RED_IN_CHART_JS, [data["x"][0], data["x"][-1], 0])
    assert present["red"] > 50, present  # the dots where someone was are drawn
    values = [v for v in data["y"] if v is not None]
    assert data["yMin"] <= min(values) and data["yMax"] >= max(values), (data["yMin"], data["yMax"], max(values))
    # the co-worker first seen about a metre away, inside the range (how far exactly depends on
    # where the arm is when they come back and on which frame is drawn first: 899 mm in one CI
    # run, above 900 mm in the earlier ones)
    assert max(values) > 800.0
    page.close()


def test_the_arm_draws_its_handles_and_every_binding_limit(browser, app):
    """Items 5, 6, 11: the gizmo's three arrows are long on screen (none a stub); a joint at its
    limit, the table and the reach sphere light up where they are; zones are violet."""
    app.replay.playing = False
    app.replay.seek(0.0)  # nobody in view
    app.loop.reset()
    page = open_page(browser, app, settle_s=3.0)
    camera = camera_of(app)
    page.mouse.move(5, 5)
    image = rgb(page)
    u, v = to_screen(camera, page, app.loop.snapshot().p_base_ee_m)[0]
    ys, xs = np.mgrid[0:image.shape[0], 0:image.shape[1]]
    near = np.hypot(xs - u, ys - v) < 220
    for axis, colour in ARROW_RGB.items():
        mask = colour_mask(image, colour, 45) & near
        assert mask.sum() > 150, f"the {axis} arrow is not drawn"
        reach = np.hypot(xs[mask] - u, ys[mask] - v).max()
        assert reach > 75, f"the {axis} arrow reaches {reach:.0f} px"

    box = next(zone for zone in app.scene.zones() if zone.name == "box zone")
    (bu, bv), = to_screen(camera, page, np.array([box.center])).astype(int)
    r, g, b = image[bv - 3:bv + 4, bu - 3:bu + 4].reshape(-1, 3).mean(axis=0) / 255.0
    hue = colorsys.rgb_to_hsv(r, g, b)[0] * 360.0
    assert 220.0 < hue < 300.0, f"the box zone is drawn at hue {hue:.0f}: not violet"  # no amber, green or red

    state = app.scene.robot.state

    def magenta_near(p_world, radius_px: float) -> int:
        (pu, pv), = to_screen(camera, page, np.atleast_2d(p_world))
        image = rgb(page)
        lit = colour_mask(image, draw.HIGHLIGHT, 90)
        lit[:, PANEL_X:] = False
        return int((lit & (np.hypot(xs - pu, ys - pv) < radius_px)).sum())

    def drive(target, binding: str) -> None:
        app.loop.reset()
        app.loop.set_gizmo_target(np.array(target, dtype=float))
        wait_until(lambda: app.loop.snapshot().report is not None and binding in app.loop.snapshot().report.binding,
                   what=binding)

    # folded in towards the base and down at the table: the joint holds the hand short of it
    # (a reachable target would be reached, the limit then no longer in play)
    drive((0.1, 0.0, 0.0), "panda_joint4 lower")
    joint = state.model.getJointId("panda_joint4")
    wait_until(lambda: magenta_near(state.data.oMi[joint].translation, 110) > 60, what="the arc at joint 4")
    drive((0.5, 0.0, -0.3), "table (panda_joint7)")
    wait_until(lambda: magenta_near((0.1, 0.0, 0.0), 400) > 3000, what="the table lit")
    drive((1.5, 0.0, 0.4), "reach extended")
    wait_until(lambda: magenta_near((0.0, 0.0, 0.3), 600) > 300, what="the reach sphere")
    app.loop.release_gizmo()
    app.loop.reset()
    wait_until(lambda: magenta_near((0.0, 0.0, 0.3), 2000) < 30, what="the highlights to go")
    page.close()


SUCCESS_WATCH = """() => {
    window.__uploadedSuccessfully = 0;
    new MutationObserver(() => {
        if (document.body.textContent.includes("File uploaded successfully")) window.__uploadedSuccessfully += 1;
    }).observe(document.body, {subtree: true, childList: true, characterData: true});
}"""


def test_a_refused_upload_keeps_the_replay_and_never_says_uploaded(browser, app):
    """Issues 22 S3 and 25 item 2: a refused upload says why in one sentence naming the file once,
    never shows viser's "File uploaded successfully.", leaves no temporary path on the page, and
    the previous replay stays; a good file still gets viser's notice (the watch can see it)."""
    from cobotsafety.human.recording import bundled_recording

    app.ensure_replay()
    before = app.replay.name
    page = open_page(browser, app)
    page.evaluate(SUCCESS_WATCH)
    page.get_by_text("Replay", exact=True).click()
    page.locator("input[type=file]").set_input_files(
        files=[{"name": "broken.jsonl.gz", "mimeType": "application/gzip", "buffer": b"this is not a recording"}])
    page.get_by_text("Recording refused").wait_for()
    time.sleep(3.0)  # viser's notice would have shown by now
    assert page.evaluate("window.__uploadedSuccessfully") == 0
    body = page.inner_text("body")
    sentence = page.get_by_text("broken.jsonl.gz is not a readable recording (").first.inner_text()
    assert sentence.count("broken.jsonl.gz") == 1
    assert "cobotsafety-upload" not in body and "/tmp" not in body
    assert app.replay.name == before
    page.locator("input[type=file]").set_input_files(
        files=[{"name": "take.jsonl.gz", "mimeType": "application/gzip", "buffer": bundled_recording().read_bytes()}])
    wait_until(lambda: page.evaluate("window.__uploadedSuccessfully") > 0, what="viser's notice for a good file")
    wait_until(lambda: app.replay.name == "take.jsonl.gz", what="the uploaded recording")
    app.panel.recording.value = before  # as the other tests expect
    wait_until(lambda: app.replay.name == before, what="the bundled recording again")
    page.close()
