"""The one trial setup: the robot's scene and the course, used by people and by the simulation.

The browser trial (``trial_app.TrialServer``) and the simulated participant
(``simulate.simulated_study``) both call ``prepare_trial_robot`` on the robot they drive and
``trial_course`` for the course, so the simulated participant drives exactly the scene and the
course people drive: on the planar arm, ``planar_scenes.trial_scene()`` (the arm's own
limitations A-E and the conditioning safeguard, the demo's damped zone, no protection zones)
with the home at the course's start; on a 3D arm, no protection zones.

``straight_drive(robot, course)`` measures what the course asks of a participant: driven
straight from target to target under sliding, which limitations each route meets (the claims
of ``course.planar_course`` and the README are tested against it; ``cobotsafety trial
--course`` prints it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cobotsafety.trial.course import Course, arm_course, planar_course

SCENES = ("planar", "arm")


def trial_course(scene: str) -> Course:
    """The course of ``scene`` (``"planar"`` or ``"arm"``)."""
    if scene not in SCENES:
        raise ValueError(f"scene must be one of {SCENES}, got {scene!r}")
    return planar_course() if scene == "planar" else arm_course()


def prepare_trial_robot(robot, scene: str) -> None:
    """Turn ``robot`` (a ``PlanarTeleop`` for ``"planar"``, a 3D arm with ``zones`` otherwise)
    into the trial's robot, in place, and send it home."""
    if scene == "planar":
        from cobotsafety.planar.planar_scenes import trial_scene  # noqa: PLC0415

        robot.scene = trial_scene()
        robot.home_m = tuple(trial_course("planar").start_m)
    else:
        robot.zones = []
    robot.reset()


def make_trial_robot(scene: str, robot_name: str = "panda"):
    """``(robot, course)`` for a headless trial: the same robot class the browser trial drives
    (``app.scenes``: ``PlanarTeleop``, or ``ArmController`` with nobody in the cell), prepared
    by ``prepare_trial_robot``."""
    course = trial_course(scene)
    if scene == "planar":
        from cobotsafety.planar.planar_teleop import PlanarTeleop  # noqa: PLC0415

        robot = PlanarTeleop()
    else:
        from cobotsafety.arm.controller import ArmController  # noqa: PLC0415

        robot = ArmController(robot_name)
    prepare_trial_robot(robot, scene)
    return robot, course


@dataclass(frozen=True)
class RouteEncounter:
    """One route of a straight drive: ``route`` k goes from target k - 1 (the start for 0) to k."""

    route: int
    limitations: tuple[str, ...]
    """Names of the limitations the sliding filter slid on along this route, in order met."""
    episodes: int
    """Separate binding episodes (a limitation starting to bind after none did)."""


def straight_drive(robot, course: Course, method: str = "anticipative", dt_s: float = 0.01,
                   gain_per_s: float = 2.5, max_speed_m_s: float = 0.25,
                   timeout_s: float = 60.0) -> tuple[int, list[RouteEncounter]]:
    """Drive ``robot`` straight at each target in turn (saturated proportional command) under
    ``method``; ``(targets reached, encounters per route)``. Under ``stop`` the drive stalls at
    the first limitation (the participant has to steer around it)."""
    robot.reset()
    reached, t = 0, 0.0
    per_route: dict[int, list[str]] = {}
    episodes: dict[int, int] = {}
    was = False
    count = len(course.targets_m)
    while reached < count and t < timeout_s:
        goal = np.array(course.targets_m[reached], dtype=float)
        p = np.asarray(robot.p_base_ee_m, dtype=float)
        offset = goal - p[:2]
        if np.linalg.norm(offset) <= course.target_radius_m:
            reached += 1
            continue
        v = gain_per_s * offset
        speed = float(np.linalg.norm(v))
        if speed > max_speed_m_s:
            v *= max_speed_m_s / speed
        if robot.dim == 3:
            v = np.array([v[0], v[1], gain_per_s * ((course.height_m or 0.0) - p[2])])
        report = robot.step(v, dt_s, method)
        t += dt_s
        names = per_route.setdefault(reached, [])
        for name in report.binding:
            if name not in names:
                names.append(name)
        if report.binding and not was:
            episodes[reached] = episodes.get(reached, 0) + 1
        was = bool(report.binding)
    return reached, [RouteEncounter(k, tuple(per_route.get(k, ())), episodes.get(k, 0)) for k in range(count)]


def describe_course(scene: str = "planar") -> str:
    """The course's measured facts (``cobotsafety trial --course``)."""
    robot, course = make_trial_robot(scene)
    reached, routes = straight_drive(robot, course)
    stop_reached, _ = straight_drive(robot, course, "stop")
    lines = [f"Course {course.name!r}: {len(course.targets_m)} targets (radius {100 * course.target_radius_m:.0f} cm), "
             f"{len(course.obstacles_m)} triangles; straight routes clear the triangles by "
             f"{100 * course.route_clearance_m():.1f} cm.",
             f"Driven straight under sliding: {reached} of {len(course.targets_m)} targets reached; "
             f"under stop the straight drive stalls after {stop_reached} target(s).",
             "", "| route | limitations slid on | binding episodes |", "|---|---|---|"]
    for r in routes:
        start = "start" if r.route == 0 else f"target {r.route}"
        lines.append(f"| {start} -> target {r.route + 1} | {', '.join(r.limitations) or '-'} | {r.episodes} |")
    return "\n".join(lines)
