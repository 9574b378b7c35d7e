"""The 3D arm view: joint frames posed like ``ViserUrdf.update_cfg`` (the oracle), and a frame
that re-poses only what moved."""

import numpy as np
import pytest
import viser
from viser.extras import ViserUrdf

from cobotsafety.app.scene_arm import REDRAW_TOLERANCE_M, REDRAW_TOLERANCE_RAD, ArmView, UrdfJointPoser
from cobotsafety.arm.robots import urdf_path
from cobotsafety.ports import free_local_port


@pytest.fixture(scope="module")
def server():
    server = viser.ViserServer(port=free_local_port(), verbose=False)
    yield server
    server.stop()


def frame_poses(viser_urdf) -> list[tuple[np.ndarray, np.ndarray]]:
    """(rotation matrix, position) of every joint frame (a quaternion and its negative agree)."""
    return [(viser.transforms.SO3(np.asarray(f.wxyz)).as_matrix(), np.asarray(f.position, dtype=float))
            for f in viser_urdf._joint_frames]


@pytest.mark.parametrize("robot", ["panda", "kinova"])  # mimic + prismatic fingers; continuous joints
def test_poser_poses_the_joint_frames_like_update_cfg(server, robot):
    reference = ViserUrdf(server, urdf_path(robot), root_node_name=f"/reference_{robot}")
    fast = ViserUrdf(server, urdf_path(robot), root_node_name=f"/fast_{robot}")
    poser = UrdfJointPoser(fast, tolerance=0.0)
    assert poser.rows is not None and len(poser.rows) >= 6
    count = len(reference.get_actuated_joint_names())
    rng = np.random.default_rng(7)
    for _ in range(10):
        values = rng.uniform(-3.0, 3.0, count)
        values[-1] = rng.uniform(0.0, 0.04)  # a finger (panda) or a finger-less last joint
        reference.update_cfg(values)
        poser.pose(values)
        for (r_ref, p_ref), (r_fast, p_fast) in zip(frame_poses(reference), frame_poses(fast), strict=True):
            np.testing.assert_allclose(r_fast, r_ref, atol=1e-12)
            np.testing.assert_allclose(p_fast, p_ref, atol=1e-12)


def test_poser_turns_only_the_joints_that_moved_by_the_tolerance(server):
    urdf = ViserUrdf(server, urdf_path("panda"), root_node_name="/tolerance")
    poser = UrdfJointPoser(urdf)
    values = np.zeros(len(urdf.get_actuated_joint_names()))
    assert poser.pose(values) == len(urdf._joint_frames)  # the first call places every frame
    assert poser.pose(values + 0.5 * REDRAW_TOLERANCE_RAD) == 0  # creeping: nothing sent
    moved = values.copy()
    moved[2] += 2 * REDRAW_TOLERANCE_RAD
    frames_before = frame_poses(urdf)
    assert poser.pose(moved) == 1
    changed = [i for i, (a, b) in enumerate(zip(frames_before, frame_poses(urdf))) if not np.allclose(a[0], b[0])]
    assert len(changed) == 1


def world_pose(handles: dict, node) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of ``node`` in the world: its pose composed with every ancestor frame in ``handles``."""
    parts = node.name.split("/")
    R, p = np.eye(3), np.zeros(3)
    for depth in range(2, len(parts) + 1):
        handle = node if depth == len(parts) else handles.get("/".join(parts[:depth]))
        if handle is None:
            continue  # a root frame (identity)
        R_local = viser.transforms.SO3(np.asarray(handle.wxyz, dtype=float)).as_matrix()
        p = p + R @ np.asarray(handle.position, dtype=float)
        R = R @ R_local
    return R, p


def test_capsules_ride_on_their_links_where_pinocchio_puts_them(server):
    from cobotsafety.arm.controller import ArmController

    teleop = ArmController("panda")
    state = teleop.state
    view = ArmView(server, teleop)
    assert view.capsule_attached.all()
    handles = {frame.name: frame for frame in view.urdf._joint_frames}
    snapshot = type("Snapshot", (), {"report": None})()
    rng = np.random.default_rng(11)
    lower, upper = state.model.lowerPositionLimit, state.model.upperPositionLimit
    for _ in range(3):  # the first pose goes through update_cfg, the next ones through the poser
        teleop.set_configuration(rng.uniform(lower, upper))
        view.update(snapshot, state.q, (state.capsule_p0, state.capsule_p1, state.capsule_radius))
        for i, node in enumerate(view.capsules):
            R, p = world_pose(handles, node)
            length = float(np.linalg.norm(state.capsule_p1_local[i] - state.capsule_p0_local[i]))
            np.testing.assert_allclose(p, state.capsule_p0[i], atol=1e-9)
            np.testing.assert_allclose(p + R @ [0.0, 0.0, length], state.capsule_p1[i], atol=1e-9)


def test_capsules_without_a_urdf_frame_move_only_when_they_moved(server):
    from cobotsafety.arm.controller import ArmController

    teleop = ArmController("panda")
    view = ArmView(server, teleop)
    view.capsule_attached[:] = False  # as for a robot without URDF meshes: posed in the world frame
    state = teleop.state
    snapshot = type("Snapshot", (), {"report": None})()
    p0, p1, radius = state.capsule_p0.copy(), state.capsule_p1.copy(), state.capsule_radius.copy()
    view.update(snapshot, state.q, (p0, p1, radius))
    np.testing.assert_allclose(view.capsules[-1].position, p0[-1])
    shifted_p0, shifted_p1 = p0.copy(), p1.copy()
    shifted_p0[-1] += [2 * REDRAW_TOLERANCE_M, 0.0, 0.0]  # the last capsule moves
    shifted_p1[-1] += [2 * REDRAW_TOLERANCE_M, 0.0, 0.0]
    shifted_p0[1] += [0.5 * REDRAW_TOLERANCE_M, 0.0, 0.0]  # another one creeps
    view.update(snapshot, state.q, (shifted_p0, shifted_p1, radius))
    np.testing.assert_allclose(view.capsules[-1].position, shifted_p0[-1])
    np.testing.assert_allclose(view.capsules[1].position, p0[1])


def test_limits_that_bind_are_drawn_where_they_bind():
    """Issue 25 item 6: a joint at its limit gets an arc at the joint whose binding end the
    needle (turning with the joint) points at; the reach sphere and the table light up."""
    from cobotsafety.app.demo_app import DemoApp, DemoConfig
    from cobotsafety.app.scene_limits import reach_geometry

    demo = DemoApp(DemoConfig(scene="arm", robot="panda", port=free_local_port()))  # threads not started
    try:
        view = demo.scene.view

        def drive(target, until: str, steps: int = 6000) -> None:
            demo.loop.reset()
            demo.loop.set_gizmo_target(np.array(target, dtype=float))
            for _ in range(steps):
                demo.loop.step_once()
                if until in demo.loop.snapshot().report.binding:
                    break
            assert until in demo.loop.snapshot().report.binding
            for _ in range(2):
                demo.render_once()

        drive((0.2, 0.0, 0.1), "panda_joint4 lower")  # folded in towards the base
        keys = ("panda_joint4 arc", "panda_joint4 lower", "panda_joint4 needle")
        assert set(keys) <= set(view.highlighted())
        assert all(view.marks.nodes[key].visible for key in keys)
        assert not view.marks.nodes["panda_joint4 upper"].visible
        handles = {frame.name: frame for frame in view.urdf._joint_frames}
        handles[view.urdf._visual_root_frame.name] = view.urdf._visual_root_frame
        R_arc, p_arc = world_pose(handles, view.marks.nodes["panda_joint4 lower"])  # the parent link's frame
        R_needle, p_needle = world_pose(handles, view.marks.nodes["panda_joint4 needle"])  # the child's
        origin = np.asarray(view.urdf._urdf.joint_map["panda_joint4"].origin, dtype=float)[:3, 3]
        np.testing.assert_allclose(p_needle, p_arc + R_arc @ origin, atol=1e-9)  # the arc's centre: the joint
        arc_points = view.marks.nodes["panda_joint4 lower"].points.astype(float)
        end = R_arc @ (arc_points[0, 0] - origin)  # the arc's first point: the lower limit
        tip = R_needle @ view.marks.nodes["panda_joint4 needle"].points.astype(float)[0, 1]
        model = demo.scene.robot.state.model
        index = model.joints[model.getJointId("panda_joint4")].idx_q
        q, lower = float(demo.scene.robot.state.q[index]), float(model.lowerPositionLimit[index])
        assert 0.0 <= q - lower < 0.2  # at (or approaching) its lower limit
        angle = float(np.arccos(np.clip(end @ tip / np.linalg.norm(end) / np.linalg.norm(tip), -1.0, 1.0)))
        assert angle == pytest.approx(q - lower, abs=2e-3)  # the needle stands that far from the binding end

        drive((1.5, 0.0, 0.4), "reach extended")
        assert "reach extended" in view.highlighted() and view.marks.nodes["reach extended"].visible
        assert not view.marks.nodes["panda_joint4 arc"].visible
        shoulder, _, extended = reach_geometry(demo.scene.robot.limitations)
        radii = np.linalg.norm(view.marks.nodes["reach extended"].points.reshape(-1, 3) - shoulder, axis=1)
        np.testing.assert_allclose(radii, extended, rtol=1e-5)

        drive((0.5, 0.0, -0.3), "table (panda_joint7)")
        assert view.marks.nodes["table bound"].visible and not view.marks.nodes["table"].visible
        demo.loop.release_gizmo()
        demo.loop.reset()
        for _ in range(5):
            demo.loop.step_once()
        demo.render_once()
        assert view.highlighted() == ()
        assert view.marks.nodes["table"].visible and not view.marks.nodes["table bound"].visible
    finally:
        demo.server.stop()
