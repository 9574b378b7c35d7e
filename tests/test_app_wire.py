"""What the demo sends a client, decoded at the client end by ``WireProbe`` (no browser).

Frames are rendered by hand (``render_once``), so counts do not depend on the machine's speed:
after the initial scene, a frame sends poses, visibility and colours, never a mesh, and the
human's capsules are updated in every frame that moves them.
"""

import time

import numpy as np
import pytest

from cobotsafety.app.demo_app import DemoApp, DemoConfig
from cobotsafety.app.wire_probe import WireProbe, decode_frame
from cobotsafety.ports import free_local_port

FRAMES = 45
CREATING = ("MeshMessage", "BoxMessage", "IcosphereMessage", "BatchedMeshesMessage", "LineSegmentsMessage",
            "LabelMessage", "GlbMessage")


def render_frames(app, frames: int, wall_dt_s: float = 1 / 30, steps_per_frame: int = 3) -> None:
    for _ in range(frames):
        for _ in range(steps_per_frame):
            app.loop.step_once()
        app.render_once(wall_dt_s)


def settle(probe: WireProbe, quiet_s: float = 1.0, timeout_s: float = 30.0) -> None:
    """Wait until the probe has received everything queued so far (no new bytes for ``quiet_s``)."""
    deadline = time.monotonic() + timeout_s
    last = -1
    while time.monotonic() < deadline:
        count = probe.counts()["bytes"]
        if count == last:
            return
        last = count
        time.sleep(quiet_s)


@pytest.fixture(scope="module")
def panda():
    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port()))  # threads not started
    demo.ensure_replay()
    probe = WireProbe(demo.url).start()
    yield demo, probe
    probe.stop()
    demo.server.stop()


def test_decode_frame_reads_viser_wire_format():
    import msgspec.msgpack
    import zstandard

    inner = msgspec.msgpack.encode({"messages": [{"type": "SetPositionMessage", "name": "/a"}],
                                    "timestampSec": 0.0, "binaryBufferLengths": []})
    compressed = zstandard.ZstdCompressor().compress(inner)
    frame = len(inner).to_bytes(8, "little") + len(compressed).to_bytes(8, "little") + compressed
    assert decode_frame(frame) == ["SetPositionMessage"]


def test_a_playing_replay_moves_the_human_without_sending_meshes(panda):
    app, probe = panda
    app.replay.playing = True
    app.replay.seek(4.5)  # exp1: the co-worker walks in and reaches from about 4 s
    render_frames(app, 3)
    settle(probe)
    probe.reset()
    present = 0
    for _ in range(FRAMES):
        render_frames(app, 1)
        present += app.human.shown_capsules > 0
        time.sleep(1 / 30)  # at the render rate: viser coalesces updates of a node not yet sent
    settle(probe)
    counts = probe.counts()
    assert present == FRAMES, "the default recording has the person in view from 4.5 s for 1.5 s"
    created = {kind: n for kind, n in counts["types"].items() if kind in CREATING}
    assert created == {}, f"scene nodes re-made during playback: {created}"
    # the batched human bodies were moved in (almost) every frame: positions change as the person walks
    moves = counts["names"].get(("SceneNodeUpdateMessage", "/human/bodies"), 0)
    assert moves >= FRAMES, (moves, counts["names"])
    assert app.human.bodies.visible and app.human.ends.visible


def test_an_idle_arm_sends_only_the_status_and_plots(panda):
    app, probe = panda
    app.replay.playing = False
    app.replay.seek(0.0)  # the demo's start: the person is not yet in reach
    render_frames(app, 1)  # the robot learns that the person is gone before it is reset (else it yields)
    app.loop.reset()
    render_frames(app, 10)
    settle(probe)
    probe.reset()
    render_frames(app, FRAMES)
    settle(probe)
    counts = probe.counts()
    scene = {key: n for key, n in counts["names"].items() if not key[0].startswith("Gui")}
    # A paused human and an arm holding still (or creeping less than the redraw tolerance in its
    # null space) leave the scene untouched.
    assert sum(n for (kind, _), n in scene.items() if kind in CREATING) == 0
    assert sum(scene.values()) <= 2 * FRAMES, sorted(scene.items(), key=lambda kv: -kv[1])[:5]


def test_planar_scene_hides_the_human_layer():
    demo = DemoApp(DemoConfig(port=free_local_port()))
    try:
        demo.ensure_replay()
        demo.replay.playing = True
        demo.replay.seek(5.0)
        render_frames(demo, 6)
        assert demo.human.shown_capsules == 0
        assert not demo.human.bodies.visible and not demo.human.segment.visible
        assert demo.last_min_distance_m is None
        assert "Person" not in demo.panel.status.content
        assert not demo.plots.distance.visible and not demo.panel.replay_folder.visible
        demo.switch_scene("panda")
        assert demo.panel.replay_folder.visible
        render_frames(demo, 3)
        assert demo.human.bodies.visible and demo.human.shown_capsules > 0
        np.testing.assert_array_less(0.0, demo.human.bodies.batched_scales[: demo.human.shown_capsules])
    finally:
        demo.server.stop()
