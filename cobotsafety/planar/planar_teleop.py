"""``PlanarTeleop``: the planar scene behind the ``cobotsafety.teleoperated.Teleoperated`` protocol."""

from __future__ import annotations

import numpy as np

from cobotsafety.planar.rr_arm import Kinematics
from cobotsafety.planar.planar_scenes import FIG9_START_M, demo_scene
from cobotsafety.planar.planar_step import PlanarScene, PlanarState, step
from cobotsafety.teleoperated import METHODS, StepReport


class PlanarTeleop:
    """The RR arm, driven by a 2D Cartesian velocity command [m/s]."""

    dim = 2

    def __init__(self, scene: PlanarScene | None = None, home_m: tuple[float, float] = FIG9_START_M):
        self.scene = scene or demo_scene()
        self.home_m = home_m
        self.reset()

    def reset(self) -> None:
        theta_1, theta_2 = self.scene.arm.inverse_kinematics(*self.home_m)
        self.state = PlanarState(theta_1, theta_2)

    @property
    def kinematics(self) -> Kinematics:
        return Kinematics(self.scene.arm, self.state.theta_1, self.state.theta_2)

    @property
    def p_base_ee_m(self) -> np.ndarray:
        kin = self.kinematics
        return np.array([kin.x, kin.y, 0.0])

    @property
    def p_base_elbow_m(self) -> np.ndarray:
        kin = self.kinematics
        return np.array([kin.elbow_x, kin.elbow_y, 0.0])

    def step(self, v_desired_m_s: np.ndarray, dt_s: float, method: str = "anticipative") -> StepReport:
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        v = np.asarray(v_desired_m_s, dtype=float).reshape(-1)
        if v.shape != (2,):
            raise ValueError(f"v_desired_m_s must have shape (2,), got {np.shape(v_desired_m_s)}")
        before = self.p_base_ee_m
        self.state, info = step(self.state, (v[0], v[1]), dt_s, self.scene, method)
        after = self.p_base_ee_m
        return StepReport(
            v_desired_m_s=np.array([info.vx_desired, info.vy_desired]),
            v_commanded_m_s=np.array([info.vx_commanded, info.vy_commanded]),
            v_executed_m_s=(after[:2] - before[:2]) / dt_s,
            p_base_ee_m=after,
            binding=info.binding,
            stopped=info.stopped,
            extras={"net_scale": info.net_scale},
        )
