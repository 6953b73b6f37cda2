"""The balancer's MuJoCo world: robot.xml in scene.xml, plus a scenario's terrain.

A ``World`` of the rig (stepping, the body force, IMU and shaft readings); it
adds the balancer's ground truth and its starting pose.
"""
from __future__ import annotations

import math

import mujoco

from wheelleg.emulators.world import World
from wheelleg_balancer import description as D


class BalancerPhysics(World):
    """The simulated balancer. All quantities SI (m, rad, s, N, N m)."""

    SCENE_PATH = D.MODEL_DIR / "scene.xml"
    MOTORS = D.WHEELS

    def ground_truth(self) -> dict[str, float]:
        """The body's pose and velocity (``World.pose_truth``: t, x, y, z, roll, pitch, yaw, vx, vy, vz,
        wx, wy, wz), for the trace only."""
        return self.pose_truth()

    def reset_upright(self, pitch_rad: float = 0.0) -> None:
        """At rest on both wheels, leaning ``pitch_rad`` (nose down positive) about the axle, time 0."""
        self._reset_data()
        qpos = self.data.qpos
        # the CoM is COM_OVER_AXLE_M above the axle; the axle stays one wheel radius over the floor
        qpos[0] = D.COM_OVER_AXLE_M * math.sin(pitch_rad)
        qpos[2] = D.WHEEL_RADIUS_M + D.COM_OVER_AXLE_M * math.cos(pitch_rad)
        qpos[3:7] = [math.cos(pitch_rad / 2), 0.0, math.sin(pitch_rad / 2), 0.0]
        mujoco.mj_forward(self.model, self.data)
