"""The demo server without a browser: scenes, highlight, gizmo return, replay refusal, URDF joints."""

import numpy as np
import pytest

from cobotsafety.app import draw
from cobotsafety.app.scene_arm import urdf_joint_values
from cobotsafety.app.demo_app import DemoApp, DemoConfig
from cobotsafety.errors import RecordingError, UnknownRobotError
from cobotsafety.ports import free_local_port


@pytest.fixture(scope="module")
def app():
    demo = DemoApp(DemoConfig(port=free_local_port()))  # threads not started: steps are driven by hand
    yield demo
    demo.server.stop()


def test_binds_localhost_by_default(app):
    assert app.server.get_host() == "127.0.0.1"
    assert app.url.startswith("http://127.0.0.1:")


def test_sliding_limitation_is_highlighted_and_gizmo_returns(app):
    app.loop.reset()
    app.loop.set_gizmo_target(np.array([0.3, 0.03, 0.0]))  # towards the base: joint 2's circle B
    for _ in range(400):
        app.loop.step_once()
    report = app.loop.snapshot().report
    assert report.binding == ("B joint 2 upper",)
    app.render_once()
    normal, bright = app.scene.view._limit_nodes["B joint 2 upper"]
    assert bright.visible and not normal.visible  # highlight = a visibility toggle: reaches open tabs
    assert tuple(bright.colors.reshape(-1, 3)[0]) == draw.HIGHLIGHT
    other_end, other_end_bright = app.scene.view._limit_nodes["B joint 2 lower"]  # only the end that binds
    assert other_end.visible and not other_end_bright.visible
    other, other_bright = app.scene.view._limit_nodes["E extended reach"]
    assert other.visible and not other_bright.visible
    assert app.scene.view.active_limitations() == ("B joint 2 upper",)
    app.loop.release_gizmo()
    for _ in range(300):
        app.loop.step_once()
    app.render_once()
    np.testing.assert_allclose(app.gizmo.position, app.loop.snapshot().p_base_ee_m, atol=1e-5)
    assert app.scene.view.active_limitations() == ()


def test_a_released_arm_resting_on_e_is_not_highlighted(app):
    """Issue 25 item 11: released at the extended reach, the filter still lists E (the arm
    touches it) but nothing asks for motion: the highlight goes."""
    app.loop.reset()
    app.loop.set_gizmo_target(np.array([-0.7, 0.2, 0.0]))  # outwards, beyond the reach circle E
    for _ in range(4000):
        app.loop.step_once()
    app.render_once()
    assert app.scene.view.active_limitations() == ("E extended reach",)
    app.loop.release_gizmo()
    for _ in range(500):
        app.loop.step_once()
    assert app.loop.snapshot().report.binding == ("E extended reach",)
    app.render_once()
    assert app.scene.view.active_limitations() == ()


def test_joint_1_lower_end_alone_lights_up(app):
    """Issue 25 item 11: D's two rays are drawn apart; only the binding end is highlighted."""
    app.loop.reset()
    app.loop.set_gizmo_target(np.array([0.25, 0.05, 0.0]))
    for _ in range(2500):
        app.loop.step_once()
        if "D joint 1 lower" in app.loop.snapshot().report.binding:
            break
    app.render_once()
    assert app.scene.view.active_limitations() == ("D joint 1 lower",)
    assert app.scene.view._limit_nodes["D joint 1 upper"][0].visible
    app.loop.release_gizmo()


def test_built_in_zones_are_selectable_at_first_load():
    """Issue 25 item 9: the Zone list holds the scene's zones before anything was added."""
    demo = DemoApp(DemoConfig(port=free_local_port()))
    try:
        assert demo.zones.selected.options == ("F circle zone", "F rectangle zone")
        assert demo.zones.selected.value == "F circle zone"
    finally:
        demo.server.stop()


def test_arm_scene_switch_renders_and_unknown_robot_keeps_previous(app):
    app.switch_scene("panda")
    assert app.loop.robot.dim == 3 and app.scene.name == "panda"
    app.loop.set_gizmo_target(app.loop.snapshot().p_base_ee_m + np.array([0.0, 0.0, 0.05]))
    for _ in range(50):
        app.loop.step_once()
    app.render_once()
    assert app.loop.snapshot().p_base_ee_m[2] > app.scene.robot.state.p_world_ee[2] - 1e-9
    with pytest.raises(UnknownRobotError, match="known robots"):
        app.switch_scene("r2d2")
    assert app.scene.name == "panda" and app.loop.robot is app.scene.robot
    app.switch_scene("planar")
    assert app.loop.robot.dim == 2


def test_zone_editor_adds_moves_and_deletes_a_planar_zone(app):
    editor = app.zones
    editor.shape.value = "sphere"
    name = editor.add_zone()
    zone = next(z for z in app.scene.zones() if z.name == name)
    assert zone.radius_m == pytest.approx(editor.size.value)
    editor.x.value = -0.1
    editor.edit_selected()
    zone = next(z for z in app.scene.zones() if z.name == name)
    assert zone.center_m[0] == pytest.approx(-0.1)
    editor.delete_zone()
    assert name not in [z.name for z in app.scene.zones()]


def test_hand_added_zones_survive_a_robot_switch_and_built_in_zones_are_editable(app):
    editor = app.zones
    app.loop.reset()
    editor.shape.value = "box"
    editor.x.value, editor.y.value, editor.z.value, editor.size.value = -0.3, -0.3, 0.8, 0.05
    name = editor.add_zone()
    assert name
    app.switch_scene("panda")
    zone = next(z for z in app.scene.zones() if z.name == name)  # carried into the 3D scene as a box
    np.testing.assert_allclose(zone.center, (-0.3, -0.3, 0.8))
    app.switch_scene("planar")
    assert name in [z.name for z in app.scene.zones()]
    editor.selected.value = "F circle zone"  # a built-in zone
    editor._load_selected()
    editor.x.value = float(editor.x.value) + 0.02
    editor.edit_selected()
    moved = next(z for z in app.scene.zones() if z.name == "F circle zone")
    assert moved.center_m[0] == pytest.approx(editor.x.value)
    editor.selected.value = name
    editor.delete_zone()
    assert name not in editor.added


def test_a_zone_dropped_onto_the_end_effector_is_refused(app):
    editor = app.zones
    app.loop.reset()
    before = [z.name for z in app.scene.zones()]
    ee = app.loop.snapshot().p_base_ee_m
    editor.shape.value = "sphere"
    editor.x.value, editor.y.value, editor.size.value = float(ee[0]), float(ee[1]), 0.05
    assert editor.add_zone() == ""
    assert [z.name for z in app.scene.zones()] == before
    assert "end-effector" in editor.last_refusal
    for _ in range(100):
        app.loop.step_once()
    np.testing.assert_allclose(app.loop.snapshot().p_base_ee_m, ee, atol=1e-9)  # nothing pushed the arm


def test_seek_maximum_and_replay_button_and_paths():
    import viser

    from cobotsafety.app.panel import play_button_look
    from cobotsafety.app.demo_app import seek_maximum_s, without_server_paths

    assert seek_maximum_s(31.999515) == pytest.approx(31.99)
    assert seek_maximum_s(32.0) == pytest.approx(32.0)
    assert play_button_look(True) == ("Pause", viser.Icon.PLAYER_PAUSE)
    assert play_button_look(False) == ("Play", viser.Icon.PLAYER_PLAY)
    from pathlib import Path

    path = Path("/tmp/cobotsafety-upload-abc123/take.bag")
    message = without_server_paths(f"refused take.bag: cannot read {path}: bad codec in /tmp/other/x.db3", path)
    assert "/tmp" not in message and "cobotsafety-upload" not in message and "take.bag" in message


def test_status_segment_and_plot_show_one_minimum_distance():
    """Issue 25 item 3: one number (the status), drawn (the segment between its witness points)
    and plotted from the same report in the same update; the controller's separation."""
    import re

    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port()))
    try:
        assert demo.replay.replay is None  # the recording is read after the server answers
        demo.ensure_replay()
        assert not demo.replay.playing and demo.replay.time_s == 0.0  # the demo starts paused
        demo.replay.seek(5.0)  # exp1: the co-worker reaches towards the table
        demo.loop.method = "off"
        for frame in range(30):  # a step, then the frame that shows it
            demo.loop.step_once()
            demo.render_once()
        shown = demo.last_min_distance_m
        assert shown is not None
        status = demo.panel.status.content
        assert re.search(rf"Person: <b>{shown * 1e3:.0f} mm</b> from the arm", status)
        shown_text = " ".join(demo.last_status_lines)
        assert len(re.findall(r"(?<![\d.])\d+ mm", shown_text)) == 2, shown_text  # the distance and its aim
        assert "SSM <b>off</b>" in status
        p_robot, p_human = demo.human.segment.points[0]
        assert float(np.linalg.norm(p_human - p_robot)) == pytest.approx(shown, abs=1e-5)
        assert demo.history.array("min_distance_m")[-1] == pytest.approx(shown)
        assert demo.plots.distance.data[1][-1] == pytest.approx(shown * 1e3)
        # the controller's separation (robot capsules but the fixed base), same human, same pose
        assert demo.loop.snapshot().report.min_distance_m == pytest.approx(shown, abs=1e-6)
    finally:
        demo.server.stop()


def test_the_motion_line_names_whose_acceleration_shapes_a_drag_from_rest():
    """Issue 20 item 7, end to end: a drag from rest ramps up within the hand's acceleration
    limit, and the status's motion line says so in a reader's words, from the loop's own
    report; once at speed, "within the robot's limits"."""
    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port()))
    try:
        ee = demo.loop.snapshot().p_base_ee_m
        demo.loop.set_gizmo_target(ee + np.array([0.0, 0.3, 0.0]))
        shown = []
        for frame in range(60):
            demo.loop.step_once()
            demo.render_once()
            shown.append(demo.last_status_lines[4] if demo.last_status_lines else "")
        assert "Motion: <b>acceleration-limited</b> by the hand" in shown
        assert shown[-1] == "Motion: within the robot's limits"
    finally:
        demo.server.stop()


def test_the_report_s_witness_points_are_drawn_when_it_has_them():
    """After the control core's rebuild the report carries the pair: the display draws exactly that."""
    from types import SimpleNamespace

    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port()))
    try:
        fields = dict(min_distance_m=0.4321, p_robot_closest_m=np.array([0.1, 0.2, 0.3]),
                      p_human_closest_m=np.array([0.5, 0.2, 0.3]))
        closest = demo.closest_pair(SimpleNamespace(**fields))
        assert closest[0] == 0.4321
        np.testing.assert_array_equal(closest[1], fields["p_robot_closest_m"])
        np.testing.assert_array_equal(closest[2], fields["p_human_closest_m"])
        assert demo.closest_pair(SimpleNamespace(**{**fields, "min_distance_m": None})) is None
    finally:
        demo.server.stop()


def test_bad_replay_is_refused_with_the_loaders_message(tmp_path):
    bad = tmp_path / "bad.jsonl.gz"
    bad.write_bytes(b"nope")
    with pytest.raises(RecordingError, match="bad.jsonl.gz"):
        DemoApp(DemoConfig(port=free_local_port(), replay=bad))


def test_uploaded_garbage_keeps_previous_replay(app):
    app.ensure_replay()
    before = app.replay.replay
    message = app.load_uploaded("garbage.jsonl.gz", b"\x00\x01")
    assert message.startswith("garbage.jsonl.gz is not a readable recording (")
    assert message.count("garbage.jsonl.gz") == 1  # one plain sentence naming the file once
    assert app.replay.replay is before
    assert message in app.panel.replay_message.content


def test_urdf_joint_values_continuous_and_missing_joints():
    import pinocchio as pin

    model = pin.Model()
    j1 = model.addJoint(0, pin.JointModelRUBZ(), pin.SE3.Identity(), "wrist")
    model.addJoint(j1, pin.JointModelRY(), pin.SE3.Identity(), "elbow")
    q = np.array([np.cos(2.5), np.sin(2.5), -0.7])
    values = urdf_joint_values(model, q, ("elbow", "finger", "wrist"))
    np.testing.assert_allclose(values, [-0.7, 0.0, 2.5])


def test_settle_heap_collects_the_garbage_then_freezes_what_lives():
    import gc
    import weakref

    from cobotsafety.app.demo_app import settle_heap

    class Node:
        pass

    garbage = Node()
    garbage.self = garbage  # a cycle: only the cyclic collector frees it
    dead = weakref.ref(garbage)
    del garbage
    try:
        settle_heap()
        assert dead() is None
        assert gc.get_freeze_count() > 1000
    finally:
        gc.unfreeze()
    assert gc.get_freeze_count() == 0
